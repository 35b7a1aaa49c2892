//! The Rust side of the overhead measurement (examples/overhead.py): loads a problem file with
//! the command's loader (not timed), then times `femvi::solve` of it `REPS` times (every node
//! kept, as `femvi.solve` keeps them) and prints the seconds of each run, one per line.
//!
//! `solve` tracks the energy at every node by default, as `femvi.solve` and `femvi run` do;
//! with NO_ENERGY set it does not (`track_energy: false`), to show what the tracking costs.
//!
//! `cargo run --release --example overhead -- PROBLEM.toml [REPS]`

use femvi::{solve, Lagrangian, Problem, SolveOptions};
use std::time::Instant;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: overhead PROBLEM.toml [REPS]")?;
    let reps: usize = args
        .next()
        .map_or(Ok(1), |r| r.parse().map_err(|e| format!("REPS: {e}")))?;
    let problem = femvi_cli::problem::load(path.as_ref()).map_err(|e| e.to_string())?;
    let options = SolveOptions {
        track_energy: std::env::var_os("NO_ENERGY").is_none(),
        ..SolveOptions::step(problem.grid.nominal(0))
    };
    for _ in 0..reps {
        let seconds = femvi_cli::with_system!(&problem.system, l => time_solve(l, &problem, &options))?;
        println!("{seconds}");
    }
    Ok(())
}

/// Seconds of one `solve` of the loaded problem with the system `lag`.
fn time_solve<L: Lagrangian + Clone>(
    lag: &L,
    problem: &femvi_cli::problem::Problem,
    options: &SolveOptions,
) -> Result<f64, String> {
    let p = Problem::new(
        lag.clone(),
        problem.start.clone(),
        problem.grid.t0(),
        problem.grid.end(),
    );
    let clock = Instant::now();
    let sol = solve(&p, &problem.element, options).map_err(|e| e.to_string())?;
    let seconds = clock.elapsed().as_secs_f64();
    if let Some(e) = sol.error {
        return Err(e.to_string());
    }
    std::hint::black_box(sol.q.len());
    Ok(seconds)
}
