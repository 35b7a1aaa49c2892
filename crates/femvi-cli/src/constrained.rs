//! Problems with a `[constraints]` table (holonomic constraints, [`femvi::constraints`]):
//! `femvi run` runs them as any run ([`crate::run`]: the one integrator with the constraints as
//! its term, `femvi::Integrator::with_constraints`, streamed rows, checkpoints and `--resume`,
//! plots), with trajectory.csv (and .npy) holding the columns of an unconstrained run plus the
//! multipliers `lambda_1 … lambda_m` (those of the exact flow at each node: −Gᵀλ is the
//! constraint force) and `residual` (max |g(q)|), summary.json, and constraints.json
//! ([`write_json`]: the largest constraint and hidden-constraint residuals, how much the start
//! momentum was projected onto the manifold's cotangent space, the enforcement). With a
//! `[forces]` table too the steps are the discrete Lagrange–d'Alembert principle on the
//! augmented action (`Integrator::with_constraints_and_force`): trajectory.csv gains the `work`
//! column after `energy` and summary.json the energy balance as forced runs report it. `femvi check`
//! measures symplecticity on the manifold (`check/constrained.rs`); `femvi bvp` solves
//! constrained boundary value problems (`bvp_constrained.rs`). Commands and modes that cannot handle constraints refuse them
//! through the table of [`crate::problem::capabilities`] (exit code 2).

use crate::problem::forces::ProblemForce;
use crate::problem::Problem;
use femvi::constraints::{
    solve_constrained_forced, solve_constrained_with, ConstrainedSolution, Enforcement, ExprConstraints,
    ForcedConstrainedSolution, NodeConstraints,
};
use femvi::Lagrangian;
use std::path::Path;

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

/// constraints.json: the residuals over the run, the start projection and the enforcement,
/// from the constraint quantities at the run's last node.
///
/// # Errors
/// The file could not be written.
pub fn write_json(dir: &Path, problem: &Problem, at: &NodeConstraints) -> std::io::Result<()> {
    let enforcement = problem.terms.constraints.as_ref().map(|(_, e)| *e).unwrap_or_default();
    let value = serde_json::json!({
        "constraints": at.multipliers.len(),
        "enforcement": format!("{enforcement:?}").to_lowercase(),
        "max_residual": at.max_residual,
        "max_hidden_residual_kept_nodes": at.max_hidden_residual,
        "start_projection": at.start_projection,
    });
    let text = serde_json::to_string_pretty(&value).map_err(std::io::Error::other)?;
    std::fs::write(dir.join("constraints.json"), text + "\n")
}
