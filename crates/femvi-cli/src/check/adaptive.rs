//! `femvi check` in `[time] mode = "adaptive"`. An adaptive run is fixed steps ds of the
//! integrator on the time-transformed Lagrangian L_g(q, q') = g(q)·(L(q, q'/g(q)) + E₀)
//! ([`femvi::adaptive::TimeTransformed`]), so its step map (q, p) ↦ (q, p) is the ordinary
//! step map of L_g, whose momentum is the physical p: the library's check
//! ([`femvi::diagnostics::check()`]) on L_g over the steps the run takes measures the
//! symplecticity of that map (the tangent map by implicit differentiation of the step, as for
//! any Lagrangian), its time reversal (L_g is reversible when L is) and the Noether momenta
//! (conserved when g shares the symmetry). The energy figures are the physical ones: H of L at
//! the run's kept nodes against E₀, and the slope of its relative error per unit physical time.

use super::report::{is_reversible, CheckReport};
use crate::adaptive::{monitor, solve_problem, AdaptiveTime};
use crate::problem::Problem;
use femvi::adaptive::{AdaptiveSolution, TimeTransformed};
use femvi::{Lagrangian, Method, Start, TimeGrid};

/// The check of an adaptive problem (the module documentation); Err carries a message and an
/// exit code (1 numerical, 2 input).
// One arm of the macro is a Copy type; the others need the clone.
#[allow(clippy::clone_on_copy)]
pub fn check(problem: &Problem, settings: &AdaptiveTime) -> Result<CheckReport, (String, u8)> {
    crate::with_system!(&problem.system, l => check_with(l.clone(), problem, settings))
}

fn check_with<L: Lagrangian + Clone>(
    lag: L,
    problem: &Problem,
    settings: &AdaptiveTime,
) -> Result<CheckReport, (String, u8)> {
    let input = |e: String| (e, crate::BAD_INPUT);
    let (t0, end) = (problem.grid.t0(), problem.grid.end());
    let p = femvi::Problem::new(lag.clone(), problem.start.clone(), t0, end);
    let sol = solve_problem(&p, problem, settings, problem.every, vec![], vec![]).map_err(input)?;
    if let Some(e) = &sol.error {
        return Err((format!("the adaptive run failed: {e}"), 1));
    }
    let g = monitor(problem, settings.monitor.as_deref()).map_err(input)?;
    let lg = TimeTransformed::new(lag.clone(), g, sol.e0).map_err(|e| input(e.to_string()))?;
    let (q0, p0) = femvi::adaptive::start_momentum(&lag, t0, &problem.start).map_err(|e| input(e.to_string()))?;
    // The steps the run took, as fixed steps in s (the run's solver: Auto is full Newton).
    let ds = settings.ds;
    let grid = TimeGrid::uniform(0.0, ds, sol.steps.max(1) as f64 * ds).map_err(|e| input(e.to_string()))?;
    let mut options = problem.options;
    if options.method == Method::Auto {
        options.method = Method::FullNewton;
    }
    let start = Start::Momentum { q: q0.clone(), p: p0 };
    let mut r = femvi::diagnostics::check(&lg, &problem.element, grid, start, options, None, &problem.symmetries)
        .map_err(|e| {
            let code = if matches!(e, femvi::Error::Step(_)) { 1 } else { 2 };
            (e.to_string(), code)
        })?;
    let mut notes = std::mem::take(&mut r.notes);
    notes.push(format!(
        "adaptive: symplecticity, time reversal and momenta are of the step map (q, p) -> (q, p) \
         in fictitious time s (fixed steps ds = {ds} on L_g = g(q)(L(q, q'/g) + E0)); the energy \
         figures are of the physical H at the run's kept nodes, in physical time"
    ));
    let reversible = is_reversible(&lag, &q0, t0);
    if !reversible {
        notes.push("time reversal not tested: L(t, q, -v) != L(t, q, v) (checked at sample points)".into());
    }
    // The run's steps in t and its physical energy, in place of those of the run in s.
    let mut report = CheckReport::from_library(problem, r, (true, reversible), notes);
    report.steps = sol.steps;
    report.final_t = sol.t.last().copied().unwrap_or(t0);
    report.max_rel_energy_error = crate::adaptive::max_rel_energy_error(&sol);
    report.energy_drift = energy_drift(&sol);
    report.max_rel_discrete_energy_error = None;
    Ok(report)
}

/// The least-squares slope of (H − E₀)/|E₀| against physical time over the kept nodes (0
/// for fewer than two distinct times).
fn energy_drift(sol: &AdaptiveSolution) -> f64 {
    let scale = if sol.e0 == 0.0 { 1.0 } else { sol.e0.abs() };
    let m = sol.t.len().min(sol.energy.len()) as f64;
    if m < 2.0 {
        return 0.0;
    }
    let errs = sol.energy.iter().map(|h| (h - sol.e0) / scale);
    let (st, se) = (sol.t.iter().sum::<f64>() / m, errs.clone().sum::<f64>() / m);
    let (mut num, mut den) = (0.0, 0.0);
    for (t, e) in sol.t.iter().zip(errs) {
        num += (t - st) * (e - se);
        den += (t - st) * (t - st);
    }
    if den > 0.0 {
        num / den
    } else {
        0.0
    }
}
