//! A Poincaré section of the Hénon–Heiles system at energy 1/8: the crossings of y = 0 with
//! p_y > 0 of a few orbits, located on the element polynomials by events, printed as
//! (x, p_x) rows. `cargo run --release -p femvi --example poincare > section.txt`

use femvi::solution::{Direction, Event};
use femvi::{models, solve, Element, Problem, SolveOptions, Start};

fn main() -> Result<(), femvi::Error> {
    let energy: f64 = 0.125;
    let element = Element::with_order(12)?;
    println!("orbit,t,x,p_x");
    for (orbit, x0) in [-0.3, -0.1, 0.05, 0.2, 0.35].into_iter().enumerate() {
        // On the section (y = 0) with p_x = 0; p_y from the energy.
        let py = (2.0 * energy - x0 * x0).sqrt();
        let start = Start::Momentum {
            q: vec![x0, 0.0],
            p: vec![0.0, py],
        };
        let problem = Problem::new(models::henon_heiles(), start, 0.0, 2000.0);
        let options = SolveOptions {
            every: 0,
            events: vec![Event::new("y = 0", |_t, q, _v| q[1]).direction(Direction::Rising)],
            ..SolveOptions::step(0.1)
        };
        let sol = solve(&problem, &element, &options)?;
        if let Some(err) = &sol.error {
            return Err(err.clone());
        }
        for e in &sol.events {
            println!("{orbit},{},{},{}", e.t, e.q[0], e.p[0]);
        }
        eprintln!("orbit {orbit}: x0 = {x0}, {} crossings", sol.events.len());
    }
    Ok(())
}
