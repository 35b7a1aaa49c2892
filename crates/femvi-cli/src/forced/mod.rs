//! Problems with a `[forces]` table (issue 19): `femvi run` integrates them with the
//! library's [`femvi::forces::solve_forced`] (discrete Lagrange–d'Alembert, Newton with exact
//! Jacobians, or the fixed point for a mechanical system under forces independent of v) and
//! writes trajectory.csv with a `work` column (the accumulated discrete work W
//! of the forces, so that `energy` − energy₀ − `work` is the balance error) and summary.json
//! with `final_work` and, as `max_rel_energy_balance_error`, the largest
//! |H − H₀ − W| / |H₀| over every node. With `[time] mode = "energy"` the steps come from
//! the forced energy equation (`femvi::forces`, `forces/energy.rs`): trajectory.csv gains a
//! `discrete_energy` column Ẽ, summary.json the energy mode's step statistics and
//! `max_rel_discrete_energy_balance_error`, the largest |Ẽ − Ẽ₀ − W| / |Ẽ₀| (round-off). `femvi bvp` solves them with
//! [`femvi::forces::solve_forced_bvp`] ([`solve_bvp`]); `femvi check` reports the energy
//! balance instead of symplecticity (`check.rs`). Commands and options that cannot handle
//! forces refuse them through the table of [`crate::problem::capabilities`].

mod check;
pub mod models;

pub use check::{check, print, ForcedCheck};

use crate::outcome::{finish, Outcome};
use crate::problem::forces::ProblemForce;
use crate::problem::Problem;
use crate::run_output::RunOutput;
use crate::summary::{empty_summary, report_work};
use femvi::bvp::{BoundaryValues, BvpOptions, BvpSolution};
use femvi::forces::{solve_forced, ForcedSolution};
use femvi::{Element, Lagrangian};
use std::path::Path;
use std::time::Instant;

/// Integrates the loaded `problem` (its system as `lag`) under `force` with the problem's
/// element, grid, solver options and `every`: what `femvi run` writes.
///
/// # Errors
/// The library's message for options it does not support with forces (events, a start from
/// (q0, q1)) or bad input.
pub fn solve_problem<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    force: &ProblemForce,
    every: usize,
) -> Result<ForcedSolution, String> {
    if !problem.events.is_empty() {
        problem.refuse(crate::problem::capabilities::Use::Events, "femvi run")?;
    }
    let p = problem.library(lag.clone());
    let options = problem.solve_options(every);
    solve_forced(&p, force, &problem.element, &options).map_err(|e| e.to_string())
}

/// `femvi run` on a problem with forces (the module documentation).
pub fn run(
    problem: &Problem,
    force: &ProblemForce,
    dir: &Path,
    out: RunOutput,
    command: &[String],
) -> std::io::Result<Outcome> {
    crate::with_system!(&problem.system, l => run_with(l, problem, force, dir, out, command))
}

fn run_with<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    force: &ProblemForce,
    dir: &Path,
    out: RunOutput,
    command: &[String],
) -> std::io::Result<Outcome> {
    let clock = Instant::now();
    let sol = match solve_problem(lag, problem, force, problem.every) {
        Ok(s) => s,
        Err(msg) => return Ok(Outcome::Rejected(msg)),
    };
    std::fs::create_dir_all(dir)?;
    let (header, rows) = table(problem, &sol);
    crate::record::write_trajectory(dir, &header, &rows, &out)?;
    if out.plots {
        let title = format!("{} ({})", problem.name, problem.scheme_label);
        let n = problem.coordinates.len();
        crate::record::plot_trajectory(dir, out.plot_format, &title, &header, &rows, n)
            .map_err(std::io::Error::other)?;
    }
    let s = &sol.solution;
    let mut summary = empty_summary(problem, clock, String::new(), command);
    let (n, last) = (s.n, s.t.len().saturating_sub(1));
    summary.steps = s.steps;
    summary.final_t = s.t.get(last).copied().unwrap_or(problem.grid.t0());
    summary.final_q = s.q.get(last * n..(last + 1) * n).unwrap_or(&[]).to_vec();
    summary.final_p = s.p.get(last * n..(last + 1) * n).unwrap_or(&[]).to_vec();
    // The energy balance of a forced run is over every node (as `femvi.solve` reports it).
    summary.energy_nodes = s.energy_report.map(|r| r.nodes.name().to_string());
    report_work(&mut summary, s, &sol.balance, &sol.work);
    if let Some(stats) = s.energy_stats {
        summary.max_rel_discrete_energy_error = Some(stats.max_rel_residual);
        summary.min_step = Some(stats.min_step);
        summary.max_step = Some(stats.max_step);
        summary.degenerate_steps = Some(stats.degenerate_steps);
    }
    summary.max_rel_discrete_energy_balance_error = sol.discrete_balance.map(|b| b.max_rel);
    summary.mean_solver_iterations = s.mean_iterations;
    summary.error = s.error.as_ref().map(|e| e.to_string());
    summary.status = crate::summary::status_of(summary.error.as_deref()).into();
    summary.wall_seconds = clock.elapsed().as_secs_f64();
    finish(dir, summary)
}

/// The trajectory's table: step, t, q, p, energy, work (and in energy mode the discrete
/// energy) at the kept nodes.
fn table(problem: &Problem, sol: &ForcedSolution) -> (Vec<String>, Vec<f64>) {
    let s = &sol.solution;
    let n = s.n;
    let mut header = vec!["step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    header.push("work".into());
    let discrete = !sol.discrete_energy.is_empty();
    if discrete {
        header.push("discrete_energy".into());
    }
    let mut rows = Vec::with_capacity(s.t.len() * header.len());
    for (i, &t) in s.t.iter().enumerate() {
        rows.extend([s.step[i] as f64, t]);
        rows.extend_from_slice(&s.q[i * n..(i + 1) * n]);
        rows.extend_from_slice(&s.p[i * n..(i + 1) * n]);
        rows.extend([s.energy[i], sol.work[i]]);
        if discrete {
            rows.push(sol.discrete_energy.get(i).copied().unwrap_or(f64::NAN));
        }
    }
    (header, rows)
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
