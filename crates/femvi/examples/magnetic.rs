//! A velocity-dependent Lagrangian: a charge in the plane with a uniform magnetic field b and
//! a harmonic trap, L = ½|v|² + ½b(x v_y − y v_x) − ½|q|². Newton's method takes the steps
//! (derivatives by automatic differentiation); the energy ½|v|² + ½|q|² is quadratic and
//! kept to round-off by Gauss elements, and the canonical angular momentum
//! x p_y − y p_x is conserved by the rotation symmetry (Noether).
//! `cargo run --release -p femvi --example magnetic`

use femvi::{solve, Element, Lagrangian, Problem, Scalar, SolveOptions, Start};

struct TrappedCharge {
    b: f64,
}

impl Lagrangian for TrappedCharge {
    fn dim(&self) -> usize {
        2
    }

    fn is_autonomous(&self) -> bool {
        true
    }

    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        // Constants to the right of a generic scalar: `x * 0.5`, not `0.5 * x`.
        let kinetic = (v[0] * v[0] + v[1] * v[1]) * 0.5;
        let magnetic = (q[0] * v[1] - q[1] * v[0]) * (0.5 * self.b);
        let trap = (q[0] * q[0] + q[1] * q[1]) * 0.5;
        kinetic + magnetic - trap
    }
}

fn main() -> Result<(), femvi::Error> {
    let start = Start::Velocity {
        q: vec![1.0, 0.0],
        v: vec![0.0, 0.3],
    };
    let problem = Problem::new(TrappedCharge { b: 3.0 }, start, 0.0, 200.0);
    let sol = solve(&problem, &Element::with_order(6)?, &SolveOptions::step(0.05))?;
    if let Some(err) = &sol.error {
        return Err(err.clone());
    }
    let e0 = sol.energy[0];
    let de = sol.energy.iter().map(|h| (h - e0).abs()).fold(0.0, f64::max);
    let momentum = |i: usize| {
        let (q, p) = (sol.q_row(i).unwrap_or_default(), sol.p_row(i).unwrap_or_default());
        q[0] * p[1] - q[1] * p[0]
    };
    let dl = (0..sol.len())
        .map(|i| (momentum(i) - momentum(0)).abs())
        .fold(0.0, f64::max);
    println!(
        "{} Newton steps, {:.2} iterations per step",
        sol.steps, sol.mean_iterations
    );
    println!("energy {e0:.6}: largest change {de:.2e}");
    println!("angular momentum {:.6}: largest change {dl:.2e}", momentum(0));
    Ok(())
}
