//! events.csv and the Poincaré plots of `femvi run` on a problem with `[[events]]`. The
//! events are located by an observer of the one run (`record/event_rows.rs`, the library's
//! [`femvi::solution::EventLocator`] on each element polynomial, as [`femvi::solve()`] locates
//! them), so trajectory.csv, the NPY file and the plots are those of a run without events,
//! and such a run streams, checkpoints and resumes like any other. Here: the header of
//! events.csv (`event,step,t,<coordinates>,p_<coordinates>`, one row per located event,
//! numbers in shortest round-trip form), and the Poincaré plot per event (`poincare_<event>.svg`: the first coordinate against its momentum,
//! as points).

use crate::plot::{file, scatter, Series};
use crate::problem::Problem;
use std::path::Path;

/// The header of events.csv.
pub fn columns(problem: &Problem) -> Vec<String> {
    let mut header = vec!["event".to_string(), "step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header
}

/// `poincare_<event>` for each event: the first coordinate against its momentum at the
/// located events (`events`: event index, q₁, p₁), as points.
pub(crate) fn poincare(
    dir: &Path,
    problem: &Problem,
    events: &[(usize, f64, f64)],
    f: crate::plot::Format,
) -> Result<(), String> {
    let c = &problem.coordinates[0];
    for (i, e) in problem.events.iter().enumerate() {
        let points = events.iter().filter(|r| r.0 == i).map(|r| (r.1, r.2)).collect();
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
