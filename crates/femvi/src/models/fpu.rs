//! The Fermi–Pasta–Ulam–Tsingou chain (Fermi, Pasta and Ulam, Los Alamos report LA-1940,
//! 1955; programmed by Mary Tsingou): n unit masses between fixed ends q_0 = q_{n+1} = 0,
//! joined by springs with the bond potential d²/2 + α d³/3 + β d⁴/4 of the elongation
//! d_i = q_{i+1} − q_i (the α-chain for β = 0, the β-chain for α = 0), so that
//! q̈_i = V'(d_i) − V'(d_{i−1}) with V'(d) = d + α d² + β d³. The dimension n is a parameter.

use super::{finite, MAX_FPU_MASSES};
use crate::error::{invalid, Result};
use crate::lagrangian::{Mechanical, Potential, Scalar};
use std::ops::Range;

/// The α/β Fermi–Pasta–Ulam–Tsingou chain with fixed ends q_0 = q_{n+1} = 0:
/// V = Σ_{i=0}^{n} (d²/2 + α d³/3 + β d⁴/4), d = q_{i+1} − q_i.
#[derive(Debug, Clone, Copy)]
pub struct FpuPotential {
    /// Number of moving masses.
    pub n: usize,
    /// Cubic coefficient.
    pub alpha: f64,
    /// Quartic coefficient.
    pub beta: f64,
}

impl FpuPotential {
    /// V''(d) = 1 + 2αd + 3βd², the stiffness of a bond of elongation d.
    #[inline]
    fn ddv(&self, d: f64) -> f64 {
        1.0 + 2.0 * self.alpha * d + 3.0 * self.beta * d * d
    }

    /// The chain of n masses with coefficients α and β.
    ///
    /// # Errors
    /// n = 0 or n > [`MAX_FPU_MASSES`], or α or β not finite.
    pub fn new(n: usize, alpha: f64, beta: f64) -> Result<Self> {
        if n == 0 {
            return Err(invalid("fpu", "the chain needs at least one mass (n >= 1)"));
        }
        if n > MAX_FPU_MASSES {
            return Err(invalid(
                "fpu",
                format!("n = {n}: the chain is limited to {MAX_FPU_MASSES} masses"),
            ));
        }
        finite("fpu", &[("alpha", alpha), ("beta", beta)])?;
        Ok(Self { n, alpha, beta })
    }
}

impl Potential for FpuPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        self.n
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let mut v = D::from(0.0);
        for i in 0..=self.n {
            let left = if i == 0 { D::from(0.0) } else { q[i - 1] };
            let right = if i == self.n { D::from(0.0) } else { q[i] };
            let d = right - left;
            v += d * d * 0.5 + d * d * d * (self.alpha / 3.0) + d * d * d * d * (self.beta / 4.0);
        }
        v
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.force_range(t, q, 0..self.n, out);
    }
    fn force_derivative(&self, _t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        // δf_i = V''(d_i) δd_i − V''(d_{i−1}) δd_{i−1}, V''(d) = 1 + 2αd + 3βd².
        let n = self.n.min(q.len()).min(dq.len()).min(out.len());
        let Some(last) = n.checked_sub(1) else { return };
        let mut prev = self.ddv(q[0] - 0.0) * (dq[0] - 0.0);
        for (i, o) in out[..last].iter_mut().enumerate() {
            let next = self.ddv(q[i + 1] - q[i]) * (dq[i + 1] - dq[i]);
            *o = next - prev;
            prev = next;
        }
        out[last] = self.ddv(0.0 - q[last]) * (0.0 - dq[last]) - prev;
    }

    /// V''(d_b) of every bond b = 0 … n (n + 1 numbers), as
    /// [`Potential::force_derivative`] computes them.
    fn prepare_force_derivative(&self, _t: f64, q: &[f64], cache: &mut Vec<f64>) -> bool {
        let n = self.n;
        if q.len() != n || n == 0 {
            return false;
        }
        cache.clear();
        cache.push(self.ddv(q[0] - 0.0));
        cache.extend(q.windows(2).map(|w| self.ddv(w[1] - w[0])));
        cache.push(self.ddv(0.0 - q[n - 1]));
        true
    }

    /// [`Potential::force_derivative`]'s operations on the prepared V''(d_b): a product per
    /// bond.
    fn prepared_force_derivative(&self, cache: &[f64], dq: &[f64], out: &mut [f64]) {
        let n = self.n;
        if dq.len() != n || out.len() != n || cache.len() != n + 1 || n == 0 {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        let mut prev = cache[0] * (dq[0] - 0.0);
        for ((o, w), k) in out.iter_mut().zip(dq.windows(2)).zip(&cache[1..n]) {
            let next = k * (w[1] - w[0]);
            *o = next - prev;
            prev = next;
        }
        out[n - 1] = cache[n] * (0.0 - dq[n - 1]) - prev;
    }

    fn force_radius(&self) -> Option<usize> {
        Some(1)
    }
    fn force_range(&self, _t: f64, q: &[f64], range: Range<usize>, out: &mut [f64]) -> bool {
        // −∂V/∂q_i = V'(d_i) − V'(d_{i−1}) with the bond d_i = q_{i+1} − q_i (q_0 = q_{n+1}
        // = 0): each component from the same two bond forces wherever the range starts, so
        // the same bits as the whole force. The inner bonds by windows of q (no branch or
        // bounds check in the loop), the last bond after it.
        let n = self.n.min(q.len());
        let (start, end) = (range.start, range.end.min(n));
        if start >= end {
            return true;
        }
        let dv = |d: f64| d + self.alpha * d * d + self.beta * d * d * d;
        let mut prev = dv(if start == 0 {
            q[0] - 0.0
        } else {
            q[start] - q[start - 1]
        });
        let inner = end.min(n - 1);
        let mut outs = out.iter_mut();
        if start < inner {
            // Windows first: zip stops on them without taking an output.
            for (w, o) in q[start..=inner].windows(2).zip(outs.by_ref()) {
                let next = dv(w[1] - w[0]);
                *o = next - prev;
                prev = next;
            }
        }
        if end == n {
            if let Some(o) = outs.next() {
                *o = dv(0.0 - q[n - 1]) - prev;
            }
        }
        true
    }
}

/// The FPUT chain with unit masses (O(n) memory: the identity mass matrix is stored by its
/// diagonal).
///
/// # Errors
/// n = 0 or n > [`MAX_FPU_MASSES`], or α or β not finite ([`crate::Error::Invalid`]).
///
/// # Example
///
/// ```
/// use femvi::models::{fpu, MAX_FPU_MASSES};
/// assert!(fpu(8, 0.25, 0.0).is_ok());
/// assert!(fpu(0, 0.25, 0.0).is_err());
/// assert!(fpu(MAX_FPU_MASSES + 1, 0.25, 0.0).is_err() && fpu(usize::MAX, 0.25, 0.0).is_err());
/// assert!(fpu(8, f64::NAN, 0.0).is_err() && fpu(8, 0.0, f64::NEG_INFINITY).is_err());
/// ```
pub fn fpu(n: usize, alpha: f64, beta: f64) -> Result<Mechanical<FpuPotential>> {
    Ok(Mechanical::unit_mass(FpuPotential::new(n, alpha, beta)?))
}

#[cfg(test)]
mod tests {
    use super::FpuPotential;
    use crate::lagrangian::Potential;

    /// The product as it was written before (bond by bond through bounds-checked closures),
    /// to pin the bits of the loop that replaced it.
    fn by_bonds(chain: &FpuPotential, q: &[f64], dq: &[f64], out: &mut [f64]) {
        let n = chain.n.min(q.len()).min(dq.len());
        let ddv = |d: f64| 1.0 + 2.0 * chain.alpha * d + 3.0 * chain.beta * d * d;
        let at = |v: &[f64], i: usize| if i < n { v[i] } else { 0.0 };
        let bond = |b: usize| {
            let (l, dl) = if b == 0 {
                (0.0, 0.0)
            } else {
                (at(q, b - 1), at(dq, b - 1))
            };
            ddv(at(q, b) - l) * (at(dq, b) - dl)
        };
        let mut prev = bond(0);
        for (i, o) in out.iter_mut().enumerate().take(n) {
            let next = bond(i + 1);
            *o = next - prev;
            prev = next;
        }
    }

    /// The product, the prepared product and the bond-by-bond product have the same bits
    /// (chains of 1 to 9 masses, α and β both on, signed zeros among the entries), and a
    /// cache or vector of the wrong length gives NaN or false, no panic.
    #[test]
    fn products_prepared_or_not_have_the_bits_of_the_bond_by_bond_product() {
        let mut uniform = crate::testing::uniform(0x7f4a_7c15_9e37_79b9);
        let mut rand = || uniform() - 0.5;
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut cache = Vec::new();
        for n in 1..=9 {
            let chain = FpuPotential::new(n, 0.25, 1.5).unwrap();
            for trial in 0..20 {
                let q: Vec<f64> = (0..n)
                    .map(|i| if (i + trial) % 4 == 0 { -0.0 } else { rand() })
                    .collect();
                assert!(chain.prepare_force_derivative(0.0, &q, &mut cache));
                for _ in 0..3 {
                    let dq: Vec<f64> = (0..n)
                        .map(|i| if (i + trial) % 3 == 1 { -0.0 } else { rand() })
                        .collect();
                    let (mut want, mut once, mut prepared) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                    by_bonds(&chain, &q, &dq, &mut want);
                    chain.force_derivative(0.0, &q, &dq, &mut once);
                    chain.prepared_force_derivative(&cache, &dq, &mut prepared);
                    assert_eq!(bits(&once), bits(&want), "n = {n}");
                    assert_eq!(bits(&prepared), bits(&want), "n = {n}");
                }
            }
            let mut out = vec![0.0; n];
            chain.prepared_force_derivative(&cache[1..], &vec![0.0; n], &mut out);
            assert!(out.iter().all(|x| x.is_nan()));
            chain.prepared_force_derivative(&cache, &vec![0.0; n + 1], &mut out);
            assert!(out.iter().all(|x| x.is_nan()));
            assert!(!chain.prepare_force_derivative(0.0, &vec![0.0; n + 1], &mut cache));
        }
    }
}
