//! The optimiser's Lagrangian at one quadrature point, and its derivatives.
//!
//! On element k with step h, at the quadrature node c with weight b, the KKT Lagrangian of the
//! discretised problem (see the module docs of `optimize`) contributes
//!
//!   Ψ(y) = h b [ C(t, q, v, u) + ∂L/∂q(t, q, v)·λ + ∂L/∂v(t, q, v)·μ̂/h + F(t, q, v, u)·λ ],
//!
//! with v = v̂/h and t = t0 + σh (σ = k + c), in the point variables
//! y = (q, v̂, u, [h], λ, μ̂): q = Σ Q_a ℓ_a(c), v̂ = Σ Q_a ℓ_a'(c) (h times the velocity),
//! u the controls at the point, h when the final time is free, and λ = Σ Λ_a ℓ_a(c),
//! μ̂ = Σ Λ_a ℓ_a'(c) from the nodal multipliers Λ. Every y is linear in the element's
//! unknowns (h in the final time), so the element's gradient and Hessian are those of Ψ
//! carried by the interpolation. The multiplier terms are the forced discrete Euler–Lagrange
//! equations (DESIGN §4) paired with Λ: the derivative of L along (λ, μ̂/h), taken with an
//! outer dual number, so the Hessian of Ψ (third derivatives of L contracted with the
//! multipliers) comes from hyper-dual numbers inside it, one pass per pair of variables. Ψ is
//! linear in (λ, μ̂), so pairs of two multiplier variables are zero and not evaluated.

use super::system::Controls;
use crate::lagrangian::{Lagrangian, Scalar};
use num_dual::{Dual, Dual64, HyperDual64};

/// Where the point variables sit in y, and the point's time data.
#[derive(Debug, Clone, Copy)]
pub(super) struct PointMap {
    /// Coordinates n.
    pub(super) n: usize,
    /// Controls m.
    pub(super) m: usize,
    /// Whether h is a variable (free final time).
    pub(super) free: bool,
}

impl PointMap {
    /// Number of variables before the multipliers: q, v̂, u and h if free.
    pub(super) fn primal(&self) -> usize {
        2 * self.n + self.m + usize::from(self.free)
    }

    /// All variables.
    pub(super) fn len(&self) -> usize {
        self.primal() + 2 * self.n
    }

    /// Index of h in y (meaningful only if free).
    pub(super) fn h_index(&self) -> usize {
        2 * self.n + self.m
    }

    /// Index of λ_0.
    pub(super) fn lambda(&self) -> usize {
        self.primal()
    }
}

/// The time data of one point: t = t0 + σh, weight b, the step when it is fixed.
#[derive(Debug, Clone, Copy)]
pub(super) struct PointTime {
    pub(super) t0: f64,
    pub(super) sigma: f64,
    pub(super) weight: f64,
    pub(super) h: f64,
}

/// Ψ(y) (module docs), generic so that hyper-dual y give its derivatives.
pub(super) fn psi<D, L, C>(lag: &L, ctl: &C, map: PointMap, time: PointTime, y: &[D]) -> D
where
    D: Scalar,
    Dual<D>: Scalar,
    L: Lagrangian + ?Sized,
    C: Controls,
{
    let n = map.n;
    let h = if map.free { y[map.h_index()] } else { D::from(time.h) };
    let t = h * time.sigma + time.t0;
    let inv_h = h.recip();
    let q = &y[..n];
    let u = &y[2 * n..2 * n + map.m];
    let lam = &y[map.lambda()..map.lambda() + n];
    let v: Vec<D> = y[n..2 * n].iter().map(|&x| x * inv_h).collect();
    // ∂L/∂q·λ + ∂L/∂v·μ̂/h as the derivative of L along (λ, μ̂/h).
    let qd: Vec<Dual<D>> = q.iter().zip(lam).map(|(&a, &b)| Dual::new(a, b)).collect();
    let vd: Vec<Dual<D>> = v
        .iter()
        .zip(&y[map.lambda() + n..map.lambda() + 2 * n])
        .map(|(&a, &b)| Dual::new(a, b * inv_h))
        .collect();
    let along = lag.value(Dual::new(t, D::from(0.0)), &qd, &vd).eps;
    let mut f = vec![D::from(0.0); n];
    ctl.force(t, q, &v, u, &mut f);
    let work = f.iter().zip(lam).fold(D::from(0.0), |s, (&a, &b)| s + a * b);
    (ctl.running_cost(t, q, &v, u) + along + work) * h * time.weight
}

/// Gradient (len y) and Hessian (row-major, len y squared) of Ψ at `y`.
pub(super) fn point_hessian<L, C>(
    lag: &L,
    ctl: &C,
    map: PointMap,
    time: PointTime,
    y: &[f64],
    grad: &mut [f64],
    hess: &mut [f64],
) where
    L: Lagrangian + ?Sized,
    C: Controls,
{
    let ny = map.len();
    let np = map.primal();
    hess.iter_mut().for_each(|x| *x = 0.0);
    let mut yd: Vec<HyperDual64> = y.iter().map(|&x| HyperDual64::from(x)).collect();
    for a in 0..np {
        for b in a..ny {
            yd[a].eps1 = 1.0;
            yd[b].eps2 = 1.0;
            let r = psi(lag, ctl, map, time, &yd);
            yd[a].eps1 = 0.0;
            yd[b].eps2 = 0.0;
            hess[a * ny + b] = r.eps1eps2;
            hess[b * ny + a] = r.eps1eps2;
            if a == 0 {
                grad[b] = r.eps2;
            }
        }
    }
}

/// The point's share of the objective and of the constraints: h b C, and ∂Ψ/∂λ = h b
/// (∂L/∂q + F) and ∂Ψ/∂μ̂ = b ∂L/∂v into `dl` and `dm` (n each).
pub(super) fn point_residual<L, C>(
    lag: &L,
    ctl: &C,
    map: PointMap,
    time: PointTime,
    y: &[f64],
    dl: &mut [f64],
    dm: &mut [f64],
) -> f64
where
    L: Lagrangian + ?Sized,
    C: Controls,
{
    let n = map.n;
    let cost = psi(lag, ctl, map, time, &zero_multipliers(map, y));
    let mut yd: Vec<Dual64> = zero_multipliers(map, y).iter().map(|&x| Dual64::from(x)).collect();
    for i in 0..n {
        for (out, k) in [(&mut *dl, map.lambda() + i), (&mut *dm, map.lambda() + n + i)] {
            yd[k].eps = 1.0;
            out[i] = psi(lag, ctl, map, time, &yd).eps;
            yd[k].eps = 0.0;
        }
    }
    cost
}

fn zero_multipliers(map: PointMap, y: &[f64]) -> Vec<f64> {
    let mut y = y.to_vec();
    y[map.lambda()..].iter_mut().for_each(|x| *x = 0.0);
    y
}
