//! The tangent map of the forced step, (δq_k, δp_k) ↦ (δq_{k+1}, δp_{k+1}), by implicit
//! differentiation of the step equations of `step.rs` (module docs of [`crate::forces`]), and
//! [`ForcedTangentRun`], a forced run that carries tangent vectors (for [`crate::chaos`]).
//!
//! With A = ∂²L_d/∂Q∂Q + ∂F_d/∂Q, the (s+1)n square derivative of the element's nodal
//! equations G_j = ∂L_d/∂Q^j + F_d^j in the nodes Q^0 … Q^s (Q^0 = q_k, Q^m = q_k + X^m), the
//! step solves R = (G_0 + p_k, G_1, …, G_{s−1}) = 0 for X and sets q_{k+1} = q_k + X^s,
//! p_{k+1} = G_s. Differentiating at the converged X:
//!
//!   J δX = −(S δq_k + E δp_k),   δq_{k+1} = δq_k + δX^s,   δp_{k+1} = S_s δq_k + A_{s,1…s} δX,
//!
//! where J = A_{0…s−1, 1…s} is Newton's matrix, S_j = Σ_m A_{jm} (a node shift moves every
//! node) and E puts δp_k in the rows of node 0. A force that depends on t is evaluated at the
//! step's times, which do not vary: t is not a state variable.
//!
//! Cost per step: one element Hessian and one force Jacobian (automatic differentiation) and
//! one LU of the s n square matrix J, then O((s n)²) per carried vector. Newton's own last
//! factorisation is not reused: it is taken at the iterate before the last correction, so the
//! map would be off by the size of that correction, and A is needed anyway (S and the
//! momentum row).

use super::element::element_forces_jacobian;
use super::solve::{check_options, start, Node};
use super::step::{ForcedStep, Taken};
use super::Force;
use crate::discrete::{Element, ElementWork};
use crate::error::{check_len, Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::solution::{grid, Problem, SolveOptions};
use crate::step::TimeGrid;
use nalgebra::DMatrix;

/// A forced run taken step by step, whose last step's tangent map carries vectors.
pub(crate) struct ForcedTangentRun<'a, L, F> {
    lag: &'a L,
    force: &'a F,
    element: &'a Element,
    stepper: ForcedStep<'a, L, F>,
    grid: TimeGrid,
    max_steps: Option<usize>,
    node: Node,
    v0: Vec<f64>,
    taken: Taken,
    /// (t_k, h, q_k) of the last step.
    last: Option<(f64, f64)>,
    q_prev: Vec<f64>,
    ework: ElementWork,
    grad: Vec<f64>,
    hess: Vec<f64>,
    fd: Vec<f64>,
    fjac: Vec<f64>,
}

impl<'a, L: Lagrangian, F: Force> ForcedTangentRun<'a, L, F> {
    /// The run of `problem` under `force` (checks as [`super::solve_forced`]).
    ///
    /// # Errors
    /// As [`super::solve_forced`].
    pub(crate) fn new(
        problem: &'a Problem<L>,
        force: &'a F,
        element: &'a Element,
        options: &SolveOptions,
    ) -> Result<Self> {
        let lag = &problem.lagrangian;
        let n = lag.dim();
        check_options(options)?;
        if matches!(options.steps, crate::solution::Steps::Energy { .. }) {
            return Err(crate::error::invalid(
                "time steps as variables (energy mode)",
                "not supported for the tangent maps of forced runs",
            ));
        }
        check_len("force", n, force.dim())?;
        element.check_nondegenerate()?;
        options.solver.validate()?;
        let grid = grid(problem, &options.steps)?;
        let (q, p, v0) = start(lag, &problem.start, problem.t0)?;
        let stepper = ForcedStep::new(lag, force, element, options.solver)?;
        let w = element.nodes() * n;
        Ok(Self {
            lag,
            force,
            element,
            stepper,
            grid,
            max_steps: options.max_steps,
            node: Node {
                k: 0,
                t: problem.t0,
                q: q.clone(),
                p,
                cq: vec![0.0; n],
                cp: vec![0.0; n],
                work: 0.0,
            },
            v0,
            taken: Taken::default(),
            last: None,
            q_prev: q,
            ework: ElementWork::new(element, n),
            grad: vec![0.0; w],
            hess: vec![0.0; w * w],
            fd: vec![0.0; w],
            fjac: vec![0.0; w * w],
        })
    }

    /// Takes the next step: Ok(false) at the end of the grid or after `max_steps`.
    ///
    /// # Errors
    /// A failed step ([`Error::Step`]).
    pub(crate) fn step(&mut self) -> Result<bool> {
        let node = &mut self.node;
        let Some((h, t_next)) = self.grid.next(node.k, node.t) else {
            return Ok(false);
        };
        if self.max_steps.is_some_and(|m| node.k >= m) {
            return Ok(false);
        }
        self.stepper
            .step(node.k, node.t, h, &node.q, &node.p, &self.v0, &mut self.taken)?;
        self.q_prev.copy_from_slice(&node.q);
        self.last = Some((node.t, h));
        node.advance(&self.taken, t_next);
        Ok(true)
    }

    /// The current node (t, q, p).
    pub(crate) fn node(&self) -> (f64, &[f64], &[f64]) {
        (self.node.t, &self.node.q, &self.node.p)
    }

    /// Length of the last step (0 before the first).
    pub(crate) fn last_step(&self) -> f64 {
        self.last.map_or(0.0, |(_, h)| h)
    }

    /// Carries the vectors `w` (each (δq, δp) of length 2n, one after another) through the
    /// last step's tangent map (module docs), in place.
    ///
    /// # Errors
    /// No step taken yet, or a singular Newton matrix ([`Error::Step`]).
    pub(crate) fn carry(&mut self, w: &mut [f64]) -> Result<()> {
        let Some((t0, h)) = self.last else {
            return Err(crate::error::invalid("tangent map", "no step has been taken"));
        };
        let (n, s) = (self.lag.dim(), self.element.degree());
        let (dim, wn) = (s * n, (s + 1) * n);
        let incr = self.stepper.increments();
        let q = &self.q_prev;
        self.element.hessian_in_place(
            self.lag,
            t0,
            h,
            q,
            incr,
            &mut self.ework,
            &mut self.grad,
            &mut self.hess,
        );
        element_forces_jacobian(self.element, self.force, t0, h, q, incr, &mut self.fd, &mut self.fjac);
        let (hess, fjac) = (&self.hess, &self.fjac);
        let a = |r: usize, c: usize| hess[r * wn + c] + fjac[r * wn + c];
        // S_j: the row sums over the node blocks, rows of all nodes 0 … s.
        let shift = DMatrix::from_fn(wn, n, |r, c| (0..=s).map(|m| a(r, m * n + c)).sum::<f64>());
        let lu = DMatrix::from_fn(dim, dim, |r, c| a(r, n + c)).lu();
        let k = w.len() / (2 * n);
        let mut rhs = DMatrix::from_fn(dim, k, |r, j| {
            let v = &w[j * 2 * n..(j + 1) * 2 * n];
            let sq: f64 = (0..n).map(|c| shift[(r, c)] * v[c]).sum();
            -sq - if r < n { v[n + r] } else { 0.0 }
        });
        if !lu.solve_mut(&mut rhs) {
            return Err(Error::Step(StepError {
                step: self.node.k.saturating_sub(1),
                t: t0,
                residual: f64::NAN,
                iterations: 0,
                failure: StepFailure::Singular,
            }));
        }
        for (j, v) in w.chunks_exact_mut(2 * n).enumerate() {
            let dx = rhs.column(j);
            for c in 0..n {
                let row = s * n + c;
                let mut dp: f64 = (0..n).map(|e| shift[(row, e)] * v[e]).sum();
                dp += (0..dim).map(|b| a(row, n + b) * dx[b]).sum::<f64>();
                v[n + c] = dp;
            }
            for c in 0..n {
                v[c] += dx[(s - 1) * n + c];
            }
        }
        Ok(())
    }
}
