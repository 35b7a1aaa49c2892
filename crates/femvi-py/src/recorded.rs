//! `solve` of a problem with `[forces]` or `[constraints]` or both (fixed steps) when Python
//! asks for `saveat`, dense output or events: the library's `forces::solve_forced_with` and
//! `constraints::solve_constrained_observed` / `solve_constrained_forced_observed`, which
//! record the integrator with the problem's terms (`Integrator::with_force`,
//! `with_constraints`, `with_constraints_and_force`) with the recorder of every plain run, so
//! that the samples, the dense output and the event times come from the element polynomials
//! of the terms' steps. Observers collect what the terms add: [`WorkAtNodes`], the discrete
//! work W_k at the kept nodes and the energy balance max_k |H_k − H_0 − W_k| over every node;
//! [`ConstraintsAtNodes`], the multipliers and max |g(q)| at the kept nodes and the largest
//! residual over the run — as `forces::solve_forced` and `constraints::solve_constrained_with`
//! report them (their nodes are the same, bit for bit).

use crate::run::{run_on, Extras, Run};
use femvi::constraints::{solve_constrained_forced_observed, solve_constrained_observed, Enforcement, ExprConstraints};
use femvi::forces::solve_forced_with;
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use femvi_cli::problem::forces::ProblemForce;
use femvi_cli::problem::Problem;
use std::path::Path;

/// What a forced or constrained run adds to the solution.
#[derive(Debug, Default)]
pub struct Added {
    /// Forces: W_k at the kept nodes, and the balance (absolute, relative to |H_0|).
    pub work: Option<(Vec<f64>, f64, f64)>,
    /// Constraints: their number m, the multipliers (kept nodes × m), max |g(q)| at each kept
    /// node and over every node.
    pub constraints: Option<(usize, Vec<f64>, Vec<f64>, f64)>,
}

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

/// The multipliers and residuals at the nodes a constrained run keeps, and the largest
/// residual over the run.
#[derive(Debug, Default)]
pub struct ConstraintsAtNodes {
    every: usize,
    m: usize,
    /// (k, λ at k, max |g(q)| at k) at the kept nodes and the node the run ended on.
    kept: Vec<(usize, Vec<f64>, f64)>,
    max_residual: f64,
}

impl ConstraintsAtNodes {
    /// An observer for a run with `m` constraints that keeps every `every`-th node.
    pub fn new(every: usize, m: usize) -> Self {
        Self {
            every,
            m,
            ..Self::default()
        }
    }

    fn keep<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) {
        let k = it.node().k;
        if self.kept.last().map(|(j, _, _)| *j) == Some(k) {
            return;
        }
        if let Some(at) = it.node_constraints() {
            self.max_residual = at.max_residual;
            self.kept.push((k, at.multipliers, at.residual));
        }
    }

    /// (m, the multipliers at each of `steps` row by row, max |g(q)| at each, the largest
    /// residual over the run); NaN at a node not kept (none is: the recorder keeps by the
    /// same rule).
    pub fn finish(self, steps: &[usize]) -> (usize, Vec<f64>, Vec<f64>, f64) {
        let (mut multipliers, mut residual) = (Vec::new(), Vec::new());
        for k in steps {
            match self.kept.binary_search_by_key(k, |(j, _, _)| *j) {
                Ok(i) => {
                    multipliers.extend_from_slice(&self.kept[i].1);
                    residual.push(self.kept[i].2);
                }
                Err(_) => {
                    multipliers.extend(std::iter::repeat_n(f64::NAN, self.m));
                    residual.push(f64::NAN);
                }
            }
        }
        (self.m, multipliers, residual, self.max_residual)
    }
}

impl<L: Lagrangian> Observer<L> for ConstraintsAtNodes {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        let k = it.node().k;
        if k == 0 || last || (self.every > 0 && k.is_multiple_of(self.every)) {
            self.keep(it);
        }
        Ok(())
    }

    fn finish(&mut self, it: &Integrator<'_, L>, _error: Option<&femvi::Error>) -> femvi::Result<()> {
        // The node the run ended on (a step limit, a stopping event, a failed step).
        self.keep(it);
        Ok(())
    }
}

/// Runs `problem` under its terms (`force`, `constraints`) with the Python side's
/// `extras`; returns the run and what the terms add.
///
/// # Errors
/// The library's refusal, as a message naming `path`.
pub fn run<L: Lagrangian + Sync>(
    lag: L,
    (force, constraints): (Option<&ProblemForce>, Option<&(ExprConstraints, Enforcement)>),
    problem: &Problem,
    path: &Path,
    extras: &Extras,
) -> Result<(Run, Added), String> {
    let mut added = Added::default();
    let r = run_on(problem, path, extras, |options| {
        let p = problem.library(lag);
        let mut work = WorkAtNodes::new(options.every);
        let m = constraints.map_or(0, |(c, _)| femvi::constraints::Constraints::count(c));
        let mut at = ConstraintsAtNodes::new(options.every, m);
        let el = &problem.element;
        let sol = match (force, constraints) {
            (Some(f), None) => solve_forced_with(&p, f, el, options, &mut [&mut work])?,
            (None, Some((c, e))) => solve_constrained_observed(&p, c, el, options, *e, &mut [&mut at])?,
            (Some(f), Some((c, e))) => {
                solve_constrained_forced_observed(&p, f, c, el, options, *e, &mut [&mut work, &mut at])?
            }
            (None, None) => femvi::solution::solve_with(&p, el, options, &mut [])?,
        };
        if force.is_some() {
            added.work = Some(work.finish(&sol.step));
        }
        if constraints.is_some() {
            added.constraints = Some(at.finish(&sol.step));
        }
        Ok(Run::of(sol))
    })?;
    Ok((r, added))
}
