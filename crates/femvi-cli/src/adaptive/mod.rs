//! `femvi run` in `[time] mode = "adaptive"`: fixed steps `ds` in the fictitious time s of
//! the Poincaré transformation dt/ds = g(q) ([`femvi::adaptive`], issue 21), with the monitor
//! g named in `[time] monitor` ("kepler": |q|^{3/2}; "nbody": the smoothed closest-pair
//! r^{3/2} of the n-body model; otherwise an expression in the coordinates and parameters;
//! default "kepler" for the Kepler model and "nbody" for n-body). Writes trajectory.csv with
//! the physical time t (columns step, t, q, p, energy, s) — or, with `output_step`, rows at
//! uniform physical times from the element polynomials (columns row, t, q, p, energy) — and
//! summary.json; the same table as trajectory.npy and columns.txt when NPY output is on
//! (`output.rs`); `[[events]]` located on the dense output in s (`femvi::adaptive`) into
//! events.csv and, with plots, Poincaré plots as for fixed steps; plots with `--plot`
//! (`plots.rs`). `femvi check` measures the step map in s and the physical energy
//! (`check.rs`).

pub mod check;
mod output;
mod plots;

use crate::outcome::{finish, Outcome};
use crate::problem::{Problem, System};
use crate::run_output::RunOutput;
use crate::summary::empty_summary;
use femvi::adaptive::{
    solve_adaptive, AdaptiveOptions, AdaptiveSolution, ExprMonitor, KeplerMonitor, Monitor, NBodyMonitor,
};
use femvi::{Lagrangian, Scalar};
use std::path::Path;
use std::time::Instant;

pub use crate::problem::AdaptiveTime;

/// The rows an adaptive run of `problem` will write when they are known before it starts:
/// with `output_step` h, ⌊span/h⌋ + 1 rows at uniform physical times (and as many times held
/// in memory). None for one row per node: their number follows the monitor along the orbit
/// (from g(q0)·ds it was 550× too large for the e = 0.9 Kepler example, which starts at
/// pericentre), so such runs are not estimated until adaptive runs stream (issue 33).
pub fn estimated_rows(problem: &Problem, settings: &AdaptiveTime) -> Option<f64> {
    let span = problem.grid.end() - problem.grid.t0();
    settings.output_step.map(|h| (span / h).floor() + 1.0)
}

/// The monitors a problem file can name.
enum AnyMonitor {
    Kepler(KeplerMonitor),
    NBody(NBodyMonitor),
    Expr(ExprMonitor),
}

impl Monitor for AnyMonitor {
    fn dim(&self) -> usize {
        match self {
            AnyMonitor::Kepler(g) => g.dim(),
            AnyMonitor::NBody(g) => g.dim(),
            AnyMonitor::Expr(g) => g.dim(),
        }
    }
    fn value<D: Scalar>(&self, q: &[D]) -> D {
        match self {
            AnyMonitor::Kepler(g) => g.value(q),
            AnyMonitor::NBody(g) => g.value(q),
            AnyMonitor::Expr(g) => g.value(q),
        }
    }
    // Forwarded, so that the built-in monitors' hand-coded derivatives are used (without it
    // every monitor went through the dual-number default).
    fn derivatives(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        match self {
            AnyMonitor::Kepler(g) => g.derivatives(q, grad, hess),
            AnyMonitor::NBody(g) => g.derivatives(q, grad, hess),
            AnyMonitor::Expr(g) => g.derivatives(q, grad, hess),
        }
    }
}

/// The monitor named in `[time] monitor`, or the model's default.
fn monitor(problem: &Problem, name: Option<&str>) -> Result<AnyMonitor, String> {
    let nbody = || match &problem.system {
        System::Gravity(l) => Ok(AnyMonitor::NBody(NBodyMonitor::new(
            l.potential.masses.len(),
            l.potential.dim,
        ))),
        _ => Err("[time] monitor = \"nbody\" needs the n-body model".to_string()),
    };
    match (name, &problem.system) {
        (Some("kepler"), _) | (None, System::Kepler(_)) => Ok(AnyMonitor::Kepler(KeplerMonitor)),
        (Some("nbody"), _) | (None, System::Gravity(_)) => nbody(),
        (Some(expr), _) => ExprMonitor::new(expr, &problem.coordinates, &problem.parameters)
            .map(AnyMonitor::Expr)
            .map_err(|e| format!("[time] monitor: {}", e.render())),
        (None, _) => Err(
            "[time] mode = \"adaptive\" needs `monitor` (\"kepler\", \"nbody\" or an expression in the coordinates)"
                .to_string(),
        ),
    }
}

/// Runs `problem` in adaptive mode with output into `dir` (the module documentation).
// One arm of the macro is a Copy type; the others need the clone.
#[allow(clippy::clone_on_copy)]
pub fn run(
    problem: &Problem,
    settings: &AdaptiveTime,
    dir: &Path,
    out: RunOutput,
    command: &[String],
) -> std::io::Result<Outcome> {
    crate::with_system!(&problem.system, l => run_with(l.clone(), problem, settings, dir, out, command))
}

fn run_with<L: Lagrangian>(
    lag: L,
    problem: &Problem,
    settings: &AdaptiveTime,
    dir: &Path,
    out: RunOutput,
    command: &[String],
) -> std::io::Result<Outcome> {
    let clock = Instant::now();
    let (t0, end) = (problem.grid.t0(), problem.grid.end());
    let saveat: Vec<f64> = match settings.output_step {
        Some(h) => {
            let rows = ((end - t0) / h * (1.0 + 4.0 * f64::EPSILON)).floor() as usize;
            (0..=rows).map(|i| t0 + i as f64 * h).filter(|&t| t <= end).collect()
        }
        None => vec![],
    };
    let p = femvi::Problem::new(lag, problem.start.clone(), t0, end);
    let events = problem.events.iter().map(|e| e.event()).collect();
    let sol = match solve_problem(&p, problem, settings, problem.every, saveat, events) {
        Ok(sol) => sol,
        Err(msg) => return Ok(Outcome::Rejected(msg)),
    };
    std::fs::create_dir_all(dir)?;
    output::write_trajectory(dir, problem, &p.lagrangian, &sol, settings, out)?;
    let mut summary = empty_summary(problem, clock, String::new(), command);
    if !problem.events.is_empty() {
        crate::events::write_events(dir, problem, &sol.events)?;
        if out.plots {
            crate::events::poincare(dir, problem, &sol.events, out.plot_format).map_err(std::io::Error::other)?;
        }
        summary.events_located = Some(sol.events.len());
        let stopper = sol.events.iter().find(|r| problem.events[r.event].stop);
        summary.stopped_by_event = Some(
            stopper
                .filter(|_| sol.stopped)
                .map(|r| problem.events[r.event].name.clone()),
        );
    }
    let last = sol.t.len().saturating_sub(1);
    let n = sol.n;
    summary.steps = sol.steps;
    summary.final_t = sol.t.get(last).copied().unwrap_or(t0);
    summary.final_q = sol.q.get(last * n..(last + 1) * n).unwrap_or(&[]).to_vec();
    summary.final_p = sol.p.get(last * n..(last + 1) * n).unwrap_or(&[]).to_vec();
    summary.max_rel_energy_error = max_rel_energy_error(&sol);
    summary.mean_solver_iterations = sol.mean_iterations;
    summary.error = sol.error.as_ref().map(|e| e.to_string());
    if out.plots {
        if let Err(e) = plots::draw(dir, out.plot_format, problem, &sol, settings.ds) {
            summary.error.get_or_insert(e);
        }
    }
    summary.status = crate::summary::status_of(summary.error.as_deref()).into();
    summary.wall_seconds = clock.elapsed().as_secs_f64();
    finish(dir, summary)
}

/// Integrates the loaded `problem` (its system as `p`) in adaptive mode with its monitor,
/// keeping every `every`-th node and the states at the physical times `saveat`, locating
/// `events`: what `femvi run` writes and the Python package returns.
///
/// # Errors
/// The message of a bad monitor or of the library's refusal.
pub fn solve_problem<L: Lagrangian>(
    p: &femvi::Problem<L>,
    problem: &Problem,
    settings: &AdaptiveTime,
    every: usize,
    saveat: Vec<f64>,
    events: Vec<femvi::solution::Event>,
) -> Result<AdaptiveSolution, String> {
    let g = monitor(problem, settings.monitor.as_deref())?;
    let options = AdaptiveOptions {
        solver: problem.options,
        every,
        saveat,
        events,
        energy_level: energy_level(p, problem),
        ..AdaptiveOptions::step(settings.ds)
    };
    solve_adaptive(p, g, &problem.element, &options).map_err(|e| e.to_string())
}

/// E₀ = H(q₀, p₀) in double-double arithmetic for the Kepler and n-body models (an E₀ off
/// by δ shifts the mean motion by about δ/E: `femvi::adaptive::kepler_energy`); None for
/// the others (the library then takes H in f64).
fn energy_level<L: Lagrangian>(p: &femvi::Problem<L>, problem: &Problem) -> Option<f64> {
    let (q0, p0) = femvi::adaptive::start_momentum(&p.lagrangian, p.t0, &p.start).ok()?;
    let level = match &problem.system {
        System::Kepler(l) => femvi::adaptive::kepler_energy(l.potential.mu, &q0, &p0),
        System::Gravity(l) => {
            let g = &l.potential;
            femvi::adaptive::nbody_energy(g.g, &g.masses, g.dim, &q0, &p0)
        }
        _ => return None,
    };
    level.is_finite().then_some(level)
}

/// The largest |H − E₀| / |E₀| over the kept nodes (|H − E₀| where E₀ = 0), as summary.json
/// has it.
pub fn max_rel_energy_error(sol: &AdaptiveSolution) -> f64 {
    let scale = if sol.e0 == 0.0 { 1.0 } else { sol.e0.abs() };
    sol.energy.iter().fold(0.0, |m, h| m.max((h - sol.e0).abs() / scale))
}
