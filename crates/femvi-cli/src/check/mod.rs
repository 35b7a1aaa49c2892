//! `femvi check`, one command for every kind of problem: [`check`] looks at the problem's
//! terms and runs the check that fits them, returning one [`Report`].
//! - A plain problem: the library's [`femvi::diagnostics::check()`] as a serializable report
//!   (here). Two things the CLI adds: for a time-dependent Lagrangian the energy figures are
//!   labelled as changes of a quantity that is not conserved (`energy_conserved`), and the
//!   time-reversal test is skipped (null, with a note) for a Lagrangian that is not
//!   reversible, L(t, q, −v) ≠ L(t, q, v), tested numerically at a few points.
//! - `[constraints]`: symplecticity on the manifold (`constrained.rs`).
//! - `[time] mode = "adaptive"`: the step map in fictitious time and the physical energy
//!   (`adaptive.rs`).
//! - `[forces]` (with or without constraints): the flow is not symplectic, so the energy
//!   balance H − H0 = W is measured instead (`forced.rs`).
//!
//! `report.rs` holds the symplectic report the first three share.

mod adaptive;
mod constrained;
mod forced;
pub mod report;
mod rotations;

use crate::problem::capabilities::Use;
use crate::problem::Problem;
use femvi::Lagrangian;
pub use forced::ForcedCheck;
pub use report::{is_reversible, CheckReport, TwoForm};
use serde::Serialize;

/// What `femvi check` reports: the symplecticity report, or for a problem with forces the
/// energy balance. Serialised as the report it holds (check.json keeps its fields).
#[derive(Debug, Serialize)]
#[serde(untagged)]
pub enum Report {
    /// Symplecticity, energy, momenta and time reversal (conservative problems).
    Symplectic(Box<CheckReport>),
    /// The energy balance of a problem with `[forces]`.
    Balance(ForcedCheck),
}

impl Report {
    /// The error that stopped the checked run, if the report has one (forced runs report it
    /// in place of failing).
    pub fn error(&self) -> Option<&str> {
        match self {
            Report::Symplectic(_) => None,
            Report::Balance(b) => b.error.as_deref(),
        }
    }
}

/// Runs the check that fits the problem's terms; Err carries a message and an exit code (1
/// numerical, 2 input).
///
/// # Example
///
/// ```
/// let text = "[system]\nmodel = \"harmonic\"\n[initial]\nq = [1.0]\np = [0.0]\n[time]\nstep = 0.1\nend = 1.0\n";
/// let p = femvi_cli::problem::load_text("x.toml".as_ref(), text, &[]).unwrap();
/// match femvi_cli::check::check(&p).unwrap() {
///     femvi_cli::check::Report::Symplectic(r) => assert!(r.symplecticity_defect.unwrap() < 1e-12),
///     femvi_cli::check::Report::Balance(_) => unreachable!("no forces"),
/// }
/// ```
pub fn check(problem: &Problem) -> Result<Report, (String, u8)> {
    if let Some(force) = &problem.terms.force {
        // Forced flows are not symplectic: their energy balance is measured instead.
        return forced::check(problem, force).map(Report::Balance);
    }
    let symplectic = |r: CheckReport| Report::Symplectic(Box::new(r));
    if let Some(c) = &problem.terms.constraints {
        return constrained::check(problem, c).map(symplectic);
    }
    if let Some(r) = &problem.terms.rotations {
        return rotations::check(problem, r).map(symplectic);
    }
    if let Some(a) = &problem.terms.adaptive {
        return adaptive::check(problem, a).map(symplectic);
    }
    problem
        .refuse(Use::Check, "femvi check")
        .map_err(|e| (e, crate::BAD_INPUT))?;
    crate::with_system!(&problem.system, l => check_with(l, problem)).map(symplectic)
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
pub fn print(report: &Report) {
    match report {
        Report::Symplectic(r) => print_symplectic(r),
        Report::Balance(b) => forced::print(b),
    }
}

fn print_symplectic(report: &CheckReport) {
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
