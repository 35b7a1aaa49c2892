//! `femvi check`: runs a problem and measures what the paper proves — the symplecticity defect
//! of the step maps ((2.17), (2.46)), the energy error and its drift, the Noether momenta of
//! declared symmetries, and the time-reversal error of the (symmetric) schemes.

use crate::problem::Problem;
use femvi::diagnostics::symplecticity_defect;
use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::{Integrator, Lagrangian, Start, TimeGrid};
use serde::Serialize;
use std::collections::BTreeMap;

/// At most this many steps get their tangent map checked (evenly spaced).
const MAX_SAMPLES: usize = 1000;

/// The report, printed as JSON with `--json`.
#[derive(Debug, Serialize)]
pub struct CheckReport {
    pub name: String,
    pub scheme: String,
    pub steps: usize,
    pub final_t: f64,
    /// max |MᵀJM − J| over the sampled steps; in energy mode of the extended map in the
    /// variables (q, t; p, −E) (the paper's (3.6)).
    pub symplecticity_defect: Option<f64>,
    /// The same, each sample divided by max(1, max|M|²): round-off makes the absolute defect
    /// grow like ε|M|² where the map has large entries (ill-conditioned energy equations).
    pub symplecticity_defect_relative: Option<f64>,
    /// How many steps were sampled for the defect.
    pub symplecticity_samples: usize,
    pub max_rel_energy_error: f64,
    /// Slope of the relative energy error against time (per unit time), least squares.
    pub energy_drift: f64,
    /// max |J − J₀| / |J₀| (absolute if J₀ = 0) per declared symmetry.
    pub momentum_drift: BTreeMap<String, f64>,
    /// Distance between the start and the end of a forward-then-backward run (null where
    /// the Lagrangian depends on time or the steps are variables).
    pub time_reversal_error: Option<f64>,
    /// Energy mode: the largest relative residual of the discrete energy equations.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_discrete_energy_error: Option<f64>,
    pub notes: Vec<String>,
}

/// Runs the check; Err is a message (input or numerical failure) with its exit code.
pub fn check(problem: &Problem) -> Result<CheckReport, (String, u8)> {
    crate::with_system!(&problem.system, l => check_with(l, problem))
}

fn numerical(e: femvi::Error) -> (String, u8) {
    let code = if matches!(e, femvi::Error::Step(_)) { 1 } else { 2 };
    (e.to_string(), code)
}

fn check_with<L: Lagrangian>(lag: &L, problem: &Problem) -> Result<CheckReport, (String, u8)> {
    let n = lag.dim();
    let (grid, start) = (problem.grid.clone(), problem.start.clone());
    let mut it = match problem.energy {
        None => Integrator::new(lag, &problem.element, grid, start, problem.options),
        Some(e) => Integrator::with_energy(lag, &problem.element, grid, start, problem.options, e),
    }
    .map_err(numerical)?;
    let mut notes = vec![];
    let total = if problem.energy.is_none() {
        problem.grid.count()
    } else {
        0
    };
    let stride = (total / MAX_SAMPLES).max(1);
    let mut work = PointDerivatives::new(n);
    let mut v = match &problem.start {
        Start::Velocity { v, .. } => v.clone(),
        _ => vec![0.0; n],
    };
    let node = it.node();
    let (q0, p0, t0) = (node.q.to_vec(), node.p.to_vec(), node.t);
    let h0 = hamiltonian(lag, t0, &q0, &p0, &mut v, &mut work).map_err(numerical)?;
    let j0: Vec<f64> = problem.symmetries.iter().map(|s| s.momentum(&q0, &p0)).collect();
    let mut drift = vec![0.0f64; j0.len()];
    let (mut max_rel, mut defect, mut defect_rel, mut samples) = (0.0f64, 0.0f64, 0.0f64, 0usize);
    // Online least squares of the relative energy error against time.
    let (mut sn, mut st, mut se, mut stt, mut ste) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut steps_taken = vec![];
    let mut last_t = t0;
    while it.step().map_err(numerical)? {
        let k = it.node().k;
        // In energy mode the first element has its step as a parameter: no extended map there.
        let sample = k.is_multiple_of(stride) || it.finished();
        if sample && (problem.energy.is_none() || k >= 2) {
            let (m, d) = if problem.energy.is_none() {
                (it.tangent_map().map_err(numerical)?, n)
            } else {
                (it.extended_tangent_map().map_err(numerical)?, n + 1)
            };
            let dev = symplecticity_defect(&m, d);
            let size = m.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            defect = defect.max(dev);
            defect_rel = defect_rel.max(dev / size.powi(2).max(1.0));
            samples += 1;
        }
        let node = it.node();
        steps_taken.push(node.t - last_t);
        last_t = node.t;
        let h = hamiltonian(lag, node.t, node.q, node.p, &mut v, &mut work).map_err(numerical)?;
        let rel = if h0 != 0.0 { (h - h0) / h0.abs() } else { h - h0 };
        max_rel = max_rel.max(rel.abs());
        sn += 1.0;
        st += node.t;
        se += rel;
        stt += node.t * node.t;
        ste += node.t * rel;
        for (i, s) in problem.symmetries.iter().enumerate() {
            let j = s.momentum(node.q, node.p);
            let d = if j0[i] != 0.0 {
                (j - j0[i]).abs() / j0[i].abs()
            } else {
                (j - j0[i]).abs()
            };
            drift[i] = drift[i].max(d);
        }
    }
    let denom = sn * stt - st * st;
    let energy_drift = if denom > 0.0 { (sn * ste - st * se) / denom } else { 0.0 };
    let node = it.node();
    let (final_q, final_p, final_t) = (node.q.to_vec(), node.p.to_vec(), node.t);
    let (symplecticity_defect, symplecticity_defect_relative) = if samples > 0 {
        (Some(defect), Some(defect_rel))
    } else {
        (None, None)
    };
    if problem.energy.is_some() {
        notes.push("energy mode: symplecticity of the extended map in (q, t; p, -E), paper (3.6)".into());
    }
    // Time reversal: from (q_N, −p_N) back over the same steps in reverse order.
    let time_reversal_error = if problem.energy.is_none() && lag.is_autonomous() && !steps_taken.is_empty() {
        let back: Vec<f64> = steps_taken.iter().rev().cloned().collect();
        let span: f64 = back.iter().sum();
        let grid = TimeGrid::steps(0.0, back, span).map_err(numerical)?;
        let start = Start::Momentum {
            q: final_q.clone(),
            p: final_p.iter().map(|x| -x).collect(),
        };
        let mut rev = Integrator::new(lag, &problem.element, grid, start, problem.options).map_err(numerical)?;
        while rev.step().map_err(numerical)? {}
        let r = rev.node();
        let dist =
            r.q.iter()
                .zip(&q0)
                .map(|(a, b)| (a - b).abs())
                .chain(r.p.iter().zip(&p0).map(|(a, b)| (a + b).abs()))
                .fold(0.0, f64::max);
        Some(dist)
    } else {
        notes.push("time reversal skipped: the Lagrangian depends on time, or the steps are variables".into());
        None
    };
    if stride > 1 {
        notes.push(format!(
            "symplecticity sampled at {samples} of {total} steps (every {stride}-th)"
        ));
    }
    let momentum_drift = problem
        .symmetries
        .iter()
        .zip(&drift)
        .map(|(s, d)| (s.label(&problem.coordinates), *d))
        .collect();
    Ok(CheckReport {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: steps_taken.len(),
        final_t,
        symplecticity_defect,
        symplecticity_defect_relative,
        symplecticity_samples: samples,
        max_rel_energy_error: max_rel,
        energy_drift,
        momentum_drift,
        time_reversal_error,
        max_rel_discrete_energy_error: it.energy_stats().map(|s| s.max_rel_residual),
        notes,
    })
}
