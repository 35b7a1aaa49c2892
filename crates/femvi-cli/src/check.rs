//! `femvi check`: the library's [`femvi::diagnostics::check`] on a problem file, as a
//! serializable report. Two things the CLI adds: for a time-dependent Lagrangian the energy
//! figures are labelled as changes of a quantity that is not conserved (`energy_conserved`),
//! and the time-reversal test is skipped (null, with a note) for a Lagrangian that is not
//! reversible, L(t, q, −v) ≠ L(t, q, v), tested numerically at a few points.

pub use crate::check_report::{is_reversible, CheckReport, TwoForm};
use crate::problem::capabilities::Use;
use crate::problem::Problem;
use femvi::Lagrangian;

/// Runs the check; Err carries a message and an exit code (1 numerical, 2 input).
pub fn check(problem: &Problem) -> Result<CheckReport, (String, u8)> {
    if let Some(c) = &problem.terms.constraints {
        return crate::constrained::check::check(problem, c);
    }
    if let Some(a) = &problem.terms.adaptive {
        return crate::adaptive::check::check(problem, a);
    }
    problem
        .refuse(Use::Check, "femvi check")
        .map_err(|e| (e, crate::BAD_INPUT))?;
    if problem.terms.force.is_some() {
        // Forced flows are not symplectic: femvi check measures their energy balance instead.
        return Err((
            "the symplecticity check does not apply to [forces] (the flow is not symplectic): use femvi_cli::forced::check".into(),
            crate::BAD_INPUT,
        ));
    }
    crate::with_system!(&problem.system, l => check_with(l, problem))
}

fn check_with<L: Lagrangian>(lag: &L, problem: &Problem) -> Result<CheckReport, (String, u8)> {
    let mut r = femvi::diagnostics::check(
        lag,
        &problem.element,
        problem.grid.clone(),
        problem.start.clone(),
        problem.options,
        problem.energy,
        &problem.symmetries,
    )
    .map_err(|e| {
        let code = if matches!(e, femvi::Error::Step(_)) { 1 } else { 2 };
        (e.to_string(), code)
    })?;
    let mut notes = std::mem::take(&mut r.notes);
    let autonomous = lag.is_autonomous();
    if !autonomous {
        notes.push("the Lagrangian depends on time: H is not conserved, so max_rel_energy_error and energy_drift measure its change, not an error".into());
    }
    let q0 = match &problem.start {
        femvi::Start::Velocity { q, .. } | femvi::Start::Momentum { q, .. } => q,
        femvi::Start::Positions { q0, .. } => q0,
    };
    let reversible = is_reversible(lag, q0, problem.grid.t0());
    if !reversible {
        notes.push("time reversal not tested: L(t, q, -v) != L(t, q, v) (checked at sample points), so reversing the momenta does not retrace the motion".into());
    }
    Ok(CheckReport::from_library(problem, r, (autonomous, reversible), notes))
}

/// Prints the report for a person (`femvi check` without `--json`).
pub fn print(report: &CheckReport) {
    println!(
        "{} ({}), {} steps to t = {}",
        report.name, report.scheme, report.steps, report.final_t
    );
    match report.symplecticity_defect {
        Some(d) => println!(
            "  symplecticity defect   {d:.3e} ({} steps sampled)",
            report.symplecticity_samples
        ),
        None => println!("  symplecticity defect   n/a"),
    }
    if report.energy_conserved {
        println!("  max rel energy error   {:.3e}", report.max_rel_energy_error);
    } else {
        println!(
            "  max rel energy change  {:.3e} (time-dependent L: H is not conserved)",
            report.max_rel_energy_error
        );
    }
    println!("  energy drift           {:.3e} per unit time", report.energy_drift);
    for (k, v) in &report.momentum_drift {
        println!("  momentum drift {k:<8} {v:.3e}");
    }
    match report.time_reversal_error {
        Some(r) => println!("  time reversal error    {r:.3e}"),
        None => println!("  time reversal error    n/a"),
    }
    if let Some(t) = &report.two_form {
        println!(
            "  two-form vs {:<10} {:.3e} max relative difference ({} steps)",
            t.formula, t.max_rel_difference, t.samples
        );
    }
    for note in &report.notes {
        println!("  note: {note}");
    }
}
