//! The plots of a run, drawn when it ends: coordinates against time, a phase portrait per
//! coordinate (the entries of rotations have theirs in `plot_rotations.rs`), the relative energy error, in energy mode the step sizes, and for systems whose
//! coordinates come in planar or spatial groups (the built-in kepler, n-body and
//! outer-solar-system) the orbits, one curve per body in the plane of its first two
//! coordinates. They show the nodes trajectory.csv keeps; every title names the scheme and
//! the step.
//!
//! Memory is bounded whatever the length of the run: the nodes are kept in a [`PlotTrace`],
//! which halves them when it holds its limit. A run with plots resumes from a checkpoint to
//! the same plots: [`PlotData::words`] and [`PlotData::resume`] carry the state across.

use super::plot_trace::{PlotTrace, TraceNode};
use super::{EventRows, NodeEnergy, Thinning, WriteFailure};
use crate::plot::{file, lines, log_lines, orbits, step_label, Format, Series};
use crate::problem::Problem;
use crate::resume::{self, PlotsSaved};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::cell::Cell;
use std::path::Path;
use std::rc::Rc;

/// What the plots need, gathered as the run goes.
pub struct PlotData<'a> {
    problem: &'a Problem,
    dir: &'a Path,
    format: Format,
    thinning: Thinning,
    energy: Rc<Cell<NodeEnergy>>,
    failure: WriteFailure,
    trace: PlotTrace,
}

impl<'a> PlotData<'a> {
    /// Plots of `problem` in `format`, drawn into `dir` at the end.
    pub fn new(
        problem: &'a Problem,
        dir: &'a Path,
        format: Format,
        energy: Rc<Cell<NodeEnergy>>,
        failure: WriteFailure,
    ) -> Self {
        PlotData {
            problem,
            dir,
            format,
            thinning: Thinning::new(problem.every),
            energy,
            failure,
            trace: PlotTrace::new(problem.coordinates.len()),
        }
    }

    /// The state of the plots after the node a checkpoint is written at: which node was kept
    /// last and the [`PlotTrace`].
    pub fn words(&self) -> Vec<u64> {
        let mut w = vec![self.thinning.last_kept() as u64];
        w.extend(self.trace.words());
        w
    }

    /// Plots of a resumed run, in the state [`PlotData::words`] gave.
    ///
    /// # Errors
    /// The words do not fit `problem`.
    pub fn resume(
        problem: &'a Problem,
        dir: &'a Path,
        format: Format,
        energy: Rc<Cell<NodeEnergy>>,
        failure: WriteFailure,
        words: &[u64],
    ) -> Result<Self, String> {
        let mut me = Self::new(problem, dir, format, energy, failure);
        let (last, trace) = words.split_first().ok_or("the checkpoint's plot state is empty")?;
        let last = usize::try_from(*last).unwrap_or(usize::MAX);
        me.thinning = Thinning::after(problem.every, last);
        me.trace = PlotTrace::from_words(problem.coordinates.len(), trace)?;
        Ok(me)
    }

    /// Draws coordinates against time, phase portraits, the energy error, (energy mode) the
    /// step sizes and (constraints) the constraint residual.
    fn draw(&self) -> Result<(), String> {
        let (dir, f, problem, trace) = (self.dir, self.format, self.problem, &self.trace);
        let n = problem.coordinates.len();
        let name = &self.title();
        let coords: Vec<Series> = (0..n)
            .map(|c| Series {
                name: problem.coordinates[c].clone(),
                points: trace
                    .t
                    .iter()
                    .enumerate()
                    .map(|(k, t)| (*t, trace.q[k * n + c]))
                    .collect(),
            })
            .collect();
        let title = format!("{name}: coordinates");
        lines(&file(dir, "coordinates", f), f, &title, "t", "q", &coords)?;
        // The entries of a rotation have their own plots (`plot_rotations.rs`), not phase
        // portraits.
        let rotation_entries = problem.terms.rotations.as_ref().map_or(0, |r| 9 * r.count());
        for (c, cname) in problem.coordinates.iter().enumerate().skip(rotation_entries) {
            let pts = (0..trace.t.len())
                .map(|k| (trace.q[k * n + c], trace.p[k * n + c]))
                .collect();
            let series = [Series {
                name: cname.clone(),
                points: pts,
            }];
            let title = format!("{name}: phase portrait of {cname}");
            let path = file(dir, &format!("phase_{cname}"), f);
            lines(&path, f, &title, cname, &format!("p_{cname}"), &series)?;
        }
        let energy = [Series {
            name: "relative energy error".into(),
            points: trace.t.iter().zip(&trace.rel_energy).map(|(t, e)| (*t, *e)).collect(),
        }];
        let title = format!("{name}: relative energy error");
        let path = file(dir, "energy_error", f);
        log_lines(&path, f, &title, "t", "|H - H0| / |H0|", &energy, false)?;
        if problem.energy.is_some() {
            let steps = [Series {
                name: "step".into(),
                points: trace
                    .t
                    .iter()
                    .zip(&trace.steps)
                    .skip(1)
                    .map(|(t, h)| (*t, *h))
                    .collect(),
            }];
            let title = format!("{name}: step size (energy mode)");
            lines(&file(dir, "step_size", f), f, &title, "t", "h", &steps)?;
        }
        if !trace.residual.is_empty() {
            let residual = [Series {
                name: "max |g(q)|".into(),
                points: trace.t.iter().zip(&trace.residual).map(|(t, g)| (*t, *g)).collect(),
            }];
            let title = format!("{name}: constraint residual");
            log_lines(
                &file(dir, "residual", f),
                f,
                &title,
                "t",
                "max |g(q)|",
                &residual,
                false,
            )?;
        }
        self.draw_orbits(name)
    }

    /// The head of every title: the problem, its scheme and its step.
    fn title(&self) -> String {
        let problem = self.problem;
        format!(
            "{} ({}, h = {})",
            problem.name,
            problem.scheme_label,
            step_label(problem)
        )
    }

    /// orbit.svg: for each body (a group of coordinates), its first two coordinates.
    fn draw_orbits(&self, name: &str) -> Result<(), String> {
        let problem = self.problem;
        let bodies = bodies(problem);
        if bodies.is_empty() {
            return Ok(());
        }
        let n = problem.coordinates.len();
        let series: Vec<Series> = bodies
            .iter()
            .map(|(label, i, j)| Series {
                name: label.clone(),
                points: (0..self.trace.t.len())
                    .map(|k| (self.trace.q[k * n + i], self.trace.q[k * n + j]))
                    .collect(),
            })
            .collect();
        let (x, y) = (&problem.coordinates[bodies[0].1], &problem.coordinates[bodies[0].2]);
        let (xl, yl) = if bodies.len() == 1 {
            (x.clone(), y.clone())
        } else {
            (
                "x (first coordinate of each body)".into(),
                "y (second coordinate of each body)".into(),
            )
        };
        let title = format!("{name}: orbits");
        let f = self.format;
        orbits(&file(self.dir, "orbit", f), f, &title, &xl, &yl, &series)
    }
}

/// The bodies of a built-in model whose coordinates come in groups: a label and the
/// indices of the body's first two coordinates. Empty for other systems.
pub fn bodies(problem: &Problem) -> Vec<(String, usize, usize)> {
    const OUTER: [&str; 6] = ["Sun", "Jupiter", "Saturn", "Uranus", "Neptune", "Pluto"];
    match &problem.model {
        Some((m, _)) if m == "kepler" => vec![("orbit".into(), 0, 1)],
        Some((m, _)) if m == "outer-solar-system" => OUTER
            .iter()
            .enumerate()
            .map(|(b, s)| (s.to_string(), 3 * b, 3 * b + 1))
            .collect(),
        Some((m, p)) if m == "n-body" => {
            let (count, dim) = (p[0] as usize, p[1] as usize);
            (0..count)
                .map(|b| (format!("body {b}"), dim * b, dim * b + 1))
                .collect()
        }
        _ => vec![],
    }
}

impl<L: Lagrangian> Observer<L> for PlotData<'_> {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        let node = it.node();
        if !self.thinning.keep(node.k, last) {
            return Ok(());
        }
        let node = TraceNode {
            t: node.t,
            q: node.q,
            p: node.p,
            rel_energy: self.energy.get().rel,
            residual: it.node_constraints().map(|at| at.residual),
        };
        self.trace.offer(node, last);
        Ok(())
    }

    /// Draws the plots, unless an output before them could not be written; a plot that
    /// cannot be drawn is the run's error (if it has none).
    fn finish(&mut self, it: &Integrator<'_, L>, error: Option<&femvi::Error>) -> femvi::Result<()> {
        if self.failure.happened() {
            return Ok(());
        }
        // A run stopped early (an event with stop = true) ends on a node the thinning may
        // have skipped: keep it, as the last node of a finished run always is.
        if error.is_none() {
            Observer::<L>::node(self, it, true)?;
        }
        let target = (self.dir, self.format);
        self.draw()
            .and_then(|()| {
                super::plot_rotations::draw(it.lagrangian(), self.problem, &self.trace, target, &self.title())
            })
            .map_err(femvi::Error::Observer)
    }
}

/// Writes the plots' state of a checkpoint into side file `slot` of `dir`: `trace` (the
/// words of [`PlotData::words`] or of an adaptive run's [`PlotTrace`]) and the Poincaré
/// points of `events`.
///
/// # Errors
/// The write failed.
pub fn save_plot_state(
    dir: &Path,
    slot: u8,
    trace: Vec<u64>,
    events: Option<&EventRows>,
) -> std::io::Result<PlotsSaved> {
    let mut sections = vec![trace];
    sections.extend(events.and_then(EventRows::kept_words));
    resume::save_plots(dir, slot, &sections)
}

/// Splits what [`save_plot_state`] wrote (read back and checked by
/// [`crate::resume::load_plots`], before any output is cut back): restores the Poincaré points
/// of `events` and returns the trace's words.
///
/// # Errors
/// A message for the user: the sections are not those of a plot state.
pub fn load_plot_state(sections: Vec<Vec<u64>>, events: Option<&mut EventRows>) -> Result<Vec<u64>, String> {
    let mut sections = sections.into_iter();
    let (Some(trace), points, None) = (sections.next(), sections.next(), sections.next()) else {
        return Err("cannot resume: the checkpoint's plot state is damaged".into());
    };
    if let (Some(events), Some(points)) = (events, points) {
        events.restore_kept(&points)?;
    }
    Ok(trace)
}
