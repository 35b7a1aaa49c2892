//! `femvi check` on a problem with `[forces]`: the flow of a forced system is not symplectic
//! (the forces change the symplectic form at the rate of their curl in v) and H is not
//! conserved, so the check runs the problem and reports the energy balance instead: the
//! largest |H_k − H_0 − W_k| over every node, W the discrete work of the forces. With a
//! `[constraints]` table too the run is the forced constrained one
//! ([`femvi::constraints::solve_constrained_forced`]: the constraint forces do no work, so the
//! same balance holds) and the report adds the largest constraint residual max |g(q)|.

use crate::problem::forces::ProblemForce;
use crate::problem::Problem;
use femvi::Lagrangian;
use serde::Serialize;

/// What `femvi check` reports for a forced problem.
#[derive(Debug, Clone, Serialize)]
pub struct ForcedCheck {
    /// The problem's name.
    pub name: String,
    /// The element.
    pub scheme: String,
    /// Steps taken.
    pub steps: usize,
    /// Why the symplecticity is not measured.
    pub note: String,
    /// max_k |H_k − H_0 − W_k|.
    pub max_energy_balance_error: f64,
    /// The same relative to |H_0|.
    pub max_rel_energy_balance_error: f64,
    /// H at the first and the last node.
    pub energy_first: f64,
    /// H at the last node.
    pub energy_last: f64,
    /// W at the last node (the work of the forces).
    pub final_work: f64,
    /// With `[constraints]`: max |g(q)| over the run's nodes (absent without).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_constraint_residual: Option<f64>,
    /// The error that stopped the run, if any.
    pub error: Option<String>,
}

const NOTE: &str = "the problem has non-conservative forces ([forces]): its flow is not symplectic and H is not conserved, so the energy balance H(t) - H(0) = W(t) (W the discrete work of the forces) is checked instead";

/// Runs the forced problem and measures its energy balance.
///
/// # Errors
/// The library's refusal of the problem's options (exit code 2).
pub fn check(problem: &Problem, force: &ProblemForce) -> Result<ForcedCheck, (String, u8)> {
    if problem.terms.rotations.is_some() {
        return crate::with_system!(&problem.system, l => check_integrated(l, problem));
    }
    match &problem.terms.constraints {
        Some(c) => crate::with_system!(&problem.system, l => check_constrained(l, problem, force, c)),
        None => crate::with_system!(&problem.system, l => check_with(l, problem, force)),
    }
}

fn check_with<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    force: &ProblemForce,
) -> Result<ForcedCheck, (String, u8)> {
    let p = problem.library(lag.clone());
    let options = problem.solve_options(0);
    let sol = femvi::forces::solve_forced(&p, force, &problem.element, &options)
        .map_err(|e| (e.to_string(), crate::BAD_INPUT))?;
    let s = &sol.solution;
    Ok(ForcedCheck {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: s.steps,
        note: NOTE.into(),
        max_energy_balance_error: sol.balance.max_abs,
        max_rel_energy_balance_error: sol.balance.max_rel,
        energy_first: s.energy.first().copied().unwrap_or(f64::NAN),
        energy_last: s.energy.last().copied().unwrap_or(f64::NAN),
        final_work: sol.work.last().copied().unwrap_or(f64::NAN),
        max_constraint_residual: None,
        error: s.error.as_ref().map(|e| e.to_string()),
    })
}

/// [`check_with`] for a problem with rotations: the one integrator of the problem's terms
/// (torques on the Lie-group element), its balance over every node.
fn check_integrated<L: Lagrangian + Sync>(lag: &L, problem: &Problem) -> Result<ForcedCheck, (String, u8)> {
    let made = problem.integrator(lag, &problem.element, problem.grid.clone(), problem.start.clone(), None);
    let mut it = made.map_err(|e| (e.to_string(), crate::BAD_INPUT))?;
    let first = it.energy().map_err(|e| (e.to_string(), crate::NUMERICAL))?;
    let scale = if first == 0.0 { 1.0 } else { first.abs() };
    let (mut worst, mut last, mut error) = (0.0f64, first, None);
    loop {
        match it.step().and_then(|more| Ok((more, it.energy()?))) {
            Ok((true, h)) => {
                worst = worst.max((h - first - it.work()).abs());
                last = h;
            }
            Ok((false, _)) => break,
            Err(e) => {
                error = Some(e.to_string());
                break;
            }
        }
    }
    Ok(ForcedCheck {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: it.node().k,
        note: format!("{NOTE}; the rotations are stepped by the Lie-group element under the torques"),
        max_energy_balance_error: worst,
        max_rel_energy_balance_error: worst / scale,
        energy_first: first,
        energy_last: last,
        final_work: it.work(),
        max_constraint_residual: None,
        error,
    })
}

/// [`check_with`] for a problem with `[constraints]` too.
fn check_constrained<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    force: &ProblemForce,
    constraints: &(femvi::constraints::ExprConstraints, femvi::constraints::Enforcement),
) -> Result<ForcedCheck, (String, u8)> {
    if problem.energy.is_some() || !problem.events.is_empty() {
        return Err((
            "[forces] with [constraints] are checked with fixed steps and without [[events]]".into(),
            crate::BAD_INPUT,
        ));
    }
    let run = crate::constrained::solve_forced(lag, problem, problem.start.clone(), constraints, force)
        .map_err(|e| (e, crate::BAD_INPUT))?;
    let s = &run.constrained.solution;
    Ok(ForcedCheck {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: s.steps,
        note: format!(
            "{NOTE}; the problem has [constraints] ({} of them, {:?} enforcement), whose forces do no work",
            run.constrained.m, run.constrained.enforcement
        ),
        max_energy_balance_error: run.balance.max_abs,
        max_rel_energy_balance_error: run.balance.max_rel,
        energy_first: s.energy.first().copied().unwrap_or(f64::NAN),
        energy_last: s.energy.last().copied().unwrap_or(f64::NAN),
        final_work: run.work.last().copied().unwrap_or(f64::NAN),
        max_constraint_residual: Some(run.constrained.max_residual),
        error: s.error.as_ref().map(|e| e.to_string()),
    })
}

/// Prints the report for people.
pub fn print(report: &ForcedCheck) {
    println!("{} ({}), {} steps", report.name, report.scheme, report.steps);
    println!("note: {}", report.note);
    println!(
        "energy balance: max |H - H0 - W| = {:.3e} ({:.3e} relative); H {:.6e} -> {:.6e}, work {:.6e}",
        report.max_energy_balance_error,
        report.max_rel_energy_balance_error,
        report.energy_first,
        report.energy_last,
        report.final_work
    );
    if let Some(g) = report.max_constraint_residual {
        println!("constraints: max |g(q)| over the run = {g:.3e}");
    }
    if let Some(e) = &report.error {
        println!("error: {e}");
    }
}
