//! The free rigid body (I = diag(1, 2, 3), w0 = (0.5, 1, 0.3), R0 = 1) by the Lie-group
//! element of `femvi::rotation`: `cargo run --release -p femvi --example rigid_body -- STEPS H
//! DEGREE`. Prints the last R and w with 17 digits, max |RᵀR − 1| over every step, the
//! largest relative change of |Π| and of the energy. The peer is `benches/peers/lgvi.c`
//! (the Lee–Leok–McClamroch LGVI); `benches/peers/lgvi.md` has the figures.

use femvi::models::RigidBody;
use femvi::rotation::so3::orthogonality_defect;
use femvi::rotation::{body_state, embedded_velocity, Rotations};
use femvi::{Element, Integrator, SolverOptions, Start, TimeGrid};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let steps: usize = args.get(1).map_or(Ok(1000), |s| s.parse())?;
    let h: f64 = args.get(2).map_or(Ok(0.01), |s| s.parse())?;
    let degree: usize = args.get(3).map_or(Ok(1), |s| s.parse())?;
    let track = args.get(4).is_some_and(|a| a == "energy");
    let body = RigidBody::free([1.0, 2.0, 3.0])?;
    let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let start = Start::Velocity {
        q: r0.to_vec(),
        v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec(),
    };
    let element = Element::with_order(2 * degree)?;
    let grid = TimeGrid::uniform(0.0, h, h * steps as f64)?;
    let mut it = Integrator::with_rotations(
        &body,
        &element,
        grid,
        start,
        SolverOptions::default(),
        Rotations::new(9, &[0])?,
    )?;
    let norm = |p: [f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    let pi0 = norm(body_state(it.node().q, it.node().p, 0).1);
    let e0 = it.energy()?;
    let (mut orth, mut dpi) = (0.0f64, 0.0f64);
    let mut halves = [0.0f64; 2];
    let mut taken = 0;
    while taken < steps && it.step()? {
        taken += 1;
        let node = it.node();
        let (r, pi) = body_state(node.q, node.p, 0);
        orth = orth.max(orthogonality_defect(&r));
        dpi = dpi.max((norm(pi) / pi0 - 1.0).abs());
        if track {
            let half = usize::from(2 * taken > steps);
            halves[half] = halves[half].max((it.energy()? / e0 - 1.0).abs());
        }
    }
    let node = it.node();
    let (r, pi) = body_state(node.q, node.p, 0);
    println!(
        "steps {taken} t {:.17e} iterations/step {:.3}",
        node.t,
        it.mean_iterations()
    );
    println!("R {}", r.map(|x| format!("{x:.17e}")).join(" "));
    println!("w {:.17e} {:.17e} {:.17e}", pi[0], pi[1] / 2.0, pi[2] / 3.0);
    println!(
        "max |R^T R - 1| {orth:.3e}  max |Pi| change {dpi:.3e}  energy change {:.3e}",
        (it.energy()? / e0 - 1.0).abs()
    );
    if track {
        println!(
            "max energy error: first half {:.3e}, second half {:.3e}",
            halves[0], halves[1]
        );
    }
    Ok(())
}
