//! The degree-1 step of a rigid body, L = ½ wᵀ𝕀w − V(R) with 𝕀 = diag(I₁, I₂, I₃)
//! ([`crate::Lagrangian::rigid_body`]), solved by a fixed-point iteration on the body's
//! equations instead of Newton with automatic derivatives (the equations are those of
//! `step.rs`, written out).
//!
//! # Derivation
//!
//! At degree 1, ζ(τ) = τ ζ¹ and w(τ) = (1/h) dexp_{−τζ¹} ζ¹ = ζ¹/h (ad_ζ ζ = 0), so the action
//! of `action.rs` is S = (1/2h) ζ¹ᵀ𝕀ζ¹ − h Σ_i b_i V(R_k exp(η̂) exp(c_i ζ̂¹)) with
//! ζ¹ = ξ − dexp_ξ⁻¹ η. With τ_i = 2 vee(R_iᵀ ∂V/∂R(R_i)), the left-trivialised gradient of V
//! at R_i = R_k exp(c_i ξ̂) (δV = τ_i·σ for δR = R_i σ̂), and the variation
//! σ_i = (Ad_{exp(−c_iξ)} − c_i dexp_{−c_iξ} dexp_ξ⁻¹) η of R_i,
//!
//!   −∂S/∂η = (1/h) dexp_{−ξ}⁻¹ 𝕀ξ + h Σ_i b_i (exp(c_iξ̂) τ_i − c_i dexp_{−ξ}⁻¹ dexp_{c_iξ} τ_i),
//!
//! using (dexp_ξ⁻¹)ᵀ = dexp_{−ξ}⁻¹ and Ad_gᵀ = g⁻¹ on R³. Setting it to μ_k and multiplying by
//! h dexp_{−ξ} gives the fixed point
//!
//!   𝕀ξ = h dexp_{−ξ}(μ_k − h Σ_i b_i exp(c_iξ̂) τ_i) + h² Σ_i b_i c_i dexp_{c_iξ} τ_i,
//!
//! a contraction with factor about |ξ| = h|w| for small steps. The new momentum is
//! μ_{k+1} = dexp_ξ⁻¹ ∂S/∂ξ = dexp_ξ⁻¹ ((1/h)𝕀ξ − h Σ_i b_i c_i dexp_{c_iξ} τ_i). For the free
//! body (τ = 0) these are the Lie–Poisson steps μ_k = dexp_{−ξ}⁻¹ 𝕀ξ/h,
//! μ_{k+1} = dexp_ξ⁻¹ 𝕀ξ/h, and exp(ξ̂) dexp_ξ⁻¹ = dexp_{−ξ}⁻¹ gives R_{k+1}μ_{k+1} = R_kμ_k.

use super::so3::{dexp, dexp_inv, exp, mul, vee, Mat3};
use crate::discrete::Element;
use crate::error::{StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::step::SolverOptions;

/// The body's data and the element's points and weights.
#[derive(Debug, Clone)]
pub(crate) struct BodyStep {
    inertia: [f64; 3],
    potential: bool,
    c: Vec<f64>,
    b: Vec<f64>,
    /// The torques τ_i of the last sweep.
    tau: Vec<[f64; 3]>,
    /// exp(c_i ξ̂) of the last sweep.
    rot: Vec<Mat3<f64>>,
}

impl BodyStep {
    /// The fast path for `lag` on `element`, if it applies: a rigid body and degree 1 with
    /// nodes at the element's ends.
    pub(crate) fn new<L: Lagrangian>(lag: &L, element: &Element) -> Option<Self> {
        let (inertia, potential) = lag.rigid_body()?;
        let ends = (0..element.points()).all(|i| {
            let c = element.rule.nodes[i];
            (element.phi(i, 1) - c).abs() < 1e-15 && (element.dphi(i, 1) - 1.0).abs() < 1e-15
        });
        (element.degree() == 1 && ends && inertia.iter().all(|i| *i > 0.0)).then(|| Self {
            inertia,
            potential,
            c: element.rule.nodes.clone(),
            b: element.rule.weights.clone(),
            tau: vec![[0.0; 3]; element.points()],
            rot: vec![[0.0; 9]; element.points()],
        })
    }

    /// τ_i at R_i = R_k exp(c_i ξ̂), with exp(c_i ξ̂) in `self.rot`.
    fn torques<L: Lagrangian>(&mut self, lag: &L, (t0, h, rk): (f64, f64, &Mat3<f64>), xi: &[f64; 3]) {
        let mut g = [0.0; 9];
        for (i, &c) in self.c.iter().enumerate() {
            let e = exp(&xi.map(|x| c * x));
            let ri = mul(rk, &e);
            lag.force(t0 + c * h, &ri, &mut g);
            // ∂V/∂R = −force; τ = 2 vee(Rᵀ ∂V/∂R).
            let a: Mat3<f64> = std::array::from_fn(|k| {
                let (p, q) = (k / 3, k % 3);
                -(ri[p] * g[q] + ri[3 + p] * g[3 + q] + ri[6 + p] * g[6 + q])
            });
            self.tau[i] = vee(&a).map(|v| 2.0 * v);
            self.rot[i] = e;
        }
    }

    /// Solves the step from R_k (`rk`) with body momentum `mu` for ξ (started from its value
    /// in `xi`); returns the sweeps and μ_{k+1}.
    pub(crate) fn solve<L: Lagrangian>(
        &mut self,
        lag: &L,
        (t0, h, rk): (f64, f64, &Mat3<f64>),
        mu: &[f64; 3],
        xi: &mut [f64; 3],
        (opts, k): (SolverOptions, usize),
    ) -> Result<(usize, [f64; 3]), StepError> {
        let (mut last, mut extra) = (f64::INFINITY, 0);
        let mut converged = false;
        for it in 1..=opts.max_iterations {
            let (mut a, mut y) = (*mu, [0.0; 3]);
            if self.potential {
                self.torques(lag, (t0, h, rk), xi);
                for i in 0..self.c.len() {
                    let (e, tau, (b, c)) = (&self.rot[i], self.tau[i], (self.b[i], self.c[i]));
                    let d = dexp(&xi.map(|x| c * x), &tau);
                    for r in 0..3 {
                        a[r] -= h * b * (e[3 * r] * tau[0] + e[3 * r + 1] * tau[1] + e[3 * r + 2] * tau[2]);
                        y[r] += h * h * b * c * d[r];
                    }
                }
            }
            let d = dexp(&xi.map(|x| -x), &a);
            let new: [f64; 3] = std::array::from_fn(|r| (h * d[r] + y[r]) / self.inertia[r]);
            let size = (0..3).fold(0.0f64, |m, r| m.max((new[r] - xi[r]).abs()));
            if !size.is_finite() || !new.iter().all(|v| v.is_finite()) {
                return Err(fail(k, t0, size, it, StepFailure::NonFinite));
            }
            let scale = xi.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            *xi = new;
            // Once within the tolerance, the polish sweeps on while the increments decrease
            // (at most three more), as the coordinates' fixed point does.
            if converged || size <= opts.tolerance * scale {
                if !opts.polish || size == 0.0 || size >= last || extra == 3 {
                    return Ok((it, self.momentum(lag, (t0, h, rk), xi)));
                }
                converged = true;
                extra += 1;
            } else if it > 3 && size >= last {
                return Err(fail(k, t0, size, it, StepFailure::Stalled));
            }
            last = size;
        }
        Err(fail(k, t0, last, opts.max_iterations, StepFailure::NotConverged))
    }

    /// μ_{k+1} at the solved ξ.
    fn momentum<L: Lagrangian>(&mut self, lag: &L, step: (f64, f64, &Mat3<f64>), xi: &[f64; 3]) -> [f64; 3] {
        let h = step.1;
        let mut g: [f64; 3] = std::array::from_fn(|r| self.inertia[r] * xi[r] / h);
        if self.potential {
            self.torques(lag, step, xi);
            for i in 0..self.c.len() {
                let (b, c) = (self.b[i], self.c[i]);
                let d = dexp(&xi.map(|x| c * x), &self.tau[i]);
                for r in 0..3 {
                    g[r] -= h * b * c * d[r];
                }
            }
        }
        dexp_inv(xi, &g)
    }
}

fn fail(step: usize, t: f64, residual: f64, iterations: usize, failure: StepFailure) -> StepError {
    StepError {
        step,
        t,
        residual,
        iterations,
        failure,
    }
}
