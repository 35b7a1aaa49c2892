//! A two-point boundary value problem by the discrete variational principle: the pendulum
//! from θ(0) = 0.1 to θ(5) = 0.1 (several solutions exist; Newton finds the one nearest the
//! straight-line guess), with 100 elements of degree 3. Prints the solution's action, its
//! residual and θ at the element ends. `cargo run --release -p femvi --example bvp`

use femvi::bvp::{line_guess, solve, BoundaryValues, BvpOptions};
use femvi::{models, Element};

fn main() -> Result<(), femvi::Error> {
    let pendulum = models::pendulum(1.0, 9.81, 1.0)?;
    let element = Element::with_order(6)?;
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![0.1],
        t1: 5.0,
        q1: vec![0.1],
        elements: 100,
    };
    let sol = solve(
        &pendulum,
        &element,
        &bv,
        &line_guess(&bv, &element),
        BvpOptions::default(),
    )?;
    println!(
        "action {:.12}, residual {:.2e}, {} Newton iterations",
        sol.action, sol.residual_norm, sol.newton_iterations
    );
    println!("t,theta,p");
    for (k, t) in sol.times.iter().enumerate().step_by(10) {
        println!("{t},{},{}", sol.q[k], sol.p[k]);
    }
    Ok(())
}
