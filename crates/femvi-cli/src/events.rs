//! `femvi run` of a problem with `[[events]]`: the run is driven by the library's
//! [`solve_with`] (whose recorder locates the events on the element polynomials, as
//! [`femvi::solve`] does) with the CLI's outputs attached as observers, so trajectory.csv,
//! the NPY file and the plots are those of a run without events. The events go to
//! events.csv (`event,step,t,<coordinates>,p_<coordinates>`, one row per located event,
//! numbers in shortest round-trip form) and, with plots on, to a Poincaré plot per event
//! (`poincare_<event>.svg`: the first coordinate against its momentum, as points).

use crate::outcome::{finish, Outcome};
use crate::plot::{file, scatter, Series};
use crate::problem::Problem;
use crate::record::Recorders;
use crate::run_output::RunOutput;
use crate::summary::{empty_summary, run_summary, RunEnd};
use femvi::constraints::{solve_constrained_forced_observed, solve_constrained_observed, NodeConstraints};
use femvi::forces::solve_forced_with;
use femvi::solution::{solve_with, EventRecord};
use femvi::step::Observer;
use femvi::{Lagrangian, SolveOptions};
use std::path::Path;
use std::time::Instant;

/// The solve options of a run with events: the problem's steps and solver, only the first
/// and last node kept by the library (the CLI's observers keep the rest, and track the energy
/// themselves), the events.
pub fn solve_options(problem: &Problem) -> SolveOptions {
    SolveOptions {
        events: problem.events.iter().map(|e| e.event()).collect(),
        track_energy: false,
        ..problem.solve_options(0)
    }
}

/// Runs `problem` (which has events) into `dir`.
pub fn run<L: Lagrangian + Clone + Sync>(
    lag: &L,
    problem: &Problem,
    dir: &Path,
    out: RunOutput,
    command: &[String],
) -> std::io::Result<Outcome> {
    let clock = Instant::now();
    let p = problem.library(lag.clone());
    let options = solve_options(problem);
    std::fs::create_dir_all(dir)?;
    let mut recorders = Recorders::attach(problem, dir, out, lag.dim())?;
    let mut at_end = AtEnd::default();
    let solved = {
        let mut observers = recorders.observers();
        observers.push(&mut at_end);
        let (el, obs) = (&problem.element, &mut observers[..]);
        match (&problem.terms.force, &problem.terms.constraints) {
            (Some(f), None) => solve_forced_with(&p, f, el, &options, obs),
            (None, None) => solve_with(&p, el, &options, obs),
            (None, Some((c, e))) => solve_constrained_observed(&p, c, el, &options, *e, obs),
            (Some(f), Some((c, e))) => solve_constrained_forced_observed(&p, f, c, el, &options, *e, obs),
        }
    };
    if let Some(e) = recorders.write_failure() {
        return Err(e);
    }
    let sol = match solved {
        Ok(sol) => sol,
        Err(femvi::Error::Step(e)) => {
            let summary = empty_summary(problem, clock, format!("first element: {e}"), command);
            return finish(dir, summary);
        }
        Err(e) => return Ok(Outcome::Rejected(e.to_string())),
    };
    write_events(dir, problem, &sol.events)?;
    if let Some(at) = &at_end.constraints {
        crate::constrained::write_json(dir, problem, at)?;
    }
    if out.plots {
        poincare(dir, problem, &sol.events, out.plot_format).map_err(std::io::Error::other)?;
    }
    let last = sol.len().saturating_sub(1);
    let end = RunEnd {
        steps: sol.steps,
        t: sol.t.get(last).copied().unwrap_or(f64::NAN),
        q: sol.q_row(last).map(<[f64]>::to_vec).unwrap_or_default(),
        p: sol.p_row(last).map(<[f64]>::to_vec).unwrap_or_default(),
        mean_iterations: sol.mean_iterations,
        stats: sol.energy_stats,
        discrete_balance: at_end.discrete_balance,
        error: sol.error.as_ref().map(|e| e.to_string()),
    };
    let mut summary = run_summary(problem, end, &recorders, clock, command);
    summary.events_located = Some(sol.events.len());
    let stopper = sol.events.iter().find(|r| problem.events[r.event].stop);
    summary.stopped_by_event = Some(
        stopper
            .filter(|_| sol.stopped)
            .map(|r| problem.events[r.event].name.clone()),
    );
    finish(dir, summary)
}

/// What the integrator knows at the node a run ends on: the constraint quantities of a
/// constrained run (for constraints.json), the discrete energy balance of a forced run in the
/// energy mode.
#[derive(Default)]
struct AtEnd {
    constraints: Option<NodeConstraints>,
    discrete_balance: Option<f64>,
}

impl<L: Lagrangian> Observer<L> for AtEnd {
    fn node(&mut self, _it: &femvi::Integrator<'_, L>, _last: bool) -> femvi::Result<()> {
        Ok(())
    }

    fn finish(&mut self, it: &femvi::Integrator<'_, L>, _error: Option<&femvi::Error>) -> femvi::Result<()> {
        self.constraints = it.node_constraints();
        self.discrete_balance = it.discrete_balance().map(|b| b.max_rel);
        Ok(())
    }
}

/// The header of events.csv.
pub fn columns(problem: &Problem) -> Vec<String> {
    let mut header = vec!["event".to_string(), "step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header
}

/// Writes `dir`/events.csv.
pub fn write_events(dir: &Path, problem: &Problem, events: &[EventRecord]) -> std::io::Result<()> {
    let mut w = csv::Writer::from_path(dir.join("events.csv"))?;
    w.write_record(columns(problem))?;
    for r in events {
        let mut row = vec![
            problem.events[r.event].name.clone(),
            r.step.to_string(),
            format!("{:?}", r.t),
        ];
        row.extend(r.q.iter().chain(&r.p).map(|x| format!("{x:?}")));
        w.write_record(&row)?;
    }
    w.flush()
}

/// `poincare_<event>` for each event: the first coordinate against its momentum at the
/// located events, as points.
pub(crate) fn poincare(
    dir: &Path,
    problem: &Problem,
    events: &[EventRecord],
    f: crate::plot::Format,
) -> Result<(), String> {
    let c = &problem.coordinates[0];
    for (i, e) in problem.events.iter().enumerate() {
        let points = events
            .iter()
            .filter(|r| r.event == i)
            .map(|r| (r.q[0], r.p[0]))
            .collect();
        let series = [Series {
            name: format!("{} ({})", e.name, e.when),
            points,
        }];
        let title = format!(
            "{}: Poincaré section '{}', {}, h = {}",
            problem.name,
            e.name,
            problem.scheme_label,
            crate::plot::step_label(problem)
        );
        let path = file(dir, &format!("poincare_{}", e.name), f);
        scatter(&path, f, &title, c, &format!("p_{c}"), &series)?;
    }
    Ok(())
}
