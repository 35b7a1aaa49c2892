//! summary.json of `femvi run`: what it holds ([`Summary`]), how it is filled at the end of a
//! run, and how it is written: atomically (a temporary file renamed over the old one), and
//! first at the start of a run with `"status": "running"`, so that a summary.json never
//! describes an earlier run than the files next to it (issue 16).

use crate::problem::Problem;
use crate::record::Recorders;
use femvi::Lagrangian;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// What summary.json holds.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// The problem's name.
    pub name: String,
    /// "running" (written at the start of a run), "done", "failed" or "interrupted".
    pub status: String,
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
    /// Which nodes `max_rel_energy_error` is over: "every" node, or the "kept" ones (those
    /// written; `[output] energy_nodes`, by default for Lagrangians without a constant mass
    /// matrix, whose H needs a Newton solve per node).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy_nodes: Option<String>,
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
    /// Whether H is a conserved quantity (false for a time-dependent Lagrangian, whose
    /// `max_rel_energy_error` is then the change of H, not an error).
    pub energy_conserved: bool,
    /// Time-dependent L only: the largest |H − H0 − W| / |H0|, W = −∫∂L/∂t dt by the
    /// trapezoid rule over the written nodes (so itself second order in the step).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_energy_balance_error: Option<f64>,
    /// `[[events]]` only: how many events were located (events.csv).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events_located: Option<usize>,
    /// `[[events]]` only: the event whose `stop = true` ended the run, or null.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stopped_by_event: Option<Option<String>>,
    /// `[forces]` only: the discrete work of the forces at the last node (then
    /// `max_rel_energy_balance_error` is the largest |H − H0 − W| / |H0| over every node).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub final_work: Option<f64>,
    /// `[forces]` in the energy mode only: the largest |Ẽ − Ẽ0 − W| / |Ẽ0| of the discrete
    /// energy Ẽ (the `discrete_energy` column) over every node: round-off where every energy
    /// equation was solved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_rel_discrete_energy_balance_error: Option<f64>,
    /// `femvi chaos --out DIR` (one orbit) only: the indicators, as chaos.json has them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub chaos: Option<crate::chaos::Indicators>,
    /// The femvi version that ran the problem.
    pub femvi_version: String,
    /// The command line (program and arguments).
    pub command_line: Vec<String>,
    /// The problem's TOML text as run, after `--set` overrides.
    pub problem: String,
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

/// Where a run ended: steps, the last node, the solver's statistics and the error.
pub(crate) struct RunEnd {
    pub(crate) steps: usize,
    pub(crate) t: f64,
    pub(crate) q: Vec<f64>,
    pub(crate) p: Vec<f64>,
    pub(crate) mean_iterations: f64,
    pub(crate) stats: Option<femvi::EnergyStats>,
    /// The largest relative gap of the discrete energy balance (forces in the energy mode).
    pub(crate) discrete_balance: Option<f64>,
    pub(crate) error: Option<String>,
}

/// The summary of a driven run, at the node it ended on.
pub(crate) fn run_summary(
    problem: &Problem,
    end: RunEnd,
    recorders: &Recorders<'_>,
    clock: Instant,
    command: &[String],
) -> Summary {
    let stats = end.stats;
    // With forces H is not conserved: the balance H − H0 = W is what is measured.
    let balance = recorders.work_balance();
    Summary {
        name: problem.name.clone(),
        status: status_of(end.error.as_deref()).into(),
        scheme: problem.scheme_label.clone(),
        steps: end.steps,
        t_end: problem.grid.end(),
        final_t: end.t,
        final_q: end.q,
        final_p: end.p,
        max_rel_energy_error: recorders.max_rel_energy_error(),
        energy_nodes: Some(recorders.energy_nodes().name().into()),
        mean_solver_iterations: end.mean_iterations,
        wall_seconds: clock.elapsed().as_secs_f64(),
        error: end.error,
        max_rel_discrete_energy_error: stats.map(|s| s.max_rel_residual),
        min_step: stats.map(|s| s.min_step),
        max_step: stats.map(|s| s.max_step),
        degenerate_steps: stats.map(|s| s.degenerate_steps),
        auto_step: auto_step(problem),
        energy_conserved: balance.is_none() && is_autonomous(problem),
        max_rel_energy_balance_error: balance
            .map(|b| b.max_rel())
            .or(recorders.max_rel_energy_balance_error()),
        events_located: None,
        stopped_by_event: None,
        final_work: balance.map(|b| b.work()),
        max_rel_discrete_energy_balance_error: end.discrete_balance,
        chaos: None,
        femvi_version: env!("CARGO_PKG_VERSION").to_string(),
        command_line: command.to_vec(),
        problem: problem.source.clone(),
    }
}

/// Whether the problem's Lagrangian does not depend on time (H is then conserved).
pub fn is_autonomous(problem: &Problem) -> bool {
    crate::with_system!(&problem.system, l => l.is_autonomous())
}

/// The summary of a run that failed before its first node (the start from (q0, q1)).
pub(crate) fn empty_summary(problem: &Problem, clock: Instant, error: String, command: &[String]) -> Summary {
    Summary {
        name: problem.name.clone(),
        status: "failed".into(),
        scheme: problem.scheme_label.clone(),
        steps: 0,
        t_end: problem.grid.end(),
        final_t: problem.grid.t0(),
        final_q: vec![],
        final_p: vec![],
        max_rel_energy_error: f64::NAN,
        energy_nodes: None,
        mean_solver_iterations: 0.0,
        wall_seconds: clock.elapsed().as_secs_f64(),
        error: Some(error),
        max_rel_discrete_energy_error: None,
        min_step: None,
        max_step: None,
        degenerate_steps: None,
        auto_step: auto_step(problem),
        energy_conserved: is_autonomous(problem),
        max_rel_energy_balance_error: None,
        events_located: None,
        stopped_by_event: None,
        final_work: None,
        max_rel_discrete_energy_balance_error: None,
        chaos: None,
        femvi_version: env!("CARGO_PKG_VERSION").to_string(),
        command_line: command.to_vec(),
        problem: problem.source.clone(),
    }
}

/// The status of a run that ended with `error`: "failed" or "done".
pub fn status_of(error: Option<&str>) -> &'static str {
    if error.is_some() {
        "failed"
    } else {
        "done"
    }
}

/// The summary of a run that is starting: `"status": "running"`, no final state yet.
pub(crate) fn running_summary(problem: &Problem, clock: Instant, command: &[String]) -> Summary {
    Summary {
        status: "running".into(),
        error: None,
        ..empty_summary(problem, clock, String::new(), command)
    }
}

/// Writes `dir`/summary.json (pretty JSON and a newline) atomically.
///
/// # Errors
/// The write failed.
pub fn write_summary(dir: &Path, s: &Summary) -> std::io::Result<()> {
    let text = serde_json::to_string_pretty(s).map_err(std::io::Error::other)?;
    crate::resume::write_atomic(&dir.join("summary.json"), (text + "\n").as_bytes())
}

/// The energy change of a forced run `s` (its `energy_report`), its energy `balance` and the
/// work `work` at its kept nodes, into summary.json's fields (the docs of [`femvi::forces`]; also
/// for forced constrained runs, `crate::constrained`).
pub fn report_work(summary: &mut Summary, s: &femvi::Solution, balance: &femvi::forces::EnergyBalance, work: &[f64]) {
    let report = s.energy_report;
    summary.max_rel_energy_error = report.map_or(f64::NAN, |r| r.max_rel_error);
    summary.energy_conserved = false;
    summary.max_rel_energy_balance_error = Some(balance.max_rel);
    summary.final_work = work.last().copied();
}
