//! `femvi check`: the library's [`femvi::diagnostics::check`] on a problem file, as a
//! serializable report.

use crate::problem::Problem;
use femvi::Lagrangian;
use serde::Serialize;
use std::collections::BTreeMap;

/// The report, printed as JSON with `--json` (README.md documents the keys).
#[derive(Debug, Serialize)]
pub struct CheckReport {
    /// The problem's name.
    pub name: String,
    /// The element used.
    pub scheme: String,
    /// Steps taken.
    pub steps: usize,
    /// Time of the last node.
    pub final_t: f64,
    /// Max |MᵀJM − J| over the sampled steps (energy mode: of the extended map).
    pub symplecticity_defect: Option<f64>,
    /// The defect of each sample divided by max(1, |M|²), maximised.
    pub symplecticity_defect_relative: Option<f64>,
    /// Steps whose tangent map was checked.
    pub symplecticity_samples: usize,
    /// Max over nodes of |H − H0|/|H0|.
    pub max_rel_energy_error: f64,
    /// Least-squares slope of the relative energy error per unit time.
    pub energy_drift: f64,
    /// Symmetry label → max |J − J0|/|J0| of its Noether momentum.
    pub momentum_drift: BTreeMap<String, f64>,
    /// Distance between the start and the end of a forward-then-backward run with reversed
    /// momenta (None for time-dependent Lagrangians or variable steps).
    pub time_reversal_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    /// Energy mode: largest relative residual of the energy equations.
    pub max_rel_discrete_energy_error: Option<f64>,
    /// For n = 1 and the paper's Lagrangians: the two-form coefficient against (2.21), (2.31)
    /// or the corrected (2.51).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub two_form: Option<TwoForm>,
    /// Remarks on what was or was not measured.
    pub notes: Vec<String>,
}

/// The two-form comparison.
#[derive(Debug, Serialize)]
pub struct TwoForm {
    /// The paper's formula compared against.
    pub formula: String,
    /// Largest relative difference of the coefficients.
    pub max_rel_difference: f64,
    /// Steps sampled.
    pub samples: usize,
}

/// Runs the check; Err carries a message and an exit code (1 numerical, 2 input).
pub fn check(problem: &Problem) -> Result<CheckReport, (String, u8)> {
    crate::with_system!(&problem.system, l => check_with(l, problem))
}

fn check_with<L: Lagrangian>(lag: &L, problem: &Problem) -> Result<CheckReport, (String, u8)> {
    let r = femvi::diagnostics::check(
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
    Ok(CheckReport {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: r.steps,
        final_t: r.final_t,
        symplecticity_defect: r.symplecticity_defect,
        symplecticity_defect_relative: r.symplecticity_defect_relative,
        symplecticity_samples: r.symplecticity_samples,
        max_rel_energy_error: r.max_rel_energy_error,
        energy_drift: r.energy_drift,
        momentum_drift: problem
            .symmetries
            .iter()
            .zip(&r.momentum_drift)
            .map(|(s, d)| (s.label(&problem.coordinates), *d))
            .collect(),
        time_reversal_error: r.time_reversal_error,
        max_rel_discrete_energy_error: r.max_rel_discrete_energy_error,
        two_form: r.two_form.map(|t| TwoForm {
            formula: t.formula,
            max_rel_difference: t.max_rel_difference,
            samples: t.samples,
        }),
        notes: r.notes,
    })
}
