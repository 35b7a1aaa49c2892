//! Boundary value problems at scale (issue 15): the pendulum (m = g = l = 1) from θ(0) = 0.1
//! to θ(5) = 0.1, degree 2 with Gauss 2 from the straight line, solved to convergence with the
//! default options at N = 10³ … 10⁷ elements. Per N: Newton iterations (Jacobian
//! factorisations), the time of `solve` (median of REPS runs, the guess made outside the
//! clock), the time per element per iteration, the residual max|∂S/∂Q| (its round-off floor
//! grows like N) and the scaled residual of `bvp/newton.rs` (which does not), and the peak
//! resident memory of the process so far.
//!
//! `cargo run --release -p femvi --example bvp_scale [-- MAX_N [REPS]]` (default 10⁷, 3 runs:
//! about four minutes and 2.5 GB at 10⁷).

use femvi::bvp::{line_guess, solve, BoundaryValues, BvpOptions};
use femvi::{models, Element, NodeFamily, QuadratureKind};
use std::time::Instant;

/// The process's peak resident set (VmHWM) in MiB, NaN where /proc is not there.
fn peak_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1).and_then(|k| k.parse::<f64>().ok()))
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn main() -> Result<(), femvi::Error> {
    let args: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let max_n = args.first().copied().unwrap_or(10_000_000);
    let reps = args.get(1).copied().unwrap_or(3).max(1);
    let lag = models::pendulum(1.0, 1.0, 1.0)?;
    let el = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2))?;
    println!("| elements | iterations | solve (s) | µs per element per iteration | residual | scaled residual | peak RSS (MiB) |");
    println!("|---|---|---|---|---|---|---|");
    let mut n = 1000;
    while n <= max_n {
        let bv = BoundaryValues {
            t0: 0.0,
            q0: vec![0.1],
            t1: 5.0,
            q1: vec![0.1],
            elements: n,
        };
        let guess = line_guess(&bv, &el);
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..reps {
            let clock = Instant::now();
            let sol = solve(&lag, &el, &bv, &guess, BvpOptions::default())?;
            times.push(clock.elapsed().as_secs_f64());
            last = Some(sol);
        }
        times.sort_by(f64::total_cmp);
        let (t, sol) = (times[times.len() / 2], last.expect("at least one run"));
        println!(
            "| {n} | {} | {t:.4} | {:.3} | {:.2e} | {:.2e} | {:.0} |",
            sol.newton_iterations,
            t / (n * sol.newton_iterations) as f64 * 1e6,
            sol.residual_norm,
            sol.scaled_residual,
            peak_mib()
        );
        n *= 10;
    }
    Ok(())
}
