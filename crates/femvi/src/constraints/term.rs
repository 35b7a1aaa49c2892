//! The constraints as a term of the one integrator ([`crate::step::term`]):
//! [`Integrator::with_constraints`] takes the constrained steps of `stepper.rs` (dense Newton
//! on the step equations of the module docs of [`crate::constraints`], or RATTLE on the
//! multipliers where it fits) with every part of an unconstrained run — the grid, the
//! compensated node sums, the last element (dense output, events), checkpoints,
//! [`crate::step::drive()`] with its observers and the chunked [`Integrator::advance`].
//!
//! The positions are committed by the integrator's compensated sum of the step's increment
//! ΔQ^s, the formula the stepper uses, so the nodes are those the stepper computes on its own,
//! bit for bit; the momentum is the projection onto T*N, set rather than summed
//! ([`StepTerm::momentum`]). The multipliers of the exact flow, the projection's velocity and
//! the residuals at the current node are [`Integrator::node_constraints`]. With a force
//! ([`Integrator::with_constraints_and_force`]) the steps are those of the discrete
//! Lagrange–d'Alembert principle on the augmented action (`forced.rs`), and each element
//! adds its discrete work to [`Integrator::work`].

use super::forcing::{Forcing, NodeForce};
use super::jet::ConstraintJet;
use super::layout::{Enforcement, Layout};
use super::project::state_multiplier;
use super::small::copy;
use super::start::start_on_manifold;
use super::stepper::{Stepper, TermNode};
use super::tangent::step_defect;
use super::Constraints;
use crate::discrete::Element;
use crate::error::{check_len, invalid, Result};
use crate::forces::Force;
use crate::lagrangian::Lagrangian;
use crate::step::checkpoint::{Reader, Words};
use crate::step::state::{Increments, LastElement, RunState};
use crate::step::term::{StepTerm, TermAdvance, TermRun};
use crate::step::Node;
use crate::step::{Integrator, Method, SolverOptions, Start, TimeGrid};
use std::cell::{Cell, RefCell};

/// The constraint quantities at a node of a constrained run ([`Integrator::node_constraints`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeConstraints {
    /// The multipliers λ of the exact flow at the node state (−G(q)ᵀλ is the constraint
    /// force; module `project`).
    pub multipliers: Vec<f64>,
    /// ‖g(q)‖∞ at the node.
    pub residual: f64,
    /// ‖G(q) v‖∞ (the hidden constraint) at the node.
    pub hidden_residual: f64,
    /// The largest ‖G(q) v‖∞ over the nodes asked about so far.
    pub max_hidden_residual: f64,
    /// The node velocity v from the projection onto T*N (∂L/∂v(t, q, v) + G(q)ᵀμ̂ = p̃,
    /// G(q) v = 0).
    pub velocity: Vec<f64>,
    /// The largest ‖g(q)‖∞ so far over the end of every step and the nodes asked about (as
    /// the constrained run's covers every step and its kept nodes).
    pub max_residual: f64,
    /// ‖p0 − p̃0‖∞: how much the start momentum was projected onto T*N.
    pub start_projection: f64,
}

impl<'a, L: Lagrangian + Sync> Integrator<'a, L> {
    /// Sets up a run of `lag` under the holonomic constraints g(q) = 0 of `constraints`
    /// (module docs of [`crate::constraints`]), enforced inside the elements as `enforcement`
    /// says: as [`Integrator::new`] for fixed or variable steps, with the start checked on the
    /// manifold and its momentum projected onto T*N. The steps are solved by RATTLE on the
    /// multipliers where it fits (degree 1, trapezoid rule, a mechanical L) under
    /// `Method::Auto`, `Explicit` and `FixedPoint`, by dense Newton otherwise.
    ///
    /// # Errors
    /// As [`super::solve_constrained_with`]: sizes, a start off the manifold (naming the
    /// residual) or from (q0, q1), a singular G(q0), a method that does not fit.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::constraints::{Enforcement, ExprConstraints};
    /// use femvi::expr::ExprLagrangian;
    /// use femvi::{Element, Integrator, SolverOptions, Start, TimeGrid};
    ///
    /// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    /// let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z", &xyz, &[])?;
    /// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[])?;
    /// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 1.0, 0.0] };
    /// let element = Element::with_order(4)?;
    /// let grid = TimeGrid::uniform(0.0, 0.01, 1.0)?;
    /// let opts = SolverOptions::default();
    /// let mut it = Integrator::with_constraints(&lag, &element, grid, start, opts, &sphere, Enforcement::Weak)?;
    /// while it.step()? {}
    /// let at_end = it.node_constraints().expect("a constrained run");
    /// assert!(at_end.max_residual < 1e-13 && at_end.multipliers.len() == 1);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_constraints<C: Constraints + Sync>(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start_at: Start,
        opts: SolverOptions,
        constraints: &'a C,
        enforcement: Enforcement,
    ) -> Result<Self> {
        let parts = Constrained::new(constraints, enforcement, None);
        Self::constrained(lag, element, grid, start_at, opts, parts)
    }

    /// [`Integrator::with_constraints`] under the non-conservative force `force`: the
    /// discrete Lagrange–d'Alembert principle on the augmented action (module docs of
    /// `forced.rs`), solved by dense Newton, with each element's discrete work added to
    /// [`Integrator::work`] (so that H − H_0 − W is the balance error).
    ///
    /// # Errors
    /// As [`Integrator::with_constraints`]; a force of another dimension; a method that asked
    /// for explicit steps.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::constraints::{Enforcement, ExprConstraints};
    /// use femvi::expr::ExprLagrangian;
    /// use femvi::forces::LinearForce;
    /// use femvi::{Element, Integrator, SolverOptions, Start, TimeGrid};
    ///
    /// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    /// let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z", &xyz, &[])?;
    /// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[])?;
    /// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 1.0, 0.0] };
    /// let (element, grid) = (Element::with_order(4)?, TimeGrid::uniform(0.0, 0.01, 5.0)?);
    /// let friction = LinearForce::damping(3, 0.5);
    /// let opts = SolverOptions::default();
    /// let mut it = Integrator::with_constraints_and_force(&lag, &element, grid, start, opts, &sphere, Enforcement::Weak, &friction)?;
    /// let h0 = it.energy()?;
    /// while it.step()? {}
    /// assert!(it.energy()? < h0 && (it.energy()? - h0 - it.work()).abs() < 1e-8);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[allow(clippy::too_many_arguments)]
    pub fn with_constraints_and_force<C: Constraints + Sync, F: Force + Sync>(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start_at: Start,
        opts: SolverOptions,
        constraints: &'a C,
        enforcement: Enforcement,
        force: &'a F,
    ) -> Result<Self> {
        check_len("force", lag.dim(), force.dim())?;
        let parts = Constrained::new(
            constraints,
            enforcement,
            Some(Box::new(Forcing::new(force, element, lag.dim()))),
        );
        Self::constrained(lag, element, grid, start_at, opts, parts)
    }

    /// The constrained run of `parts` (the constructors above; with `tangent`, the steps'
    /// symplecticity defect is measured too, [`Integrator::term_defect`]).
    pub(super) fn constrained<C: Constraints + Sync>(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start_at: Start,
        opts: SolverOptions,
        parts: Constrained<'a, C>,
    ) -> Result<Self> {
        opts.validate()?;
        element.check_nondegenerate()?;
        let layout = Layout::new(element, parts.enforcement)?;
        let on = start_on_manifold(lag, parts.constraints, &start_at, grid.t0(), opts)?;
        let (n, m) = (lag.dim(), parts.constraints.count());
        let stepper = Stepper::new(element, layout, (n, m), opts, lag, parts.forcing.is_some())?;
        let mut jet = ConstraintJet::new(m, n);
        jet.eval(parts.constraints, &on.q, false);
        let term = Box::new(ConstrainedTerm {
            lag,
            con: parts.constraints,
            element,
            stepper,
            forcing: parts.forcing,
            synced: true,
            q: on.q.clone(),
            p: on.p.clone(),
            v: on.v,
            max_residual: Cell::new(jet.residual()),
            max_hidden: Cell::new(0.0),
            start_projection: on.projection,
            jet: RefCell::new(ConstraintJet::new(m, n)),
            force_at: RefCell::new(vec![0.0; n]),
            work: 0.0,
            defect: parts.tangent.then_some(0.0),
        });
        let start = Start::Momentum { q: on.q, p: on.p };
        // The integrator's own solver is never asked: one that fits any Lagrangian.
        let plain = SolverOptions {
            method: Method::Auto,
            ..opts
        };
        Integrator::with_term(lag, element, grid, start, plain, term)
    }
}

/// What a constrained run is made of besides the Lagrangian and the element.
pub(super) struct Constrained<'a, C> {
    pub constraints: &'a C,
    pub enforcement: Enforcement,
    /// The non-conservative force, as the constrained step takes it.
    pub forcing: Option<Box<dyn NodeForce + Send + 'a>>,
    /// Whether the steps' symplecticity defect is measured.
    pub tangent: bool,
}

impl<'a, C> Constrained<'a, C> {
    /// The parts of a run without the symplecticity measurement.
    pub(super) fn new(
        constraints: &'a C,
        enforcement: Enforcement,
        forcing: Option<Box<dyn NodeForce + Send + 'a>>,
    ) -> Self {
        Self {
            constraints,
            enforcement,
            forcing,
            tangent: false,
        }
    }
}

/// The constrained step (`stepper.rs`) as a term.
struct ConstrainedTerm<'a, L, C> {
    lag: &'a L,
    con: &'a C,
    element: &'a Element,
    stepper: Stepper,
    forcing: Option<Box<dyn NodeForce + Send + 'a>>,
    /// The node as the stepper moves it: q_k, p_k and the projection's velocity v_k; `synced`
    /// while they are the integrator's node (false after a restore).
    synced: bool,
    q: Vec<f64>,
    p: Vec<f64>,
    v: Vec<f64>,
    max_residual: Cell<f64>,
    max_hidden: Cell<f64>,
    start_projection: f64,
    /// Scratch of the node quantities.
    jet: RefCell<ConstraintJet>,
    force_at: RefCell<Vec<f64>>,
    /// The discrete work of the last element.
    work: f64,
    /// The largest symplecticity defect so far, when measured.
    defect: Option<f64>,
}

impl<L: Lagrangian, C: Constraints> StepTerm for ConstrainedTerm<'_, L, C> {
    fn solve(
        &mut self,
        state: &RunState,
        _last: &mut LastElement,
        (h, t_next): (f64, f64),
        out: &mut Increments,
    ) -> Result<usize> {
        let n = state.n;
        // The integrator's node: after a step of this term it is the stepper's own node, bit
        // for bit (the same compensated sum; the momentum set); after a restore it is read
        // here. Element by element: a few numbers, not worth a call to memmove per step.
        if !self.synced {
            copy(&mut self.q, &state.q);
            copy(&mut self.p, &state.p);
            self.synced = true;
        }
        let (lag, con, element) = (self.lag, self.con, self.element);
        let term = self.forcing.as_ref().map(|f| f.term());
        let times = (state.k, state.t, h, t_next);
        self.stepper
            .step(lag, con, element, times, &mut self.q, &mut self.p, &mut self.v, term)?;
        let end = self.stepper.sys.end.residual();
        self.max_residual.set(self.max_residual.get().max(end));
        // Row 0 is zero; rows 1 … s are the solved increments Q^j − q_k.
        let x = self.stepper.unknowns();
        let rows = out.incr.len() / n - 1;
        let (zero, rest) = out.incr.split_at_mut(n);
        zero.iter_mut().for_each(|z| *z = 0.0);
        copy(
            rest,
            x.get(..rows * n).ok_or_else(|| invalid("constraints", "step layout"))?,
        );
        copy(&mut out.dq, &rest[(rows - 1) * n..]);
        for ((d, a), b) in out.dp.iter_mut().zip(&self.p).zip(&state.p) {
            *d = a - b;
        }
        if let Some(f) = &self.forcing {
            let time_work = self.stepper.time_work(lag, element, state.t, h);
            let (qk, _) = self.stepper.previous();
            self.work = f.work(element, state.t, h, qk, self.stepper.sys.increments()) + time_work;
        }
        if let Some(worst) = self.defect {
            let phi = self
                .stepper
                .tangent_map(lag, con, element, (state.t, h, t_next), &self.q, &self.v, term);
            let (q0, p0) = self.stepper.previous();
            self.defect = Some(worst.max(step_defect(lag, con, phi, (state.t, q0, p0))));
        }
        Ok(self.stepper.iterations)
    }

    fn accepted(&mut self, _n: usize) {}

    fn element_work(&self) -> f64 {
        self.work
    }

    fn save(&self, w: &mut Words) {
        self.stepper.save(w);
        w.fs(&self.v);
        w.f(self.max_residual.get());
        w.f(self.max_hidden.get());
    }

    fn load(&mut self, r: &mut Reader<'_>, _last: &LastElement) -> Result<()> {
        self.synced = false;
        self.stepper.load(r)?;
        r.fs(&mut self.v)?;
        self.max_residual.set(r.f()?);
        self.max_hidden.set(r.f()?);
        Ok(())
    }

    fn name(&self) -> &'static str {
        if self.forcing.is_some() {
            "constraints+forces"
        } else {
            "constraints"
        }
    }

    fn works(&self) -> bool {
        self.forcing.is_some()
    }

    fn momentum(&self) -> Option<&[f64]> {
        Some(&self.p)
    }

    fn constraints(&self, t: f64, q: &[f64]) -> Option<NodeConstraints> {
        let n = q.len();
        let mut jet = self.jet.borrow_mut();
        jet.eval(self.con, q, true);
        // The largest residual covers the nodes asked about, as the constrained run's covers
        // its kept nodes, besides every step's end.
        self.max_residual.set(self.max_residual.get().max(jet.residual()));
        let v = &self.v;
        let hidden = (0..jet.m)
            .map(|l| (0..n).map(|a| jet.jac[l * n + a] * v[a]).sum::<f64>().abs())
            .fold(0.0f64, f64::max);
        self.max_hidden.set(self.max_hidden.get().max(hidden));
        let mut f = self.force_at.borrow_mut();
        let force = self.forcing.as_ref().map(|forcing| {
            forcing.at(t, q, v, &mut f);
            &f[..]
        });
        Some(NodeConstraints {
            multipliers: state_multiplier(self.lag, &jet, (t, q, v), force),
            residual: jet.residual(),
            hidden_residual: hidden,
            max_hidden_residual: self.max_hidden.get(),
            velocity: v.clone(),
            max_residual: self.max_residual.get(),
            start_projection: self.start_projection,
        })
    }

    fn defect(&self) -> Option<f64> {
        self.defect
    }

    fn advance(
        &mut self,
        run: TermRun<'_>,
        max_steps: usize,
        at_node: &mut dyn FnMut(Node<'_>) -> bool,
    ) -> Option<TermAdvance> {
        if self.forcing.is_some() || self.defect.is_some() {
            return None;
        }
        if !self.synced {
            copy(&mut self.q, &run.state.q);
            copy(&mut self.p, &run.state.p);
            self.synced = true;
        }
        let parts = (self.lag, self.con, self.element);
        let sizes = (run.state.n, self.con.count());
        let node = TermNode {
            q: &mut self.q,
            p: &mut self.p,
            v: &mut self.v,
        };
        let stepper = &mut self.stepper;
        // The sizes the RATTLE loop is compiled for (coordinates, constraints): a point on a
        // circle or a sphere, a point on a curve, a planar double pendulum.
        macro_rules! fast {
            ($n:literal, $m:literal) => {
                stepper.rattle_loop::<L, C, $n, $m>(parts, node, &self.max_residual, run, max_steps, at_node)
            };
        }
        match sizes {
            (2, 1) => fast!(2, 1),
            (3, 1) => fast!(3, 1),
            (3, 2) => fast!(3, 2),
            (4, 2) => fast!(4, 2),
            _ => None,
        }
    }

    fn ambient_tangent(&mut self, step: (f64, f64, f64)) -> Option<Option<nalgebra::DMatrix<f64>>> {
        let (lag, con, element) = (self.lag, self.con, self.element);
        let term = self.forcing.as_ref().map(|f| f.term());
        Some(
            self.stepper
                .tangent_map(lag, con, element, step, &self.q, &self.v, term),
        )
    }
}
