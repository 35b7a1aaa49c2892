//! Relativistic Kepler, L = −c²√(1 − |v|²/c²) + μ/|q| in the plane: a Lagrangian that depends
//! on the velocities beyond a quadratic form (no constant mass matrix), so it takes the
//! general path (Newton on the element equations, with derivatives by automatic
//! differentiation). It is written through [`Lagrangian::value`] alone, as a user's Rust
//! Lagrangian would be; the benchmarks of that path (`benches/general.rs`) and its tests use it.
//! As c → ∞ it tends to the Kepler problem ½|v|² + μ/|q| (up to the constant −c²).

use crate::lagrangian::{Lagrangian, Scalar};

/// The relativistic Kepler Lagrangian with speed of light `c` and μ = 1.
///
/// # Example
///
/// ```
/// use femvi::models::RelativisticKepler;
/// use femvi::Lagrangian;
///
/// let lag = RelativisticKepler { c: 10.0 };
/// // At rest at distance 2: L = −c² + 1/2.
/// let l: f64 = lag.value(0.0, &[2.0, 0.0], &[0.0, 0.0]);
/// assert!((l - (-100.0 + 0.5)).abs() < 1e-12);
/// assert!(lag.mass_matrix().is_none());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelativisticKepler {
    /// The speed of light (> |v| along the motion).
    pub c: f64,
}

impl Lagrangian for RelativisticKepler {
    fn dim(&self) -> usize {
        2
    }

    fn is_autonomous(&self) -> bool {
        true
    }

    #[inline]
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let (Some(&[q0, q1]), Some(&[v0, v1])) = (q.first_chunk::<2>(), v.first_chunk::<2>()) else {
            return D::from(f64::NAN);
        };
        let c2 = self.c * self.c;
        let w = (v0 * v0 + v1 * v1) * (-1.0 / c2) + 1.0;
        -(w.sqrt() * c2) + (q0 * q0 + q1 * q1).sqrt().recip()
    }
}
