//! Problems with a `[constraints]` table (holonomic constraints, [`femvi::constraints`]):
//! `femvi run` writes trajectory.csv with the columns of an unconstrained run plus the
//! multipliers `lambda_1 … lambda_m` (those of the exact flow at each node: −Gᵀλ is the
//! constraint force) and `residual` (max |g(q)|), summary.json, and constraints.json (the
//! largest constraint and hidden-constraint residuals, how much the start momentum was
//! projected onto the manifold's cotangent space, the enforcement). With a `[forces]` table too
//! the run is [`femvi::constraints::solve_constrained_forced`] (discrete Lagrange–d'Alembert on
//! the augmented action): trajectory.csv gains the `work` column after `energy` and summary.json
//! the energy balance as forced runs report it ([`crate::summary::report_work`]). `femvi check`
//! measures symplecticity on the manifold (`check.rs`); `femvi bvp` solves constrained boundary
//! value problems (`bvp.rs`). Commands and modes that cannot handle constraints refuse them
//! through the table of [`crate::problem::capabilities`] (exit code 2).

pub mod bvp;
pub mod check;

use crate::outcome::{finish, Outcome};
use crate::problem::forces::ProblemForce;
use crate::problem::Problem;
use crate::run_output::RunOutput;
use crate::summary::empty_summary;
use femvi::constraints::{
    solve_constrained_forced, solve_constrained_with, ConstrainedSolution, Enforcement, ExprConstraints,
    ForcedConstrainedSolution,
};
use femvi::Lagrangian;
use std::path::Path;
use std::time::Instant;

/// Runs a constrained problem with output into `dir` (the module documentation); the options
/// its terms refuse were refused before ([`crate::problem::capabilities`]).
pub fn run(
    problem: &Problem,
    constraints: &(ExprConstraints, Enforcement),
    dir: &Path,
    out: RunOutput,
    command: &[String],
) -> std::io::Result<Outcome> {
    crate::with_system!(&problem.system, l => run_with(l, problem, (constraints, problem.terms.force.as_ref()), (dir, out), command))
}

/// The library's constrained solve of a loaded problem from `start` (the file's, or an
/// ensemble member's): what `femvi run` writes.
///
/// # Errors
/// The library's refusal (bad start, unsupported options) as a message.
pub fn solve<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    start: femvi::Start,
    constraints: &(ExprConstraints, Enforcement),
) -> Result<ConstrainedSolution, String> {
    let p = femvi::Problem::new(lag.clone(), start, problem.grid.t0(), problem.grid.end());
    let options = problem.solve_options(problem.every);
    solve_constrained_with(&p, &constraints.0, &problem.element, &options, constraints.1).map_err(|e| e.to_string())
}

/// The library's constrained solve under the force of a loaded problem with both tables, from
/// `start`: what `femvi run` writes.
///
/// # Errors
/// The library's refusal (bad start, unsupported options) as a message.
pub fn solve_forced<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    start: femvi::Start,
    constraints: &(ExprConstraints, Enforcement),
    force: &ProblemForce,
) -> Result<ForcedConstrainedSolution, String> {
    let p = femvi::Problem::new(lag.clone(), start, problem.grid.t0(), problem.grid.end());
    let options = problem.solve_options(problem.every);
    solve_constrained_forced(&p, force, &constraints.0, &problem.element, &options, constraints.1)
        .map_err(|e| e.to_string())
}

// One arm of `with_system!` is a Copy type; `solve` clones.
fn run_with<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    (constraints, force): (&(ExprConstraints, Enforcement), Option<&ProblemForce>),
    (dir, out): (&Path, RunOutput),
    command: &[String],
) -> std::io::Result<Outcome> {
    let clock = Instant::now();
    let solved = match force {
        Some(f) => solve_forced(lag, problem, problem.start.clone(), constraints, f)
            .map(|r| (r.constrained, Some((r.work, r.balance)))),
        None => solve(lag, problem, problem.start.clone(), constraints).map(|r| (r, None)),
    };
    let (run, forced) = match solved {
        Ok(run) => run,
        Err(msg) => return Ok(Outcome::Rejected(msg)),
    };
    let work = forced.as_ref().map(|(w, _)| &w[..]);
    std::fs::create_dir_all(dir)?;
    let (header, rows) = table(problem, &run, work);
    crate::record::write_trajectory(dir, &header, &rows, &out)?;
    if out.plots {
        let title = format!("{} ({}, {} constraints)", problem.name, problem.scheme_label, run.m);
        let n = problem.coordinates.len();
        crate::record::plot_trajectory(dir, out.plot_format, &title, &header, &rows, n)
            .map_err(std::io::Error::other)?;
    }
    write_json(dir, &run)?;
    let sol = &run.solution;
    let mut summary = empty_summary(problem, clock, String::new(), command);
    let (n, last) = (sol.n, sol.len().saturating_sub(1));
    summary.steps = sol.steps;
    summary.final_t = sol.t.get(last).copied().unwrap_or(problem.grid.t0());
    summary.final_q = sol.q.get(last * n..(last + 1) * n).unwrap_or(&[]).to_vec();
    summary.final_p = sol.p.get(last * n..(last + 1) * n).unwrap_or(&[]).to_vec();
    let e0 = sol.energy.first().copied().unwrap_or(0.0);
    let scale = if e0 == 0.0 { 1.0 } else { e0.abs() };
    summary.max_rel_energy_error = sol.energy.iter().fold(0.0, |m, h| m.max((h - e0).abs() / scale));
    if let Some((work, balance)) = &forced {
        crate::summary::report_work(&mut summary, sol, balance, work);
    }
    summary.mean_solver_iterations = sol.mean_iterations;
    summary.error = sol.error.as_ref().map(|e| e.to_string());
    summary.status = crate::summary::status_of(summary.error.as_deref()).into();
    summary.wall_seconds = clock.elapsed().as_secs_f64();
    finish(dir, summary)
}

/// The trajectory's table: step, t, q, p, energy, the work (forced runs), the multipliers
/// and the constraint residual at the kept nodes.
fn table(problem: &Problem, run: &ConstrainedSolution, work: Option<&[f64]>) -> (Vec<String>, Vec<f64>) {
    let (sol, m) = (&run.solution, run.m);
    let n = sol.n;
    let mut header = vec!["step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    if work.is_some() {
        header.push("work".into());
    }
    header.extend((1..=m).map(|l| format!("lambda_{l}")));
    header.push("residual".into());
    let mut rows = Vec::with_capacity(sol.len() * header.len());
    for i in 0..sol.len() {
        rows.extend([sol.step[i] as f64, sol.t[i]]);
        rows.extend_from_slice(&sol.q[i * n..(i + 1) * n]);
        rows.extend_from_slice(&sol.p[i * n..(i + 1) * n]);
        rows.push(sol.energy[i]);
        if let Some(w) = work {
            rows.push(w.get(i).copied().unwrap_or(f64::NAN));
        }
        rows.extend_from_slice(&run.multipliers[i * m..(i + 1) * m]);
        rows.push(run.residual[i]);
    }
    (header, rows)
}

/// constraints.json: residuals, the start projection and the enforcement.
fn write_json(dir: &Path, run: &ConstrainedSolution) -> std::io::Result<()> {
    let hidden = run.hidden_residual.iter().fold(0.0f64, |a, &b| a.max(b));
    let value = serde_json::json!({
        "constraints": run.m,
        "enforcement": format!("{:?}", run.enforcement).to_lowercase(),
        "max_residual": run.max_residual,
        "max_hidden_residual_kept_nodes": hidden,
        "start_projection": run.start_projection,
    });
    let text = serde_json::to_string_pretty(&value).map_err(std::io::Error::other)?;
    std::fs::write(dir.join("constraints.json"), text + "\n")
}
