//! The Rust side of the overhead measurement (examples/overhead.py): loads a problem file with
//! the command's loader (not timed), then times `femvi::solve` of it `REPS` times (every node
//! kept, as `femvi.solve` keeps them) and prints the seconds of each run, one per line.
//!
//! `cargo run --release --example overhead -- PROBLEM.toml [REPS]`

use femvi::{solve, Problem, SolveOptions};
use std::time::Instant;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or("usage: overhead PROBLEM.toml [REPS]")?;
    let reps: usize = args.next().map_or(Ok(1), |r| r.parse().map_err(|e| format!("REPS: {e}")))?;
    let problem = femvi_cli::problem::load(path.as_ref()).map_err(|e| e.to_string())?;
    let options = SolveOptions::step(problem.grid.nominal(0));
    let (t0, end) = (problem.grid.t0(), problem.grid.end());
    for _ in 0..reps {
        let seconds = femvi_cli::with_system!(&problem.system, l => {
            let p = Problem::new(l.clone(), problem.start.clone(), t0, end);
            let clock = Instant::now();
            let sol = solve(&p, &problem.element, &options).map_err(|e| e.to_string())?;
            let s = clock.elapsed().as_secs_f64();
            if let Some(e) = sol.error {
                return Err(e.to_string());
            }
            std::hint::black_box(sol.q.len());
            s
        });
        println!("{seconds}");
    }
    Ok(())
}
