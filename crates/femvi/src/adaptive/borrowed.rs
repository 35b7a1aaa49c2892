//! A borrowed Lagrangian as a Lagrangian: every method delegated, so that
//! [`super::solve_adaptive`] can wrap the problem's Lagrangian in L_g without cloning it
//! (the trait has no blanket implementation for references).

use crate::lagrangian::{Lagrangian, MassMatrix, PointDerivatives, Scalar};

/// `&L`, delegating every method of [`Lagrangian`] (the hand-coded ones included).
///
/// ```
/// use femvi::adaptive::Borrowed;
/// use femvi::{models, Lagrangian};
/// let kepler = models::kepler(1.0)?;
/// assert_eq!(Borrowed(&kepler).dim(), 2);
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Borrowed<'a, L>(pub &'a L);

impl<L: Lagrangian> Lagrangian for Borrowed<'_, L> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.0.value(t, q, v)
    }
    fn is_autonomous(&self) -> bool {
        self.0.is_autonomous()
    }
    fn mass_matrix(&self) -> Option<&MassMatrix> {
        self.0.mass_matrix()
    }
    fn potential_value(&self, t: f64, q: &[f64]) -> Option<f64> {
        self.0.potential_value(t, q)
    }
    fn gyroscopic_mass(&self) -> Option<&MassMatrix> {
        self.0.gyroscopic_mass()
    }
    fn gyroscopic_terms(&self, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        self.0.gyroscopic_terms(t, q, v, out)
    }
    fn gyroscopic_divisor(&self, t: f64, q: &[f64]) -> f64 {
        self.0.gyroscopic_divisor(t, q)
    }
    fn gyroscopic_terms_divided(&self, d: f64, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        self.0.gyroscopic_terms_divided(d, t, q, v, out)
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.0.force(t, q, out)
    }
    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        self.0.forces(t, q, out)
    }
    fn force_radius(&self) -> Option<usize> {
        self.0.force_radius()
    }
    fn force_range(&self, t: f64, q: &[f64], range: std::ops::Range<usize>, out: &mut [f64]) -> bool {
        self.0.force_range(t, q, range, out)
    }
    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        self.0.first_derivatives(t, q, v, with_t, out)
    }
    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        self.0.second_derivatives(t, q, v, with_t, out)
    }
}
