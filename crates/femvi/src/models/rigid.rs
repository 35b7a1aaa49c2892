//! Rigid bodies on the embedding of SO(3) ([`crate::rotation`]): the free body with principal
//! moments of inertia I₁, I₂, I₃ and the heavy top (a body on a fixed point at the origin, its
//! centre of mass at χ in the body frame, gravity g along −z), as Lagrangians of the nine
//! entries of R and Ṙ:
//!
//!   L̃(R, Ṙ) = ½ Σ_a I_a w_a² + ½ c |sym(RᵀṘ)|² − m g e₃·(R χ),   w = vee(skew(RᵀṘ)),
//!
//! with c = (I₁ + I₂ + I₃)/3. On T SO(3), RᵀṘ = ŵ is skew and L̃ is the body's L(R, w); the
//! symmetric part's term vanishes there with its first derivatives and only makes the
//! Hessian in Ṙ regular on R⁹.

use crate::error::{invalid, Result};
use crate::lagrangian::{Lagrangian, Scalar};

/// A free rigid body or a heavy top, on the nine entries of R (row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct RigidBody {
    inertia: [f64; 3],
    /// m g and χ of a heavy top.
    weight: f64,
    centre: [f64; 3],
}

impl RigidBody {
    /// A free rigid body with principal moments of inertia `inertia` (about the body axes).
    ///
    /// # Errors
    /// A moment that is not positive and finite.
    ///
    /// # Example
    /// ```
    /// use femvi::{models::RigidBody, Lagrangian};
    /// let body = RigidBody::free([1.0, 2.0, 3.0])?;
    /// let r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// // Spinning about the body z axis at rate 2: Ṙ = R ŵ, L = ½ I₃ w₃² = 6.
    /// let v = femvi::rotation::embedded_velocity(&r, &[0.0, 0.0, 2.0]);
    /// assert!((body.value(0.0, &r, &v) - 6.0).abs() < 1e-15);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn free(inertia: [f64; 3]) -> Result<Self> {
        Self::heavy_top(inertia, 0.0, 0.0, [0.0; 3])
    }

    /// A heavy top: mass `mass`, gravity `gravity` along −z, centre of mass at `centre` in the
    /// body frame, moments `inertia` about the fixed point.
    ///
    /// # Errors
    /// A moment that is not positive and finite, or another parameter that is not finite.
    ///
    /// # Example
    /// ```
    /// use femvi::{models::RigidBody, Lagrangian};
    /// let top = RigidBody::heavy_top([1.0, 2.0, 3.0], 1.0, 9.81, [0.0, 0.0, 0.5])?;
    /// let upright = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// // At rest upright the Lagrangian is −V = −m g χ₃.
    /// assert!((top.value(0.0, &upright, &[0.0f64; 9]) + 4.905).abs() < 1e-15);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn heavy_top(inertia: [f64; 3], mass: f64, gravity: f64, centre: [f64; 3]) -> Result<Self> {
        if !inertia.iter().all(|i| i.is_finite() && *i > 0.0) {
            return Err(invalid(
                "rigid body",
                format!("the moments of inertia {inertia:?} must be positive and finite"),
            ));
        }
        let weight = mass * gravity;
        if !(weight.is_finite() && centre.iter().all(|c| c.is_finite())) {
            return Err(invalid("rigid body", "mass, gravity and centre must be finite"));
        }
        Ok(Self {
            inertia,
            weight,
            centre,
        })
    }

    /// The principal moments of inertia.
    pub fn inertia(&self) -> [f64; 3] {
        self.inertia
    }
}

impl Lagrangian for RigidBody {
    fn dim(&self) -> usize {
        9
    }

    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        if q.len() != 9 || v.len() != 9 {
            return D::from(f64::NAN);
        }
        // A = RᵀṘ.
        let a: [D; 9] = std::array::from_fn(|k| {
            let (i, j) = (k / 3, k % 3);
            q[i] * v[j] + q[3 + i] * v[3 + j] + q[6 + i] * v[6 + j]
        });
        let w = [(a[7] - a[5]) * 0.5, (a[2] - a[6]) * 0.5, (a[3] - a[1]) * 0.5];
        let kinetic =
            (w[0] * w[0] * self.inertia[0] + w[1] * w[1] * self.inertia[1] + w[2] * w[2] * self.inertia[2]) * 0.5;
        let mut sym = D::from(0.0);
        for i in 0..3 {
            for j in 0..3 {
                let s = (a[3 * i + j] + a[3 * j + i]) * 0.5;
                sym += s * s;
            }
        }
        let c = (self.inertia[0] + self.inertia[1] + self.inertia[2]) / 3.0;
        let height = q[6] * self.centre[0] + q[7] * self.centre[1] + q[8] * self.centre[2];
        kinetic + sym * (0.5 * c) - height * self.weight
    }

    fn is_autonomous(&self) -> bool {
        true
    }

    fn rigid_body(&self) -> Option<([f64; 3], bool)> {
        Some((
            self.inertia,
            self.weight != 0.0 && self.centre.iter().any(|c| *c != 0.0),
        ))
    }

    /// ∂L̃/∂R at Ṙ = 0: −∂V/∂R, which is −m g χ_j in row 3 and zero elsewhere.
    fn force(&self, _t: f64, _q: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        for (o, c) in out.iter_mut().skip(6).zip(self.centre) {
            *o = -self.weight * c;
        }
    }
}
