//! `solve` of a problem with `[forces]` (fixed steps) when Python asks for `saveat`, dense
//! output or events: the library's `forces::solve_forced_with`, which records the forced
//! integrator (`Integrator::with_force`) with the recorder of every plain run, so that the
//! samples, the dense output and the event times come from the forced element polynomials.
//! [`WorkAtNodes`] observes the run for what the forced solution adds: the discrete work W_k
//! at the kept nodes and the energy balance max_k |H_k − H_0 − W_k| over every node, as
//! `forces::solve_forced` reports them (its nodes are the same, bit for bit).

use crate::run::{run_on, Extras, Run};
use femvi::forces::solve_forced_with;
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use femvi_cli::problem::forces::ProblemForce;
use femvi_cli::problem::Problem;
use std::path::Path;

/// W at the kept nodes, max |H − H0 − W| over every node, the same relative to |H0|.
pub type Work = (Vec<f64>, f64, f64);

/// The work at the nodes a run keeps, and the balance over every node.
#[derive(Debug, Default)]
pub struct WorkAtNodes {
    every: usize,
    /// (k, W_k) at the nodes the run keeps by `every`, and the node it ended on.
    kept: Vec<(usize, f64)>,
    h0: Option<f64>,
    max_abs: f64,
    max_rel: f64,
}

impl WorkAtNodes {
    /// An observer for a run that keeps every `every`-th node (none between for 0).
    pub fn new(every: usize) -> Self {
        Self {
            every,
            ..Self::default()
        }
    }

    fn keep(&mut self, k: usize, work: f64) {
        if self.kept.last().map(|&(j, _)| j) != Some(k) {
            self.kept.push((k, work));
        }
    }

    /// W_k at each of `steps` (the node indices of the solution), and the balance
    /// (absolute, relative to |H_0|, absolute where H_0 = 0). A node this observer did not
    /// keep gets NaN (none does: the recorder keeps by the same rule).
    pub fn finish(self, steps: &[usize]) -> Work {
        let work = steps
            .iter()
            .map(|k| {
                self.kept
                    .binary_search_by_key(k, |&(j, _)| j)
                    .map_or(f64::NAN, |i| self.kept[i].1)
            })
            .collect();
        (work, self.max_abs, self.max_rel)
    }
}

impl<L: Lagrangian> Observer<L> for WorkAtNodes {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        let (k, work) = (it.node().k, it.work());
        let h = it.energy()?;
        let h0 = *self.h0.get_or_insert(h);
        let abs = (h - h0 - work).abs();
        self.max_abs = self.max_abs.max(abs);
        self.max_rel = self.max_rel.max(if h0 != 0.0 { abs / h0.abs() } else { abs });
        if k == 0 || last || (self.every > 0 && k % self.every == 0) {
            self.keep(k, work);
        }
        Ok(())
    }

    fn finish(&mut self, it: &Integrator<'_, L>, _error: Option<&femvi::Error>) -> femvi::Result<()> {
        // The node the run ended on (a step limit, a stopping event, a failed step).
        self.keep(it.node().k, it.work());
        Ok(())
    }
}

/// Runs `problem` under `force` with the Python side's `extras`; returns the run and
/// (W at the kept nodes, max |H − H0 − W|, the same relative to |H0|).
///
/// # Errors
/// The library's refusal, as a message naming `path`.
pub fn run<L: Lagrangian + Sync>(
    lag: L,
    force: &ProblemForce,
    problem: &Problem,
    path: &Path,
    extras: &Extras,
) -> Result<(Run, Work), String> {
    let mut added = None;
    let r = run_on(problem, path, extras, |options| {
        let p = problem.library(lag);
        let mut work = WorkAtNodes::new(options.every);
        let sol = solve_forced_with(&p, force, &problem.element, options, &mut [&mut work])?;
        added = Some(work.finish(&sol.step));
        let max_rel_energy_error = sol.energy_report.map_or(f64::NAN, |r| r.max_rel_error);
        Ok(Run {
            sol,
            max_rel_energy_error,
            message: None,
            event_names: vec![],
            file_events: 0,
        })
    })?;
    Ok((r, added.unwrap_or_default()))
}
