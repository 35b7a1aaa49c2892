//! A constrained run whose tangent vectors live on the manifold, for
//! [`crate::chaos::constrained_indicators`] and [`crate::chaos::constrained_sensitivity`]:
//! the run is the one integrator with the constraints' term
//! ([`Integrator::with_constraints`], with or without forces: the steps of `femvi run`); each
//! step's ambient tangent map Φ is the term's (`tangent.rs`, through
//! `Integrator::ambient_tangent_map`), and the symplectic coordinates of `chart.rs` at each
//! node reduce it to the map on T*N. Nothing here takes a step itself.

use super::chart::{chart, Chart};
use super::layout::Enforcement;
use super::start::check_options;
use super::Constraints;
use crate::discrete::Element;
use crate::error::{Error, Result, StepError, StepFailure};
use crate::forces::Force;
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions};
use crate::step::Integrator;
use nalgebra::DMatrix;

/// A constrained run of the integrator and the chart at its node.
pub(crate) struct ManifoldRun<'a, L: Lagrangian, C> {
    it: Integrator<'a, L>,
    lag: &'a L,
    con: &'a C,
    /// Steps left before `SolveOptions::max_steps` stops the run (None: to the grid's end).
    left: Option<usize>,
    /// The chart at the current node.
    pub chart: Chart,
}

impl<'a, L: Lagrangian + Sync, C: Constraints + Sync> ManifoldRun<'a, L, C> {
    /// The run of `problem` on `constraints` (checks as [`super::solve_constrained_with`]).
    ///
    /// # Errors
    /// As [`super::solve_constrained_with`]; a singular chart at the start.
    pub(crate) fn new(
        problem: &'a Problem<L>,
        con: &'a C,
        element: &'a Element,
        (options, enforcement): (&SolveOptions, Enforcement),
    ) -> Result<Self> {
        check_options(options)?;
        let (lag, grid) = (&problem.lagrangian, crate::solution::grid(problem, &options.steps)?);
        let (start, opts) = (problem.start.clone(), options.solver);
        let it = Integrator::with_constraints(lag, element, grid, start, opts, con, enforcement)?;
        Self::around(it, lag, con, options.max_steps)
    }

    /// The same run under `force`: the steps of [`super::solve_constrained_forced`] (the
    /// discrete Lagrange–d'Alembert principle on the augmented action).
    ///
    /// # Errors
    /// As [`super::solve_constrained_forced`]; a singular chart at the start.
    pub(crate) fn forced<F: Force + Sync>(
        problem: &'a Problem<L>,
        con: &'a C,
        element: &'a Element,
        (options, enforcement): (&SolveOptions, Enforcement),
        force: &'a F,
    ) -> Result<Self> {
        check_options(options)?;
        let (lag, grid) = (&problem.lagrangian, crate::solution::grid(problem, &options.steps)?);
        let (start, opts) = (problem.start.clone(), options.solver);
        let it = Integrator::with_constraints_and_force(lag, element, grid, start, opts, con, enforcement, force)?;
        Self::around(it, lag, con, options.max_steps)
    }

    fn around(it: Integrator<'a, L>, lag: &'a L, con: &'a C, max_steps: Option<usize>) -> Result<Self> {
        let node = it.node();
        let chart = chart(lag, con, node.t, node.q, node.p).ok_or_else(|| singular(0, node.t))?;
        Ok(Self {
            it,
            lag,
            con,
            left: max_steps,
            chart,
        })
    }
}

impl<L: Lagrangian, C: Constraints> ManifoldRun<'_, L, C> {
    /// Takes the next step: Ok(false) at the end of the grid or after `max_steps`.
    ///
    /// # Errors
    /// A failed step.
    pub(crate) fn step(&mut self) -> Result<bool> {
        match self.left.as_mut() {
            Some(0) => return Ok(false),
            Some(left) => *left -= 1,
            None => {}
        }
        self.it.step()
    }

    /// The current node (t, q, p).
    pub(crate) fn node(&self) -> (f64, &[f64], &[f64]) {
        let node = self.it.node();
        (node.t, node.q, node.p)
    }

    /// Length of the last step (0 before the first).
    pub(crate) fn last_step(&self) -> f64 {
        self.it.last_element().map_or(0.0, |e| e.h)
    }

    /// The last step's ambient tangent map Φ (2n square).
    ///
    /// # Errors
    /// No step taken, or a singular linear system ([`Error::Step`]).
    pub(crate) fn ambient_map(&mut self) -> Result<DMatrix<f64>> {
        self.it.ambient_tangent_map()
    }

    /// The last step's map in the charts' symplectic coordinates, 2(n − m) square: from the
    /// chart before the step to the chart at the new node (which becomes the current one).
    ///
    /// # Errors
    /// As [`ManifoldRun::ambient_map`]; a singular chart.
    pub(crate) fn reduced_map(&mut self) -> Result<DMatrix<f64>> {
        let phi = self.ambient_map()?;
        let node = self.it.node();
        let (k, t) = (node.k, node.t);
        let next = chart(self.lag, self.con, t, node.q, node.p).ok_or_else(|| singular(k.saturating_sub(1), t))?;
        let m = &next.reduce * phi * &self.chart.lift;
        self.chart = next;
        Ok(m)
    }
}

fn singular(step: usize, t: f64) -> Error {
    Error::Step(StepError {
        step,
        t,
        residual: f64::NAN,
        iterations: 0,
        failure: StepFailure::Singular,
    })
}
