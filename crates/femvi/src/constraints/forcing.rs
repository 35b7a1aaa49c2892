//! A non-conservative force as the constrained step takes it, without its type: the discrete
//! forces F_d^j of each element as a term of the step equations, the element's discrete work,
//! and F at a node (for the multipliers of the forced flow). Module docs of `forced.rs` for the
//! equations.

use crate::bvp::ElementTerm;
use crate::discrete::Element;
use crate::forces::{element_forces, Force, ForceTerm};
use std::cell::RefCell;

/// What the constrained run needs of a force, without its type.
pub(super) trait NodeForce {
    /// The discrete forces as an element term of the step equations.
    fn term(&self) -> &dyn ElementTerm;
    /// The work h Σ_i b_i F(c_i)·q̇_h(c_i) of the element [t0, t0 + h] with first node `qk`
    /// and increments `incr` (Q^j − q_k, j = 0 … s).
    fn work(&self, element: &Element, t0: f64, h: f64, qk: &[f64], incr: &[f64]) -> f64;
    /// F(t, q, v) into `out`.
    fn at(&self, t: f64, q: &[f64], v: &[f64], out: &mut [f64]);
}

/// A force with its element term and scratch.
pub(super) struct Forcing<'a, F> {
    force: &'a F,
    term: ForceTerm<'a, F>,
    fd: RefCell<Vec<f64>>,
}

impl<'a, F: Force> Forcing<'a, F> {
    /// `force` on elements like `element` in dimension n.
    pub(super) fn new(force: &'a F, element: &'a Element, n: usize) -> Self {
        let w = element.nodes().saturating_mul(n);
        Self {
            force,
            term: ForceTerm::new(force, element, w),
            fd: RefCell::new(vec![0.0; w]),
        }
    }
}

impl<F: Force> NodeForce for Forcing<'_, F> {
    fn term(&self) -> &dyn ElementTerm {
        &self.term
    }
    fn work(&self, element: &Element, t0: f64, h: f64, qk: &[f64], incr: &[f64]) -> f64 {
        element_forces(element, self.force, t0, h, qk, incr, &mut self.fd.borrow_mut())
    }
    fn at(&self, t: f64, q: &[f64], v: &[f64], out: &mut [f64]) {
        self.force.force(t, q, v, out);
    }
}
