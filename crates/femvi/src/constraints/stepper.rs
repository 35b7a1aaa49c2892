//! One constrained step at a time: the Newton solve of the step equations (`step.rs`), the new
//! node q_{k+1} by compensated summation and its momentum projected onto T*N (`project.rs`);
//! or, where [`super::rattle::choose`] picks them, RATTLE steps solved on the multipliers
//! (`rattle.rs`) or SHAKE-style fixed-point steps (`shake/`), committed the same way; under
//! `Method::Auto` a fixed-point step that fails is taken again by Newton.
//! The run of `solve.rs` and the chaos run on the manifold ([`crate::chaos`]) take their
//! steps here, so both follow the same nodes.

#[path = "rattle_loop.rs"]
mod rattle_loop;

pub(super) use rattle_loop::TermNode;

use super::jet::ConstraintJet;
use super::layout::Layout;
use super::limits::RANK_TOLERANCE;
use super::project::Projector;
use super::rattle::{Path, RattleStep};
use super::shake::ShakeStep;
use super::small::{conditioning, copy, project_linear};
use super::start::{singular, step_error};
use super::step::StepSystem;
use super::tangent::{step_map, StepEnds};
use super::Constraints;
use crate::bvp::ElementTerm;
use crate::discrete::Element;
use crate::error::{invalid, Error, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::solve::{newton_dense, DenseNewtonWork};
use crate::step::{Method, SolverOptions};
use nalgebra::DMatrix;

/// The scratch of the constrained step and the node before the last step.
pub(crate) struct Stepper {
    pub sys: StepSystem,
    pub projector: Projector,
    newton: DenseNewtonWork,
    tol: f64,
    max_iterations: usize,
    /// The Newton unknowns of the last step.
    x: Vec<f64>,
    comp: Vec<f64>,
    /// After a step: the node before it (q_k, p_k).
    q_prev: Vec<f64>,
    p_prev: Vec<f64>,
    /// μ̂_k of the last step.
    pub mu: Vec<f64>,
    /// Newton iterations of the last step.
    pub iterations: usize,
    /// The RATTLE step, if the run takes it ([`super::rattle::choose`]).
    rattle: Option<RattleStep>,
    /// The SHAKE-style step, if the run takes it, and whether a failed one falls back to
    /// Newton (`Method::Auto`).
    shake: Option<ShakeStep>,
    fallback: bool,
    /// Whether the method asked for explicit steps (an error under forces, which need Newton).
    insist: bool,
    /// m n scratch of the end node's conditioning.
    scratch: Vec<f64>,
    /// A jet for the RATTLE loop's evaluations (`rattle_loop.rs`).
    jet: ConstraintJet,
    /// Scratch of the linear projection (`small::project_linear`).
    projection: Vec<f64>,
    /// Whether `sys.end` (and the RATTLE step's end force) are those of the current node,
    /// evaluated there by the last RATTLE step: the next step takes them as its start.
    end_at_node: bool,
}

impl Stepper {
    /// The stepper of a run of `lag` (n coordinates, m constraints); `forced` if its steps
    /// carry discrete forces.
    ///
    /// # Errors
    /// A method that does not fit ([`super::rattle::choose`]).
    pub fn new<L: Lagrangian>(
        element: &Element,
        layout: Layout,
        (n, m): (usize, usize),
        solver: SolverOptions,
        lag: &L,
        forced: bool,
    ) -> Result<Self, Error> {
        let path = super::rattle::choose(solver.method, lag, element, &layout, forced)?;
        let shake = match path {
            Path::Shake => ShakeStep::new(element, &layout, n, m),
            _ => None,
        };
        if path == Path::Shake && shake.is_none() && solver.method != Method::Auto {
            return Err(invalid(
                "solver method",
                "the element has no fixed-point form; use the newton method",
            ));
        }
        let sys = StepSystem::new(element, layout, n, m);
        let newton = DenseNewtonWork::new(sys.unknowns());
        Ok(Self {
            x: vec![0.0; sys.unknowns()],
            sys,
            projector: Projector::new(n, m),
            newton,
            tol: solver.tolerance,
            max_iterations: solver.max_iterations,
            comp: vec![0.0; n],
            q_prev: vec![0.0; n],
            p_prev: vec![0.0; n],
            mu: vec![0.0; m],
            iterations: 0,
            rattle: (path == Path::Rattle).then(|| RattleStep::new(n, m)),
            shake,
            fallback: solver.method == Method::Auto,
            insist: matches!(solver.method, Method::Explicit | Method::FixedPoint),
            scratch: vec![0.0; m * n],
            jet: ConstraintJet::new(m, n),
            projection: vec![0.0; m * n + m * m + m],
            end_at_node: false,
        })
    }

    /// Step k from (t, q, p, v) to t1 = t + h: on success (q, p, v) hold node k + 1 and the
    /// node before is kept for [`Stepper::tangent_map`]. With `term` (the discrete forces,
    /// [`StepSystem::add_term`]) the step is that of the discrete Lagrange–d'Alembert
    /// principle on the augmented action.
    ///
    /// # Errors
    /// A failed Newton solve or projection ([`Error::Step`]), a singular constraint Jacobian
    /// ([`Error::SingularConstraints`]); (q, p, v) are then those of node k. Forces under a
    /// method that asked for explicit steps ([`Error::Invalid`]).
    #[allow(clippy::too_many_arguments)]
    pub fn step<L: Lagrangian, C: Constraints>(
        &mut self,
        lag: &L,
        con: &C,
        element: &Element,
        (k, t, h, t1): (usize, f64, f64, f64),
        q: &mut Vec<f64>,
        p: &mut Vec<f64>,
        v: &mut [f64],
        term: Option<&dyn ElementTerm>,
    ) -> Result<(), Error> {
        if term.is_none() && self.rattle.is_some() {
            let reuse = std::mem::take(&mut self.end_at_node);
            self.rattle_step(lag, con, element, (k, t, h, t1), q, p, v, reuse)?;
            self.end_at_node = true;
            return Ok(());
        }
        if term.is_none() && self.shake.is_some() {
            let reuse = std::mem::take(&mut self.end_at_node);
            match self.shake_step(lag, con, (k, t, h, t1), q, p, v, reuse) {
                Ok(()) => {
                    self.end_at_node = true;
                    return Ok(());
                }
                Err(e) if !self.fallback => return Err(e),
                Err(_) => {}
            }
        }
        self.end_at_node = false;
        if term.is_some() && self.insist {
            return Err(invalid(
                "solver method",
                "a constrained run takes explicit (RATTLE) steps only with no non-conservative forces; \
                 use the newton method (or auto) for this problem",
            ));
        }
        let (n, s) = (q.len(), element.degree());
        let x = &mut self.x;
        // Guess: straight line with the node velocity; multipliers from the last step.
        for j in 1..=s {
            let tau = element.basis.nodes[j];
            for c in 0..n {
                x[(j - 1) * n + c] = tau * h * v[c];
            }
        }
        self.sys.start.eval(con, q, true);
        let scale = q.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
        let sys = &mut self.sys;
        let solved = newton_dense(
            x,
            self.tol,
            self.max_iterations,
            |_| scale,
            &mut self.newton,
            |xx, r, jac| {
                sys.eval(element, lag, con, t, h, q, p, xx, jac.is_some());
                if let Some(term) = term {
                    sys.add_term(term, t, h, q, jac.is_some());
                }
                sys.summed_row_zero(element, p, h);
                sys.newton_residual(r);
                if let Some(jac) = jac {
                    sys.newton_jacobian(jac);
                }
            },
        );
        let report = solved.map_err(|f| failed(k, t, &self.sys.start, f))?;
        self.iterations = report.iterations;
        // q_{k+1} = q_k + ΔQ^s with compensated summation (into q_prev, swapped below).
        let (q1, p1) = (&mut self.q_prev, &mut self.p_prev);
        commit(q, &x[(s - 1) * n..s * n], &mut self.comp, q1);
        self.sys.momentum_by_sums(element, p, h);
        let p_tilde = self.sys.summed_momentum();
        if self.sys.end.conditioning() <= RANK_TOLERANCE {
            return Err(singular(k + 1, t1, &self.sys.end));
        }
        let mu = self
            .projector
            .project(
                lag,
                &self.sys.end,
                t1,
                q1,
                p_tilde,
                v,
                p1,
                self.tol,
                self.max_iterations,
            )
            .map_err(|f| step_error(k, t, f))?;
        self.mu.copy_from_slice(mu);
        std::mem::swap(q, &mut self.q_prev);
        std::mem::swap(p, &mut self.p_prev);
        Ok(())
    }

    /// The RATTLE step of [`Stepper::step`] (`rattle.rs`): the same unknowns (Δq and h·λ̂ in
    /// `x`, λ̂ in `sys.mult`), the same commit of q_{k+1} and the same jets (`sys.start` at
    /// q_k, without second derivatives; `sys.end` at q_{k+1}), μ̂ from the linear projection.
    /// With `reuse` (`sys.end` and the end force were evaluated at this very node q_k by the
    /// step before), the start jet is copied from `sys.end` and, for an autonomous L, the start
    /// force is the last end force: the same bits as evaluating them again.
    #[allow(clippy::too_many_arguments)]
    fn rattle_step<L: Lagrangian, C: Constraints>(
        &mut self,
        lag: &L,
        con: &C,
        element: &Element,
        (k, t, h, t1): (usize, f64, f64, f64),
        q: &mut Vec<f64>,
        p: &mut Vec<f64>,
        v: &mut [f64],
        reuse: bool,
    ) -> Result<(), Error> {
        let (Some(rattle), Some(mass)) = (self.rattle.as_mut(), lag.mass_matrix()) else {
            return Err(invalid("solver method", "RATTLE steps need a mechanical Lagrangian"));
        };
        let (n, m) = (q.len(), self.mu.len());
        start_jet(&mut self.sys, con, q, reuse);
        let scale = q.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
        let (dq, u) = self.x.split_at_mut(n);
        let solved = rattle.solve(
            (lag, mass, con),
            (&self.sys.start, &mut self.sys.end),
            (t, h, reuse && lag.is_autonomous()),
            (q, p, &self.comp),
            (dq, &mut u[..m]),
            (self.tol, self.max_iterations, scale),
        );
        self.iterations = solved.map_err(|f| failed(k, t, &self.sys.start, f))?;
        let lambda = &mut self.sys.mult[..m];
        for (l, &ul) in lambda.iter_mut().zip(&u[..m]) {
            *l = ul / h;
        }
        rattle.momentum(lag, element, &self.sys.start, (t, h), &self.sys.mult[..m]);
        let (q1, p1) = (&mut self.q_prev, &mut self.p_prev);
        commit(q, dq, &mut self.comp, q1);
        // `end` was evaluated at q1 itself (`RattleStep::solve`).
        let end = &self.sys.end;
        if conditioning(&end.jac, m, n, &mut self.scratch) <= RANK_TOLERANCE {
            return Err(singular(k + 1, t1, end));
        }
        let Some(mu) = rattle.project(mass, end, p, p1, v) else {
            return Err(singular(k + 1, t1, end));
        };
        self.mu.copy_from_slice(mu);
        std::mem::swap(q, &mut self.q_prev);
        std::mem::swap(p, &mut self.p_prev);
        Ok(())
    }

    /// The SHAKE-style step of [`Stepper::step`] (`shake/`): the same unknowns in `x`, the
    /// same commit of q_{k+1} and jets (`sys.start` at q_k, `sys.end` at q_{k+1}, without
    /// second derivatives), μ̂ from the linear projection onto T*N. With `reuse`, the start jet
    /// is the last step's end jet, evaluated at this very node.
    #[allow(clippy::too_many_arguments)]
    fn shake_step<L: Lagrangian, C: Constraints>(
        &mut self,
        lag: &L,
        con: &C,
        (k, t, h, t1): (usize, f64, f64, f64),
        q: &mut Vec<f64>,
        p: &mut Vec<f64>,
        v: &mut [f64],
        reuse: bool,
    ) -> Result<(), Error> {
        let (Some(shake), Some(mass)) = (self.shake.as_mut(), lag.mass_matrix()) else {
            return Err(invalid(
                "solver method",
                "fixed-point steps need a mechanical Lagrangian",
            ));
        };
        let (n, m) = (q.len(), self.mu.len());
        start_jet(&mut self.sys, con, q, reuse);
        let scale = q.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
        let solved = shake.solve(
            (lag, mass, con),
            &self.sys.start,
            (t, h),
            (q, p, v, &self.comp),
            (self.tol, self.max_iterations, scale),
        );
        self.iterations = solved.map_err(|f| failed(k, t, &self.sys.start, f))?;
        shake.finish(&self.sys.start, (h, p), &mut self.x);
        let s = self.sys.s;
        for (l, &xl) in self.sys.mult.iter_mut().zip(&self.x[s * n..]) {
            *l = xl / h;
        }
        let (q1, p1) = (&mut self.q_prev, &mut self.p_prev);
        commit(q, &self.x[(s - 1) * n..s * n], &mut self.comp, q1);
        // The end jet was evaluated at q1 itself (`ShakeStep::solve`).
        let end = &mut self.sys.end;
        copy(&mut end.g, &shake.end_jet().g);
        copy(&mut end.jac, &shake.end_jet().jac);
        if conditioning(&end.jac, m, n, &mut self.scratch) <= RANK_TOLERANCE {
            return Err(singular(k + 1, t1, end));
        }
        if !project_linear(mass, end, &shake.ptilde, &mut self.projection, p1, v, &mut self.mu) {
            return Err(singular(k + 1, t1, end));
        }
        std::mem::swap(q, &mut self.q_prev);
        std::mem::swap(p, &mut self.p_prev);
        Ok(())
    }

    /// −h Σ_i b_i ∂L/∂t at the quadrature points of the last step's element (the
    /// explicit-time part of the energy balance, `crate::forces`; 0 for an autonomous L).
    /// Call it after [`Stepper::step`] succeeded; it overwrites the element's scratch.
    pub fn time_work<L: Lagrangian>(&mut self, lag: &L, element: &Element, t: f64, h: f64) -> f64 {
        if lag.is_autonomous() {
            return 0.0;
        }
        self.sys.time_work(element, lag, t, h, &self.q_prev)
    }

    /// The Newton unknowns of the last step: the node increments Q^j − q_k, j = 1 … s, row
    /// by row (n each), then the multipliers (for a RATTLE step, Δq and h·λ̂).
    pub fn unknowns(&self) -> &[f64] {
        &self.x
    }

    /// What the next step reads of this one, into a checkpoint: the unknowns (the next
    /// multiplier guess), the compensation of q and μ̂.
    pub fn save(&self, w: &mut crate::step::checkpoint::Words) {
        w.fs(&self.x);
        w.fs(&self.comp);
        w.fs(&self.mu);
        if let Some(rattle) = &self.rattle {
            rattle.save(w);
        }
        if let Some(shake) = &self.shake {
            shake.save(w);
        }
    }

    /// Reads what [`Stepper::save`] wrote; the next step evaluates its start jet again (the
    /// same bits as reusing the last end jet).
    ///
    /// # Errors
    /// A damaged checkpoint.
    pub fn load(&mut self, r: &mut crate::step::checkpoint::Reader<'_>) -> crate::error::Result<()> {
        r.fs(&mut self.x)?;
        r.fs(&mut self.comp)?;
        r.fs(&mut self.mu)?;
        if let Some(rattle) = self.rattle.as_mut() {
            rattle.load(r)?;
        }
        if let Some(shake) = self.shake.as_mut() {
            shake.load(r)?;
        }
        self.end_at_node = false;
        Ok(())
    }

    /// The node before the last step, (q_k, p_k).
    pub fn previous(&self) -> (&[f64], &[f64]) {
        (&self.q_prev, &self.p_prev)
    }

    /// The ambient tangent map Φ (2n square, `tangent.rs`) of the last step from (t, q_k, p_k)
    /// with step h to node (t1, q, v), with the derivatives of the discrete forces `term` if the
    /// step had them; None if singular.
    #[allow(clippy::too_many_arguments)]
    pub fn tangent_map<L: Lagrangian, C: Constraints>(
        &mut self,
        lag: &L,
        con: &C,
        element: &Element,
        (t, h, t1): (f64, f64, f64),
        q: &[f64],
        v: &[f64],
        term: Option<&dyn ElementTerm>,
    ) -> Option<DMatrix<f64>> {
        // The jet at q_k with second derivatives (the RATTLE step evaluates G only); `sys.end`
        // moves to Q^s of the dense system.
        self.end_at_node = false;
        self.sys.start.eval(con, &self.q_prev, true);
        self.sys
            .eval(element, lag, con, t, h, &self.q_prev, &self.p_prev, &self.x, true);
        if let Some(term) = term {
            self.sys.add_term(term, t, h, &self.q_prev, true);
        }
        let ends = StepEnds {
            t1,
            q1: q,
            v1: v,
            mu: &self.mu,
        };
        step_map(lag, con, &self.sys, &ends)
    }
}

/// A failed step solve as the run reports it: a singular matrix at a node where G itself is
/// rank deficient names the constraints ([`singular`]), anything else is a step error.
fn failed(k: usize, t: f64, start: &super::jet::ConstraintJet, f: crate::solve::NewtonFailure) -> Error {
    if f.failure == StepFailure::Singular && start.conditioning() <= RANK_TOLERANCE {
        singular(k, t, start)
    } else {
        step_error(k, t, f)
    }
}

/// g and G at q_k into `sys.start` (without second derivatives): with `reuse`, the last
/// step's end jet, evaluated at this very node (the same bits as evaluating them again).
fn start_jet<C: Constraints>(sys: &mut StepSystem, con: &C, q: &[f64], reuse: bool) {
    if reuse {
        copy(&mut sys.start.g, &sys.end.g);
        copy(&mut sys.start.jac, &sys.end.jac);
    } else {
        sys.start.eval(con, q, false);
    }
}

/// q_{k+1} = q_k + Δq by compensated summation into `q1`, carrying the compensation `comp`
/// (the one commit of every constrained step).
fn commit(q: &[f64], dq: &[f64], comp: &mut [f64], q1: &mut [f64]) {
    for c in 0..q.len() {
        let y = dq[c] + comp[c];
        let sum = q[c] + y;
        comp[c] = y - (sum - q[c]);
        q1[c] = sum;
    }
}
