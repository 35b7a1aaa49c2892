//! `femvi bvp` on a problem with `[constraints]`: the library's
//! [`femvi::constraints::solve_constrained_bvp_with`] (with the table's enforcement), from the
//! straight line or a guess file as for an unconstrained problem. Writes trajectory.csv with
//! the columns of the unconstrained `femvi bvp` plus the multipliers `lambda_1 … lambda_m` at
//! the element ends (those of the exact flow at the node state, as `femvi run` writes them)
//! and `residual` (max |g(q)|), summary.json as for an unconstrained problem, constraints.json
//! (the largest constraint and hidden-constraint residuals, the enforcement) and, with
//! `--plot`, coordinates.svg. With `[forces]` too, the forced constrained problem
//! ([`femvi::constraints::solve_constrained_forced_bvp`]).

use crate::bvp_output::{guess_from_file, plots, BvpSummary};
use crate::plot::Format;
use crate::problem::BvpProblem;
use femvi::bvp::{line_guess, node_times, BvpOptions};
use femvi::constraints::{
    solve_constrained_bvp_with, solve_constrained_forced_bvp, ConstrainedBvpSolution, Enforcement, ExprConstraints,
};
use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::Lagrangian;
use std::path::Path;
use std::time::Instant;

/// Solves a constrained boundary value problem with output into `dir` (the module
/// documentation), drawing the plots in format `plot` if given.
///
/// # Errors
/// A message and exit code 2 for input the library refuses (ends off the manifold, a moving
/// mesh, ...) or output that cannot be written; a failed Newton iteration is reported in the
/// summary instead.
pub fn run(
    problem: &BvpProblem,
    constraints: &(ExprConstraints, Enforcement),
    dir: &Path,
    plot: Option<Format>,
) -> Result<BvpSummary, (String, u8)> {
    crate::with_system!(&problem.system, l => run_with(l, problem, constraints, dir, plot))
}

fn run_with<L: Lagrangian>(
    lag: &L,
    problem: &BvpProblem,
    constraints: &(ExprConstraints, Enforcement),
    dir: &Path,
    plot: Option<Format>,
) -> Result<BvpSummary, (String, u8)> {
    let clock = Instant::now();
    let (bv, el) = (&problem.boundary, &problem.element);
    let guess = match &problem.guess {
        None => line_guess(bv, el),
        Some(file) => guess_from_file(file, &problem.coordinates, &node_times(bv, el)).map_err(|e| (e, 2))?,
    };
    let opts = BvpOptions {
        tolerance: problem.options.tolerance,
        max_iterations: problem.options.max_iterations,
        moving_mesh: problem.moving_mesh,
    };
    let io = |e: std::io::Error| (format!("cannot write the output in {}: {e}", dir.display()), 2);
    std::fs::create_dir_all(dir).map_err(io)?;
    let mut summary = BvpSummary {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        elements: bv.elements,
        time_mode: "fixed",
        action: None,
        residual_norm: None,
        scaled_residual: None,
        newton_iterations: 0,
        wall_seconds: 0.0,
        error: None,
        femvi_version: env!("CARGO_PKG_VERSION").to_string(),
        command_line: std::env::args().collect(),
        problem: problem.source.clone(),
    };
    let solved = match &problem.terms.force {
        Some(f) => solve_constrained_forced_bvp(lag, f, &constraints.0, el, bv, &guess, opts, constraints.1),
        None => solve_constrained_bvp_with(lag, &constraints.0, el, bv, &guess, opts, constraints.1),
    };
    match solved {
        Ok(sol) => {
            write_csv(lag, dir, problem, &sol).map_err(io)?;
            write_json(dir, &sol).map_err(io)?;
            if let Some(f) = plot {
                plots(problem, dir, f, &sol.solution.times, &sol.solution.q).map_err(|e| (e, 2))?;
            }
            summary.action = Some(sol.solution.action);
            summary.residual_norm = Some(sol.solution.residual_norm);
            summary.scaled_residual = Some(sol.solution.scaled_residual);
            summary.newton_iterations = sol.solution.newton_iterations;
        }
        Err(femvi::Error::Step(e)) => {
            summary.error = Some(format!(
                "Newton's method on the constrained discrete action failed: {e}"
            ));
            summary.residual_norm = Some(e.residual);
            summary.newton_iterations = e.iterations;
        }
        Err(e @ femvi::Error::SingularConstraints { step, .. }) if step > 0 && step < bv.elements => {
            summary.error = Some(format!(
                "Newton's method on the constrained discrete action failed: {e}"
            ));
        }
        Err(e) => return Err((e.to_string(), 2)),
    }
    summary.wall_seconds = clock.elapsed().as_secs_f64();
    let text = serde_json::to_string_pretty(&summary).map_err(|e| (e.to_string(), 2))?;
    std::fs::write(dir.join("summary.json"), text + "\n").map_err(io)?;
    Ok(summary)
}

/// trajectory.csv: step, t, q, p, energy, the multipliers and the constraint residual at the
/// element ends.
fn write_csv<L: Lagrangian>(
    lag: &L,
    dir: &Path,
    problem: &BvpProblem,
    run: &ConstrainedBvpSolution,
) -> std::io::Result<()> {
    let (sol, m) = (&run.solution, run.m);
    let n = problem.coordinates.len();
    let mut w = csv::Writer::from_path(dir.join("trajectory.csv"))?;
    let mut header = vec!["step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    header.extend((1..=m).map(|l| format!("lambda_{l}")));
    header.push("residual".into());
    w.write_record(&header)?;
    let num = |x: f64| format!("{x:?}");
    let (mut work, mut v) = (PointDerivatives::new(n), vec![0.0; n]);
    for (k, &t) in sol.times.iter().enumerate() {
        let (q, p) = (&sol.q[k * n..(k + 1) * n], &sol.p[k * n..(k + 1) * n]);
        let e = hamiltonian(lag, t, q, p, &mut v, &mut work).unwrap_or(f64::NAN);
        let mut row = vec![k.to_string(), num(t)];
        row.extend(q.iter().chain(p).map(|&x| num(x)));
        row.push(num(e));
        row.extend(run.multipliers[k * m..(k + 1) * m].iter().map(|&x| num(x)));
        row.push(num(run.residual[k]));
        w.write_record(&row)?;
    }
    w.flush()
}

/// constraints.json: residuals and the enforcement.
fn write_json(dir: &Path, run: &ConstrainedBvpSolution) -> std::io::Result<()> {
    let hidden = run.hidden_residual.iter().fold(0.0f64, |a, &b| a.max(b));
    let value = serde_json::json!({
        "constraints": run.m,
        "enforcement": format!("{:?}", run.enforcement).to_lowercase(),
        "max_residual": run.max_residual,
        "max_hidden_residual": hidden,
    });
    let text = serde_json::to_string_pretty(&value).map_err(std::io::Error::other)?;
    std::fs::write(dir.join("constraints.json"), text + "\n")
}
