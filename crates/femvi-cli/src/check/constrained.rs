//! `femvi check` on a constrained problem: the run of [`crate::constrained::solve`] with the symplecticity
//! defect of every step measured on the tangent space of the constraint manifold's cotangent
//! bundle ([`femvi::constraints::manifold_symplecticity`]), the energy error and drift, and
//! notes on the constraint residuals; the time-reversal test and the Noether momenta of
//! `[symmetries]` are not measured (notes say so).

use super::report::CheckReport;
use crate::problem::Problem;
use femvi::constraints::{manifold_symplecticity, Enforcement, ExprConstraints};
use femvi::Lagrangian;

/// The report for a constrained problem; Err carries a message and an exit code.
pub fn check(problem: &Problem, constraints: &(ExprConstraints, Enforcement)) -> Result<CheckReport, (String, u8)> {
    crate::with_system!(&problem.system, l => check_with(l, problem, constraints))
}

fn check_with<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    constraints: &(ExprConstraints, Enforcement),
) -> Result<CheckReport, (String, u8)> {
    if problem.energy.is_some() || !problem.events.is_empty() {
        return Err((
            "[constraints] are checked with fixed steps and without [[events]]".into(),
            crate::BAD_INPUT,
        ));
    }
    let p = problem.library(lag.clone());
    let options = problem.solve_options(1);
    let r = manifold_symplecticity(&p, &constraints.0, &problem.element, &options, constraints.1)
        .map_err(|e| (e.to_string(), crate::BAD_INPUT))?;
    let sol = &r.run.solution;
    if let Some(e) = &sol.error {
        return Err((e.to_string(), 1));
    }
    let e0 = sol.energy.first().copied().unwrap_or(0.0);
    let scale = if e0 == 0.0 { 1.0 } else { e0.abs() };
    let rel: Vec<f64> = sol.energy.iter().map(|h| (h - e0) / scale).collect();
    let autonomous = lag.is_autonomous();
    let mut notes = vec![
        format!(
            "constrained ({} constraints, {:?} enforcement): the symplecticity defect is measured on the tangent space of the constraint manifold's cotangent bundle; max |g(q)| over the run {:.3e}; start momentum projected by {:.3e}",
            r.run.m, r.run.enforcement, r.run.max_residual, r.run.start_projection
        ),
        "time reversal and [symmetries] momenta are not measured for constrained problems".into(),
    ];
    if !autonomous {
        notes.push("the Lagrangian depends on time: H is not conserved".into());
    }
    Ok(CheckReport {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: sol.steps,
        final_t: sol.t.last().copied().unwrap_or(problem.grid.t0()),
        symplecticity_defect: Some(r.max_defect),
        symplecticity_defect_relative: None,
        symplecticity_samples: r.steps,
        max_rel_energy_error: rel.iter().fold(0.0, |m, x| m.max(x.abs())),
        energy_conserved: autonomous,
        energy_drift: slope(&sol.t, &rel),
        momentum_drift: Default::default(),
        time_reversal_error: None,
        max_rel_discrete_energy_error: None,
        two_form: None,
        notes,
    })
}

/// Least-squares slope of y against t.
pub(super) fn slope(t: &[f64], y: &[f64]) -> f64 {
    let n = t.len() as f64;
    if t.len() < 2 {
        return 0.0;
    }
    let (tm, ym) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (a, b) in t.iter().zip(y) {
        sxy += (a - tm) * (b - ym);
        sxx += (a - tm) * (a - tm);
    }
    if sxx > 0.0 {
        sxy / sxx
    } else {
        0.0
    }
}
