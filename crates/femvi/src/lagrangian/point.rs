//! Derivatives of a Lagrangian at one point by forward-mode automatic differentiation,
//! into buffers that are reused so that repeated evaluations do not allocate. For n ≤
//! [`ONE_PASS_MAX_DIM`] the derivatives with respect to (q, v) take one pass of num-dual's
//! stack-allocated vector types (gradient: `DualSVec64<2n>`, Hessian: `Dual2SVec64<2n>`, see
//! `one_pass.rs`); otherwise, and for ∂L/∂t, value and gradient with dual numbers (one pass
//! per direction), and the Hessian with hyper-dual numbers (one pass per pair of directions).

use super::one_pass;
use super::{Lagrangian, Scalar};
use num_dual::{Dual64, HyperDual64};

/// The largest dimension n whose derivatives with respect to (q, v) are taken in one pass of
/// vector dual numbers (issue 15 item 2; measured in README "General Lagrangians").
///
/// ```
/// use femvi::lagrangian::{PointDerivatives, ONE_PASS_MAX_DIM};
/// use femvi::{Lagrangian, Scalar};
/// struct Spin;
/// impl Lagrangian for Spin {
///     fn dim(&self) -> usize { 2 }
///     fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
///         (v[0] * v[0] + v[1] * v[1]) * 0.5 * (q[0] * q[1]).cos() + v[0] * q[1]
///     }
/// }
/// assert!(Spin.dim() <= ONE_PASS_MAX_DIM);
/// let (mut one, mut pairs) = (PointDerivatives::new(2), PointDerivatives::new(2));
/// one.second_by_ad(&Spin, 0.0, &[0.3, 0.4], &[1.0, -2.0], false); // one pass
/// pairs.second_by_pairs(&Spin, 0.0, &[0.3, 0.4], &[1.0, -2.0], false); // ten passes
/// for (a, b) in one.hess.iter().zip(&pairs.hess) {
///     assert!((a - b).abs() <= 1e-15 * (1.0 + b.abs()));
/// }
/// ```
pub const ONE_PASS_MAX_DIM: usize = 4;

/// Value, gradient and Hessian of L at one point with respect to z = (t, q, v), m = 2n + 1
/// entries: index 0 is t, 1 ..= n are q, n + 1 ..= 2n are v. Holds its own AD scratch so
/// that repeated evaluations do not allocate. The Hessian's (2n + 1)² entries are allocated
/// by the first second-derivative evaluation (or [`PointDerivatives::hessian_mut`]), not by
/// [`PointDerivatives::new`]: a large mechanical system that never needs them (n = 10⁵ would
/// need 320 GB) stays O(n).
#[derive(Debug, Clone)]
pub struct PointDerivatives {
    pub(super) n: usize,
    /// L at the point.
    pub value: f64,
    /// ∂L/∂z (length 2n + 1).
    pub grad: Vec<f64>,
    /// ∂²L/∂z∂z, row-major (2n + 1)²; empty until second derivatives are first evaluated.
    pub hess: Vec<f64>,
    pub(super) d1: Vec<Dual64>,
    d2: Vec<HyperDual64>,
}

impl PointDerivatives {
    /// Buffers for a configuration space of dimension n.
    pub fn new(n: usize) -> Self {
        let m = 2 * n + 1;
        Self {
            n,
            value: 0.0,
            grad: vec![0.0; m],
            hess: Vec::new(),
            d1: vec![Dual64::from(0.0); m],
            d2: vec![HyperDual64::from(0.0); m],
        }
    }

    /// ∂L/∂t (NaN if `grad` was emptied).
    pub fn l_t(&self) -> f64 {
        self.grad.first().copied().unwrap_or(f64::NAN)
    }
    /// ∂L/∂q (empty if `grad` was shortened).
    pub fn l_q(&self) -> &[f64] {
        self.grad.get(1..=self.n).unwrap_or(&[])
    }
    /// ∂L/∂v (empty if `grad` was shortened).
    pub fn l_v(&self) -> &[f64] {
        self.grad.get(self.n + 1..).unwrap_or(&[])
    }
    /// ∂²L/∂z_a∂z_b with z = (t, q, v): 0 before any second derivatives were evaluated, NaN
    /// for an index beyond 2n.
    #[inline]
    pub fn h(&self, a: usize, b: usize) -> f64 {
        let m = self.width();
        if a < m && b < m {
            self.hess.get(a * m + b).copied().unwrap_or(0.0)
        } else {
            f64::NAN
        }
    }
    /// The Hessian's entries, row-major (2n + 1)², allocated (as zeros) on the first call:
    /// for implementations of [`Lagrangian::second_derivatives`] that fill it themselves.
    pub fn hessian_mut(&mut self) -> &mut [f64] {
        let m = self.width();
        if self.hess.len() != m * m {
            self.hess = vec![0.0; m * m];
        }
        &mut self.hess
    }
    /// Whether `grad` and the scratch fit n, and the point (q, v) has n entries each. When
    /// not, the value and gradient are set to NaN: the caller passed buffers of another size.
    pub(super) fn fits<L: Lagrangian + ?Sized>(&mut self, lag: &L, q: &[f64], v: &[f64]) -> bool {
        let m = self.width();
        let ok = lag.dim() == self.n
            && q.len() == self.n
            && v.len() == self.n
            && self.grad.len() == m
            && self.d1.len() == m
            && self.d2.len() == m;
        if !ok {
            self.value = f64::NAN;
            self.grad.iter_mut().for_each(|g| *g = f64::NAN);
        }
        ok
    }
    /// The dimension n of the configuration space these buffers are for.
    pub fn dim(&self) -> usize {
        self.n
    }
    /// Number of entries of z.
    pub fn width(&self) -> usize {
        2 * self.n + 1
    }

    fn load<D: Scalar>(buf: &mut [D], t: f64, q: &[f64], v: &[f64]) {
        buf[0] = D::from(t);
        for (b, &x) in buf[1..].iter_mut().zip(q.iter().chain(v)) {
            *b = D::from(x);
        }
    }

    /// Fills value and gradient by forward-mode AD, one pass per direction. With a
    /// Lagrangian of another dimension or q, v not of length n, value and gradient are NaN.
    #[inline]
    pub fn first_by_ad<L: Lagrangian + ?Sized>(&mut self, lag: &L, t: f64, q: &[f64], v: &[f64], with_t: bool) {
        if !self.fits(lag, q, v) {
            return;
        }
        let with_t = with_t && !lag.is_autonomous();
        if let Some(value) = one_pass::gradient(lag, t, q, v, &mut self.grad[1..]) {
            self.value = value;
            self.grad[0] = 0.0;
            if with_t {
                self.first_by_passes(lag, t, q, v, 0, 1);
            }
            return;
        }
        self.first_by_directions_unchecked(lag, t, q, v, with_t);
    }

    /// [`PointDerivatives::first_by_ad`] by one dual pass per direction, whatever n (the
    /// reference the one-pass path is tested against).
    pub fn first_by_directions<L: Lagrangian + ?Sized>(&mut self, lag: &L, t: f64, q: &[f64], v: &[f64], with_t: bool) {
        if self.fits(lag, q, v) {
            self.first_by_directions_unchecked(lag, t, q, v, with_t && !lag.is_autonomous());
        }
    }

    fn first_by_directions_unchecked<L: Lagrangian + ?Sized>(
        &mut self,
        lag: &L,
        t: f64,
        q: &[f64],
        v: &[f64],
        with_t: bool,
    ) {
        let start = if with_t { 0 } else { 1 };
        if !with_t {
            self.grad[0] = 0.0;
        }
        self.first_by_passes(lag, t, q, v, start, 2 * self.n + 1);
    }

    /// The gradient entries start..end by one dual pass each (sizes already checked).
    fn first_by_passes<L: Lagrangian + ?Sized>(
        &mut self,
        lag: &L,
        t: f64,
        q: &[f64],
        v: &[f64],
        start: usize,
        end: usize,
    ) {
        let n = self.n;
        Self::load(&mut self.d1, t, q, v);
        for a in start..end {
            self.d1[a].eps = 1.0;
            let (zt, rest) = self.d1.split_at(1);
            let r = lag.value(zt[0], &rest[..n], &rest[n..]);
            self.d1[a].eps = 0.0;
            self.value = r.re;
            self.grad[a] = r.eps;
        }
    }

    /// Fills value, gradient and Hessian: for n ≤ [`ONE_PASS_MAX_DIM`] without ∂/∂t in one
    /// pass of `Dual2SVec64<2n>`, otherwise by hyper-dual numbers, one pass per pair of
    /// directions. Sizes that do not fit give NaN, as for [`PointDerivatives::first_by_ad`].
    pub fn second_by_ad<L: Lagrangian + ?Sized>(&mut self, lag: &L, t: f64, q: &[f64], v: &[f64], with_t: bool) {
        self.hessian_mut();
        if !self.fits(lag, q, v) {
            self.hess.iter_mut().for_each(|h| *h = f64::NAN);
            return;
        }
        let with_t = with_t && !lag.is_autonomous();
        if !with_t {
            if let Some(value) = one_pass::hessian(lag, t, q, v, &mut self.grad, &mut self.hess) {
                self.value = value;
                return;
            }
        }
        self.second_by_pairs(lag, t, q, v, with_t);
    }

    /// [`PointDerivatives::second_by_ad`] by hyper-dual numbers, one pass per pair of
    /// directions, whatever n (the reference the one-pass path is tested against).
    pub fn second_by_pairs<L: Lagrangian + ?Sized>(&mut self, lag: &L, t: f64, q: &[f64], v: &[f64], with_t: bool) {
        self.hessian_mut();
        if !self.fits(lag, q, v) {
            self.hess.iter_mut().for_each(|h| *h = f64::NAN);
            return;
        }
        let n = self.n;
        let m = 2 * n + 1;
        Self::load(&mut self.d2, t, q, v);
        let with_t = with_t && !lag.is_autonomous();
        let start = if with_t { 0 } else { 1 };
        if !with_t {
            self.grad[0] = 0.0;
            for a in 0..m {
                self.hess[a] = 0.0;
                self.hess[a * m] = 0.0;
            }
        }
        for a in start..m {
            for b in a..m {
                self.d2[a].eps1 = 1.0;
                self.d2[b].eps2 = 1.0;
                let (zt, rest) = self.d2.split_at(1);
                let r = lag.value(zt[0], &rest[..n], &rest[n..]);
                self.d2[a].eps1 = 0.0;
                self.d2[b].eps2 = 0.0;
                self.value = r.re;
                if a == b {
                    self.grad[a] = r.eps1;
                }
                self.hess[a * m + b] = r.eps1eps2;
                self.hess[b * m + a] = r.eps1eps2;
            }
        }
    }
}
