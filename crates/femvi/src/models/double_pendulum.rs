//! The planar double pendulum: bobs of masses m1, m2 on massless rods l1, l2, angles θ1, θ2
//! from the downward vertical, gravity g:
//! L = ½(m1 + m2) l1² θ̇1² + ½ m2 l2² θ̇2² + m2 l1 l2 θ̇1 θ̇2 cos(θ1 − θ2)
//!     + (m1 + m2) g l1 cos θ1 + m2 g l2 cos θ2.
//! Its mass matrix depends on the configuration, so it is a general [`Lagrangian`] (no
//! `mass_matrix`, no hand-coded force): every derivative comes from automatic differentiation
//! of `value`.

use super::finite;
use crate::error::{invalid, Result};
use crate::lagrangian::{Lagrangian, Scalar};

/// The planar double pendulum, angles from the downward vertical.
#[derive(Debug, Clone, Copy)]
pub struct DoublePendulum {
    /// Mass of the first bob.
    pub m1: f64,
    /// Mass of the second bob.
    pub m2: f64,
    /// First rod.
    pub l1: f64,
    /// Second rod.
    pub l2: f64,
    /// Gravity.
    pub g: f64,
}

impl DoublePendulum {
    /// The double pendulum with masses m1, m2, rods l1, l2 and gravity g.
    ///
    /// # Errors
    /// A parameter that is not finite, or a mass or rod that is not positive (the kinetic
    /// energy would not be positive definite).
    pub fn new(m1: f64, m2: f64, l1: f64, l2: f64, g: f64) -> Result<Self> {
        finite(
            "double-pendulum",
            &[("m1", m1), ("m2", m2), ("l1", l1), ("l2", l2), ("g", g)],
        )?;
        if [m1, m2, l1, l2].iter().any(|&x| x <= 0.0) {
            return Err(invalid("double-pendulum", "masses and rods must be positive"));
        }
        // Finite parameters can still overflow in the products the Lagrangian uses.
        let products = [
            ("(m1 + m2) l1^2", (m1 + m2) * l1 * l1),
            ("m2 l2^2", m2 * l2 * l2),
            ("m2 l1 l2", m2 * l1 * l2),
            ("(m1 + m2) g l1", (m1 + m2) * g * l1),
            ("m2 g l2", m2 * g * l2),
        ];
        finite("double-pendulum", &products)?;
        Ok(Self { m1, m2, l1, l2, g })
    }
}

impl Lagrangian for DoublePendulum {
    fn dim(&self) -> usize {
        2
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let (m1, m2, l1, l2, g) = (self.m1, self.m2, self.l1, self.l2, self.g);
        let kin = v[0] * v[0] * (0.5 * (m1 + m2) * l1 * l1)
            + v[1] * v[1] * (0.5 * m2 * l2 * l2)
            + v[0] * v[1] * (q[0] - q[1]).cos() * (m2 * l1 * l2);
        let pot = -q[0].cos() * ((m1 + m2) * g * l1) - q[1].cos() * (m2 * g * l2);
        kin - pot
    }
}
