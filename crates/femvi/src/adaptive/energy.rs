//! The energy level E₀ = H(q₀, p₀) of the Poincaré transformation to about 1e-30 relative
//! (issue 21): the transformed flow conserves K = g(H − E₀) at K₀ = g(q₀)(H(q₀, p₀) − E₀),
//! so an E₀ off by δ from the exact H(q₀, p₀) integrates H + δ·g(q₀)/g(q) in place of H, and
//! the orbit's mean motion is off by about δ/E. For an eccentric orbit H is a difference of
//! two large numbers (e = 0.99: ½|p|² ≈ 99.5 and μ/r = 100 for E = −½), so E₀ in plain f64 is
//! off by ~1e-14: measured, after 1 000 periods at e = 0.99 the phase lags 4e-10 (5.5e-9 at
//! pericentre), whatever Δs (benches/peers/eccentric.md). Here in double-double arithmetic
//! (error-free transformations: Dekker, Knuth; Hida, Li, Bailey's QD library), for the
//! Kepler and n-body models.

use crate::fem::dd::Dd;

/// Σ x_i² in double-double.
fn norm2(x: &[f64]) -> Dd {
    x.iter().fold(Dd::new(0.0), |s, &v| s.add(Dd::two_prod(v, v)))
}

/// H = ½|p|² − μ/|q| of the Kepler model ([`crate::models::kepler`]), rounded once.
///
/// ```
/// // q0 = 1/64, p0 = 11.25: H = 126.5625/2 − 64 = −0.71875 exactly.
/// assert_eq!(femvi::adaptive::kepler_energy(1.0, &[0.015625, 0.0], &[0.0, 11.25]), -0.71875);
/// ```
pub fn kepler_energy(mu: f64, q: &[f64], p: &[f64]) -> f64 {
    let (r2, kinetic) = (norm2(q), norm2(p));
    let kinetic = Dd {
        hi: 0.5 * kinetic.hi,
        lo: 0.5 * kinetic.lo,
    };
    kinetic.add(Dd::new(mu).div(r2.sqrt()).neg()).hi
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
    let mut h = Dd::new(0.0);
    for (i, &mi) in masses.iter().enumerate() {
        let p2 = norm2(&p[i * dim..(i + 1) * dim]);
        h = h.add(p2.div(Dd::new(2.0 * mi)));
        for (j, &mj) in masses.iter().enumerate().skip(i + 1) {
            let mut r2 = Dd::new(0.0);
            for c in 0..dim {
                let dx = Dd::two_sum(q[i * dim + c], -q[j * dim + c]);
                r2 = r2.add(dx.mul(dx));
            }
            let gm = Dd::two_prod(g, mi).mul(Dd::new(mj));
            h = h.add(gm.div(r2.sqrt()).neg());
        }
    }
    h.hi
}
