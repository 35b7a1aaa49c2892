//! The tangent map of a step under a force term (issue 33: one tangent map, the integrator's),
//! (δq_k, δp_k) ↦ (δq_{k+1}, δp_{k+1}), by implicit differentiation of the forced step
//! equations of [`crate::forces`] at the solved element, whichever solver took it.
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
//! step's times, which do not vary: t is not a state variable. Without forces this is the map
//! of [`Integrator::tangent_map`] (A the element Hessian alone).
//!
//! Cost per step: one element Hessian and one force Jacobian (automatic differentiation) and
//! one LU of the s n square matrix J, then O((s n)²) per carried vector.

use super::element_work::{buffers, check_dense_newton};
use super::integrator::Integrator;
use super::ElementNodes;
use crate::error::{invalid, Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use nalgebra::DMatrix;

impl<L: Lagrangian> Integrator<'_, L> {
    /// Carries the vectors `w` (each (δq, δp) of length 2n, one after another) through the
    /// tangent map of the last step of a run with forces (module docs), in place.
    ///
    /// # Errors
    /// No step taken yet, a run without forces or with constraints (their maps are
    /// [`Integrator::tangent_map`] and [`crate::chaos::constrained_indicators`]'), or a
    /// singular Newton matrix ([`Error::Step`]).
    pub(crate) fn term_tangent_apply(&mut self, w: &mut [f64]) -> Result<()> {
        if !self.last.valid {
            return Err(invalid("tangent map", "no step has been taken"));
        }
        let n = self.state.n;
        check_dense_newton(&self.element, n)?;
        let (s, t0, h) = (self.element.degree(), self.last.t, self.last.h);
        let (dim, wn) = (s * n, (s + 1) * n);
        let (ework, grad, hess) = buffers(&mut self.bufs, &self.element, n).with_hessian();
        let (base, incr) = (&self.last.base, &self.last.incr);
        self.element
            .hessian_in_place(&*self.lag, t0, h, base, incr, ework, grad, hess);
        let el = ElementNodes { t: t0, h, base, incr };
        let Some(fjac) = self.term.as_mut().and_then(|term| term.force_jacobian(el)) else {
            return Err(invalid(
                "tangent map",
                "this helper carries the steps of runs with forces only (plain runs: tangent_map; constraints: on the manifold)",
            ));
        };
        let hess = &*hess;
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
                step: self.state.k.saturating_sub(1),
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

    /// The ambient tangent map Φ (2n square) of the last step of a constrained run
    /// ([`Integrator::with_constraints`], with or without forces): the linearisation of the
    /// constrained step equations of [`crate::constraints`] (`constraints/tangent.rs`), which
    /// the charts of T*N reduce to the map on the manifold (`chaos/constrained.rs`).
    ///
    /// # Errors
    /// No step taken yet, a run without constraints, or a singular linear system.
    pub(crate) fn ambient_tangent_map(&mut self) -> Result<DMatrix<f64>> {
        if !self.last.valid {
            return Err(invalid("tangent map", "no step has been taken"));
        }
        let step = (self.last.t, self.last.h, self.state.t);
        match self.term.as_mut().and_then(|term| term.ambient_tangent(step)) {
            Some(Some(phi)) => Ok(phi),
            Some(None) => Err(Error::Step(StepError {
                step: self.state.k.saturating_sub(1),
                t: self.last.t,
                residual: f64::NAN,
                iterations: 0,
                failure: StepFailure::Singular,
            })),
            None => Err(invalid("tangent map", "the ambient map is that of a constrained run")),
        }
    }
}
