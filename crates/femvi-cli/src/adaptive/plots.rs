//! Plots of an adaptive run (`--plot` or `[output] plots = true`), against the physical time
//! of the nodes: the coordinates, the relative energy error, the physical step size
//! Δt = t_{k+1} − t_k (which the monitor sets), and the orbits of bodies. They are drawn
//! from the bounded [`PlotTrace`] the writer keeps (`stream.rs`), so a run of any length
//! plots in bounded memory and resumes to the same plots.

use crate::plot::{file, lines, log_lines, orbits, Format, Series};
use crate::problem::{Problem, System};
use crate::record::PlotTrace;
use std::path::Path;

/// Draws coordinates, energy_error, step_size and (for bodies) orbit into `dir`.
pub(super) fn draw(dir: &Path, f: Format, problem: &Problem, sol: &PlotTrace, ds: f64) -> Result<(), String> {
    let n = problem.coordinates.len();
    let name = format!("{} ({}, adaptive, ds = {ds})", problem.name, problem.scheme_label);
    let coords: Vec<Series> = (0..n)
        .map(|c| Series {
            name: problem.coordinates[c].clone(),
            points: sol.t.iter().enumerate().map(|(k, t)| (*t, sol.q[k * n + c])).collect(),
        })
        .collect();
    lines(
        &file(dir, "coordinates", f),
        f,
        &format!("{name}: coordinates"),
        "t",
        "q",
        &coords,
    )?;
    let energy = [Series {
        name: "relative energy error".into(),
        points: sol.t.iter().zip(&sol.rel_energy).map(|(t, e)| (*t, *e)).collect(),
    }];
    let title = format!("{name}: relative energy error");
    log_lines(
        &file(dir, "energy_error", f),
        f,
        &title,
        "t",
        "|H - H0| / |H0|",
        &energy,
        false,
    )?;
    let steps = [Series {
        name: "physical step between kept nodes".into(),
        points: sol.t.iter().zip(&sol.steps).skip(1).map(|(t, dt)| (*t, *dt)).collect(),
    }];
    let title = format!("{name}: physical step size");
    lines(&file(dir, "step_size", f), f, &title, "t", "dt", &steps)?;
    let bodies = bodies(&problem.system);
    if bodies.is_empty() {
        return Ok(());
    }
    let series: Vec<Series> = bodies
        .iter()
        .map(|(label, i, j)| Series {
            name: label.clone(),
            points: (0..sol.t.len()).map(|k| (sol.q[k * n + i], sol.q[k * n + j])).collect(),
        })
        .collect();
    let (xl, yl) = (&problem.coordinates[bodies[0].1], &problem.coordinates[bodies[0].2]);
    orbits(&file(dir, "orbit", f), f, &format!("{name}: orbits"), xl, yl, &series)
}

/// The bodies whose first two coordinates make an orbit plot: Kepler's one, or each body of
/// the n-body models in 2 or 3 dimensions (the record module's list is private to it).
fn bodies(system: &System) -> Vec<(String, usize, usize)> {
    match system {
        System::Kepler(_) => vec![("orbit".into(), 0, 1)],
        System::Gravity(l) if l.potential.dim >= 2 => (0..l.potential.masses.len())
            .map(|b| (format!("body {b}"), l.potential.dim * b, l.potential.dim * b + 1))
            .collect(),
        _ => vec![],
    }
}
