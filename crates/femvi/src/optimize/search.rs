//! The optimiser's step length (`solver.rs` takes the Newton step from `newton.rs`, then
//! this): the fraction to the boundary that keeps the primal unknowns and the bound duals
//! strictly inside their bounds, and a backtracking search on the exact penalty
//! φ = J_μ + ν‖c‖₁ (Armijo, 10⁻⁴) with a second-order correction of the full step against
//! the Maratos effect (Wächter and Biegler, Math. Program. 106, 2006, §2.5 and §2.4, in a
//! plain form).

use super::assemble::{Border, Model};
use super::iterate::{value_of, Bound, Iterate};
use super::kkt::{bordered_solve, dot};
use super::system::Controls;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solve::BandMatrix;

/// The factored KKT matrix with its border and the gradient it was assembled with.
pub(super) struct Kkt<'a> {
    pub(super) band: &'a BandMatrix,
    pub(super) border: &'a Border,
    /// The final time's diagonal entry, as factored.
    pub(super) diag: f64,
    pub(super) grad: &'a [f64],
    pub(super) lambda_rows: &'a [usize],
}

/// The barrier μ, the penalty ν of ‖c‖₁ and the rounding of ‖c‖₁ (`backward_error`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Penalty {
    pub(super) mu: f64,
    pub(super) nu: f64,
    pub(super) c_noise: f64,
}

/// Fraction to the boundary (τ = max(0.99, 1 − μ)): the largest primal step α ≤ 1 and dual
/// step α_z ≤ 1 that keep x and z that fraction inside their bounds, with the duals' steps
/// (dz_l, dz_u) per bound.
pub(super) fn to_the_boundary(
    it: &Iterate,
    bounds: &[Bound],
    dx: &[f64],
    dt: f64,
    mu: f64,
) -> (f64, f64, Vec<(f64, f64)>) {
    let tau = 0.99f64.max(1.0 - mu);
    let mut alpha = 1.0f64;
    let mut dz = Vec::with_capacity(bounds.len());
    for (k, b) in bounds.iter().enumerate() {
        let (x, d) = (value_of(it, b), b.var.map_or(dt, |i| dx[i]));
        if b.lo.is_finite() && d < 0.0 {
            alpha = alpha.min(-tau * (x - b.lo) / d);
        }
        if b.up.is_finite() && d > 0.0 {
            alpha = alpha.min(tau * (b.up - x) / d);
        }
        let dzl = if b.lo.is_finite() {
            mu / (x - b.lo) - it.zl[k] - it.zl[k] / (x - b.lo) * d
        } else {
            0.0
        };
        let dzu = if b.up.is_finite() {
            mu / (b.up - x) - it.zu[k] + it.zu[k] / (b.up - x) * d
        } else {
            0.0
        };
        dz.push((dzl, dzu));
    }
    let mut alpha_z = 1.0f64;
    for (k, &(dzl, dzu)) in dz.iter().enumerate() {
        if dzl < 0.0 {
            alpha_z = alpha_z.min(-tau * it.zl[k] / dzl);
        }
        if dzu < 0.0 {
            alpha_z = alpha_z.min(-tau * it.zu[k] / dzu);
        }
    }
    (alpha, alpha_z, dz)
}

/// The backtracking search from `it` along (dx, dt) on the exact penalty, halving `alpha`
/// (at most 40 times) from the fraction to the boundary; at the full step, a second-order
/// correction before the first halving. The accepted iterate (duals not yet moved), or
/// `None` when no step length decreases φ beyond its rounding.
pub(super) fn line_search<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    it: &Iterate,
    bounds: &[Bound],
    kkt: &Kkt<'_>,
    penalty: Penalty,
    (dx, dt): (&[f64], f64),
    alpha: &mut f64,
) -> Result<Option<Iterate>> {
    let Penalty { mu, nu, c_noise } = penalty;
    let lambda_rows = kkt.lambda_rows;
    let vals = model.values(&it.x, it.t1);
    let c1: f64 = lambda_rows.iter().map(|&i| vals.c[i].abs()).sum();
    let phi0 = vals.objective + barrier(it, bounds, mu) + nu * c1;
    let gbar = barrier_gradient(it, bounds, kkt.grad, kkt.border.grad, lambda_rows, mu, dx, dt);
    let slope = gbar - nu * c1 + lambda_rows.iter().map(|&i| it.x[i] * vals.c[i]).sum::<f64>();
    let merit = |trial: &Iterate| {
        let tv = model.values(&trial.x, trial.t1);
        let tc: f64 = lambda_rows.iter().map(|&i| tv.c[i].abs()).sum();
        (tv.objective + barrier(trial, bounds, mu) + nu * tc, tv.c)
    };
    // A decrease below the rounding of φ itself cannot be asked for: that of J, and ν
    // times that of ‖c‖₁, whose rows are sums of terms of size (|K||x|)_i (at 10⁴
    // elements ν‖c‖₁ rounds at 1e-6 while a step near the optimum gains 1e-8).
    let noise = 10.0 * f64::EPSILON * phi0.abs() + nu * c_noise;
    let armijo = |phi: f64, alpha: f64| phi.is_finite() && (slope >= 0.0 || phi <= phi0 + 1e-4 * alpha * slope + noise);
    let mut accepted = None;
    for _ in 0..40 {
        let trial = moved(it, dx, dt, *alpha);
        let (phi, c) = merit(&trial);
        if armijo(phi, *alpha) {
            accepted = Some(trial);
            break;
        }
        if *alpha == 1.0 {
            // A second-order correction of the full step (against the Maratos effect):
            // the least change that removes the constraint residual the step left.
            let mut soc = vec![0.0; dx.len()];
            lambda_rows.iter().for_each(|&i| soc[i] = -c[i]);
            if let Some(dts) = bordered_solve(kkt.band, model.free, &kkt.border.col, kkt.diag, &mut soc, 0.0)? {
                let mut corrected = trial.clone();
                corrected.x.iter_mut().zip(&soc).for_each(|(x, d)| *x += d);
                corrected.t1 += dts;
                if within(&corrected, bounds) && armijo(merit(&corrected).0, 1.0) {
                    accepted = Some(corrected);
                    break;
                }
            }
        }
        *alpha *= 0.5;
    }
    Ok(accepted)
}

/// The step from `it` by α (multipliers too).
fn moved(it: &Iterate, dx: &[f64], dt: f64, alpha: f64) -> Iterate {
    let mut next = it.clone();
    next.x.iter_mut().zip(dx).for_each(|(x, d)| *x += alpha * d);
    next.t1 += alpha * dt;
    next
}

/// Whether every bounded unknown is strictly inside its bounds.
fn within(it: &Iterate, bounds: &[Bound]) -> bool {
    bounds.iter().all(|b| {
        let x = value_of(it, b);
        x > b.lo && x < b.up
    })
}

/// −μ Σ ln(x − l) + ln(u − x); +∞ outside the bounds.
fn barrier(it: &Iterate, bounds: &[Bound], mu: f64) -> f64 {
    let mut s = 0.0;
    for b in bounds {
        let x = value_of(it, b);
        for gap in [x - b.lo, b.up - x] {
            if gap.is_finite() {
                s -= if gap > 0.0 { mu * gap.ln() } else { f64::NEG_INFINITY };
            }
        }
    }
    s
}

/// ∇J_μ·d less the multiplier part: g_μ·dx where g_μ is the barrier gradient of the KKT
/// Lagrangian (the Λ·c term is added by the caller).
#[allow(clippy::too_many_arguments)]
fn barrier_gradient(
    it: &Iterate,
    bounds: &[Bound],
    grad: &[f64],
    grad_t: f64,
    lambda_rows: &[usize],
    mu: f64,
    dx: &[f64],
    dt: f64,
) -> f64 {
    let mut s = dot(grad, dx) + grad_t * dt - lambda_rows.iter().map(|&i| grad[i] * dx[i]).sum::<f64>();
    for b in bounds {
        let x = value_of(it, b);
        let d = b.var.map_or(dt, |i| dx[i]);
        if b.lo.is_finite() {
            s -= mu / (x - b.lo) * d;
        }
        if b.up.is_finite() {
            s += mu / (b.up - x) * d;
        }
    }
    s
}
