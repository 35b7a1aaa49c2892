//! Hand-coded derivatives of the time-transformed Lagrangian for a mechanical
//! L = ½vᵀMv − V(q) (the fast path of issue 21): with φ = V − E₀, T₂ = q'ᵀMq', u = Mq' and
//! the force F = −∇V, J = −∇²V,
//!
//!   L_g = ½T₂/g − gφ,
//!   ∂L_g/∂q' = u/g,   ∂L_g/∂q = −½T₂∇g/g² − φ∇g + gF,
//!   ∂²L_g/∂q'∂q' = M/g,   ∂²L_g/∂q'_a∂q_b = −u_a ∂_b g/g²,
//!   ∂²L_g/∂q_a∂q_b = −½T₂(∂²_ab g/g² − 2∂_a g ∂_b g/g³) − φ∂²_ab g + ∂_a g F_b + F_a ∂_b g + gJ_ab.
//!
//! V, F and J come from the physical Lagrangian (its hand-coded force and force Jacobian for
//! the built-in models), g's gradient and Hessian from [`Monitor::derivatives`] (by hand for
//! the Kepler monitor, otherwise dual numbers over g alone: n and n(n+1)/2 passes over a
//! cheap function), instead of hyper-dual passes over the whole of L_g
//! ((2n+1)(n+1) passes, each evaluating V and g). Scratch lives on the stack up to
//! [`STACK`] numbers, so the step loop does not allocate for small systems.

use super::lagrangian::TimeTransformed;
use super::monitor::Monitor;
use crate::lagrangian::{Lagrangian, PointDerivatives};
use num_dual::{Dual64, HyperDual64};

/// Numbers of scratch kept on the stack (beyond: the heap), in two sizes: zeroing the large
/// buffer for a small system cost a quarter of the step time (measured with perf, Kepler).
const SMALL: usize = 32;
const STACK: usize = 640;

/// Runs `f` with a zeroed scratch slice of `len` numbers of type T.
fn scratch<T: Copy, R>(len: usize, zero: T, f: impl FnOnce(&mut [T]) -> R) -> R {
    if len <= SMALL {
        let mut fixed = [zero; SMALL];
        f(&mut fixed[..len])
    } else if len <= STACK {
        let mut fixed = [zero; STACK];
        f(&mut fixed[..len])
    } else {
        let mut heap = vec![zero; len];
        f(&mut heap)
    }
}

/// Whether the buffers fit; otherwise value, gradient (and Hessian, `second`) become NaN.
fn fits(n: usize, q: &[f64], v: &[f64], out: &mut PointDerivatives, second: bool) -> bool {
    let ok = out.dim() == n && q.len() == n && v.len() == n && out.grad.len() == 2 * n + 1;
    if !ok {
        out.value = f64::NAN;
        out.grad.iter_mut().for_each(|g| *g = f64::NAN);
        if second {
            out.hessian_mut().iter_mut().for_each(|h| *h = f64::NAN);
        }
    }
    ok
}

/// g and ∇g into `grad` (n dual passes).
pub(super) fn monitor_gradient<G: Monitor + ?Sized>(g: &G, q: &[f64], grad: &mut [f64]) -> f64 {
    let n = q.len();
    scratch(n, Dual64::from(0.0), |d| {
        for (di, &x) in d.iter_mut().zip(q) {
            *di = Dual64::from(x);
        }
        let mut value = g.value(q);
        for a in 0..n {
            d[a].eps = 1.0;
            let r = g.value(d);
            d[a].eps = 0.0;
            value = r.re;
            grad[a] = r.eps;
        }
        value
    })
}

/// g, ∇g and ∇²g (row-major n²) (n(n+1)/2 hyper-dual passes).
pub(super) fn monitor_hessian<G: Monitor + ?Sized>(g: &G, q: &[f64], grad: &mut [f64], hess: &mut [f64]) -> f64 {
    let n = q.len();
    scratch(n, HyperDual64::from(0.0), |d| {
        for (di, &x) in d.iter_mut().zip(q) {
            *di = HyperDual64::from(x);
        }
        let mut value = g.value(q);
        for a in 0..n {
            for b in a..n {
                d[a].eps1 = 1.0;
                d[b].eps2 = 1.0;
                let r = g.value(d);
                d[a].eps1 = 0.0;
                d[b].eps2 = 0.0;
                value = r.re;
                if a == b {
                    grad[a] = r.eps1;
                }
                hess[a * n + b] = r.eps1eps2;
                hess[b * n + a] = r.eps1eps2;
            }
        }
        value
    })
}

/// Value and gradient of L_g (mechanical L) into `out`.
pub(super) fn first<L: Lagrangian, G: Monitor>(
    lg: &TimeTransformed<L, G>,
    t: f64,
    q: &[f64],
    v: &[f64],
    out: &mut PointDerivatives,
) {
    let n = lg.dim();
    if !fits(n, q, v, out, false) {
        return;
    }
    let Some(mass) = lg.inner().mass_matrix() else {
        out.first_by_ad(lg, t, q, v, false);
        return;
    };
    scratch(4 * n, 0.0, |buf| {
        let (force, rest) = buf.split_at_mut(n);
        let (dg, rest) = rest.split_at_mut(n);
        let (u, zeros) = rest.split_at_mut(n);
        let g = lg.monitor().derivatives(q, dg, None);
        lg.inner().force(t, q, force);
        let phi = -lg.inner().value(t, q, zeros) - lg.e0();
        mass.apply(v, u);
        let t2: f64 = u.iter().zip(v).map(|(a, b)| a * b).sum();
        out.value = 0.5 * t2 / g - g * phi;
        out.grad[0] = 0.0;
        let c = -0.5 * t2 / (g * g) - phi;
        for a in 0..n {
            out.grad[1 + a] = c * dg[a] + g * force[a];
            out.grad[1 + n + a] = u[a] / g;
        }
    });
}

/// The gyroscopic terms of L_g (mechanical L) for the divisor d, by point
/// ([`Lagrangian::gyroscopic_terms_divided`]): A = u/g − u/d with u = Mq', and ∂L_g/∂q as in
/// [`first`]. With d = g(q_k) the momentum u/g is Mq'/d + A, A of the size of the change of g
/// over the step, so the gyroscopic fixed point contracts like the step.
pub(super) fn gyroscopic_terms<L: Lagrangian, G: Monitor>(
    lg: &TimeTransformed<L, G>,
    d: f64,
    t: &[f64],
    q: &[f64],
    v: &[f64],
    out: &mut [f64],
) {
    let n = lg.dim();
    let Some(mass) = lg.inner().mass_matrix() else {
        out.iter_mut().for_each(|x| *x = f64::NAN);
        return;
    };
    if n == 0 {
        return;
    }
    let (inv_d, identity) = (1.0 / d, mass.is_identity());
    scratch(4 * n, 0.0, |buf| {
        let (force, rest) = buf.split_at_mut(n);
        let (dg, rest) = rest.split_at_mut(n);
        let (u, zeros) = rest.split_at_mut(n);
        let points = q.chunks_exact(n).zip(v.chunks_exact(n));
        for ((&ti, (qi, vi)), oi) in t.iter().zip(points).zip(out.chunks_exact_mut(2 * n)) {
            let g = lg.monitor().derivatives(qi, dg, None);
            lg.inner().force(ti, qi, force);
            let v_pot = match lg.inner().potential_value(ti, qi) {
                Some(v) => v,
                None => -lg.inner().value(ti, qi, zeros),
            };
            let phi = v_pot - lg.e0();
            if identity {
                u.copy_from_slice(vi);
            } else {
                mass.apply(vi, u);
            }
            let t2: f64 = u.iter().zip(vi).map(|(a, b)| a * b).sum();
            let c = -0.5 * t2 / (g * g) - phi;
            let w = 1.0 / g - inv_d;
            let (a, lq) = oi.split_at_mut(n);
            for k in 0..n {
                a[k] = u[k] * w;
                lq[k] = c * dg[k] + g * force[k];
            }
        }
    });
}

/// Value, gradient and Hessian of L_g (mechanical L) into `out`.
pub(super) fn second<L: Lagrangian, G: Monitor>(
    lg: &TimeTransformed<L, G>,
    t: f64,
    q: &[f64],
    v: &[f64],
    out: &mut PointDerivatives,
) {
    let n = lg.dim();
    let m = 2 * n + 1;
    if !fits(n, q, v, out, true) {
        return;
    }
    let Some(mass) = lg.inner().mass_matrix() else {
        out.second_by_ad(lg, t, q, v, false);
        return;
    };
    scratch(4 * n + 2 * n * n, 0.0, |buf| {
        let (force, rest) = buf.split_at_mut(n);
        let (dg, rest) = rest.split_at_mut(n);
        let (u, rest) = rest.split_at_mut(n);
        let (zeros, rest) = rest.split_at_mut(n);
        let (d2g, jac) = rest.split_at_mut(n * n);
        let g = lg.monitor().derivatives(q, dg, Some(d2g));
        // The physical Lagrangian at v = 0: value −V, ∂L/∂q = F, ∂²L/∂q² = J.
        lg.inner().second_derivatives(t, q, zeros, false, out);
        let phi = -out.value - lg.e0();
        for a in 0..n {
            force[a] = out.grad[1 + a];
            for b in 0..n {
                jac[a * n + b] = out.h(1 + a, 1 + b);
            }
        }
        mass.apply(v, u);
        let t2: f64 = u.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
        out.value = 0.5 * t2 / g - g * phi;
        out.grad[0] = 0.0;
        let (g2, g3) = (g * g, g * g * g);
        let c = -0.5 * t2 / g2 - phi;
        for a in 0..n {
            out.grad[1 + a] = c * dg[a] + g * force[a];
            out.grad[1 + n + a] = u[a] / g;
        }
        let hess = out.hessian_mut();
        hess.iter_mut().for_each(|h| *h = 0.0);
        for a in 0..n {
            for b in 0..n {
                let qq = -0.5 * t2 * (d2g[a * n + b] / g2 - 2.0 * dg[a] * dg[b] / g3) - phi * d2g[a * n + b]
                    + dg[a] * force[b]
                    + force[a] * dg[b]
                    + g * jac[a * n + b];
                hess[(1 + a) * m + 1 + b] = qq;
                let vq = -u[a] * dg[b] / g2;
                hess[(1 + n + a) * m + 1 + b] = vq;
                hess[(1 + b) * m + 1 + n + a] = vq;
                hess[(1 + n + a) * m + 1 + n + b] = mass.get(a, b).unwrap_or(0.0) / g;
            }
        }
    });
}
