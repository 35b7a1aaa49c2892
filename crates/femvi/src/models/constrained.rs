//! Constrained systems in Cartesian coordinates (for [`crate::constraints`]): N point masses
//! in the plane or in space under uniform gravity along the last axis, L = Σ ½ m|v_i|² − m g z_i
//! ([`UniformGravity`] with [`Mechanical`]), linked by rigid massless rods into a chain hanging
//! from a pivot at the origin ([`Chain`]: |q_1|² = l², |q_i − q_{i−1}|² = l²). One particle in
//! space is the spherical pendulum, two in the plane the planar double pendulum in Cartesian
//! coordinates (Hairer, Lubich, Wanner, Geometric Numerical Integration, VII.1).

use crate::constraints::Constraints;
use crate::error::{invalid, Result};
use crate::lagrangian::{MassMatrix, Mechanical, Potential, Scalar};

/// V = m g Σ_i z_i, z_i the last coordinate of particle i (d coordinates per particle).
#[derive(Debug, Clone, Copy)]
pub struct UniformGravity {
    /// Coordinates per particle (2 or 3).
    pub d: usize,
    /// Number of particles.
    pub particles: usize,
    /// m g.
    pub mg: f64,
}

impl Potential for UniformGravity {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        self.d * self.particles
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let mut v = D::from(0.0);
        for i in 0..self.particles {
            v += q[i * self.d + self.d - 1];
        }
        v * self.mg
    }
    fn force(&self, _t: f64, _q: &[f64], out: &mut [f64]) {
        for (c, o) in out.iter_mut().enumerate() {
            *o = if c % self.d == self.d - 1 { -self.mg } else { 0.0 };
        }
    }
}

/// A chain of rigid rods of length l from a pivot at the origin: g_1 = |q_1|² − l²,
/// g_i = |q_i − q_{i−1}|² − l².
#[derive(Debug, Clone, Copy)]
pub struct Chain {
    /// Coordinates per particle (2 or 3).
    pub d: usize,
    /// Number of particles.
    pub particles: usize,
    /// Rod length l.
    pub l: f64,
}

impl Constraints for Chain {
    fn dim(&self) -> usize {
        self.d * self.particles
    }
    fn count(&self) -> usize {
        self.particles
    }
    fn value<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        let d = self.d;
        for i in 0..self.particles {
            let mut s = D::from(-self.l * self.l);
            for c in 0..d {
                let prev = if i == 0 { D::from(0.0) } else { q[(i - 1) * d + c] };
                let e = q[i * d + c] - prev;
                s += e * e;
            }
            out[i] = s;
        }
    }
}

/// N particles of mass m in d = 2 or 3 dimensions under gravity g, on a chain of rods of
/// length l (the Lagrangian and the constraints).
///
/// # Errors
/// d not 2 or 3, no particles, or non-positive or non-finite m, g < 0, l.
///
/// # Example
///
/// ```
/// use femvi::constraints::Constraints;
/// use femvi::Lagrangian;
/// // The spherical pendulum: one particle in space.
/// let (lag, rods) = femvi::models::chain(3, 1, 1.0, 9.81, 2.0)?;
/// assert_eq!((lag.dim(), rods.count()), (3, 1));
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn chain(d: usize, particles: usize, m: f64, g: f64, l: f64) -> Result<(Mechanical<UniformGravity>, Chain)> {
    if !(d == 2 || d == 3) || particles == 0 {
        return Err(invalid(
            "chain",
            format!("needs 2 or 3 dimensions and at least one particle, got d = {d}, {particles} particles"),
        ));
    }
    if !(m > 0.0 && m.is_finite() && g >= 0.0 && g.is_finite() && l > 0.0 && l.is_finite()) {
        return Err(invalid(
            "chain",
            format!("needs m > 0, g >= 0, l > 0 finite, got m = {m}, g = {g}, l = {l}"),
        ));
    }
    let gravity = UniformGravity {
        d,
        particles,
        mg: m * g,
    };
    let lag = Mechanical::new(gravity, MassMatrix::diagonal(vec![m; d * particles])?)?;
    Ok((lag, Chain { d, particles, l }))
}
