//! The small classical systems, each L = ½vᵀMv − V(q) with a constant mass matrix and a
//! hand-coded force −∇V (the potential's `value`, generic over [`Scalar`], gives the other
//! derivatives by automatic differentiation):
//!
//! - the harmonic oscillator, L = m/2 ẋ² − k/2 x² (closed form in
//!   [`diagnostics::exact::harmonic`](crate::diagnostics::exact::harmonic));
//! - the pendulum, L = m l²/2 θ̇² + m g l cos θ (mass m l², V = −m g l cos θ);
//! - Kepler's problem in the plane, L = |v|²/2 + μ/|q| (Hairer, Lubich and Wanner, Geometric
//!   Numerical Integration, Sect. I.2; closed form by Kepler's equation in
//!   [`diagnostics::exact::kepler`](crate::diagnostics::exact::kepler));
//! - the Hénon–Heiles system, L = |v|²/2 − (x² + y²)/2 − x²y + y³/3 (Hénon and Heiles,
//!   Astron. J. 69, 1964).

use super::finite;
use crate::error::Result;
use crate::lagrangian::{Lanes, MassMatrix, Mechanical, Potential, Scalar, LANES};

/// V = k/2 x².
#[derive(Debug, Clone, Copy)]
pub struct HarmonicPotential {
    /// Spring constant k.
    pub k: f64,
}

impl Potential for HarmonicPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0] * q[0] * (0.5 * self.k)
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.k * q[0];
    }
    fn force_derivative(&self, _t: f64, _q: &[f64], dq: &[f64], out: &mut [f64]) {
        out[0] = -self.k * dq[0];
    }
}

/// V = −m g l cos θ.
///
/// The hand-coded force takes its sine from the `libm` crate (musl's algorithm, under 1 ulp)
/// rather than `f64::sin` (the platform's libm: glibc's on Linux): on P3 the force is most of
/// the work, and glibc's sine took 8.4 ns a call against 4.1 ns for `libm::sin` in a loop of
/// eight independent arguments in [−1.7, 1.7] (P3's range), the two differing by at most 1 ulp
/// (in 2.8 % of 10⁶ arguments). The AD paths ([`Potential::value`]) keep `f64::sin`/`cos`.
/// [`Potential::forces`] is written out as one loop over the points rather than the default
/// call of `force` per point, which the compiler did not inline: P3 with degree 10 at
/// h = 1.5, 13 100 → 11 700 instructions per step (cachegrind), results unchanged.
#[derive(Debug, Clone, Copy)]
pub struct PendulumPotential {
    /// m g l.
    pub mgl: f64,
}

impl Potential for PendulumPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].cos() * self.mgl
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.mgl * libm::sin(q[0]);
    }
    fn forces(&self, _t: &[f64], q: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(q) {
            *o = -self.mgl * libm::sin(x);
        }
    }
    fn force_jacobian(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.mgl * libm::cos(q[0]);
    }
    fn force_derivative(&self, _t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        out[0] = -self.mgl * libm::cos(q[0]) * dq[0];
    }
}

/// V = −μ/|q| in the plane.
#[derive(Debug, Clone, Copy)]
pub struct KeplerPotential {
    /// Gravitational parameter μ.
    pub mu: f64,
}

impl KeplerPotential {
    /// The potential with gravitational parameter μ.
    ///
    /// # Errors
    /// μ not finite.
    pub fn new(mu: f64) -> Result<Self> {
        finite("kepler", &[("mu", mu)])?;
        Ok(Self { mu })
    }
}

impl Potential for KeplerPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        2
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -(q[0] * q[0] + q[1] * q[1]).sqrt().recip() * self.mu
    }
    #[inline]
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let r2 = q[0] * q[0] + q[1] * q[1];
        let k = -self.mu / (r2 * r2.sqrt());
        out[0] = k * q[0];
        out[1] = k * q[1];
    }
    /// The scalar force's operations on every lane (the same bits), in vector registers.
    #[inline]
    fn force_lanes(&self, _t: f64, q: &[Lanes], out: &mut [Lanes]) {
        let ([x, y], [fx, fy]) = (q, out) else { return };
        for l in 0..LANES {
            let r2 = x[l] * x[l] + y[l] * y[l];
            let k = -self.mu / (r2 * r2.sqrt());
            fx[l] = k * x[l];
            fy[l] = k * y[l];
        }
    }
    /// −μ/r lane by lane, as `value` forms it.
    #[inline]
    fn value_lanes(&self, _t: f64, q: &[Lanes]) -> Lanes {
        let mut v = [f64::NAN; LANES];
        if let [x, y] = q {
            for l in 0..LANES {
                v[l] = -(1.0 / (x[l] * x[l] + y[l] * y[l]).sqrt()) * self.mu;
            }
        }
        v
    }
    fn force_jacobian(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        // f = −μ q / r³: ∂f_i/∂q_j = −μ (δ_ij − 3 q_i q_j / r²) / r³.
        let r2 = q[0] * q[0] + q[1] * q[1];
        let k = -self.mu / (r2 * r2.sqrt());
        let c = -3.0 / r2;
        out[0] = k * (1.0 + c * q[0] * q[0]);
        out[1] = k * c * q[0] * q[1];
        out[2] = out[1];
        out[3] = k * (1.0 + c * q[1] * q[1]);
    }
    fn force_derivative(&self, _t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        // −μ (dq − 3 q (q·dq)/r²) / r³.
        let r2 = q[0] * q[0] + q[1] * q[1];
        let k = -self.mu / (r2 * r2.sqrt());
        let c = -3.0 * (q[0] * dq[0] + q[1] * dq[1]) / r2;
        out[0] = k * (dq[0] + c * q[0]);
        out[1] = k * (dq[1] + c * q[1]);
    }
}

/// V = (x² + y²)/2 + x²y − y³/3.
#[derive(Debug, Clone, Copy)]
pub struct HenonHeilesPotential;

impl Potential for HenonHeilesPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        2
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (x, y) = (q[0], q[1]);
        (x * x + y * y) * 0.5 + x * x * y - y * y * y * (1.0 / 3.0)
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let (x, y) = (q[0], q[1]);
        out[0] = -(x + 2.0 * x * y);
        out[1] = -(y + x * x - y * y);
    }
    #[inline]
    fn force_lanes(&self, _t: f64, q: &[Lanes], out: &mut [Lanes]) {
        let ([x, y], [fx, fy]) = (q, out) else { return };
        for l in 0..LANES {
            let (x, y) = (x[l], y[l]);
            fx[l] = -(x + 2.0 * x * y);
            fy[l] = -(y + x * x - y * y);
        }
    }
    #[inline]
    fn value_lanes(&self, _t: f64, q: &[Lanes]) -> Lanes {
        let mut v = [f64::NAN; LANES];
        if let [x, y] = q {
            for l in 0..LANES {
                let (x, y) = (x[l], y[l]);
                v[l] = (x * x + y * y) * 0.5 + x * x * y - y * y * y * (1.0 / 3.0);
            }
        }
        v
    }
    fn force_jacobian(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let (x, y) = (q[0], q[1]);
        out[0] = -(1.0 + 2.0 * y);
        out[1] = -2.0 * x;
        out[2] = -2.0 * x;
        out[3] = -(1.0 - 2.0 * y);
    }
    fn force_derivative(&self, _t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        let (x, y) = (q[0], q[1]);
        out[0] = -(1.0 + 2.0 * y) * dq[0] - 2.0 * x * dq[1];
        out[1] = -2.0 * x * dq[0] - (1.0 - 2.0 * y) * dq[1];
    }
}

/// The harmonic oscillator with mass m and spring constant k.
///
/// # Errors
/// A parameter that is not finite, or a mass that is not positive.
pub fn harmonic(m: f64, k: f64) -> Result<Mechanical<HarmonicPotential>> {
    finite("harmonic", &[("m", m), ("k", k)])?;
    Mechanical::new(HarmonicPotential { k }, MassMatrix::diagonal(vec![m])?)
}

/// The pendulum with mass m, gravity g and length l.
///
/// # Errors
/// A parameter (or m g l, m l²) that is not finite, or m l² not positive.
pub fn pendulum(m: f64, g: f64, l: f64) -> Result<Mechanical<PendulumPotential>> {
    finite("pendulum", &[("m", m), ("g", g), ("l", l)])?;
    // Finite parameters can still overflow in the products the system uses.
    finite("pendulum", &[("m g l", m * g * l), ("m l^2", m * l * l)])?;
    Mechanical::new(
        PendulumPotential { mgl: m * g * l },
        MassMatrix::diagonal(vec![m * l * l])?,
    )
}

/// Kepler's problem with gravitational parameter μ, unit mass.
///
/// # Errors
/// μ not finite ([`crate::Error::Invalid`]).
///
/// # Example
///
/// ```
/// use femvi::models::kepler;
/// assert!(kepler(1.0).is_ok());
/// assert!(kepler(f64::NAN).is_err() && kepler(f64::INFINITY).is_err());
/// ```
pub fn kepler(mu: f64) -> Result<Mechanical<KeplerPotential>> {
    Ok(Mechanical::unit_mass(KeplerPotential::new(mu)?))
}

/// Hénon–Heiles, unit masses.
pub fn henon_heiles() -> Mechanical<HenonHeilesPotential> {
    Mechanical::unit_mass(HenonHeilesPotential)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lagrangian::Lagrangian;

    /// The pendulum's force uses `libm`'s sine and cosine: within 1 ulp of the platform's
    /// (an independent implementation, also under 1 ulp) for small, medium and huge angles.
    #[test]
    fn pendulum_trigonometry_agrees_with_the_platform_to_one_ulp() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let p = PendulumPotential { mgl: 1.0 };
        let (mut f, mut j) = ([0.0], [0.0]);
        let mut worst = 0;
        let mut differ = 0;
        let huge = [1e6, -3.5e9, 1e15, 2.0f64.powi(60), 1e300, f64::MAX];
        for x in (0..200_001).map(|i| -10.0 + 1e-4 * i as f64).chain(huge) {
            p.force(0.0, &[x], &mut f);
            p.force_jacobian(0.0, &[x], &mut j);
            let (ds, dc) = (ulps(-f[0], x.sin()), ulps(-j[0], x.cos()));
            worst = worst.max(ds).max(dc);
            differ += usize::from(ds + dc > 0);
        }
        assert!(worst <= 1, "{worst} ulps");
        // Two implementations, not one: they do differ somewhere.
        assert!(differ > 0);
    }

    /// `forces` (several points at once; the pendulum overrides it, the others take the
    /// per-point default) gives what `force` gives point by point, bit for bit, also through
    /// the `Lagrangian` of a `Mechanical` system with a non-unit mass.
    #[test]
    fn forces_at_several_points_are_the_force_at_each() {
        fn check<L: Lagrangian>(lag: &L, n: usize) {
            let k = 7;
            let t: Vec<f64> = (0..k).map(|i| 0.3 * i as f64).collect();
            let q: Vec<f64> = (0..k * n).map(|i| -2.0 + 0.61 * i as f64).collect();
            let mut all = vec![f64::NAN; k * n];
            lag.forces(&t, &q, &mut all);
            for i in 0..k {
                let mut one = vec![f64::NAN; n];
                lag.force(t[i], &q[i * n..(i + 1) * n], &mut one);
                assert_eq!(&all[i * n..(i + 1) * n], &one[..], "point {i}");
            }
        }
        check(&pendulum(2.0, 9.81, 0.5).unwrap(), 1);
        check(&Mechanical::unit_mass(PendulumPotential { mgl: 1.0 }), 1);
        check(&kepler(1.0).unwrap(), 2);
        check(&henon_heiles(), 2);
    }
}
