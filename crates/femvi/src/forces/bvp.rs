//! Two-point boundary value problems with non-conservative forces: the discrete
//! Lagrange–d'Alembert equations ∂S/∂Q + F_d = 0 at every interior node (the sum over the
//! elements that share it of ∂L_d/∂Q^j + F_d^j), solved by [`crate::bvp`]'s banded Newton
//! iteration with the discrete forces and their Jacobian added element by element. The end
//! momenta are the forced discrete Legendre transforms p_0 = −∂L_d/∂Q^0 − F_d^0 and
//! p_N = ∂L_d/∂Q^s + F_d^s. Fixed meshes only: no variational principle gives the moving
//! mesh's energy equations with forces.

use super::element::{element_forces, element_forces_jacobian};
use super::Force;
use crate::bvp::{solve_with_term, BoundaryValues, BvpOptions, BvpSolution, ElementTerm};
use crate::discrete::Element;
use crate::error::{check_len, invalid, Result};
use crate::lagrangian::Lagrangian;
use std::cell::RefCell;

/// The discrete forces of `force` as an element term of the boundary value assembly (also
/// of the constrained one, `constraints/bvp_forced.rs`).
pub(crate) struct ForceTerm<'a, F> {
    force: &'a F,
    element: &'a Element,
    /// Scratch: F_d and its Jacobian.
    scratch: RefCell<(Vec<f64>, Vec<f64>)>,
}

impl<'a, F: Force> ForceTerm<'a, F> {
    /// The term with scratch for w = (s+1)·n element unknowns.
    pub(crate) fn new(force: &'a F, element: &'a Element, w: usize) -> Self {
        Self {
            force,
            element,
            scratch: RefCell::new((vec![0.0; w], vec![0.0; w.saturating_mul(w)])),
        }
    }
}

impl<F: Force> ElementTerm for ForceTerm<'_, F> {
    fn add(&self, t0: f64, h: f64, base: &[f64], incr: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) {
        let mut scratch = self.scratch.borrow_mut();
        let (fd, jac) = &mut *scratch;
        match hess {
            Some(hess) => {
                element_forces_jacobian(self.element, self.force, t0, h, base, incr, fd, jac);
                for (a, b) in hess.iter_mut().zip(jac.iter()) {
                    *a += b;
                }
            }
            None => {
                element_forces(self.element, self.force, t0, h, base, incr, fd);
            }
        }
        for (g, f) in grad.iter_mut().zip(fd.iter()) {
            *g += f;
        }
    }
}

/// Solves the boundary value problem q(t0) = q0, q(t1) = q1 of `lag` under `force` from the
/// initial guess `guess` (all global nodal values, as for [`crate::bvp::solve`]).
/// [`BvpSolution::action`] is the discrete action S (not stationary with forces) and
/// [`BvpSolution::residual_norm`] the largest |∂S/∂Q + F_d| over the interior nodes.
///
/// # Errors
/// As [`crate::bvp::solve`]; also a force whose dimension is not the Lagrangian's and a
/// moving mesh (not supported with forces).
///
/// # Example
///
/// ```
/// use femvi::bvp::{line_guess, BoundaryValues, BvpOptions};
/// use femvi::forces::{solve_forced_bvp, LinearForce};
/// use femvi::{models, Element};
///
/// let bv = BoundaryValues { t0: 0.0, q0: vec![1.0], t1: 2.0, q1: vec![0.0], elements: 20 };
/// let element = Element::with_order(4)?;
/// let sol = solve_forced_bvp(&models::harmonic(1.0, 1.0)?, &LinearForce::damping(1, 0.5), &element, &bv, &line_guess(&bv, &element), BvpOptions::default())?;
/// assert!(sol.residual_norm < 1e-12);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn solve_forced_bvp<L: Lagrangian, F: Force>(
    lag: &L,
    force: &F,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
) -> Result<BvpSolution> {
    let n = lag.dim();
    check_len("force", n, force.dim())?;
    if options.moving_mesh {
        return Err(invalid(
            "moving mesh",
            "not supported with non-conservative forces (use a fixed mesh)",
        ));
    }
    let w = element.nodes().saturating_mul(n);
    let term = ForceTerm::new(force, element, w);
    solve_with_term(lag, element, bv, guess, options, Some(&term))
}
