//! What `femvi check` reports ([`CheckReport`], printed as JSON with `--json`): shared by the
//! check of a Lagrangian (`mod.rs`), the check on a constraint manifold (`constrained.rs`)
//! and the check of adaptive steps (`adaptive.rs`), which `mod.rs` dispatches to; and the
//! reversibility test they share ([`is_reversible`]).

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

impl CheckReport {
    /// The report of the library's check `r` of `problem`: its figures as they are, the
    /// Noether momenta named by their symmetries, the time reversal only where the Lagrangian
    /// is `reversible`, `energy_conserved` as given, and `notes`.
    pub fn from_library(
        problem: &crate::problem::Problem,
        r: femvi::diagnostics::CheckReport,
        (energy_conserved, reversible): (bool, bool),
        notes: Vec<String>,
    ) -> Self {
        CheckReport {
            name: problem.name.clone(),
            scheme: problem.scheme_label.clone(),
            steps: r.steps,
            final_t: r.final_t,
            symplecticity_defect: r.symplecticity_defect,
            symplecticity_defect_relative: r.symplecticity_defect_relative,
            symplecticity_samples: r.symplecticity_samples,
            max_rel_energy_error: r.max_rel_energy_error,
            energy_conserved,
            energy_drift: r.energy_drift,
            momentum_drift: problem
                .symmetries
                .iter()
                .zip(&r.momentum_drift)
                .map(|(s, d)| (s.label(&problem.coordinates), *d))
                .collect(),
            time_reversal_error: r.time_reversal_error.filter(|_| reversible),
            max_rel_discrete_energy_error: r.max_rel_discrete_energy_error,
            two_form: r.two_form.map(|t| TwoForm {
                formula: t.formula,
                max_rel_difference: t.max_rel_difference,
                samples: t.samples,
            }),
            notes,
        }
    }
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

/// Whether L(t, q, −v) = L(t, q, v) (to 1e-12 relative) at eight pseudo-random points with q
/// near `q0` and v of unit size (the points are fixed, so the answer is reproducible).
pub fn is_reversible<L: Lagrangian>(lag: &L, q0: &[f64], t0: f64) -> bool {
    let n = lag.dim();
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..8).all(|_| {
        let t = t0 + next();
        let q: Vec<f64> = (0..n)
            .map(|i| q0.get(i).copied().unwrap_or(0.0) + 0.5 * next())
            .collect();
        let v: Vec<f64> = (0..n).map(|_| next()).collect();
        let minus: Vec<f64> = v.iter().map(|x| -x).collect();
        let (a, b): (f64, f64) = (lag.value(t, &q, &v), lag.value(t, &q, &minus));
        !(a.is_finite() && b.is_finite()) || (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1.0)
    })
}
