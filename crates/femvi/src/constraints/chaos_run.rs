//! A constrained run taken step by step whose tangent vectors live on the manifold: the steps
//! of `stepper.rs`, each step's ambient tangent map Φ (`tangent.rs`) and the symplectic
//! coordinates of `chart.rs`, for [`crate::chaos::constrained_indicators`] and
//! [`crate::chaos::constrained_sensitivity`].

use super::chart::{chart, Chart};
use super::layout::Enforcement;
use super::start::begin;
use super::stepper::Stepper;
use super::Constraints;
use crate::bvp::ElementTerm;
use crate::discrete::Element;
use crate::error::{Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions};
use crate::step::TimeGrid;
use nalgebra::DMatrix;

/// A constrained run, its node and the chart at that node.
pub(crate) struct ManifoldRun<'a, L, C> {
    lag: &'a L,
    con: &'a C,
    element: &'a Element,
    grid: TimeGrid,
    max_steps: Option<usize>,
    stepper: Stepper,
    pub q: Vec<f64>,
    pub p: Vec<f64>,
    v: Vec<f64>,
    pub t: f64,
    k: usize,
    /// (t_k, h) of the last step.
    last: Option<(f64, f64)>,
    /// The chart at the current node.
    pub chart: Chart,
    /// The discrete forces of a forced run ([`ManifoldRun::with_term`]).
    term: Option<&'a dyn ElementTerm>,
}

impl<'a, L: Lagrangian, C: Constraints> ManifoldRun<'a, L, C> {
    /// The run of `problem` on `constraints` (checks as [`super::solve_constrained_with`]).
    ///
    /// # Errors
    /// As [`super::solve_constrained_with`]; a singular chart at the start.
    pub(crate) fn new(
        problem: &'a Problem<L>,
        con: &'a C,
        element: &'a Element,
        options: &SolveOptions,
        enforcement: Enforcement,
    ) -> Result<Self> {
        let lag = &problem.lagrangian;
        let (n, m) = (lag.dim(), con.count());
        let start = begin(problem, con, element, options, enforcement)?;
        let chart = chart(lag, con, problem.t0, &start.on.q, &start.on.p).ok_or_else(|| singular(0, problem.t0))?;
        Ok(Self {
            lag,
            con,
            element,
            grid: start.grid,
            max_steps: options.max_steps,
            stepper: Stepper::new(element, start.layout, (n, m), options.solver, lag, false)?,
            q: start.on.q,
            p: start.on.p,
            v: start.on.v,
            t: problem.t0,
            k: 0,
            last: None,
            chart,
            term: None,
        })
    }

    /// The same run under the discrete forces `term` (those of
    /// [`super::solve_constrained_forced`]'s steps): its steps and tangent maps are those of
    /// the discrete Lagrange–d'Alembert principle on the augmented action.
    pub(crate) fn with_term(mut self, term: &'a dyn ElementTerm) -> Self {
        self.term = Some(term);
        self
    }

    /// Takes the next step: Ok(false) at the end of the grid or after `max_steps`.
    ///
    /// # Errors
    /// A failed step.
    pub(crate) fn step(&mut self) -> Result<bool> {
        let Some((h, t1)) = self.grid.next(self.k, self.t) else {
            return Ok(false);
        };
        if self.max_steps.is_some_and(|cap| self.k >= cap) {
            return Ok(false);
        }
        let ends = (self.k, self.t, h, t1);
        self.stepper.step(
            self.lag,
            self.con,
            self.element,
            ends,
            &mut self.q,
            &mut self.p,
            &mut self.v,
            self.term,
        )?;
        self.last = Some((self.t, h));
        self.t = t1;
        self.k += 1;
        Ok(true)
    }

    /// Length of the last step (0 before the first).
    pub(crate) fn last_step(&self) -> f64 {
        self.last.map_or(0.0, |(_, h)| h)
    }

    /// The last step's ambient tangent map Φ (2n square).
    ///
    /// # Errors
    /// No step taken, or a singular linear system ([`Error::Step`]).
    pub(crate) fn ambient_map(&mut self) -> Result<DMatrix<f64>> {
        let Some((t0, h)) = self.last else {
            return Err(crate::error::invalid("tangent map", "no step has been taken"));
        };
        let (lag, con, element) = (self.lag, self.con, self.element);
        self.stepper
            .tangent_map(lag, con, element, (t0, h, self.t), &self.q, &self.v, self.term)
            .ok_or_else(|| singular(self.k - 1, t0))
    }

    /// The last step's map in the charts' symplectic coordinates, 2(n − m) square: from the
    /// chart before the step to the chart at the new node (which becomes the current one).
    ///
    /// # Errors
    /// As [`ManifoldRun::ambient_map`]; a singular chart.
    pub(crate) fn reduced_map(&mut self) -> Result<DMatrix<f64>> {
        let phi = self.ambient_map()?;
        let (t0, _) = self.last.unwrap_or((self.t, 0.0));
        let next = chart(self.lag, self.con, self.t, &self.q, &self.p).ok_or_else(|| singular(self.k - 1, t0))?;
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
