//! Kepler's problem with eccentricity 0.6 over 100 periods with the element of order 8
//! (degree 4): the relative energy error stays bounded, and the final position is compared
//! with the closed form. `cargo run --release -p femvi --example kepler`

use femvi::{models, solve, Element, Problem, SolveOptions, Start};

fn main() -> Result<(), femvi::Error> {
    let e: f64 = 0.6;
    // Pericentre at (1 − e, 0) with a = 1 (period 2π).
    let start = Start::Momentum {
        q: vec![1.0 - e, 0.0],
        p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()],
    };
    let periods = 100.0;
    let problem = Problem::new(
        models::kepler(1.0).unwrap(),
        start,
        0.0,
        periods * 2.0 * std::f64::consts::PI,
    );
    let options = SolveOptions {
        every: 100,
        ..SolveOptions::step(2.0 * std::f64::consts::PI / 200.0)
    };
    let sol = solve(&problem, &Element::with_order(8)?, &options)?;
    if let Some(err) = &sol.error {
        return Err(err.clone());
    }
    let e0 = sol.energy[0];
    let worst = sol.energy.iter().map(|h| ((h - e0) / e0).abs()).fold(0.0, f64::max);
    let last = sol.q_row(sol.len() - 1).unwrap_or_default();
    println!(
        "{} steps, {:.2} solver iterations per step",
        sol.steps, sol.mean_iterations
    );
    println!("max relative energy error {worst:.2e}");
    println!(
        "final position ({:.12}, {:.12}); after whole periods it is ({:.12}, 0)",
        last[0],
        last[1],
        1.0 - e
    );
    Ok(())
}
