//! Gradient and Hessian of a Lagrangian with respect to (q, v) in one forward pass of
//! num-dual's stack-allocated vector dual numbers (issue 15 item 2): `DualSVec64<K>` carries
//! all K = 2n first derivatives, `Dual2SVec64<K>` also the K × K second derivatives, so a
//! point costs one evaluation of L instead of 2n (gradient) or n(2n + 1) (Hessian) passes of
//! scalar duals. Dispatched on n for n ≤ [`ONE_PASS_MAX_DIM`] (K a const generic, so the
//! numbers live on the stack); larger n keep the per-direction passes of `point.rs`, whose
//! K² work per operation would no longer pay.

use super::point::ONE_PASS_MAX_DIM;
use super::Lagrangian;
use nalgebra::SVector;
use num_dual::{Derivative, Dual2SVec64, DualSVec64};

/// L and ∂L/∂(q, v) into `grad_qv` (2n entries) if n ≤ [`ONE_PASS_MAX_DIM`]; None otherwise
/// (nothing written). Sizes are the caller's to check.
#[inline]
pub(super) fn gradient<L: Lagrangian + ?Sized>(
    lag: &L,
    t: f64,
    q: &[f64],
    v: &[f64],
    grad_qv: &mut [f64],
) -> Option<f64> {
    match q.len() {
        1 => Some(gradient_k::<2, L>(lag, t, q, v, grad_qv)),
        2 => Some(gradient_k::<4, L>(lag, t, q, v, grad_qv)),
        3 => Some(gradient_k::<6, L>(lag, t, q, v, grad_qv)),
        4 => Some(gradient_k::<8, L>(lag, t, q, v, grad_qv)),
        _ => None,
    }
}

/// L, ∂L/∂z and ∂²L/∂z∂z for z = (t, q, v) into `grad` (2n + 1) and `hess` ((2n + 1)²,
/// row-major), the t row and column zero, if n ≤ [`ONE_PASS_MAX_DIM`]; None otherwise.
pub(super) fn hessian<L: Lagrangian + ?Sized>(
    lag: &L,
    t: f64,
    q: &[f64],
    v: &[f64],
    grad: &mut [f64],
    hess: &mut [f64],
) -> Option<f64> {
    const _: () = assert!(ONE_PASS_MAX_DIM == 4, "extend the dispatch below");
    match q.len() {
        1 => Some(hessian_k::<2, L>(lag, t, q, v, grad, hess)),
        2 => Some(hessian_k::<4, L>(lag, t, q, v, grad, hess)),
        3 => Some(hessian_k::<6, L>(lag, t, q, v, grad, hess)),
        4 => Some(hessian_k::<8, L>(lag, t, q, v, grad, hess)),
        _ => None,
    }
}

#[inline]
fn gradient_k<const K: usize, L: Lagrangian + ?Sized>(
    lag: &L,
    t: f64,
    q: &[f64],
    v: &[f64],
    grad_qv: &mut [f64],
) -> f64 {
    let n = K / 2;
    // Built in place (not by `from_re(x).derivative(a)` over a chained iterator, which was
    // half of this function's own cost beside L: callgrind, relativistic Kepler).
    let z: [DualSVec64<K>; K] = std::array::from_fn(|a| {
        let x = if a < n { q[a] } else { v[a - n] };
        DualSVec64::new(
            x,
            Derivative::some(SVector::from_fn(|i, _| if i == a { 1.0 } else { 0.0 })),
        )
    });
    let r = lag.value(DualSVec64::from_re(t), &z[..n], &z[n..]);
    match r.eps.0 {
        Some(d) => grad_qv.iter_mut().zip(d.iter()).for_each(|(g, &x)| *g = x),
        None => grad_qv.iter_mut().for_each(|g| *g = 0.0),
    }
    r.re
}

fn hessian_k<const K: usize, L: Lagrangian + ?Sized>(
    lag: &L,
    t: f64,
    q: &[f64],
    v: &[f64],
    grad: &mut [f64],
    hess: &mut [f64],
) -> f64 {
    let (n, m) = (K / 2, K + 1);
    let mut z = [Dual2SVec64::<K>::from_re(0.0); K];
    for (a, (za, &x)) in z.iter_mut().zip(q.iter().chain(v)).enumerate() {
        *za = Dual2SVec64::from_re(x).derivative(a);
    }
    let r = lag.value(Dual2SVec64::from_re(t), &z[..n], &z[n..]);
    grad.iter_mut().for_each(|g| *g = 0.0);
    hess.iter_mut().for_each(|h| *h = 0.0);
    if let Some(d) = r.v1.0 {
        grad[1..].iter_mut().zip(d.iter()).for_each(|(g, &x)| *g = x);
    }
    if let Some(d2) = r.v2.0 {
        // The upper triangle, mirrored, as the per-pair path fills it.
        for a in 0..K {
            for b in a..K {
                let x = d2[(a, b)];
                hess[(1 + a) * m + 1 + b] = x;
                hess[(1 + b) * m + 1 + a] = x;
            }
        }
    }
    r.re
}
