//! Adaptive-mode problems (`[time] mode = "adaptive"`, the Poincaré time transformation) from
//! Python: integrated by the command's own `femvi_cli::adaptive::solve_problem` (the same
//! monitor, options and library call as `femvi run`), returned as a solution whose nodes carry
//! their physical time t and, in `s`, their fictitious time, and the located events (the
//! problem file's, then Python's).

use crate::run::{Extras, Run};
use femvi::adaptive::AdaptiveSolution;
use femvi::solution::Solution;
use femvi_cli::adaptive::AdaptiveTime;
use femvi_cli::problem::Problem;
use std::path::Path;

/// Runs an adaptive problem. Err: the message (the command's, where it has one).
// The macro's systems are all Clone, one of them also Copy.
#[allow(clippy::clone_on_copy)]
pub fn run(
    problem: &Problem,
    path: &Path,
    extras: &Extras,
    settings: &AdaptiveTime,
) -> Result<(Run, Vec<f64>), String> {
    femvi_cli::with_system!(&problem.system, l => run_lagrangian(l.clone(), problem, path, extras, settings))
}

/// [`run`] with the Lagrangian `lag` in place of the file's system (a Python potential).
pub fn run_lagrangian<L: femvi::Lagrangian + Sync>(
    lag: L,
    problem: &Problem,
    path: &Path,
    extras: &Extras,
    settings: &AdaptiveTime,
) -> Result<(Run, Vec<f64>), String> {
    let bad = |e: &str| format!("{}: {e}", path.display());
    if extras.dense || extras.max_steps.is_some() {
        return Err(bad(
            "dense= and max_steps= are not available in [time] mode = \"adaptive\"",
        ));
    }
    let every = extras.every.unwrap_or(problem.every);
    // The problem file's events first (as `femvi run` locates them), then Python's.
    let mut events: Vec<femvi::solution::Event> = problem.events.iter().map(|e| e.event()).collect();
    let file_events = events.len();
    events.extend(extras.events.iter().cloned());
    let event_names = events.iter().map(|e| e.name.clone()).collect();
    let (t0, end) = (problem.grid.t0(), problem.grid.end());
    let p = femvi::Problem::new(lag, problem.start.clone(), t0, end);
    let sol = femvi_cli::adaptive::solve_problem(&p, problem, settings, every, extras.saveat.clone(), events)
        .map_err(|e| bad(&e))?;
    let max_rel = femvi_cli::adaptive::max_rel_energy_error(&sol);
    let s = sol.s.clone();
    Ok((
        Run {
            sol: solution(sol, settings.ds),
            max_rel_energy_error: max_rel,
            message: None,
            event_names,
            file_events,
        },
        s,
    ))
}

/// The adaptive solution as the library's solution type (node indices from s = k·ds).
fn solution(a: AdaptiveSolution, ds: f64) -> Solution {
    Solution {
        n: a.n,
        step: a.s.iter().map(|s| (s / ds).round() as usize).collect(),
        t: a.t,
        q: a.q,
        p: a.p,
        v: a.v,
        energy: a.energy,
        saved: a.saved,
        events: a.events,
        dense: None,
        steps: a.steps,
        mean_iterations: a.mean_iterations,
        energy_stats: None,
        energy_report: None,
        stopped: a.stopped,
        error: a.error,
    }
}
