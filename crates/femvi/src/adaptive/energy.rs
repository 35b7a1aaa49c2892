//! The energy level E₀ = H(q₀, p₀) of the Poincaré transformation to about 1e-30 relative
//! (issue 21): the transformed flow conserves K = g(H − E₀) at K₀ = g(q₀)(H(q₀, p₀) − E₀),
//! so an E₀ off by δ from the exact H(q₀, p₀) integrates H + δ·g(q₀)/g(q) in place of H, and
//! the orbit's mean motion is off by about δ/E. For an eccentric orbit H is a difference of
//! two large numbers (e = 0.99: ½|p|² ≈ 99.5 and μ/r = 100 for E = −½), so E₀ in plain f64 is
//! off by ~1e-14: measured, after 1 000 periods at e = 0.99 the phase lags 4e-10 (5.5e-9 at
//! pericentre), whatever Δs (benches/peers/eccentric.md). Here in double-double arithmetic
//! (error-free transformations: Dekker, Knuth; Hida, Li, Bailey's QD library), for the
//! Kepler and n-body models.

/// A double-double number hi + lo, |lo| ≤ ulp(hi)/2.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Dd {
    hi: f64,
    lo: f64,
}

fn two_sum(a: f64, b: f64) -> Dd {
    let s = a + b;
    let bb = s - a;
    Dd {
        hi: s,
        lo: (a - (s - bb)) + (b - bb),
    }
}

fn quick_two_sum(a: f64, b: f64) -> Dd {
    let s = a + b;
    Dd { hi: s, lo: b - (s - a) }
}

fn two_prod(a: f64, b: f64) -> Dd {
    let p = a * b;
    Dd {
        hi: p,
        lo: a.mul_add(b, -p),
    }
}

impl Dd {
    fn from(x: f64) -> Self {
        Self { hi: x, lo: 0.0 }
    }
    fn neg(self) -> Self {
        Self {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
    fn add(self, y: Self) -> Self {
        let s = two_sum(self.hi, y.hi);
        let t = two_sum(self.lo, y.lo);
        let s = quick_two_sum(s.hi, s.lo + t.hi);
        quick_two_sum(s.hi, s.lo + t.lo)
    }
    fn mul(self, y: Self) -> Self {
        let p = two_prod(self.hi, y.hi);
        quick_two_sum(p.hi, p.lo + (self.hi * y.lo + self.lo * y.hi))
    }
    fn div(self, y: Self) -> Self {
        let q1 = self.hi / y.hi;
        let r = self.add(y.mul(Dd::from(q1)).neg());
        let q2 = r.hi / y.hi;
        let r = r.add(y.mul(Dd::from(q2)).neg());
        let q3 = r.hi / y.hi;
        quick_two_sum(q1, q2).add(Dd::from(q3))
    }
    fn sqrt(self) -> Self {
        let s = self.hi.sqrt();
        if s == 0.0 || !s.is_finite() {
            return Dd::from(s);
        }
        let r = self.add(two_prod(s, s).neg());
        quick_two_sum(s, r.hi / (2.0 * s))
    }
}

/// H = ½|p|² − μ/|q| of the Kepler model ([`crate::models::kepler`]), rounded once.
///
/// ```
/// // q0 = 1/64, p0 = 11.25: H = 126.5625/2 − 64 = −0.71875 exactly.
/// assert_eq!(femvi::adaptive::kepler_energy(1.0, &[0.015625, 0.0], &[0.0, 11.25]), -0.71875);
/// ```
pub fn kepler_energy(mu: f64, q: &[f64], p: &[f64]) -> f64 {
    let r2 = q.iter().fold(Dd::from(0.0), |s, &x| s.add(two_prod(x, x)));
    let kinetic = p.iter().fold(Dd::from(0.0), |s, &x| s.add(two_prod(x, x)));
    let kinetic = Dd {
        hi: 0.5 * kinetic.hi,
        lo: 0.5 * kinetic.lo,
    };
    kinetic.add(Dd::from(mu).div(r2.sqrt()).neg()).hi
}

/// H = Σ|p_i|²/(2m_i) − G Σ_{i<j} m_i m_j / r_ij of the n-body model
/// ([`crate::models::n_body`]; coordinates body by body, `dim` per body), rounded once.
/// NaN if the lengths do not fit.
///
/// ```
/// // Two unit masses at distance 1/2 at rest: H = −2.
/// let h = femvi::adaptive::nbody_energy(1.0, &[1.0, 1.0], 1, &[0.0, 0.5], &[0.0, 0.0]);
/// assert_eq!(h, -2.0);
/// ```
pub fn nbody_energy(g: f64, masses: &[f64], dim: usize, q: &[f64], p: &[f64]) -> f64 {
    let n = masses.len() * dim;
    if dim == 0 || q.len() != n || p.len() != n {
        return f64::NAN;
    }
    let mut h = Dd::from(0.0);
    for (i, &mi) in masses.iter().enumerate() {
        let p2 = p[i * dim..(i + 1) * dim]
            .iter()
            .fold(Dd::from(0.0), |s, &x| s.add(two_prod(x, x)));
        h = h.add(p2.div(Dd::from(2.0 * mi)));
        for (j, &mj) in masses.iter().enumerate().skip(i + 1) {
            let mut r2 = Dd::from(0.0);
            for c in 0..dim {
                let dx = two_sum(q[i * dim + c], -q[j * dim + c]);
                r2 = r2.add(dx.mul(dx));
            }
            let gm = two_prod(g, mi).mul(Dd::from(mj));
            h = h.add(gm.div(r2.sqrt()).neg());
        }
    }
    h.hi
}
