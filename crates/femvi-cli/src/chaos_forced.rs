//! `femvi chaos` for problems with `[forces]` (the library's
//! [`femvi::chaos::forced_indicators`]) or `[constraints]`
//! ([`femvi::chaos::constrained_indicators`]: tangent vectors on the constraint manifold,
//! 2(n − m) of them, the initial vector projected onto its phase space's tangent space): one
//! orbit's indicators, printed, as `--json` and in `--out`'s chaos.json and summary.json like
//! an unconstrained problem. Maps (`--grid`) are refused for them (not available yet).

use crate::chaos::{pick, Axis, Indicator, Indicators};
use crate::problem::Problem;
use femvi::chaos::{constrained_indicators, forced_indicators, ChaosOptions};
use femvi::Lagrangian;

/// The indicators of a problem with `[forces]` or `[constraints]`; None for a problem with
/// neither (the caller runs the unconstrained indicators).
///
/// # Errors
/// A message (bad input, exit code 2): both tables, `--grid`, energy mode, a transient that is
/// not a time ≥ 0, or the library's refusal of the problem (e.g. a start off the manifold).
pub fn compute(
    problem: &Problem,
    axes: &[Axis],
    wanted: &[Indicator],
    transient: f64,
) -> Result<Option<Vec<Indicators>>, String> {
    let force = crate::forced::force_of(problem)?;
    let constraints = crate::constrained::settings(problem)?;
    let what = match (&force, &constraints) {
        (None, None) => return Ok(None),
        (Some(_), Some(_)) => return Err("[forces] and [constraints] together are not supported (yet)".into()),
        (Some(_), None) => "[forces]",
        (None, Some(_)) => "[constraints]",
    };
    if !axes.is_empty() {
        return Err(format!(
            "femvi chaos --grid is not available with {what} (yet); run one orbit at a time"
        ));
    }
    if problem.energy.is_some() {
        return Err(format!(
            "[time] mode = \"energy\" is not available with {what}: use mode = \"fixed\""
        ));
    }
    if !(transient.is_finite() && transient >= 0.0) {
        return Err(format!("--transient must be a time >= 0, not {transient}"));
    }
    let chaos = ChaosOptions {
        spectrum: wanted.contains(&Indicator::Spectrum),
        spectrum_transient: transient,
        ..ChaosOptions::default()
    };
    let report = crate::with_system!(&problem.system, l => {
        one_orbit(l, problem, force.as_ref(), constraints.as_ref(), &chaos)
    });
    match report {
        Ok(r) => Ok(Some(vec![pick(&r, wanted)])),
        // A step that fails is in the report; an Err is the problem itself.
        Err(e) => Err(e.to_string()),
    }
}

// One arm of `with_system!` is a Copy type; the library problem clones.
fn one_orbit<L: Lagrangian + Clone>(
    lag: &L,
    problem: &Problem,
    force: Option<&crate::problem::forces::ProblemForce>,
    constraints: Option<&(femvi::constraints::ExprConstraints, femvi::constraints::Enforcement)>,
    chaos: &ChaosOptions,
) -> femvi::Result<femvi::chaos::ChaosReport> {
    let p = problem.library(lag.clone());
    let options = problem.solve_options(0);
    match (force, constraints) {
        (Some(f), _) => forced_indicators(&p, f, &problem.element, &options, chaos),
        (None, Some((c, enforcement))) => {
            constrained_indicators(&p, c, &problem.element, &options, *enforcement, chaos)
        }
        (None, None) => Err(femvi::Error::Invalid {
            what: "femvi chaos".into(),
            reason: "neither [forces] nor [constraints]".into(),
        }),
    }
}
