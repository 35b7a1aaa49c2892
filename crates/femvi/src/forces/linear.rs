//! A force linear in the velocity plus a harmonic drive, F = −c v + f cos(ω t): the damped
//! and driven oscillators of the models and tests, without expressions.

use super::Force;
use crate::lagrangian::Scalar;

/// F_c(t, q, v) = −damping·v_c + amplitude_c·cos(ω t).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearForce {
    /// The damping coefficient c (≥ 0 dissipates).
    pub damping: f64,
    /// The drive amplitudes, one per coordinate.
    pub amplitude: Vec<f64>,
    /// The drive's angular frequency ω.
    pub omega: f64,
}

impl LinearForce {
    /// Linear damping −c v in dimension n.
    ///
    /// ```
    /// use femvi::forces::{Force, LinearForce};
    /// let mut f = [0.0; 2];
    /// LinearForce::damping(2, 0.1).force(0.0, &[0.0, 0.0], &[1.0, -2.0], &mut f);
    /// assert_eq!(f, [-0.1, 0.2]);
    /// ```
    pub fn damping(n: usize, c: f64) -> Self {
        Self {
            damping: c,
            amplitude: vec![0.0; n],
            omega: 0.0,
        }
    }

    /// The drive f cos(ω t) alone.
    pub fn drive(amplitude: Vec<f64>, omega: f64) -> Self {
        Self {
            damping: 0.0,
            amplitude,
            omega,
        }
    }
}

impl Force for LinearForce {
    fn dim(&self) -> usize {
        self.amplitude.len()
    }

    fn force<D: Scalar>(&self, t: D, _q: &[D], v: &[D], out: &mut [D]) {
        let drive = (t * self.omega).cos();
        for ((o, &vc), &a) in out.iter_mut().zip(v).zip(&self.amplitude) {
            *o = drive * a - vc * self.damping;
        }
    }

    fn depends_on_velocity(&self) -> bool {
        self.damping != 0.0
    }
}
