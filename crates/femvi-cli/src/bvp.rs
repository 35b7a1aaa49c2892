//! `femvi bvp`: solves a two-point boundary value problem by the discrete variational
//! principle (the library's [`femvi::bvp::solve`]; with `[forces]`,
//! [`femvi::forces::solve_forced_bvp`]; with `[constraints]`, `crate::bvp_constrained`),
//! from the straight line or from a trajectory file interpolated onto the mesh; writes
//! trajectory.csv and summary.json and, with plots on, coordinates.svg (coordinates against
//! t) and, with a moving mesh, steps.svg.

pub use crate::bvp_output::BvpSummary;
use crate::bvp_output::{guess_from_file, plots};
use crate::plot::Format;
use crate::problem::forces::ProblemForce;
use crate::problem::BvpProblem;
use femvi::bvp::{line_guess, node_times, BoundaryValues, BvpOptions, BvpSolution};
use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::Element;
use femvi::Lagrangian;
use std::path::Path;
use std::time::Instant;

/// How a solve ended: Ok with the summary (also on numerical failure, with `error` set), or
/// Err with a message and an exit code for bad input.
pub fn run(problem: &BvpProblem, dir: &Path) -> Result<BvpSummary, (String, u8)> {
    run_plotted(problem, dir, None)
}

/// [`run`], drawing the plots in format `plot` if given.
pub fn run_plotted(problem: &BvpProblem, dir: &Path, plot: Option<Format>) -> Result<BvpSummary, (String, u8)> {
    if let Some(c) = &problem.terms.constraints {
        return crate::bvp_constrained::run(problem, c, dir, plot);
    }
    crate::with_system!(&problem.system, l => run_with(l, problem, dir, plot))
}

fn run_with<L: Lagrangian>(
    lag: &L,
    problem: &BvpProblem,
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
        time_mode: if problem.moving_mesh { "energy" } else { "fixed" },
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
    match solve_bvp(lag, problem.terms.force.as_ref(), el, bv, &guess, opts) {
        Ok(sol) => {
            let n = lag.dim();
            let mut csv = csv::Writer::from_path(dir.join("trajectory.csv")).map_err(|e| (e.to_string(), 2))?;
            let mut header = vec!["step".to_string(), "t".to_string()];
            header.extend(problem.coordinates.iter().cloned());
            header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
            header.push("energy".into());
            csv.write_record(&header).map_err(|e| (e.to_string(), 2))?;
            let mut work = PointDerivatives::new(n);
            let mut v = vec![0.0; n];
            for (k, t) in sol.times.iter().enumerate() {
                let (q, p) = (&sol.q[k * n..(k + 1) * n], &sol.p[k * n..(k + 1) * n]);
                let e = hamiltonian(lag, *t, q, p, &mut v, &mut work).unwrap_or(f64::NAN);
                let mut row = vec![k.to_string(), format!("{t:?}")];
                row.extend(q.iter().chain(p).map(|x| format!("{x:?}")));
                row.push(format!("{e:?}"));
                csv.write_record(&row).map_err(|e| (e.to_string(), 2))?;
            }
            csv.flush().map_err(io)?;
            if let Some(f) = plot {
                plots(problem, dir, f, &sol.times, &sol.q).map_err(|e| (e, 2))?;
            }
            summary.action = Some(sol.action);
            summary.residual_norm = Some(sol.residual_norm);
            summary.scaled_residual = Some(sol.scaled_residual);
            summary.newton_iterations = sol.newton_iterations;
        }
        Err(femvi::Error::Step(e)) => {
            summary.error = Some(format!("Newton's method on the discrete action failed: {e}"));
            summary.residual_norm = Some(e.residual);
            summary.newton_iterations = e.iterations;
        }
        Err(e) => return Err((e.to_string(), 2)),
    }
    summary.wall_seconds = clock.elapsed().as_secs_f64();
    let text = serde_json::to_string_pretty(&summary).map_err(|e| (e.to_string(), 2))?;
    std::fs::write(dir.join("summary.json"), text + "\n").map_err(io)?;
    Ok(summary)
}

/// The boundary value problem's solve under `force` if it has one, else the conservative
/// [`femvi::bvp::solve`].
///
/// # Errors
/// As the library's solvers.
pub fn solve_bvp<L: Lagrangian>(
    lag: &L,
    force: Option<&ProblemForce>,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
) -> femvi::Result<BvpSolution> {
    match force {
        Some(f) => femvi::forces::solve_forced_bvp(lag, f, element, bv, guess, options),
        None => femvi::bvp::solve(lag, element, bv, guess, options),
    }
}
