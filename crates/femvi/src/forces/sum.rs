//! The sum of two forces (e.g. a Rayleigh dissipation and a drive given per coordinate).

use super::Force;
use crate::lagrangian::Scalar;

/// F = A + B (A's dimension).
///
/// ```
/// use femvi::forces::{Force, LinearForce, Sum};
/// let f = Sum(LinearForce::damping(1, 0.5), LinearForce::drive(vec![1.0], 0.0));
/// let mut out = [0.0];
/// f.force(0.0, &[0.0], &[2.0], &mut out);
/// assert_eq!(out, [0.0]); // −0.5·2 + 1·cos(0)
/// ```
#[derive(Debug, Clone)]
pub struct Sum<A, B>(pub A, pub B);

impl<A: Force, B: Force> Force for Sum<A, B> {
    fn dim(&self) -> usize {
        self.0.dim()
    }

    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], out: &mut [D]) {
        self.0.force(t, q, v, out);
        let mut other = vec![D::from(0.0); out.len()];
        self.1.force(t, q, v, &mut other);
        for (o, b) in out.iter_mut().zip(other) {
            *o += b;
        }
    }

    fn depends_on_velocity(&self) -> bool {
        self.0.depends_on_velocity() || self.1.depends_on_velocity()
    }
}
