//! One step of the Lie-group element by Newton's method (module docs of [`super`]): the
//! unknowns x = (ξ^1 … ξ^s, d^1 … d^s) solve
//!
//!   ∂S/∂e + p̄_k = 0,   ∂S/∂x^j = 0 (0 < j < s),
//!
//! where p̄_k holds the body angular momenta μ_k of the rotations and the momenta p_k of the
//! ordinary coordinates, and S is the action of `action.rs`. Residual and Jacobian come from
//! hyper-dual passes through the action (one per pair of a row and a column variable); the new
//! node's momenta are μ_{k+1} = dexp_{ξ^s}⁻¹ ∂S/∂ξ^s (the left-trivialised D₂L_d, since
//! exp(ξ̂) exp(εη̂) = exp(ξ + ε dexp_{−ξ}⁻¹ η) and (dexp_{−ξ}⁻¹)ᵀ = dexp_ξ⁻¹) and
//! p_{k+1} = ∂S/∂d^s.

use super::action::{action, StepData};
use super::layout::Rotations;
use super::so3::dexp_inv;
use crate::discrete::Element;
use crate::error::{StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::step::SolverOptions;
use nalgebra::{DMatrix, DVector};
use num_dual::HyperDual64;

/// The Newton workspace of the step and the last solution (the next step's start).
#[derive(Debug, Clone)]
pub(crate) struct LieStep {
    /// Slots per node and degree.
    ne: usize,
    s: usize,
    /// The unknowns x^1 … x^s of the last solved step (or the start's guess).
    pub x: Vec<f64>,
    /// The step of the last solved element (0 before the first).
    pub h_prev: f64,
    z: Vec<HyperDual64>,
    /// The end gradient ∂S/∂x^s of the last solve.
    pub end: Vec<f64>,
}

impl LieStep {
    pub(crate) fn new(layout: &Rotations, element: &Element) -> Self {
        let (ne, s) = (layout.slots(), element.degree());
        Self {
            ne,
            s,
            x: vec![0.0; s * ne],
            h_prev: 0.0,
            z: vec![HyperDual64::from(0.0); (s + 1) * ne],
            end: vec![0.0; ne],
        }
    }

    /// Loads z = (0, x) with no dual parts.
    fn load(&mut self) {
        for (k, zk) in self.z.iter_mut().enumerate() {
            *zk = HyperDual64::from(if k < self.ne { 0.0 } else { self.x[k - self.ne] });
        }
    }

    /// The residual and the Jacobian at the current x (row-major, (s·ne)²).
    fn linearise<L: Lagrangian>(
        &mut self,
        lag: &L,
        element: &Element,
        layout: &Rotations,
        data: &StepData<'_>,
        mom: &[f64],
    ) -> (DVector<f64>, DMatrix<f64>) {
        let m = self.s * self.ne;
        let mut f = DVector::zeros(m);
        let mut jac = DMatrix::zeros(m, m);
        self.load();
        for a in 0..m {
            for b in 0..m {
                self.z[a].eps1 = 1.0;
                self.z[self.ne + b].eps2 = 1.0;
                let r = action(lag, element, layout, data, &self.z);
                self.z[a].eps1 = 0.0;
                self.z[self.ne + b].eps2 = 0.0;
                if b == 0 {
                    f[a] = r.eps1 + if a < self.ne { mom[a] } else { 0.0 };
                }
                jac[(a, b)] = r.eps1eps2;
            }
        }
        (f, jac)
    }

    /// Solves the step from the node in `data` with the momenta `mom` (slots), starting from
    /// the last solution scaled to the new step; returns the iterations.
    pub(crate) fn solve<L: Lagrangian>(
        &mut self,
        lag: &L,
        element: &Element,
        layout: &Rotations,
        data: &StepData<'_>,
        mom: &[f64],
        (opts, k): (SolverOptions, usize),
    ) -> Result<usize, StepError> {
        if self.h_prev > 0.0 {
            let scale = data.h / self.h_prev;
            self.x.iter_mut().for_each(|v| *v *= scale);
        }
        let fail = |residual: f64, iterations: usize, failure: StepFailure| StepError {
            step: k,
            t: data.t0,
            residual,
            iterations,
            failure,
        };
        let qscale = data.q.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let mut last = f64::INFINITY;
        for it in 1..=opts.max_iterations {
            let (f, jac) = self.linearise(lag, element, layout, data, mom);
            let res = f.amax();
            if !res.is_finite() || jac.iter().any(|v| !v.is_finite()) {
                return Err(fail(res, it, StepFailure::NonFinite));
            }
            let dx = jac
                .lu()
                .solve(&(-f))
                .ok_or_else(|| fail(res, it, StepFailure::Singular))?;
            self.x.iter_mut().zip(dx.iter()).for_each(|(x, d)| *x += d);
            let size = dx.amax();
            let scale = self.x.iter().fold(qscale, |m, v| m.max(v.abs()));
            if size <= opts.tolerance * scale {
                self.h_prev = data.h;
                self.end_gradient(lag, element, layout, data);
                return Ok(it);
            }
            if it > 3 && size >= last {
                return Err(fail(size, it, StepFailure::Stalled));
            }
            last = size;
        }
        Err(fail(last, opts.max_iterations, StepFailure::NotConverged))
    }

    /// ∂S/∂x^s at the solution, turned into the new node's momenta (slots).
    fn end_gradient<L: Lagrangian>(&mut self, lag: &L, element: &Element, layout: &Rotations, data: &StepData<'_>) {
        self.load();
        let off = self.s * self.ne;
        for b in 0..self.ne {
            self.z[off + b].eps1 = 1.0;
            self.end[b] = action(lag, element, layout, data, &self.z).eps1;
            self.z[off + b].eps1 = 0.0;
        }
        for r in 0..layout.count() {
            let xi: [f64; 3] = std::array::from_fn(|c| self.x[off - self.ne + 3 * r + c]);
            let g: [f64; 3] = std::array::from_fn(|c| self.end[3 * r + c]);
            self.end[3 * r..3 * r + 3].copy_from_slice(&dexp_inv(&xi, &g));
        }
    }
}
