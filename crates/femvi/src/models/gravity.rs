//! The gravitational n-body problem in the plane or in space (dim = 2 or 3):
//! L = Σ_i m_i |v_i|²/2 + G Σ_{i<j} m_i m_j / |x_i − x_j|, so that
//! m_i ẍ_i = G Σ_{j≠i} m_i m_j (x_j − x_i) / |x_j − x_i|³. The mass matrix is diagonal, each
//! body's mass repeated over its coordinates x_i = (q_{i·dim}, …). The outer solar system
//! (Hairer, Lubich and Wanner, Geometric Numerical Integration, Sect. I.2.4) is the instance
//! with the data of `models::outer_solar_system`.

use super::finite;
use crate::error::{invalid, Result};
use crate::lagrangian::{MassMatrix, Mechanical, Potential, Scalar};

/// V = −G Σ_{i<j} m_i m_j / |x_i − x_j| for bodies in `dim` dimensions.
#[derive(Debug, Clone)]
pub struct GravityPotential {
    /// Gravitational constant.
    pub g: f64,
    /// Masses.
    pub masses: Vec<f64>,
    /// 1, 2 or 3 ([`n_body`] checks it; with another value the force is NaN).
    pub dim: usize,
}

impl Potential for GravityPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        self.masses.len() * self.dim
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (nb, d) = (self.masses.len(), self.dim);
        let mut v = D::from(0.0);
        for i in 0..nb {
            for j in i + 1..nb {
                let mut r2 = D::from(0.0);
                for c in 0..d {
                    let x = q[i * d + c] - q[j * d + c];
                    r2 += x * x;
                }
                v -= r2.sqrt().recip() * (self.g * self.masses[i] * self.masses[j]);
            }
        }
        v
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let (nb, d) = (self.masses.len(), self.dim);
        if !(1..=3).contains(&d) {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        out.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..nb {
            for j in i + 1..nb {
                let mut dx = [0.0; 3];
                let mut r2 = 0.0;
                for c in 0..d {
                    dx[c] = q[j * d + c] - q[i * d + c];
                    r2 += dx[c] * dx[c];
                }
                let k = self.g * self.masses[i] * self.masses[j] / (r2 * r2.sqrt());
                for c in 0..d {
                    out[i * d + c] += k * dx[c];
                    out[j * d + c] -= k * dx[c];
                }
            }
        }
    }

    /// By hand, O(pairs) as the force: with A of [`Potential::force_jacobian`] below, the
    /// pair adds A·(dx_j − dx_i) = k δ − 3k d (d·δ)/r² to body i and subtracts it from j.
    fn force_derivative(&self, _t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        let (nb, d) = (self.masses.len(), self.dim);
        if !(1..=3).contains(&d) || q.len() != nb * d || dq.len() != q.len() {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        out.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..nb {
            for j in i + 1..nb {
                let (mut dx, mut dd) = ([0.0; 3], [0.0; 3]);
                let (mut r2, mut dot) = (0.0, 0.0);
                for c in 0..d {
                    dx[c] = q[j * d + c] - q[i * d + c];
                    dd[c] = dq[j * d + c] - dq[i * d + c];
                    r2 += dx[c] * dx[c];
                    dot += dx[c] * dd[c];
                }
                let k = self.g * self.masses[i] * self.masses[j] / (r2 * r2.sqrt());
                let k5 = 3.0 * k / r2 * dot;
                for c in 0..d {
                    let e = k * dd[c] - k5 * dx[c];
                    out[i * d + c] += e;
                    out[j * d + c] -= e;
                }
            }
        }
    }

    /// Each pair's d = x_j − x_i, k = G m_i m_j r⁻³ and 3k/r² (dim + 2 numbers, the pairs in
    /// the order of the loops), computed as [`Potential::force_derivative`] computes them.
    fn prepare_force_derivative(&self, _t: f64, q: &[f64], cache: &mut Vec<f64>) -> bool {
        let (nb, d) = (self.masses.len(), self.dim);
        if !(1..=3).contains(&d) || q.len() != nb * d {
            return false;
        }
        cache.clear();
        for i in 0..nb {
            for j in i + 1..nb {
                let mut r2 = 0.0;
                for c in 0..d {
                    let x = q[j * d + c] - q[i * d + c];
                    r2 += x * x;
                    cache.push(x);
                }
                let k = self.g * self.masses[i] * self.masses[j] / (r2 * r2.sqrt());
                cache.push(k);
                cache.push(3.0 * k / r2);
            }
        }
        true
    }

    /// [`Potential::force_derivative`]'s operations on the prepared pairs: no square root, no
    /// division.
    fn prepared_force_derivative(&self, cache: &[f64], dq: &[f64], out: &mut [f64]) {
        let (nb, d) = (self.masses.len(), self.dim);
        let pairs = nb * nb.saturating_sub(1) / 2;
        if !(1..=3).contains(&d) || dq.len() != nb * d || out.len() != dq.len() || cache.len() != pairs * (d + 2) {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        out.iter_mut().for_each(|x| *x = 0.0);
        match d {
            1 => prepared_pairs::<1>(nb, cache, dq, out),
            2 => prepared_pairs::<2>(nb, cache, dq, out),
            _ => prepared_pairs::<3>(nb, cache, dq, out),
        }
    }

    /// By hand (the hyper-dual default took half of a Pleiades step of the adaptive Newton
    /// solve): the pair force k·d on body i, d = x_j − x_i, k = G m_i m_j r⁻³, has
    /// A = ∂(k d)/∂d = G m_i m_j (I r⁻³ − 3 d dᵀ r⁻⁵), so J_ii, J_jj −= A and J_ij, J_ji += A.
    fn force_jacobian(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let (nb, d) = (self.masses.len(), self.dim);
        let n = nb * d;
        if !(1..=3).contains(&d) || q.len() != n || out.len() != n * n {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        out.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..nb {
            for j in i + 1..nb {
                let mut dx = [0.0; 3];
                let mut r2 = 0.0;
                for c in 0..d {
                    dx[c] = q[j * d + c] - q[i * d + c];
                    r2 += dx[c] * dx[c];
                }
                let k = self.g * self.masses[i] * self.masses[j] / (r2 * r2.sqrt());
                let k5 = 3.0 * k / r2;
                for a in 0..d {
                    for b in 0..d {
                        let eye = if a == b { k } else { 0.0 };
                        let entry = eye - k5 * dx[a] * dx[b];
                        let (ia, ja, ib, jb) = (i * d + a, j * d + a, i * d + b, j * d + b);
                        out[ia * n + ib] -= entry;
                        out[ja * n + jb] -= entry;
                        out[ia * n + jb] += entry;
                        out[ja * n + ib] += entry;
                    }
                }
            }
        }
    }
}

/// The gravitational n-body problem of the bodies with `masses` in `dim` = 1, 2 or 3
/// dimensions (O(n) memory: the mass matrix is stored by its diagonal).
///
/// # Errors
/// A dimension other than 1, 2 or 3, no body, G (or G m_i m_j) not finite, or a mass that is
/// not positive and finite.
pub fn n_body(g: f64, masses: Vec<f64>, dim: usize) -> Result<Mechanical<GravityPotential>> {
    if !(1..=3).contains(&dim) {
        return Err(invalid(
            "n-body",
            format!("dim = {dim}: the bodies move in 1, 2 or 3 dimensions"),
        ));
    }
    if masses.is_empty() {
        return Err(invalid("n-body", "there is no body"));
    }
    finite("n-body", &[("G", g)])?;
    // Finite parameters can still overflow in G m_i m_j.
    let heaviest = masses.iter().fold(0.0f64, |a, m| a.max(m.abs()));
    finite(
        "n-body",
        &[("G m_i m_j of the heaviest bodies", g * heaviest * heaviest)],
    )?;
    let diag: Vec<f64> = masses.iter().flat_map(|m| std::iter::repeat_n(*m, dim)).collect();
    Mechanical::new(GravityPotential { g, masses, dim }, MassMatrix::diagonal(diag)?)
}

/// The outer solar system (Sun and five outer planets), 3-D.
pub fn outer_solar_system() -> Mechanical<GravityPotential> {
    n_body(
        super::outer_solar_system::G,
        super::outer_solar_system::MASSES.to_vec(),
        3,
    )
    .unwrap_or_else(|_| unreachable!("the masses are positive"))
}

/// The pairs' products of [`GravityPotential::prepared_force_derivative`] in `D`
/// dimensions (a compile-time constant, so that the coordinate loops unroll), added to `out`.
fn prepared_pairs<const D: usize>(nb: usize, cache: &[f64], dq: &[f64], out: &mut [f64]) {
    let mut prepared = cache.chunks_exact(D + 2);
    for i in 0..nb {
        for j in i + 1..nb {
            let Some(pair) = prepared.next() else {
                return;
            };
            let (dx, kr) = pair.split_at(D);
            let (k, k3) = (kr[0], kr[1]);
            let (xi, xj) = (&dq[i * D..(i + 1) * D], &dq[j * D..(j + 1) * D]);
            let (mut dd, mut dot) = ([0.0; D], 0.0);
            for c in 0..D {
                dd[c] = xj[c] - xi[c];
                dot += dx[c] * dd[c];
            }
            let k5 = k3 * dot;
            for c in 0..D {
                let e = k * dd[c] - k5 * dx[c];
                out[i * D + c] += e;
                out[j * D + c] -= e;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    // The module of data and the function of the same name, both.
    use crate::models::outer_solar_system;

    #[test]
    fn outer_solar_system_energy_matches_the_data() {
        // H0 = Σ|p|²/(2m) − G Σ m_i m_j / r_ij from ../shared/problems (an independent sum).
        let sys = outer_solar_system();
        let q: Vec<f64> = outer_solar_system::X0.iter().flatten().cloned().collect();
        let v: Vec<f64> = outer_solar_system::V0.iter().flatten().cloned().collect();
        let mut h = 0.0;
        for b in 0..6 {
            let m = outer_solar_system::MASSES[b];
            h += 0.5 * m * (0..3).map(|c| v[b * 3 + c].powi(2)).sum::<f64>();
        }
        h += sys.potential.value(0.0, &q);
        assert!((h - (-3.2154531832081636e-08)).abs() < 1e-20, "{h:e}");
    }

    #[test]
    fn prepared_products_have_the_bits_of_force_derivative() {
        // Pseudo-random states in 1, 2 and 3 dimensions, several products per prepared point.
        let mut uniform = crate::testing::uniform(0x2545_f491_4f6c_dd1d);
        let mut rand = || uniform() - 0.5;
        for dim in 1..=3 {
            let bodies = n_body(1.3, vec![1.0, 1e-3, 3e-4, 2e-2], dim).unwrap();
            let n = 4 * dim;
            let mut cache = Vec::new();
            for _ in 0..20 {
                let q: Vec<f64> = (0..n).map(|_| 3.0 * rand()).collect();
                assert!(bodies.potential.prepare_force_derivative(0.0, &q, &mut cache));
                for _ in 0..5 {
                    let dq: Vec<f64> = (0..n).map(|_| rand()).collect();
                    let (mut once, mut prepared) = (vec![0.0; n], vec![0.0; n]);
                    bodies.potential.force_derivative(0.0, &q, &dq, &mut once);
                    bodies.potential.prepared_force_derivative(&cache, &dq, &mut prepared);
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&once), bits(&prepared), "dim {dim}");
                }
            }
            // A cache of another length, or a vector of another length: NaN, no panic.
            let mut out = vec![0.0; n];
            bodies
                .potential
                .prepared_force_derivative(&cache[1..], &vec![0.0; n], &mut out);
            assert!(out.iter().all(|x| x.is_nan()));
            bodies
                .potential
                .prepared_force_derivative(&cache, &vec![0.0; n + 1], &mut out);
            assert!(out.iter().all(|x| x.is_nan()));
            assert!(!bodies
                .potential
                .prepare_force_derivative(0.0, &vec![0.0; n + 1], &mut cache));
        }
    }
}
