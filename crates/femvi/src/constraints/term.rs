//! The constraints as a term of the one integrator ([`crate::step::term`]):
//! [`Integrator::with_constraints`] takes the constrained steps of `stepper.rs` (dense Newton
//! on the step equations of the module docs of [`crate::constraints`], or RATTLE on the
//! multipliers where it fits) with every part of an unconstrained run — the grid, the
//! compensated node sums, the last element (dense output, events), checkpoints,
//! [`crate::step::drive()`] with its observers and the chunked [`Integrator::advance`].
//!
//! The positions are committed by the integrator's compensated sum of the step's increment
//! ΔQ^s, the formula the stepper uses, so the nodes are [`super::solve_constrained_with`]'s bit
//! for bit; the momentum is the projection onto T*N, set rather than summed
//! ([`StepTerm::momentum`]); the node velocity is the projection's, so the energy
//! H = p·v − L is the constrained run's too. The multipliers of the exact flow and the
//! residuals at the current node are [`Integrator::node_constraints`].

use super::jet::ConstraintJet;
use super::layout::{Enforcement, Layout};
use super::project::state_multiplier;
use super::start::start_on_manifold;
use super::stepper::Stepper;
use super::Constraints;
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::lagrangian::Lagrangian;
use crate::step::checkpoint::{Reader, Words};
use crate::step::state::{Increments, LastElement, RunState};
use crate::step::term::StepTerm;
use crate::step::{Integrator, Method, SolverOptions, Start, TimeGrid};

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
    /// `Method::Auto`, `Explicit` and `FixedPoint`, by dense Newton otherwise. The nodes are
    /// [`super::solve_constrained_with`]'s bit for bit.
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
    /// # Ok::<(), femvi::Error>(())
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
        opts.validate()?;
        element.check_nondegenerate()?;
        let layout = Layout::new(element, enforcement)?;
        let on = start_on_manifold(lag, constraints, &start_at, grid.t0(), opts)?;
        let (n, m) = (lag.dim(), constraints.count());
        let stepper = Stepper::new(element, layout, (n, m), opts, lag, false)?;
        let mut jet = ConstraintJet::new(m, n);
        jet.eval(constraints, &on.q, false);
        let term = Box::new(ConstrainedTerm {
            lag,
            con: constraints,
            element,
            stepper,
            q: on.q.clone(),
            p: on.p.clone(),
            v: on.v,
            max_residual: jet.residual(),
            start_projection: on.projection,
            jet: ConstraintJet::new(m, n),
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

/// The constrained step (`stepper.rs`) as a term.
struct ConstrainedTerm<'a, L, C> {
    lag: &'a L,
    con: &'a C,
    element: &'a Element,
    stepper: Stepper,
    /// The node as the stepper moves it: q_k, p_k and the projection's velocity v_k.
    q: Vec<f64>,
    p: Vec<f64>,
    v: Vec<f64>,
    max_residual: f64,
    start_projection: f64,
    /// Scratch of the node quantities.
    jet: ConstraintJet,
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
        // The integrator's node: the same bits as the stepper's own after each step.
        self.q.copy_from_slice(&state.q);
        self.p.copy_from_slice(&state.p);
        let times = (state.k, state.t, h, t_next);
        self.stepper.step(
            self.lag,
            self.con,
            self.element,
            times,
            &mut self.q,
            &mut self.p,
            &mut self.v,
            None,
        )?;
        self.max_residual = self.max_residual.max(self.stepper.sys.end.residual());
        // Row 0 is zero; rows 1 … s are the solved increments Q^j − q_k.
        let x = self.stepper.unknowns();
        let rows = out.incr.len() / n - 1;
        let (zero, rest) = out.incr.split_at_mut(n);
        zero.fill(0.0);
        rest.copy_from_slice(x.get(..rows * n).ok_or_else(|| invalid("constraints", "step layout"))?);
        out.dq.copy_from_slice(&rest[(rows - 1) * n..]);
        for ((d, a), b) in out.dp.iter_mut().zip(&self.p).zip(&state.p) {
            *d = a - b;
        }
        Ok(self.stepper.iterations)
    }

    fn accepted(&mut self, _n: usize) {}

    fn element_work(&self) -> f64 {
        0.0
    }

    fn save(&self, w: &mut Words) {
        self.stepper.save(w);
        w.fs(&self.v);
        w.f(self.max_residual);
    }

    fn load(&mut self, r: &mut Reader<'_>, _last: &LastElement) -> Result<()> {
        self.stepper.load(r)?;
        r.fs(&mut self.v)?;
        self.max_residual = r.f()?;
        Ok(())
    }

    fn name(&self) -> &'static str {
        "constraints"
    }

    fn momentum(&self) -> Option<&[f64]> {
        Some(&self.p)
    }

    fn velocity(&self) -> Option<&[f64]> {
        Some(&self.v)
    }

    fn constraints(&mut self, t: f64, q: &[f64]) -> Option<NodeConstraints> {
        let n = q.len();
        self.jet.eval(self.con, q, true);
        // The largest residual covers the nodes asked about, as the constrained run's covers
        // its kept nodes, besides every step's end.
        self.max_residual = self.max_residual.max(self.jet.residual());
        let jet = &self.jet;
        let v = &self.v;
        let hidden = (0..jet.m)
            .map(|l| (0..n).map(|a| jet.jac[l * n + a] * v[a]).sum::<f64>().abs())
            .fold(0.0f64, f64::max);
        Some(NodeConstraints {
            multipliers: state_multiplier(self.lag, jet, (t, q, v), None),
            residual: jet.residual(),
            hidden_residual: hidden,
            max_residual: self.max_residual,
            start_projection: self.start_projection,
        })
    }
}
