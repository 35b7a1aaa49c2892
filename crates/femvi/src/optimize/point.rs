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
use crate::lagrangian::{Lagrangian, PointDerivatives, Scalar};
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

/// Configuration spaces up to this dimension evaluate Ψ in stack buffers (no allocation in
/// the point loop); larger ones allocate them per call.
const STACK_DIM: usize = 16;

/// Ψ(y) (module docs), generic so that hyper-dual y give its derivatives.
pub(super) fn psi<D, L, C>(lag: &L, ctl: &C, map: PointMap, time: PointTime, y: &[D]) -> D
where
    D: Scalar,
    Dual<D>: Scalar,
    L: Lagrangian + ?Sized,
    C: Controls,
{
    let n = map.n;
    let zero = D::from(0.0);
    if n <= STACK_DIM {
        let (mut v, mut f) = ([zero; STACK_DIM], [zero; STACK_DIM]);
        let (mut qd, mut vd) = ([Dual::from_re(zero); STACK_DIM], [Dual::from_re(zero); STACK_DIM]);
        psi_in(
            lag,
            ctl,
            map,
            time,
            y,
            (&mut v[..n], &mut f[..n]),
            (&mut qd[..n], &mut vd[..n]),
        )
    } else {
        let (mut v, mut f) = (vec![zero; n], vec![zero; n]);
        let (mut qd, mut vd) = (vec![Dual::from_re(zero); n], vec![Dual::from_re(zero); n]);
        psi_in(lag, ctl, map, time, y, (&mut v, &mut f), (&mut qd, &mut vd))
    }
}

/// [`psi`] with its buffers: v and F (n each), and q and v as outer dual numbers.
fn psi_in<D, L, C>(
    lag: &L,
    ctl: &C,
    map: PointMap,
    time: PointTime,
    y: &[D],
    (v, f): (&mut [D], &mut [D]),
    (qd, vd): (&mut [Dual<D>], &mut [Dual<D>]),
) -> D
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
    let mu = &y[map.lambda() + n..map.lambda() + 2 * n];
    for i in 0..n {
        v[i] = y[n + i] * inv_h;
        // ∂L/∂q·λ + ∂L/∂v·μ̂/h as the derivative of L along (λ, μ̂/h).
        qd[i] = Dual::new(q[i], lam[i]);
        vd[i] = Dual::new(v[i], mu[i] * inv_h);
    }
    let along = lag.value(Dual::new(t, D::from(0.0)), qd, vd).eps;
    f.iter_mut().for_each(|x| *x = D::from(0.0));
    ctl.force(t, q, v, u, f);
    let work = f.iter().zip(lam).fold(D::from(0.0), |s, (&a, &b)| s + a * b);
    (ctl.running_cost(t, q, v, u) + along + work) * h * time.weight
}

/// Reused buffers of [`point_hessian`].
pub(super) struct PointScratch {
    /// Derivatives of L in (t, q, v).
    pd: PointDerivatives,
    /// F and its Jacobian in z = (t, q, v, u), row-major n × (1 + 2n + m).
    f: Vec<f64>,
    fz: Vec<f64>,
    zd: Vec<Dual64>,
    fd: Vec<Dual64>,
    yd: Vec<HyperDual64>,
}

impl PointScratch {
    pub(super) fn new(map: PointMap) -> Self {
        let (n, m) = (map.n, map.m);
        let nz = 1 + 2 * n + m;
        Self {
            pd: PointDerivatives::new(n),
            f: vec![0.0; n],
            fz: vec![0.0; n * nz],
            zd: vec![Dual64::from(0.0); nz],
            fd: vec![Dual64::from(0.0); n],
            yd: vec![HyperDual64::from(0.0); map.len()],
        }
    }
}

/// Gradient (len y) and Hessian (row-major, len y squared) of Ψ at `y`.
///
/// Ψ is linear in the multipliers, so its rows there are first derivatives of the
/// constraint terms: ∂Ψ/∂λ_i = h b (∂L/∂q_i + F_i) and ∂Ψ/∂μ̂_i = b ∂L/∂v_i, whose
/// derivatives in the primal variables come from the Hessian of L in (t, q, v) (the
/// Lagrangian's own, symbolic for expressions) and the Jacobian of F by dual numbers, with
/// v = v̂/h and t = t0 + σh. Only the primal block, where third derivatives of L meet the
/// multipliers, takes hyper-dual passes of Ψ, one per pair.
#[allow(clippy::too_many_arguments)]
pub(super) fn point_hessian<L, C>(
    lag: &L,
    ctl: &C,
    map: PointMap,
    time: PointTime,
    y: &[f64],
    scratch: &mut PointScratch,
    grad: &mut [f64],
    hess: &mut [f64],
) where
    L: Lagrangian + ?Sized,
    C: Controls,
{
    let ny = map.len();
    let np = map.primal();
    hess.iter_mut().for_each(|x| *x = 0.0);
    let yd = &mut scratch.yd;
    yd.iter_mut().zip(y).for_each(|(d, &x)| *d = HyperDual64::from(x));
    for a in 0..np {
        for b in a..np {
            yd[a].eps1 = 1.0;
            yd[b].eps2 = 1.0;
            let r = psi(lag, ctl, map, time, yd);
            yd[a].eps1 = 0.0;
            yd[b].eps2 = 0.0;
            hess[a * ny + b] = r.eps1eps2;
            hess[b * ny + a] = r.eps1eps2;
            if a == 0 {
                grad[b] = r.eps2;
            }
        }
    }
    multiplier_rows(lag, ctl, map, time, y, scratch, grad, hess);
}

/// The multiplier rows and columns of Ψ's gradient and Hessian (see [`point_hessian`]).
#[allow(clippy::too_many_arguments)]
fn multiplier_rows<L, C>(
    lag: &L,
    ctl: &C,
    map: PointMap,
    time: PointTime,
    y: &[f64],
    sc: &mut PointScratch,
    grad: &mut [f64],
    hess: &mut [f64],
) where
    L: Lagrangian + ?Sized,
    C: Controls,
{
    let (n, m, ny) = (map.n, map.m, map.len());
    let nz = 1 + 2 * n + m;
    let h = if map.free { y[map.h_index()] } else { time.h };
    let t = time.t0 + time.sigma * h;
    let b = time.weight;
    let q = &y[..n];
    let v: Vec<f64> = y[n..2 * n].iter().map(|x| x / h).collect();
    let u = &y[2 * n..2 * n + m];
    lag.second_derivatives(t, q, &v, map.free, &mut sc.pd);
    // F and its Jacobian in z = (t, q, v, u), one dual pass per direction.
    for (k, z) in std::iter::once(t)
        .chain(q.iter().copied())
        .chain(v.iter().copied())
        .chain(u.iter().copied())
        .enumerate()
    {
        sc.zd[k] = Dual64::from(z);
    }
    for k in 0..nz {
        sc.zd[k].eps = 1.0;
        let (zt, rest) = sc.zd.split_at(1);
        let (zq, rest) = rest.split_at(n);
        let (zv, zu) = rest.split_at(n);
        ctl.force(zt[0], zq, zv, zu, &mut sc.fd);
        sc.zd[k].eps = 0.0;
        for i in 0..n {
            sc.fz[i * nz + k] = sc.fd[i].eps;
            sc.f[i] = sc.fd[i].re;
        }
    }
    let (pd, fz, f) = (&sc.pd, &sc.fz, &sc.f);
    let w = 2 * n + 1;
    let lh = |r: usize, c: usize| pd.hess[r * w + c];
    let mut put = |r: usize, c: usize, x: f64| {
        hess[r * ny + c] = x;
        hess[c * ny + r] = x;
    };
    for i in 0..n {
        let (li, mi) = (map.lambda() + i, map.lambda() + n + i);
        let (lqi, lvi) = (1 + i, 1 + n + i);
        grad[li] = h * b * (pd.grad[lqi] + f[i]);
        grad[mi] = b * pd.grad[lvi];
        let fzi = &fz[i * nz..(i + 1) * nz];
        for j in 0..n {
            put(li, j, h * b * (lh(lqi, 1 + j) + fzi[1 + j]));
            put(li, n + j, b * (lh(lqi, 1 + n + j) + fzi[1 + n + j]));
            put(mi, j, b * lh(lvi, 1 + j));
            put(mi, n + j, b * lh(lvi, 1 + n + j) / h);
        }
        for c in 0..m {
            put(li, 2 * n + c, h * b * fzi[1 + 2 * n + c]);
        }
        if map.free {
            let hi = map.h_index();
            let dv_l: f64 = (0..n).map(|j| (lh(lqi, 1 + n + j) + fzi[1 + n + j]) * v[j]).sum();
            let dv_m: f64 = (0..n).map(|j| lh(lvi, 1 + n + j) * v[j]).sum();
            put(
                li,
                hi,
                b * (pd.grad[lqi] + f[i]) + h * b * time.sigma * (lh(lqi, 0) + fzi[0]) - b * dv_l,
            );
            put(mi, hi, b * (time.sigma * lh(lvi, 0) - dv_m / h));
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
