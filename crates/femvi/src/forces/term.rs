//! The force as a term of the one integrator ([`crate::step::term`]): [`Integrator::with_force`]
//! runs the discrete Lagrange–d'Alembert equations of the module docs of [`crate::forces`]
//! with every part of an unforced run — the grid, the compensated node sums, the last element
//! (dense output and starting values), checkpoints, [`crate::step::drive()`] with its
//! observers, the chunked [`Integrator::advance`] — and the accumulated discrete work
//! ([`Integrator::work`]). The step is solved as `solve_forced` solves it: dense Newton on
//! the forced rows (`step.rs`) or, for a constant mass matrix and a force independent of v,
//! the mechanical fixed point on the augmented force −∇V + F (`fixed_point.rs`), with the same
//! starting values, so both give the same nodes bit for bit.

use super::element::element_forces_jacobian;
use super::fixed_point::{ElementWorkOf, WithForce};
use super::solve::{fixed_point_fits, start};
use super::step::{ForcedStep, Taken};
use super::Force;
use crate::discrete::Element;
use crate::error::{check_len, Result};
use crate::lagrangian::{hamiltonian, Lagrangian, PointDerivatives};
use crate::step::checkpoint::{Reader, Words};
use crate::step::fixed_point_step::FixedPointStep;
use crate::step::solver::StepContext;
use crate::step::state::{Increments, LastElement, RunState};
use crate::step::term::StepTerm;
use crate::step::{ElementNodes, Integrator, Method, SolverOptions, Start, TimeGrid};

impl<'a, L: Lagrangian + Sync> Integrator<'a, L> {
    /// Sets up a run of `lag` under the non-conservative force `force` (discrete
    /// Lagrange–d'Alembert, module docs of [`crate::forces`]): as [`Integrator::new`], with
    /// the step solved by fixed-point iteration when L has a constant mass matrix and F does
    /// not depend on v (for `Method::Auto`, `FixedPoint` and `Explicit`), by Newton's method
    /// otherwise, and the discrete work accumulated in [`Integrator::work`].
    ///
    /// # Errors
    /// As [`Integrator::new`]; a force of another dimension; a start from (q0, q1); a method
    /// that does not fit (fixed point for a velocity-dependent force).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::forces::LinearForce;
    /// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
    ///
    /// // The damped oscillator x'' = −x − 0.2 x': H(t) − H(0) = W(t) up to the method's error.
    /// let (lag, element) = (models::harmonic(1.0, 1.0)?, Element::with_order(4)?);
    /// let friction = LinearForce::damping(1, 0.2);
    /// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
    /// let grid = TimeGrid::uniform(0.0, 0.05, 10.0)?;
    /// let mut it = Integrator::with_force(&lag, &element, grid, start, SolverOptions::default(), &friction)?;
    /// let h0 = it.energy()?;
    /// while it.step()? {}
    /// assert!(it.energy()? < 0.2 * h0);
    /// assert!((it.energy()? - h0 - it.work()).abs() < 1e-7);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn with_force<F: Force + Sync>(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start_at: Start,
        opts: SolverOptions,
        force: &'a F,
    ) -> Result<Self> {
        let n = lag.dim();
        check_len("force", n, force.dim())?;
        opts.validate()?;
        element.check_nondegenerate()?;
        let t0 = grid.t0();
        // The start as `solve_forced` takes it: (q0, p0), and the velocity at the node as
        // its energy evaluation leaves it (the Newton step's first predictor).
        let (q0, p0, mut v0) = start(lag, &start_at, t0)?;
        hamiltonian(lag, t0, &q0, &p0, &mut v0, &mut PointDerivatives::new(n))?;
        let term: Box<dyn StepTerm + Send + 'a> = if fixed_point_fits(lag, force, opts.method)? {
            Box::new(FixedPointTerm {
                jac: ForceJacobian::new(force, element, n),
                fp: Box::new(FixedPointStep::new(element, n)?),
                wrapped: WithForce::new(lag, force),
                lag,
                force,
                element,
                opts: SolverOptions {
                    method: Method::FixedPoint,
                    ..opts
                },
                work_of: ElementWorkOf::new(element, n),
                last_work: 0.0,
            })
        } else {
            Box::new(NewtonTerm {
                jac: ForceJacobian::new(force, element, n),
                step: ForcedStep::new(lag, force, element, opts)?,
                taken: Taken::default(),
                v0,
            })
        };
        let start = Start::Momentum { q: q0, p: p0 };
        // The integrator's own solver is never asked: one that fits any Lagrangian.
        let plain = SolverOptions {
            method: Method::Auto,
            ..opts
        };
        Integrator::with_term(lag, element, grid, start, plain, term)
    }
}

/// The forced step by dense Newton (`step.rs`).
/// ∂F_d/∂Q of the discrete forces at an element ([`element_forces_jacobian`]), for the tangent
/// map of a forced step (`step/term_tangent.rs`).
struct ForceJacobian<'a, F> {
    force: &'a F,
    element: &'a Element,
    fd: Vec<f64>,
    fjac: Vec<f64>,
}

impl<'a, F: Force> ForceJacobian<'a, F> {
    fn new(force: &'a F, element: &'a Element, n: usize) -> Self {
        let w = element.nodes() * n;
        Self {
            force,
            element,
            fd: vec![0.0; w],
            fjac: vec![0.0; w * w],
        }
    }

    fn at(&mut self, el: ElementNodes<'_>) -> &[f64] {
        let (t, h, base, incr) = (el.t, el.h, el.base, el.incr);
        element_forces_jacobian(self.element, self.force, t, h, base, incr, &mut self.fd, &mut self.fjac);
        &self.fjac
    }
}

struct NewtonTerm<'a, L, F> {
    jac: ForceJacobian<'a, F>,
    step: ForcedStep<'a, L, F>,
    taken: Taken,
    /// The velocity at the start node: the predictor of the first step.
    v0: Vec<f64>,
}

impl<L: Lagrangian, F: Force> StepTerm for NewtonTerm<'_, L, F> {
    fn solve(
        &mut self,
        state: &RunState,
        _last: &mut LastElement,
        (h, _): (f64, f64),
        out: &mut Increments,
    ) -> Result<usize> {
        self.step
            .step(state.k, state.t, h, &state.q, &state.p, &self.v0, &mut self.taken)?;
        out.dq.copy_from_slice(&self.taken.dq);
        out.dp.copy_from_slice(&self.taken.dp);
        out.incr.copy_from_slice(self.step.increments());
        Ok(self.taken.iterations)
    }

    fn accepted(&mut self, _n: usize) {}

    fn element_work(&self) -> f64 {
        self.taken.work + self.taken.time_work
    }

    // The predictor's state is the last element, which the integrator saves.
    fn save(&self, _w: &mut Words) {}

    fn load(&mut self, _r: &mut Reader<'_>, last: &LastElement) -> Result<()> {
        if let Some(el) = last.view() {
            self.step.set_previous(el.incr, el.h);
        }
        Ok(())
    }

    fn name(&self) -> &'static str {
        "forces"
    }

    fn force_jacobian(&mut self, el: ElementNodes<'_>) -> Option<&[f64]> {
        Some(self.jac.at(el))
    }
}

/// The forced step by the mechanical fixed point on −∇V + F (`fixed_point.rs`).
struct FixedPointTerm<'a, L, F> {
    jac: ForceJacobian<'a, F>,
    fp: Box<FixedPointStep>,
    wrapped: WithForce<'a, L, F>,
    lag: &'a L,
    force: &'a F,
    element: &'a Element,
    opts: SolverOptions,
    work_of: ElementWorkOf<'a>,
    last_work: f64,
}

impl<L: Lagrangian, F: Force> StepTerm for FixedPointTerm<'_, L, F> {
    fn solve(
        &mut self,
        state: &RunState,
        last: &mut LastElement,
        (h, _): (f64, f64),
        out: &mut Increments,
    ) -> Result<usize> {
        let cx = StepContext {
            lag: &self.wrapped,
            element: self.element,
            opts: self.opts,
        };
        let sweeps = self.fp.solve(&cx, state, last, h, out)?;
        let el = ElementNodes {
            t: state.t,
            h,
            base: &state.q,
            incr: &out.incr,
        };
        self.last_work = self.work_of.of(self.lag, self.force, el);
        Ok(sweeps)
    }

    fn accepted(&mut self, n: usize) {
        let identity = self.lag.mass_matrix().is_some_and(|m| m.is_identity());
        self.fp.accepted(identity, self.element.points(), n);
    }

    fn element_work(&self) -> f64 {
        self.last_work
    }

    fn save(&self, w: &mut Words) {
        self.fp.save(w);
    }

    fn load(&mut self, r: &mut Reader<'_>, _last: &LastElement) -> Result<()> {
        self.fp.load(r)
    }

    fn name(&self) -> &'static str {
        "forces"
    }

    fn force_jacobian(&mut self, el: ElementNodes<'_>) -> Option<&[f64]> {
        Some(self.jac.at(el))
    }
}
