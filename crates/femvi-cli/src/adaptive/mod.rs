//! `femvi run` in `[time] mode = "adaptive"`: fixed steps `ds` in the fictitious time s of
//! the Poincaré transformation dt/ds = g(q) ([`femvi::adaptive`], issue 21), with the monitor
//! g named in `[time] monitor` ("kepler": |q|^{3/2}; "nbody": the smoothed closest-pair
//! r^{3/2} of the n-body model; otherwise an expression in the coordinates and parameters;
//! default "kepler" for the Kepler model and "nbody" for n-body). Writes trajectory.csv with
//! the physical time t (columns step, t, q, p, energy, s) — or, with `output_step`, rows at
//! uniform physical times from the element polynomials (columns row, t, q, p, energy) — and
//! summary.json; the same table as trajectory.npy and columns.txt when NPY output is on;
//! `[[events]]` located on the dense output in s (`femvi::adaptive`) into events.csv and,
//! with plots, Poincaré plots as for fixed steps; plots with `--plot` (`plots.rs`). The run
//! is the library's integrator on L_g driven with the library's adaptive recorder inside a
//! writer that streams the rows, checkpoints and resumes (`stream.rs`). `femvi check`
//! measures the step map in s and the physical energy (`check/adaptive.rs`).

mod plots;
pub mod stream;

use crate::outcome::{finish, Outcome};
use crate::problem::{Problem, System};
use crate::record::Checkpointing;
use crate::run_output::RunOutput;
use crate::summary::{empty_summary, running_summary, write_summary};
use femvi::adaptive::{
    solve_adaptive, AdaptiveOptions, AdaptiveSolution, ExprMonitor, KeplerMonitor, Monitor, NBodyMonitor, Recorder,
};
use femvi::{Integrator, Lagrangian, Scalar};
use std::path::Path;
use std::time::Instant;

pub use crate::problem::AdaptiveTime;

/// The rows an adaptive run of `problem` will write when they are known before it starts:
/// with `output_step` h, ⌊span/h⌋ + 1 rows at uniform physical times (and as many times held
/// in memory). None for one row per node: their number follows the monitor along the orbit
/// (from g(q0)·ds it was 550× too large for the e = 0.9 Kepler example, which starts at
/// pericentre), so such runs are not estimated: they stream their rows with bounded memory,
/// stop on a signal with a checkpoint and resume (`stream.rs`).
pub fn estimated_rows(problem: &Problem, settings: &AdaptiveTime) -> Option<f64> {
    let span = problem.grid.end() - problem.grid.t0();
    settings.output_step.map(|h| (span / h).floor() + 1.0)
}

/// The monitors a problem file can name.
pub(crate) enum AnyMonitor {
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
pub(crate) fn monitor(problem: &Problem, name: Option<&str>) -> Result<AnyMonitor, String> {
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

/// Runs `problem` in adaptive mode with output into `dir` (the module documentation): a
/// fresh run, or with `resume` the continuation of the stopped one in `dir`, checkpointed by
/// the policy `checkpoints`.
// One arm of the macro is a Copy type; the others need the clone.
#[allow(clippy::clone_on_copy)]
pub fn run(
    problem: &Problem,
    settings: &AdaptiveTime,
    dir: &Path,
    out: RunOutput,
    (checkpoints, resume): (crate::resume::Policy, bool),
    command: &[String],
) -> std::io::Result<Outcome> {
    let args = Args {
        problem,
        settings,
        dir,
        out,
        checkpoints,
        resume,
        command,
    };
    crate::with_system!(&problem.system, l => run_with(l.clone(), &args))
}

/// What [`run`] is asked to do.
struct Args<'a> {
    problem: &'a Problem,
    settings: &'a AdaptiveTime,
    dir: &'a Path,
    out: RunOutput,
    checkpoints: crate::resume::Policy,
    resume: bool,
    command: &'a [String],
}

fn run_with<L: Lagrangian>(lag: L, a: &Args<'_>) -> std::io::Result<Outcome> {
    let (problem, settings, dir, out) = (a.problem, a.settings, a.dir, a.out);
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
    let options = AdaptiveOptions {
        solver: problem.options,
        every: problem.every,
        saveat,
        events: problem.events.iter().map(|e| e.event()).collect(),
        energy_level: energy_level(&p, problem),
        ..AdaptiveOptions::step(settings.ds)
    };
    let g = match monitor(problem, settings.monitor.as_deref()) {
        Ok(g) => g,
        Err(msg) => return Ok(Outcome::Rejected(msg)),
    };
    let run = match femvi::adaptive::setup(&p, g, &options) {
        Ok(run) => run,
        Err(e) => return Ok(Outcome::Rejected(e.to_string())),
    };
    let made = Integrator::new(
        &run.lagrangian,
        &problem.element,
        run.grid.clone(),
        run.start.clone(),
        run.solver,
    );
    let mut it = match made {
        Ok(it) => it,
        Err(e) => return Ok(Outcome::Rejected(e.to_string())),
    };
    let n = problem.coordinates.len();
    let recorder = Recorder::new(&problem.element, n, t0, end, &options);
    let tag = crate::resume::problem_hash(problem);
    let checkpointing = Checkpointing {
        policy: a.checkpoints,
        tag: tag.clone(),
        outputs: crate::resume::outputs_label(&out),
    };
    let start = stream::Start {
        problem,
        settings,
        dir,
        out,
        e0: run.e0,
        checkpoints: Some(checkpointing),
    };
    // A run killed before its first checkpoint resumes by starting again.
    let fresh = !a.resume || crate::resume::killed_before_first_checkpoint(dir, problem);
    let mut writer = if fresh {
        std::fs::create_dir_all(dir)?;
        crate::resume::remove_checkpoint(dir)?;
        write_summary(dir, &running_summary(problem, clock, a.command))?;
        stream::Writer::create(start, recorder)?
    } else {
        let resumed = crate::resume::load(dir, problem, &out).and_then(|cp| {
            let w = stream::Writer::resume(start, recorder, &cp)?;
            it.restore(&cp.integrator, &tag)
                .map_err(|e| format!("cannot resume: {e}"))?;
            Ok(w)
        });
        match resumed {
            Ok(w) => {
                write_summary(dir, &running_summary(problem, clock, a.command))?;
                w
            }
            Err(msg) => return Ok(Outcome::Rejected(msg)),
        }
    };
    let report = femvi::step::drive(&mut it, &mut [&mut writer]);
    if let Some(e) = writer.write_failure() {
        return Err(e);
    }
    let mut summary = empty_summary(problem, clock, String::new(), a.command);
    summary.steps = it.node().k;
    match &writer.last {
        Some((_, t, q, pp)) => {
            summary.final_t = *t;
            summary.final_q = q.clone();
            summary.final_p = pp.clone();
        }
        None => summary.final_t = t0,
    }
    summary.max_rel_energy_error = writer.max_rel;
    summary.mean_solver_iterations = it.mean_iterations();
    summary.error = report.error.as_ref().map(|e| e.to_string());
    if let Some(events) = &writer.events {
        summary.events_located = Some(events.count());
        let stopped = report.stopped && !writer.recorder.reached();
        summary.stopped_by_event = Some(events.stopper().filter(|_| stopped).map(str::to_string));
    }
    if let Some(kept) = writer.kept.take() {
        if let Some(events) = &writer.events {
            let drawn = crate::events::poincare(dir, problem, events.kept(), out.plot_format);
            if let Err(e) = drawn {
                summary.error.get_or_insert(e);
            }
        }
        if let Err(e) = plots::draw(dir, out.plot_format, problem, &kept, settings.ds) {
            summary.error.get_or_insert(e);
        }
    }
    summary.status = crate::summary::status_of(summary.error.as_deref()).into();
    summary.wall_seconds = clock.elapsed().as_secs_f64();
    match writer.signal {
        Some(sig) => crate::outcome::interrupted(dir, summary, sig),
        None => {
            if summary.error.is_none() {
                crate::resume::remove_checkpoint(dir)?;
            }
            finish(dir, summary)
        }
    }
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
