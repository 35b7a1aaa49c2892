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
    /// The Jacobian kept from an earlier iteration, with its factors and step.
    pub kept: Option<Kept>,
}

/// A Jacobian of the step equations, its LU factors and the step h it was formed for.
#[derive(Debug, Clone)]
pub(crate) struct Kept {
    pub jac: DMatrix<f64>,
    lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    pub h: f64,
}

impl Kept {
    /// The kept Jacobian `jac` for step `h`, factored again (as a checkpoint restores it: the
    /// factors are a function of the matrix, so the iterations after a resume are the same).
    pub(crate) fn restore(jac: DMatrix<f64>, h: f64) -> Self {
        Self {
            lu: jac.clone().lu(),
            jac,
            h,
        }
    }
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
            kept: None,
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

    /// The residual alone at the current x (one dual pass per row).
    fn residual<L: Lagrangian>(
        &mut self,
        lag: &L,
        element: &Element,
        layout: &Rotations,
        data: &StepData<'_>,
        mom: &[f64],
    ) -> DVector<f64> {
        let m = self.s * self.ne;
        let mut f = DVector::zeros(m);
        self.load();
        for a in 0..m {
            self.z[a].eps1 = 1.0;
            f[a] = action(lag, element, layout, data, &self.z).eps1 + if a < self.ne { mom[a] } else { 0.0 };
            self.z[a].eps1 = 0.0;
        }
        f
    }

    /// Forms the Jacobian at the current x and factors it; returns the residual there.
    fn refresh<L: Lagrangian>(
        &mut self,
        lag: &L,
        element: &Element,
        layout: &Rotations,
        data: &StepData<'_>,
        mom: &[f64],
    ) -> Option<DVector<f64>> {
        let (f, jac) = self.linearise(lag, element, layout, data, mom);
        if !(f.iter().chain(jac.iter()).all(|v| v.is_finite())) {
            self.kept = None;
            return Some(f);
        }
        self.kept = Some(Kept {
            lu: jac.clone().lu(),
            jac,
            h: data.h,
        });
        Some(f)
    }

    /// Solves the step from the node in `data` with the momenta `mom` (slots), starting from
    /// the last solution scaled to the new step; returns the iterations.
    ///
    /// Newton's method with the Jacobian kept from step to step while the step h is the same
    /// and the iteration contracts well (each new Jacobian costs (s·n)² hyper-dual passes,
    /// each residual s·n): it is formed again at the current iterate when a correction is not
    /// at least ten times smaller than the one before. Once within the tolerance, the iteration goes on while
    /// the corrections decrease (at most three more) if `polish` is set, so that the
    /// equations hold to round-off and the momentum maps are kept.
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
        let (mut last, mut extra, mut converged) = (f64::INFINITY, 0, false);
        let mut pending: Option<DVector<f64>> = None;
        // The iteration at which the Jacobian in use was formed (0: kept from a step before).
        let mut formed = 0;
        if self.kept.as_ref().is_none_or(|kept| kept.h != data.h) {
            pending = self.refresh(lag, element, layout, data, mom);
            formed = 1;
        }
        for it in 1..=opts.max_iterations {
            let f = match pending.take() {
                Some(f) => f,
                None => self.residual(lag, element, layout, data, mom),
            };
            let res = f.amax();
            let Some(kept) = self.kept.as_ref().filter(|_| res.is_finite()) else {
                return Err(fail(res, it, StepFailure::NonFinite));
            };
            let dx = kept
                .lu
                .solve(&(-f))
                .ok_or_else(|| fail(res, it, StepFailure::Singular))?;
            self.x.iter_mut().zip(dx.iter()).for_each(|(x, d)| *x += d);
            let size = dx.amax();
            let scale = self.x.iter().fold(qscale, |m, v| m.max(v.abs()));
            if converged || size <= opts.tolerance * scale {
                if !opts.polish || size == 0.0 || size >= last || extra == 3 {
                    self.h_prev = data.h;
                    self.end_gradient(lag, element, layout, data);
                    return Ok(it);
                }
                converged = true;
                extra += 1;
            } else if size > 0.1 * last && formed < it {
                // A slow contraction: the Jacobian is stale; Newton's own from here.
                pending = self.refresh(lag, element, layout, data, mom);
                formed = it + 1;
            } else if it > 3 && size >= last && formed < it {
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
