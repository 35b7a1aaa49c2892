//! `femvi run` on a loaded problem: builds its integrator, checks the output estimate
//! ([`crate::estimate`]), attaches the outputs ([`Recorders`]: trajectory.csv and .npy
//! streamed as the run goes, plots, the energy error, the progress bar, checkpoints), drives
//! the run in chunks of steps ([`crate::record::drive_in_chunks`]) and writes summary.json ([`crate::summary`]): with
//! `"status": "running"` at the start, and at the end (also after a failure or a stop by a
//! signal, with the error). With [`RunControl::resume`] it continues a stopped run from its
//! checkpoint ([`crate::resume`]), bit for bit. A problem with `[[events]]` is driven by the
//! library's [`femvi::solution::solve_with`] instead, with the same outputs as observers and
//! the located events written by [`crate::events`]. Forces and constraints are terms of the
//! same integrator (`Integrator::with_force`, `with_constraints`, `with_constraints_and_force`):
//! their runs stream, stop, resume and plot as any run, with the work and the multipliers as
//! columns and constraints.json beside summary.json ([`crate::constrained`]).

use crate::problem::capabilities::Use;
use crate::problem::Problem;
use crate::record::{Checkpointing, Recorders};
use crate::resume::{self, Policy};
use femvi::{Integrator, Lagrangian};
use std::path::Path;
use std::time::Instant;

pub use crate::outcome::Outcome;
use crate::outcome::{finish, interrupted};
pub use crate::run_output::RunOutput;
use crate::summary::{empty_summary, run_summary, running_summary, write_summary, RunEnd};
pub use crate::summary::{is_autonomous, AutoStep, Summary};

/// How a run is controlled beyond its outputs: checkpoints, resume, the output limit.
#[derive(Debug, Clone, PartialEq)]
pub struct RunControl {
    /// When checkpoints are written (besides the first node and a stop by a signal).
    pub checkpoints: Policy,
    /// Continue the stopped run in the output directory from its checkpoint.
    pub resume: bool,
    /// Refuse a run whose output estimate exceeds this many bytes.
    pub max_output: u64,
}

/// The run options that the problem's terms refuse (the table of
/// [`crate::problem::capabilities`]), checked before anything is written.
fn refuse(problem: &Problem, out: &RunOutput, resume: bool) -> Result<(), String> {
    let asked = [
        (!problem.events.is_empty(), Use::Events),
        (resume, Use::Resume),
        (out.plots, Use::Plots),
        (out.npy, Use::Npy),
    ];
    asked
        .iter()
        .filter(|(on, _)| *on)
        .try_for_each(|(_, what)| problem.refuse(*what, "femvi run"))
}

impl Default for RunControl {
    /// Checkpoints every 10 s, a fresh run, at most 10 GB of output.
    fn default() -> Self {
        RunControl {
            checkpoints: Policy::default(),
            resume: false,
            max_output: crate::estimate::DEFAULT_MAX_OUTPUT,
        }
    }
}

/// Runs a problem with output into `dir`; summary.json records this process's command line.
pub fn run(problem: &Problem, dir: &Path, out: RunOutput) -> std::io::Result<Outcome> {
    run_controlled(problem, dir, out, &RunControl::default())
}

/// [`run`] with `control`.
pub fn run_controlled(problem: &Problem, dir: &Path, out: RunOutput, control: &RunControl) -> std::io::Result<Outcome> {
    let command: Vec<String> = std::env::args().collect();
    run_as(problem, dir, out, control, &command)
}

/// [`run_controlled`], recording `command` as the command line in summary.json.
pub fn run_as(
    problem: &Problem,
    dir: &Path,
    out: RunOutput,
    control: &RunControl,
    command: &[String],
) -> std::io::Result<Outcome> {
    let out = RunOutput {
        plots: out.plots || problem.plots,
        ..out
    };
    if let Some(a) = &problem.terms.adaptive {
        // Adaptive runs stream their rows (`adaptive/stream.rs`); the times at `output_step`
        // are allocated before the run, so such a run is refused up front when its rows are
        // too many, like every run.
        let estimated = match crate::adaptive::estimated_rows(problem, a) {
            Some(rows) => {
                let e = crate::estimate::of_rows(problem, &out, rows, rows);
                crate::estimate::check_estimate(problem, e, dir, control.max_output, 0)
            }
            None => Ok(()),
        };
        if let Err(msg) = refuse(problem, &out, control.resume).and(estimated) {
            return Ok(Outcome::Rejected(msg));
        }
        return crate::adaptive::run(problem, a, dir, out, (control.checkpoints, control.resume), command);
    }
    if problem.terms.force.is_some() || problem.terms.constraints.is_some() {
        if let Err(msg) = refuse(problem, &out, control.resume) {
            return Ok(Outcome::Rejected(msg));
        }
    }
    let args = RunArgs {
        problem,
        dir,
        out,
        control,
        command,
    };
    crate::with_system!(&problem.system, l => run_with(l, &args))
}

/// What [`run_with`] is asked to do.
struct RunArgs<'a> {
    problem: &'a Problem,
    dir: &'a Path,
    out: RunOutput,
    control: &'a RunControl,
    command: &'a [String],
}

/// Builds the integrator, attaches the outputs (or resumes them), drives the run and writes
/// summary.json.
fn run_with<L: Lagrangian + Sync>(lag: &L, a: &RunArgs<'_>) -> std::io::Result<Outcome> {
    let RunArgs {
        problem,
        dir,
        out,
        control,
        command,
    } = *a;
    let clock = Instant::now();
    let (grid, start) = (problem.grid.clone(), problem.start.clone());
    let made = problem.integrator(lag, &problem.element, grid, start, problem.energy);
    let mut it = match made {
        Ok(it) => it,
        Err(femvi::Error::Step(e)) => {
            // Only the start from (q0, q1) solves anything here.
            let summary = empty_summary(problem, clock, format!("first element: {e}"), command);
            std::fs::create_dir_all(dir)?;
            resume::remove_checkpoint(dir)?;
            write_summary(dir, &summary)?;
            return Ok(Outcome::Failed(summary));
        }
        Err(e) => return Ok(Outcome::Rejected(e.to_string())),
    };
    let checkpointing = Checkpointing {
        policy: control.checkpoints,
        tag: resume::problem_hash(problem),
        outputs: resume::outputs_label(&out),
    };
    // A run killed before its first checkpoint resumes by starting again.
    let fresh = !control.resume || resume::killed_before_first_checkpoint(dir, problem);
    let mut recorders = if !fresh {
        match resume_outputs(&mut it, a, checkpointing)? {
            Ok(r) => r,
            Err(msg) => return Ok(Outcome::Rejected(msg)),
        }
    } else {
        if let Err(msg) = crate::estimate::check(problem, &out, dir, control.max_output, 0) {
            return Ok(Outcome::Rejected(msg));
        }
        std::fs::create_dir_all(dir)?;
        resume::remove_checkpoint(dir)?;
        write_summary(dir, &running_summary(problem, clock, command))?;
        Recorders::start(problem, dir, out, lag.dim(), Some(checkpointing))?
    };
    let report = crate::record::drive_in_chunks(lag, &mut it, &mut recorders);
    if let Some(e) = recorders.write_failure() {
        return Err(e);
    }
    let (steps, t, q, p) = recorders.last_good();
    let end = RunEnd {
        steps,
        t,
        q: q.to_vec(),
        p: p.to_vec(),
        mean_iterations: it.mean_iterations(),
        stats: it.energy_stats(),
        discrete_balance: it.discrete_balance().map(|b| b.max_rel),
        error: report.error.as_ref().map(|e| e.to_string()),
    };
    if let Some(at) = it.node_constraints() {
        crate::constrained::write_json(dir, problem, &at)?;
    }
    let mut summary = run_summary(problem, end, &recorders, clock, command);
    if let Some(events) = recorders.events() {
        summary.events_located = Some(events.count());
        summary.stopped_by_event = Some(events.stopper().map(str::to_string));
        if out.plots {
            let drawn = crate::events::poincare(dir, problem, events.kept(), out.plot_format);
            if let Err(e) = drawn {
                summary.error.get_or_insert(e);
            }
        }
    }
    match recorders.stopped_by() {
        Some(sig) => interrupted(dir, summary, sig),
        None => {
            if summary.error.is_none() {
                resume::remove_checkpoint(dir)?;
            }
            finish(dir, summary)
        }
    }
}

/// The outputs of the stopped run in the output directory, cut back to its checkpoint, and
/// the integrator restored from it; a message for the user if the run cannot be resumed.
fn resume_outputs<'a, L: Lagrangian>(
    it: &mut Integrator<'_, L>,
    a: &RunArgs<'a>,
    checkpointing: Checkpointing,
) -> std::io::Result<Result<Recorders<'a>, String>> {
    let (problem, dir, out) = (a.problem, a.dir, a.out);
    let cp = match resume::load(dir, problem, &out) {
        Ok(cp) => cp,
        Err(msg) => return Ok(Err(msg)),
    };
    let already: u64 = ["trajectory.csv", "trajectory.npy"]
        .iter()
        .filter_map(|f| std::fs::metadata(dir.join(f)).ok())
        .map(|m| m.len())
        .sum();
    if let Err(msg) = crate::estimate::check(problem, &out, dir, a.control.max_output, already) {
        return Ok(Err(msg));
    }
    let tag = checkpointing.tag.clone();
    let recorders = match Recorders::resume(problem, dir, out, it, &cp, checkpointing) {
        Ok(r) => r,
        Err(msg) => return Ok(Err(msg)),
    };
    if let Err(e) = it.restore(&cp.integrator, &tag) {
        return Ok(Err(format!("cannot resume: {e}")));
    }
    write_summary(dir, &running_summary(problem, Instant::now(), a.command))?;
    Ok(Ok(recorders))
}
