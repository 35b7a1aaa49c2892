//! The forced harmonic oscillator, L = m/2 ẋ² − k/2 x² + f0 x cos(ω t), i.e.
//! m ẍ = −k x + f0 cos(ω t): the built-in system whose Lagrangian depends on time explicitly
//! (not autonomous: its energy is not conserved, and `femvi check` skips the time-reversal
//! test for it).

use super::finite;
use crate::error::Result;
use crate::lagrangian::{MassMatrix, Mechanical, Potential, Scalar};

/// V = k/2 x² − f0 x cos(ω t): the forced oscillator (time-dependent).
#[derive(Debug, Clone, Copy)]
pub struct ForcedPotential {
    /// Spring constant.
    pub k: f64,
    /// Forcing amplitude.
    pub f0: f64,
    /// Forcing frequency.
    pub omega: f64,
}

impl Potential for ForcedPotential {
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D {
        q[0] * q[0] * (0.5 * self.k) - q[0] * (t * self.omega).cos() * self.f0
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.k * q[0] + self.f0 * libm::cos(self.omega * t);
    }
}

/// The forced oscillator.
///
/// # Errors
/// A parameter that is not finite, or a mass that is not positive.
pub fn forced_oscillator(m: f64, k: f64, f0: f64, omega: f64) -> Result<Mechanical<ForcedPotential>> {
    finite("forced-oscillator", &[("m", m), ("k", k), ("f0", f0), ("omega", omega)])?;
    Mechanical::new(ForcedPotential { k, f0, omega }, MassMatrix::diagonal(vec![m])?)
}
