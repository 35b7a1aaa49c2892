//! One run of a problem file, as `femvi run` does it: the problem is loaded with the
//! command's loader, its grid becomes the library's `Steps`, and `solve` drives the same
//! integrator the command builds. The library's energy tracker is the one behind the
//! command's energy observer, so the energies (and their largest relative error) are the
//! command's bit for bit, computed once per node. What a run returns ([`Run`]) and the options
//! the Python side adds ([`Extras`]) are here; `solve.rs` dispatches to this run, to the runs
//! of the terms (`tables.rs`, `adaptive.rs`) and to a Python potential (`callable.rs`), which
//! all build on this module.

use femvi::solution::{solve, Solution, SolveOptions};
use femvi::Lagrangian;
use femvi_cli::problem::capabilities::Use;
use femvi_cli::problem::{self, Problem};
use std::path::Path;

/// What the Python side may ask of a run besides the problem file.
#[derive(Debug, Clone, Default)]
pub struct Extras {
    pub every: Option<usize>,
    pub saveat: Vec<f64>,
    pub dense: bool,
    pub max_steps: Option<usize>,
    pub events: Vec<femvi::solution::Event>,
}

/// A finished (or failed) run: the library's solution and what the command adds.
pub struct Run {
    pub sol: Solution,
    pub max_rel_energy_error: f64,
    /// The error's message where it is not the library's (as summary.json has it).
    pub message: Option<String>,
    /// Names of the events (the problem file's, then Python's).
    pub event_names: Vec<String>,
    /// How many of them the problem file declared.
    pub file_events: usize,
}

impl Run {
    /// The run of a library solution: its energy report's largest relative error, no events
    /// named yet ([`run_on`] names them).
    pub fn of(sol: Solution) -> Self {
        let max_rel_energy_error = sol.energy_report.map_or(f64::NAN, |r| r.max_rel_error);
        Run {
            sol,
            max_rel_energy_error,
            message: None,
            event_names: vec![],
            file_events: 0,
        }
    }
}

/// Loads `path` as `femvi run` does (the message of a bad file is the command's), for
/// ensembles: what the capability table refuses for them (forces in energy mode) is refused.
pub fn load(path: &Path) -> Result<Problem, String> {
    let problem = load_any(path)?;
    let named = |e: String| format!("{}: {e}", path.display());
    problem.refuse(Use::Ensemble, "femvi.ensemble").map_err(named)?;
    Ok(problem)
}

/// [`load`] that accepts every problem `femvi run` does (for `solve`).
pub fn load_any(path: &Path) -> Result<Problem, String> {
    let problem = problem::load(path).map_err(|e| e.to_string())?;
    problem
        .refuse(Use::Python, "femvi.solve")
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(problem)
}

/// Runs a loaded problem. Err: the library rejected it (message as the command prints it).
// The macro's systems are all Clone, one of them also Copy.
#[allow(clippy::clone_on_copy)]
pub fn run(problem: &Problem, path: &Path, extras: &Extras) -> Result<Run, String> {
    run_on(
        problem,
        path,
        extras,
        |options| femvi_cli::with_system!(&problem.system, l => run_with(l.clone(), problem, options)),
    )
}

/// Runs a loaded problem with the system `go` integrates (given the solve options): the
/// problem file's [[events]] first (as `femvi run` locates them), then Python's.
pub fn run_on(
    problem: &Problem,
    path: &Path,
    extras: &Extras,
    go: impl FnOnce(&SolveOptions) -> femvi::Result<Run>,
) -> Result<Run, String> {
    let mut events: Vec<femvi::solution::Event> = problem.events.iter().map(|e| e.event()).collect();
    let offset = events.len();
    events.extend(extras.events.iter().cloned());
    let options = SolveOptions {
        steps: problem.steps.clone(),
        solver: problem.options,
        every: extras.every.unwrap_or(problem.every),
        saveat: extras.saveat.clone(),
        max_steps: extras.max_steps,
        dense: extras.dense,
        events,
        track_energy: true,
        energy_nodes: problem.energy_nodes,
    };
    let mut r = go(&options).map_err(|e| format!("{}: {e}", path.display()))?;
    r.event_names = options.events.iter().map(|e| e.name.clone()).collect();
    r.file_events = offset;
    Ok(r)
}

/// `solve` of the loaded problem with the system `lag`.
pub fn run_with<L: Lagrangian>(lag: L, problem: &Problem, options: &SolveOptions) -> femvi::Result<Run> {
    let n = lag.dim();
    let p = femvi::Problem::new(lag, problem.start.clone(), problem.grid.t0(), problem.grid.end());
    let sol = match solve(&p, &problem.element, options) {
        Ok(sol) => sol,
        // The start from (q0, q1) failed: a numerical failure with no node, as the command has it.
        Err(femvi::Error::Step(e)) => return Ok(first_element_failed(n, e)),
        Err(e) => return Err(e),
    };
    Ok(Run::of(sol))
}

/// The run of a start from (q0, q1) whose first element failed.
fn first_element_failed(n: usize, e: femvi::StepError) -> Run {
    let message = Some(format!("first element: {e}"));
    let sol = Solution {
        n,
        step: vec![],
        t: vec![],
        q: vec![],
        p: vec![],
        v: vec![],
        energy: vec![],
        saved: Default::default(),
        events: vec![],
        dense: None,
        steps: 0,
        mean_iterations: 0.0,
        energy_stats: None,
        energy_report: None,
        stopped: false,
        error: Some(femvi::Error::Step(e)),
    };
    Run {
        sol,
        max_rel_energy_error: f64::NAN,
        message,
        event_names: vec![],
        file_events: 0,
    }
}
