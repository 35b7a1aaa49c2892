//! The plots of a run, drawn when it ends: coordinates against time, a phase portrait per
//! coordinate, the relative energy error, in energy mode the step sizes, and for systems whose
//! coordinates come in planar or spatial groups (the built-in kepler, n-body and
//! outer-solar-system) the orbits, one curve per body in the plane of its first two
//! coordinates. They show the nodes trajectory.csv keeps; every title names the scheme and
//! the step.
//!
//! Memory is bounded whatever the length of the run: the nodes kept for the plots (after
//! `every`) are decimated by halving — when [`PlotData`] holds its limit of nodes
//! ([`max_nodes`], at most 65 536 and about 32 MB of values), every other one is dropped and
//! from then on only every 2nd, 4th, … node is taken — and the last node is always kept. A
//! plot draws at most 5 000 points per line anyway (`plot::thin`), so for runs of up to 65 536
//! kept nodes the plots are unchanged.

use super::{NodeEnergy, Thinning, WriteFailure};
use crate::plot::{file, lines, log_lines, orbits, step_label, Format, Series};
use crate::problem::Problem;
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
    t: Vec<f64>,
    q: Vec<f64>,
    p: Vec<f64>,
    rel_energy: Vec<f64>,
    /// A constrained run's max |g(q)| per kept node (empty otherwise).
    residual: Vec<f64>,
    /// Per kept node: the time since the previous node after `every` (NaN for the first).
    steps: Vec<f64>,
    /// The previous node after `every`, kept or not.
    previous: Option<f64>,
    decimation: Decimation,
}

/// Which nodes (after `every`) the plots hold: those whose index is a multiple of `stride`,
/// and the last; when `limit` are held, every other one goes and the stride doubles.
#[derive(Debug, Clone, Copy)]
struct Decimation {
    seen: usize,
    stride: usize,
    limit: usize,
}

impl Decimation {
    fn new(limit: usize) -> Self {
        Decimation {
            seen: 0,
            stride: 1,
            limit: limit.max(2),
        }
    }

    /// For the next node (`last`: the run's final one), with `held` nodes held: whether to
    /// halve those first, and whether to keep this one.
    fn offer(&mut self, held: usize, last: bool) -> (bool, bool) {
        let index = self.seen;
        self.seen += 1;
        if !(last || index.is_multiple_of(self.stride)) {
            return (false, false);
        }
        if held >= self.limit {
            self.stride *= 2;
            return (true, last || index.is_multiple_of(self.stride));
        }
        (false, true)
    }
}

/// Most values (times, coordinates, momenta, energies, steps) [`PlotData`] keeps.
const MAX_VALUES: usize = 1 << 22;

/// Most nodes [`PlotData`] keeps for a system with n coordinates: 65 536, fewer when a node's
/// 2n + 3 values would take more than [`MAX_VALUES`] in all, and at least 16.
pub fn max_nodes(n: usize) -> usize {
    (MAX_VALUES / (2 * n + 3)).clamp(16, 1 << 16)
}

/// Keeps the chunks of `width` values of `v` at even positions (0, 2, 4, …).
fn keep_even<T: Copy>(v: &mut Vec<T>, width: usize) {
    let chunks = v.len() / width.max(1);
    for c in (0..chunks).step_by(2) {
        let to = c / 2 * width;
        v.copy_within(c * width..(c + 1) * width, to);
    }
    v.truncate(chunks.div_ceil(2) * width);
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
            t: vec![],
            q: vec![],
            p: vec![],
            rel_energy: vec![],
            residual: vec![],
            steps: vec![],
            previous: None,
            decimation: Decimation::new(max_nodes(problem.coordinates.len())),
        }
    }

    /// Halves the nodes kept (those at even positions stay).
    fn decimate(&mut self) {
        let n = self.problem.coordinates.len();
        keep_even(&mut self.t, 1);
        keep_even(&mut self.q, n);
        keep_even(&mut self.p, n);
        keep_even(&mut self.rel_energy, 1);
        keep_even(&mut self.residual, 1);
        keep_even(&mut self.steps, 1);
    }

    /// Draws coordinates against time, phase portraits, the energy error, (energy mode) the
    /// step sizes and (constraints) the constraint residual.
    fn draw(&self) -> Result<(), String> {
        let (dir, f, problem) = (self.dir, self.format, self.problem);
        let n = problem.coordinates.len();
        let name = &format!(
            "{} ({}, h = {})",
            problem.name,
            problem.scheme_label,
            step_label(problem)
        );
        let coords: Vec<Series> = (0..n)
            .map(|c| Series {
                name: problem.coordinates[c].clone(),
                points: self
                    .t
                    .iter()
                    .enumerate()
                    .map(|(k, t)| (*t, self.q[k * n + c]))
                    .collect(),
            })
            .collect();
        let title = format!("{name}: coordinates");
        lines(&file(dir, "coordinates", f), f, &title, "t", "q", &coords)?;
        for (c, cname) in problem.coordinates.iter().enumerate() {
            let pts = (0..self.t.len())
                .map(|k| (self.q[k * n + c], self.p[k * n + c]))
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
            points: self.t.iter().zip(&self.rel_energy).map(|(t, e)| (*t, *e)).collect(),
        }];
        let title = format!("{name}: relative energy error");
        let path = file(dir, "energy_error", f);
        log_lines(&path, f, &title, "t", "|H - H0| / |H0|", &energy, false)?;
        if problem.energy.is_some() {
            let steps = [Series {
                name: "step".into(),
                points: self.t.iter().zip(&self.steps).skip(1).map(|(t, h)| (*t, *h)).collect(),
            }];
            let title = format!("{name}: step size (energy mode)");
            lines(&file(dir, "step_size", f), f, &title, "t", "h", &steps)?;
        }
        if !self.residual.is_empty() {
            let residual = [Series {
                name: "max |g(q)|".into(),
                points: self.t.iter().zip(&self.residual).map(|(t, g)| (*t, *g)).collect(),
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
                points: (0..self.t.len())
                    .map(|k| (self.q[k * n + i], self.q[k * n + j]))
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
        let step = self.previous.map_or(f64::NAN, |previous| node.t - previous);
        self.previous = Some(node.t);
        let (halve, keep) = self.decimation.offer(self.t.len(), last);
        if halve {
            self.decimate();
        }
        if !keep {
            return Ok(());
        }
        self.steps.push(step);
        self.t.push(node.t);
        self.q.extend_from_slice(node.q);
        self.p.extend_from_slice(node.p);
        self.rel_energy.push(self.energy.get().rel);
        if let Some(at) = it.node_constraints() {
            self.residual.push(at.residual);
        }
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
        self.draw().map_err(femvi::Error::Observer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nodes offered one by one: never more than the limit held, evenly spaced by the final
    /// stride from node 0, and the last one always held.
    #[test]
    fn decimation_holds_a_bounded_evenly_spaced_subset_and_the_last_node() {
        for (total, limit) in [
            (1usize, 16usize),
            (10, 16),
            (16, 16),
            (17, 16),
            (1000, 16),
            (100_003, 1000),
        ] {
            let mut d = Decimation::new(limit);
            let mut held: Vec<usize> = vec![];
            for i in 0..total {
                let (halve, keep) = d.offer(held.len(), i + 1 == total);
                if halve {
                    keep_even(&mut held, 1);
                }
                if keep {
                    held.push(i);
                }
                assert!(held.len() <= limit, "{total} {limit}: {} held", held.len());
            }
            assert_eq!(held.last(), Some(&(total - 1)));
            let body = &held[..held.len() - 1];
            for (j, &i) in body.iter().enumerate() {
                assert_eq!(i, j * d.stride, "{total} {limit}");
            }
            // Not thinned more than needed: at least a quarter of the limit held.
            assert!(held.len() >= (limit / 4).min(total), "{total} {limit}: {}", held.len());
        }
    }

    #[test]
    fn keep_even_keeps_chunks_at_even_positions() {
        let mut v: Vec<f64> = (0..10).map(f64::from).collect();
        keep_even(&mut v, 2);
        assert_eq!(v, [0.0, 1.0, 4.0, 5.0, 8.0, 9.0]);
        let mut w = vec![1, 2, 3];
        keep_even(&mut w, 1);
        assert_eq!(w, [1, 3]);
    }

    #[test]
    fn node_limits_are_bounded() {
        assert_eq!(max_nodes(1), 1 << 16);
        assert!(max_nodes(1000) * 2003 <= MAX_VALUES);
        assert!(max_nodes(100_000) * 200_003 <= MAX_VALUES);
        assert_eq!(max_nodes(10_000_000), 16);
    }
}
