//! The potential V(t, q) of a mechanical Lagrangian L = ½vᵀMv − V (`Mechanical`), with its
//! force −∇V and the derivatives of the force that the tangent maps multiply by
//! (`step/tangent_mechanical.rs`); defaults by automatic differentiation of V, which models
//! override with hand-written code.

use super::{directional, lanes, Lanes, Scalar, LANES};
use num_dual::{Dual64, HyperDual64};

/// A potential V(t, q) for a mechanical Lagrangian. As for [`crate::Lagrangian`], the library calls
/// its methods with slices of length [`Potential::dim`] only.
pub trait Potential {
    /// Dimension n.
    fn dim(&self) -> usize;

    /// V(t, q), for any scalar type.
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D;

    /// Whether V does not depend on t. Default: false.
    fn is_autonomous(&self) -> bool {
        false
    }

    /// The force −∇V(t, q) into `out`. The default differentiates [`Potential::value`]
    /// (n forward passes); override it with a hand-coded force for speed.
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let n = q.len();
        let mut stack = [Dual64::from(0.0); 16];
        let mut heap = Vec::new();
        let buf: &mut [Dual64] = if n <= 16 {
            &mut stack[..n]
        } else {
            heap.resize(n, Dual64::from(0.0));
            &mut heap
        };
        for (b, &x) in buf.iter_mut().zip(q) {
            *b = Dual64::from(x);
        }
        for (i, o) in out.iter_mut().enumerate().take(n) {
            buf[i].eps = 1.0;
            *o = -self.value(Dual64::from(t), buf).eps;
            buf[i].eps = 0.0;
        }
    }

    /// As [`crate::Lagrangian::force_radius`]: the radius of a local force, or None (the default).
    fn force_radius(&self) -> Option<usize> {
        None
    }

    /// As [`crate::Lagrangian::force_range`]: components `range` of [`Potential::force`], the same
    /// bits, or false (the default, nothing written).
    fn force_range(&self, t: f64, q: &[f64], range: std::ops::Range<usize>, out: &mut [f64]) -> bool {
        let _ = (t, q, range, out);
        false
    }

    /// The forces at several points at once (see [`crate::Lagrangian::forces`]). Default: one
    /// [`Potential::force`] call per point.
    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        super::per_point(self.dim(), t, q, out, |ti, qi, oi| self.force(ti, qi, oi));
    }

    /// As [`crate::Lagrangian::force_lanes`]: −∇V at [`LANES`] points at once, the bits of
    /// [`Potential::force`]. Default: one `force` call per lane.
    fn force_lanes(&self, t: f64, q: &[Lanes], out: &mut [Lanes]) {
        lanes::potential_force_per_lane(self, t, q, out);
    }

    /// V at [`LANES`] points at once (as [`crate::Lagrangian::potential_lanes`]), the bits of
    /// [`Potential::value`]. Default: lane by lane.
    fn value_lanes(&self, t: f64, q: &[Lanes]) -> Lanes {
        lanes::value_per_lane(q, |x| Some(self.value(t, x))).unwrap_or([f64::NAN; LANES])
    }

    /// The derivative of [`Potential::force`] along dq, −∇²V(t, q)·dq, into `out` (see
    /// [`crate::Lagrangian::force_derivative`]). Default: n hyper-dual passes over
    /// [`Potential::value`]; override it with a hand-coded product for speed.
    ///
    /// ```
    /// use femvi::{models, Potential};
    /// // The FPU chain's hand-coded product against its Jacobian (hyper-dual AD).
    /// let chain = models::fpu(3, 0.25, 0.0)?.potential;
    /// let (q, dq) = ([0.1, -0.2, 0.3], [1.0, 0.5, -0.5]);
    /// let (mut out, mut jac) = ([0.0; 3], [0.0; 9]);
    /// chain.force_derivative(0.0, &q, &dq, &mut out);
    /// chain.force_jacobian(0.0, &q, &mut jac);
    /// for i in 0..3 {
    ///     let want: f64 = (0..3).map(|j| jac[i * 3 + j] * dq[j]).sum();
    ///     assert!((out[i] - want).abs() < 1e-14);
    /// }
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn force_derivative(&self, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        directional::potential_default(self, t, q, dq, out);
    }

    /// As [`crate::Lagrangian::prepare_force_derivative`]: what repeated products
    /// [`Potential::force_derivative`] at (t, q) share, into `cache`, and true; or false (the
    /// default), nothing written.
    fn prepare_force_derivative(&self, t: f64, q: &[f64], cache: &mut Vec<f64>) -> bool {
        let _ = (t, q, cache);
        false
    }

    /// As [`crate::Lagrangian::prepared_force_derivative`]: the bits of
    /// [`Potential::force_derivative`] from a prepared `cache`. Default: NaN.
    fn prepared_force_derivative(&self, cache: &[f64], dq: &[f64], out: &mut [f64]) {
        let _ = (cache, dq);
        out.iter_mut().for_each(|x| *x = f64::NAN);
    }

    /// The Jacobian of the force, −∇²V, row-major n×n into `out`. Default: hyper-dual AD.
    fn force_jacobian(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let n = q.len();
        if out.len() != n * n {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        let mut buf: Vec<HyperDual64> = q.iter().map(|&x| HyperDual64::from(x)).collect();
        for i in 0..n {
            for j in i..n {
                buf[i].eps1 = 1.0;
                buf[j].eps2 = 1.0;
                let h = -self.value(HyperDual64::from(t), &buf).eps1eps2;
                buf[i].eps1 = 0.0;
                buf[j].eps2 = 0.0;
                out[i * n + j] = h;
                out[j * n + i] = h;
            }
        }
    }
}
