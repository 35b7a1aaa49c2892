//! `femvi run` on a loaded problem: builds its integrator, attaches the outputs (src/record/:
//! trajectory.csv streamed as the run goes, trajectory.npy, plots, the energy error, the
//! progress bar), drives the run with [`femvi::step::drive`] and writes summary.json at the
//! end (also after a failure, with the error).

use crate::problem::Problem;
use crate::record::Recorders;
use femvi::step::{drive, DriveReport};
use femvi::{Integrator, Lagrangian};
use serde::Serialize;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// What summary.json holds.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// The problem's name.
    pub name: String,
    /// The element used.
    pub scheme: String,
    /// Steps completed.
    pub steps: usize,
    /// The requested end time.
    pub t_end: f64,
    /// Time of the last node.
    pub final_t: f64,
    /// Positions at the last node.
    pub final_q: Vec<f64>,
    /// Momenta at the last node.
    pub final_p: Vec<f64>,
    /// Max over nodes of |H − H0|/|H0| (absolute if H0 = 0), H by the Legendre transform.
    pub max_rel_energy_error: f64,
    /// Solver iterations per step (0 for explicit steps).
    pub mean_solver_iterations: f64,
    /// Run time.
    pub wall_seconds: f64,
    /// The message of the error that stopped the run, if any.
    pub error: Option<String>,
    /// Energy mode only: largest relative residual of the discrete energy equations (3.3).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_discrete_energy_error: Option<f64>,
    /// Energy mode only: smallest step taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_step: Option<f64>,
    /// Energy mode only: largest step taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_step: Option<f64>,
    /// Energy mode only: steps taken with time as a parameter (on_degenerate = "fixed").
    #[serde(skip_serializing_if = "Option::is_none")]
    pub degenerate_steps: Option<usize>,
    /// `[time] accuracy` only: the step femvi chose.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_step: Option<AutoStep>,
}

/// The step chosen for `[time] accuracy` (femvi::step::auto::StepChoice), for summary.json.
#[derive(Debug, Serialize)]
pub struct AutoStep {
    /// The relative position error requested at the end.
    pub accuracy: f64,
    /// The step chosen.
    pub step: f64,
    /// The element degree used.
    pub degree: usize,
    /// The estimated relative position error at the end with this step.
    pub estimated_error: f64,
    /// Steps taken by the pilot runs.
    pub pilot_steps: usize,
}

/// summary.json's `auto_step` for a problem with `[time] accuracy`.
fn auto_step(problem: &Problem) -> Option<AutoStep> {
    problem.auto_step.as_ref().map(|c| AutoStep {
        accuracy: c.accuracy,
        step: c.step,
        degree: problem.element.degree(),
        estimated_error: c.estimated_error,
        pilot_steps: c.pilot_steps,
    })
}

/// How a run ended.
pub enum Outcome {
    /// Finished; the summary.
    Done(Summary),
    /// A numerical failure after some steps (written to disk); the summary has the error.
    Failed(Summary),
    /// The problem could not be started (bad input the library detected).
    Rejected(String),
}

/// Output formats of a run and whether a progress bar may be shown.
#[derive(Debug, Clone, Copy)]
pub struct RunOutput {
    /// Write trajectory.csv.
    pub csv: bool,
    /// Write trajectory.npy and columns.txt.
    pub npy: bool,
    /// Show a progress bar (on a terminal, after a second).
    pub progress: bool,
    /// Draw plots.
    pub plots: bool,
    /// Image format of the plots.
    pub plot_format: crate::plot::Format,
}

/// Runs a problem with output into `dir`.
pub fn run(problem: &Problem, dir: &Path, out: RunOutput) -> std::io::Result<Outcome> {
    crate::with_system!(&problem.system, l => run_with(l, problem, dir, out))
}

/// Builds the integrator, attaches the outputs, drives the run and writes summary.json.
fn run_with<L: Lagrangian>(lag: &L, problem: &Problem, dir: &Path, out: RunOutput) -> std::io::Result<Outcome> {
    let clock = Instant::now();
    let out = RunOutput {
        plots: out.plots || problem.plots,
        ..out
    };
    let (grid, start) = (problem.grid.clone(), problem.start.clone());
    let made = match problem.energy {
        None => Integrator::new(lag, &problem.element, grid, start, problem.options),
        Some(e) => Integrator::with_energy(lag, &problem.element, grid, start, problem.options, e),
    };
    let mut it = match made {
        Ok(it) => it,
        Err(femvi::Error::Step(e)) => {
            // Only the start from (q0, q1) solves anything here.
            let summary = empty_summary(problem, clock.elapsed().as_secs_f64(), format!("first element: {e}"));
            std::fs::create_dir_all(dir)?;
            write_summary(dir, &summary)?;
            return Ok(Outcome::Failed(summary));
        }
        Err(e) => return Ok(Outcome::Rejected(e.to_string())),
    };
    std::fs::create_dir_all(dir)?;
    let mut recorders = Recorders::attach(problem, dir, out, lag.dim())?;
    let report = drive(&mut it, &mut recorders.observers());
    if let Some(e) = recorders.write_failure() {
        return Err(e);
    }
    let summary = run_summary(problem, &it, &report, recorders.max_rel_energy_error(), clock);
    write_summary(dir, &summary)?;
    Ok(if summary.error.is_some() {
        Outcome::Failed(summary)
    } else {
        Outcome::Done(summary)
    })
}

/// The summary of a driven run, at the node it ended on.
fn run_summary<L: Lagrangian>(
    problem: &Problem,
    it: &Integrator<'_, L>,
    report: &DriveReport,
    max_rel_energy_error: f64,
    clock: Instant,
) -> Summary {
    let node = it.node();
    let stats = it.energy_stats();
    Summary {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: report.steps,
        t_end: problem.grid.end(),
        final_t: node.t,
        final_q: node.q.to_vec(),
        final_p: node.p.to_vec(),
        max_rel_energy_error,
        mean_solver_iterations: it.mean_iterations(),
        wall_seconds: clock.elapsed().as_secs_f64(),
        error: report.error.as_ref().map(|e| e.to_string()),
        max_rel_discrete_energy_error: stats.map(|s| s.max_rel_residual),
        min_step: stats.map(|s| s.min_step),
        max_step: stats.map(|s| s.max_step),
        degenerate_steps: stats.map(|s| s.degenerate_steps),
        auto_step: auto_step(problem),
    }
}

/// The summary of a run that failed before its first node (the start from (q0, q1)).
fn empty_summary(problem: &Problem, wall: f64, error: String) -> Summary {
    Summary {
        name: problem.name.clone(),
        scheme: problem.scheme_label.clone(),
        steps: 0,
        t_end: problem.grid.end(),
        final_t: problem.grid.t0(),
        final_q: vec![],
        final_p: vec![],
        max_rel_energy_error: f64::NAN,
        mean_solver_iterations: 0.0,
        wall_seconds: wall,
        error: Some(error),
        max_rel_discrete_energy_error: None,
        min_step: None,
        max_step: None,
        degenerate_steps: None,
        auto_step: auto_step(problem),
    }
}

/// Writes `dir`/summary.json (pretty JSON and a newline).
fn write_summary(dir: &Path, s: &Summary) -> std::io::Result<()> {
    let mut f = std::fs::File::create(dir.join("summary.json"))?;
    let text = serde_json::to_string_pretty(s).map_err(std::io::Error::other)?;
    writeln!(f, "{text}")
}
