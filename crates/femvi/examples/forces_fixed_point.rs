//! The speed-up of the fixed-point forced step (`forces/fixed_point.rs`) against the forced
//! Newton step, on two systems with a force F(t, q) independent of v: the driven harmonic
//! oscillator (`models::harmonic`, F = f0 cos(ωt), h = 0.1) and the forced Duffing oscillator
//! from expressions (L = ½v² + ½x² − ¼x⁴ as in tests/all/forces_fixed_point.rs, F = γ cos(ωt) +
//! εx², h = 0.05), 2·10⁴ steps each, degrees 1, 2 and 4 (Gauss). The two methods run
//! alternately, `REPS` times each; printed are the medians and the ratio of medians
//! Newton / fixed point, and the largest difference of the final states (after t = 1000 the
//! Duffing orbit at these parameters is chaotic: the two round-off-level differences grow to
//! O(1) there; over t = 20 they agree to ≤ 1e-13, tests/all/forces_fixed_point.rs).
//!
//! `cargo run --release -p femvi --example forces_fixed_point`

use femvi::expr::ExprLagrangian;
use femvi::forces::{solve_forced, ExprForces, Force, ForcedSolution, LinearForce};
use femvi::{models, Element, Lagrangian, Method, Problem, SolveOptions, Start};
use std::time::Instant;

const REPS: usize = 9;
const STEPS: f64 = 20_000.0;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn run<L: Lagrangian + Sync, F: Force + Sync>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    h: f64,
    method: Method,
) -> (f64, ForcedSolution) {
    let mut options = SolveOptions::step(h);
    options.every = 0;
    options.solver.method = method;
    let clock = Instant::now();
    let sol = solve_forced(problem, force, element, &options).expect("valid input");
    (clock.elapsed().as_secs_f64(), sol)
}

fn measure<L: Lagrangian + Sync, F: Force + Sync>(
    name: &str,
    problem: &Problem<L>,
    force: &F,
    h: f64,
) -> Result<(), femvi::Error> {
    for s in [1, 2, 4] {
        let element = Element::with_order(2 * s)?;
        let (mut tn, mut tf) = (vec![], vec![]);
        let mut diff = 0.0f64;
        for _ in 0..REPS {
            let (a, newton) = run(problem, force, &element, h, Method::Newton);
            let (b, fixed) = run(problem, force, &element, h, Method::Auto);
            tn.push(a);
            tf.push(b);
            let (qa, qb) = (&newton.solution.q, &fixed.solution.q);
            diff = qa.iter().zip(qb).fold(diff, |m, (x, y)| m.max((x - y).abs()));
        }
        let (mn, mf) = (median(tn), median(tf));
        println!(
            "{name}, s = {s}: Newton {:.2} ms, fixed point {:.2} ms, ratio {:.2} (|Δq_end| {diff:.1e})",
            1e3 * mn,
            1e3 * mf,
            mn / mf
        );
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let start = || Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    let h = 0.1;
    let driven = Problem::new(models::harmonic(1.0, 1.0)?, start(), 0.0, STEPS * h);
    measure("driven oscillator", &driven, &LinearForce::drive(vec![0.5], 1.7), h)?;

    let coords = ["x".to_string()];
    let params: Vec<(String, f64)> = [("a", -1.0), ("b", 1.0), ("g", 0.3), ("w", 1.2), ("e", 0.1)]
        .iter()
        .map(|(k, v)| (k.to_string(), *v))
        .collect();
    let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*a*x^2 - 0.25*b*x^4", &coords, &params)?;
    let force = ExprForces::new(&["g*cos(w*t) + e*x^2"], &coords, &params)?;
    let h = 0.05;
    let duffing = Problem::new(lag, start(), 0.0, STEPS * h);
    measure("forced Duffing", &duffing, &force, h)?;
    Ok(())
}
