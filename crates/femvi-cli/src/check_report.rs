//! What `femvi check` reports ([`CheckReport`], printed as JSON with `--json`): shared by the
//! check of a Lagrangian (`check.rs`) and the check on a constraint manifold
//! (`constrained/check.rs`), which `check.rs` dispatches to.

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
    /// Max over nodes of |H − H0|/|H0| (for a time-dependent L a change, not an error).
    pub max_rel_energy_error: f64,
    /// Whether H is conserved (false for a time-dependent Lagrangian).
    pub energy_conserved: bool,
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
