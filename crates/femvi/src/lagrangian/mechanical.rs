//! Mechanical Lagrangians L = ½vᵀMv − V(t, q) with a constant mass matrix M ([`Mechanical`]):
//! the kinetic part from M, the rest from a [`Potential`], whose force (and, for local forces,
//! its parts) the fast solvers call directly; first and second derivatives without automatic
//! differentiation of the kinetic part (the paper's examples, (2.18), are of this form).

use super::{Lagrangian, Lanes, MassMatrix, PointDerivatives, Potential, Scalar};
use crate::error::Result;
use num_dual::Dual64;

/// L = ½vᵀMv − V(t, q) with a constant symmetric positive definite M.
#[derive(Debug, Clone)]
pub struct Mechanical<P> {
    /// The potential V.
    pub potential: P,
    mass: MassMatrix,
}

impl<P: Potential> Mechanical<P> {
    /// A mechanical Lagrangian with the given mass matrix.
    ///
    /// # Errors
    /// The mass matrix and the potential disagree on the dimension.
    pub fn new(potential: P, mass: MassMatrix) -> Result<Self> {
        crate::error::check_len("mass matrix", potential.dim(), mass.dim())?;
        Ok(Self { potential, mass })
    }

    /// Unit masses.
    pub fn unit_mass(potential: P) -> Self {
        let mass = MassMatrix::identity(potential.dim());
        Self { potential, mass }
    }
}

impl<P: Potential> Lagrangian for Mechanical<P> {
    fn dim(&self) -> usize {
        self.potential.dim()
    }

    #[inline]
    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        let mut kin = D::from(0.0);
        match (self.mass.diagonal_entries(), self.mass.dense_entries()) {
            (Some(d), _) => {
                for (&vi, &mi) in v.iter().zip(d) {
                    kin += vi * vi * mi;
                }
            }
            (None, Some(m)) => {
                for (&vi, row) in v.iter().zip(m.chunks_exact(self.mass.dim().max(1))) {
                    for (&vj, &mij) in v.iter().zip(row) {
                        if mij != 0.0 {
                            kin += vi * vj * mij;
                        }
                    }
                }
            }
            (None, None) => {}
        }
        kin * 0.5 - self.potential.value(t, q)
    }

    fn mass_matrix(&self) -> Option<&MassMatrix> {
        Some(&self.mass)
    }

    fn potential_value(&self, t: f64, q: &[f64]) -> Option<f64> {
        Some(self.potential.value(t, q))
    }

    fn is_autonomous(&self) -> bool {
        self.potential.is_autonomous()
    }

    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.potential.force(t, q, out);
    }

    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        self.potential.forces(t, q, out);
    }

    #[inline]
    fn force_lanes(&self, t: f64, q: &[Lanes], out: &mut [Lanes]) {
        self.potential.force_lanes(t, q, out);
    }

    #[inline]
    fn potential_lanes(&self, t: f64, q: &[Lanes]) -> Option<Lanes> {
        Some(self.potential.value_lanes(t, q))
    }

    fn force_jacobian(&self, t: f64, q: &[f64], out: &mut [f64]) -> bool {
        self.potential.force_jacobian(t, q, out);
        true
    }

    fn force_derivative(&self, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        self.potential.force_derivative(t, q, dq, out);
    }

    fn prepare_force_derivative(&self, t: f64, q: &[f64], cache: &mut Vec<f64>) -> bool {
        self.potential.prepare_force_derivative(t, q, cache)
    }

    fn prepared_force_derivative(&self, cache: &[f64], dq: &[f64], out: &mut [f64]) {
        self.potential.prepared_force_derivative(cache, dq, out);
    }

    fn force_radius(&self) -> Option<usize> {
        self.potential.force_radius()
    }

    fn force_range(&self, t: f64, q: &[f64], range: std::ops::Range<usize>, out: &mut [f64]) -> bool {
        self.potential.force_range(t, q, range, out)
    }

    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        let n = self.dim();
        if !out.fits(self, q, v) {
            return;
        }
        let (gt, rest) = out.grad.split_at_mut(1);
        let (gq, gv) = rest.split_at_mut(n);
        self.potential.force(t, q, gq);
        self.mass.apply(v, gv);
        let kin: f64 = 0.5 * v.iter().zip(gv.iter()).map(|(a, b)| a * b).sum::<f64>();
        let vt = if with_t && !self.potential.is_autonomous() {
            // ∂V/∂t by a dual number in t, in the scratch this struct owns (no allocation).
            let qd = &mut out.d1[..n];
            for (d, &x) in qd.iter_mut().zip(q) {
                *d = Dual64::from(x);
            }
            let r = self.potential.value(Dual64::new(t, 1.0), qd);
            gt[0] = -r.eps;
            r.re
        } else {
            gt[0] = 0.0;
            self.potential.value(t, q)
        };
        out.value = kin - vt;
    }

    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        if with_t {
            // Time derivatives of V are rare: take the generic route.
            out.second_by_ad(self, t, q, v, true);
            return;
        }
        let n = self.dim();
        let m = 2 * n + 1;
        out.hessian_mut();
        if !out.fits(self, q, v) {
            out.hess.iter_mut().for_each(|h| *h = f64::NAN);
            return;
        }
        self.first_derivatives(t, q, v, false, out);
        out.hess.iter_mut().for_each(|h| *h = 0.0);
        let mut jac = vec![0.0; n * n];
        self.potential.force_jacobian(t, q, &mut jac);
        for i in 0..n {
            for j in 0..n {
                out.hess[(1 + i) * m + 1 + j] = jac[i * n + j];
                out.hess[(1 + n + i) * m + 1 + n + j] = self.mass.get(i, j).unwrap_or(0.0);
            }
        }
    }
}
