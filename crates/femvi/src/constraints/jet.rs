//! Values and derivatives of the constraints g(q) at one point by forward-mode automatic
//! differentiation: g and the Jacobian G = ∂g/∂q with dual numbers (n passes), and with
//! hyper-dual numbers (n(n+1)/2 passes) also the second derivatives ∂²g_l/∂q_a∂q_b, which the
//! Newton Jacobian of the constrained step needs contracted with the multipliers.

use super::Constraints;
use num_dual::{Dual64, HyperDual64};

/// g, G and optionally ∇²g at one point (m constraints, n coordinates).
#[derive(Debug, Clone)]
pub struct ConstraintJet {
    /// Number of constraints m.
    pub m: usize,
    /// Number of coordinates n.
    pub n: usize,
    /// g(q), m entries.
    pub g: Vec<f64>,
    /// G = ∂g/∂q, row-major m×n.
    pub jac: Vec<f64>,
    /// ∂²g_l/∂q_a∂q_b at `[(l n + a) n + b]` (m n² entries; zeros unless asked for).
    pub hess: Vec<f64>,
    d1: Vec<Dual64>,
    o1: Vec<Dual64>,
    d2: Vec<HyperDual64>,
    o2: Vec<HyperDual64>,
}

/// Infinity norm of the constraint values `g`, NaN if any is NaN ([`ConstraintJet::residual`]).
#[inline(always)]
pub(crate) fn residual(g: &[f64]) -> f64 {
    g.iter()
        .fold(0.0f64, |a, &x| if x.is_nan() { f64::NAN } else { a.max(x.abs()) })
}

impl ConstraintJet {
    /// Buffers for m constraints on n coordinates.
    pub fn new(m: usize, n: usize) -> Self {
        Self {
            m,
            n,
            g: vec![0.0; m],
            jac: vec![0.0; m * n],
            hess: vec![0.0; m * n * n],
            d1: vec![Dual64::from(0.0); n],
            o1: vec![Dual64::from(0.0); m],
            d2: vec![HyperDual64::from(0.0); n],
            o2: vec![HyperDual64::from(0.0); m],
        }
    }

    /// Evaluates g and G at `q` (n entries), and ∇²g if `second`.
    pub fn eval<C: Constraints + ?Sized>(&mut self, c: &C, q: &[f64], second: bool) {
        let (m, n) = (self.m, self.n);
        if second {
            for (d, &x) in self.d2.iter_mut().zip(q) {
                *d = HyperDual64::from(x);
            }
            for a in 0..n {
                for b in a..n {
                    self.d2[a].eps1 = 1.0;
                    self.d2[b].eps2 = 1.0;
                    c.value(&self.d2, &mut self.o2);
                    self.d2[a].eps1 = 0.0;
                    self.d2[b].eps2 = 0.0;
                    for l in 0..m {
                        let o = self.o2[l];
                        if a == 0 && b == 0 {
                            self.g[l] = o.re;
                        }
                        if a == b {
                            self.jac[l * n + a] = o.eps1;
                        }
                        self.hess[(l * n + a) * n + b] = o.eps1eps2;
                        self.hess[(l * n + b) * n + a] = o.eps1eps2;
                    }
                }
            }
            if n == 0 {
                self.value_only(c, q);
            }
            return;
        }
        if c.value_and_jacobian(q, &mut self.g, &mut self.jac) {
            // Compiled g and G (expression constraints).
            return;
        }
        for (d, &x) in self.d1.iter_mut().zip(q) {
            *d = Dual64::from(x);
        }
        for a in 0..n {
            self.d1[a].eps = 1.0;
            c.value(&self.d1, &mut self.o1);
            self.d1[a].eps = 0.0;
            for l in 0..m {
                if a == 0 {
                    self.g[l] = self.o1[l].re;
                }
                self.jac[l * n + a] = self.o1[l].eps;
            }
        }
        if n == 0 {
            self.value_only(c, q);
        }
    }

    fn value_only<C: Constraints + ?Sized>(&mut self, c: &C, q: &[f64]) {
        c.value(q, &mut self.g);
    }

    /// Adds `scale` Σ_l λ_l ∇²g_l to the n×n block of `out` (row-major, row stride `stride`)
    /// starting at (`row`, `col`).
    pub fn add_contracted_hessian(
        &self,
        lambda: &[f64],
        scale: f64,
        out: &mut [f64],
        stride: usize,
        row: usize,
        col: usize,
    ) {
        let n = self.n;
        for (l, &lam) in lambda.iter().enumerate().take(self.m) {
            if lam == 0.0 {
                continue;
            }
            for a in 0..n {
                for b in 0..n {
                    out[(row + a) * stride + col + b] += scale * lam * self.hess[(l * n + a) * n + b];
                }
            }
        }
    }

    /// Gᵀλ added, times `scale`, to `out` (n entries).
    pub fn add_transpose_times(&self, lambda: &[f64], scale: f64, out: &mut [f64]) {
        let n = self.n;
        for (l, &lam) in lambda.iter().enumerate().take(self.m) {
            for (o, &gla) in out.iter_mut().zip(&self.jac[l * n..(l + 1) * n]) {
                *o += scale * lam * gla;
            }
        }
    }

    /// Infinity norm of g.
    pub fn residual(&self) -> f64 {
        residual(&self.g)
    }

    /// The first constraint (0-based) whose value or Jacobian row is not finite at the last
    /// evaluation.
    pub fn first_not_finite(&self) -> Option<usize> {
        let n = self.n;
        (0..self.m).find(|&l| {
            !self.g.get(l).is_some_and(|g| g.is_finite())
                || !self
                    .jac
                    .get(l * n..(l + 1) * n)
                    .is_some_and(|row| row.iter().all(|x| x.is_finite()))
        })
    }

    /// Ratio of the smallest to the largest singular value of G (1 for m = 0; 0 if G is
    /// rank deficient, zero or not finite: the entries are checked before the SVD, which
    /// panics on NaN).
    pub fn conditioning(&self) -> f64 {
        if self.m == 0 {
            return 1.0;
        }
        if self.n < self.m || !self.jac.iter().all(|x| x.is_finite()) {
            return 0.0;
        }
        let g = nalgebra::DMatrix::from_row_slice(self.m, self.n, &self.jac);
        let sv = g.singular_values();
        let (lo, hi) = (sv.min(), sv.max());
        if hi > 0.0 && hi.is_finite() {
            lo / hi
        } else {
            0.0
        }
    }
}
