//! What a run with rotations reports of each rotation at a node, in the body frame
//! ([`crate::Integrator::node_rotations`], [`body_states`]): the body angular momentum
//! Π = 2 vee(RᵀP) of the node's embedded momentum P = ½ R Π̂, and the body angular velocity
//! w = vee(RᵀṘ) of the velocity whose Legendre transform is P.

use super::layout::Rotations;
use super::so3::{mul_tn, vee, Mat3};
use crate::lagrangian::{velocity_from_momentum, Lagrangian, PointDerivatives};

/// A rotation's state at a node, in the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    /// The body angular velocity w (Ṙ = R ŵ), from the inverse Legendre transform of the
    /// node's momentum (NaN where it does not converge).
    pub w: [f64; 3],
    /// The body angular momentum Π = 2 vee(RᵀP).
    pub pi: [f64; 3],
}

/// The body angular momentum Π = 2 vee(RᵀP) of a block's embedded momentum P = ½ R Π̂.
pub(crate) fn body_momentum(r: &Mat3<f64>, p: &Mat3<f64>) -> [f64; 3] {
    let a: Mat3<f64> = std::array::from_fn(|k| {
        let (i, j) = (k / 3, k % 3);
        r[i] * p[j] + r[3 + i] * p[3 + j] + r[6 + i] * p[6 + j]
    });
    vee(&a).map(|v| 2.0 * v)
}

/// A block of nine entries as a matrix.
pub(crate) fn block(x: &[f64], o: usize) -> Mat3<f64> {
    std::array::from_fn(|k| x.get(o + k).copied().unwrap_or(f64::NAN))
}

/// The state of each rotation of `layout` at the node (t, q, p) of a run of `lag`: w from the
/// inverse Legendre transform of the whole node (NaN where it does not converge) and Π.
///
/// # Example
///
/// ```
/// use femvi::models::RigidBody;
/// use femvi::rotation::{body_states, Rotations};
/// let body = RigidBody::free([1.0, 2.0, 3.0])?;
/// let r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// // P = ½ R Π̂ with Π = (0, 0, 3): spinning about the third axis with w3 = 1.
/// let p = [0.0, -1.5, 0.0, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0];
/// let states = body_states(&body, &Rotations::new(9, &[0])?, 0.0, &r, &p);
/// assert!((states[0].w[2] - 1.0).abs() < 1e-12 && states[0].pi == [0.0, 0.0, 3.0]);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn body_states<L: Lagrangian>(lag: &L, layout: &Rotations, t: f64, q: &[f64], p: &[f64]) -> Vec<BodyState> {
    let n = layout.dim();
    let mut v = vec![0.0; n];
    let mut work = PointDerivatives::new(n);
    let solved = velocity_from_momentum(lag, t, q, p, &mut v, &mut work).is_ok();
    layout
        .offsets()
        .iter()
        .map(|&o| {
            let r = block(q, o);
            let w = if solved {
                vee(&mul_tn(&r, &block(&v, o)))
            } else {
                [f64::NAN; 3]
            };
            BodyState {
                w,
                pi: body_momentum(&r, &block(p, o)),
            }
        })
        .collect()
}
