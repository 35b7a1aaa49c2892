//! Constrained boundary value problems with non-conservative forces: the discrete
//! Lagrange–d'Alembert principle on the augmented action (Marsden–West 2001, §3.2 and §3.5),
//! i.e. the equations of `bvp.rs` with the discrete forces F_d^j of each element
//! ([`crate::forces::element_forces`]) added to its node rows, and their exact Jacobian
//! ([`crate::forces::element_forces_jacobian`]) to Newton's. The end momenta are the forced
//! constrained discrete Legendre transforms, projected onto T*N; the multipliers at the ends
//! are those of the forced flow (F in the right-hand side, module `project`).

use super::bvp::{solve_parts, BvpParts, ConstrainedBvpSolution};
use super::forcing::Forcing;
use super::layout::Enforcement;
use super::Constraints;
use crate::bvp::{BoundaryValues, BvpOptions};
use crate::discrete::Element;
use crate::error::{check_len, Result};
use crate::forces::Force;
use crate::lagrangian::Lagrangian;

/// Solves the constrained boundary value problem of `lag` under the non-conservative `force`
/// (see [`super::solve_constrained_bvp_with`] for the rest). The action reported is the
/// discrete action S (not stationary with forces); the residual includes the forces.
///
/// # Errors
/// As [`super::solve_constrained_bvp_with`]; also a force whose dimension is not the
/// Lagrangian's.
///
/// # Example
///
/// A damped spherical pendulum between two points of the sphere:
///
/// ```
/// use femvi::bvp::{line_guess, BoundaryValues, BvpOptions};
/// use femvi::constraints::{solve_constrained_forced_bvp, Enforcement};
/// use femvi::forces::LinearForce;
/// use femvi::{models, Element};
///
/// let (lag, sphere) = models::chain(3, 1, 1.0, 9.81, 1.0)?;
/// let bv = BoundaryValues { t0: 0.0, q0: vec![0.6, 0.0, -0.8], t1: 0.5, q1: vec![0.0, 0.6, -0.8], elements: 20 };
/// let element = Element::with_order(4)?;
/// let damping = LinearForce::damping(3, 0.3);
/// let sol = solve_constrained_forced_bvp(&lag, &damping, &sphere, &element, &bv, &line_guess(&bv, &element), BvpOptions::default(), Enforcement::default())?;
/// assert!(sol.solution.residual_norm < 1e-12 && sol.max_residual < 1e-13);
/// # Ok::<(), femvi::Error>(())
/// ```
#[allow(clippy::too_many_arguments)]
pub fn solve_constrained_forced_bvp<L: Lagrangian, F: Force, C: Constraints>(
    lag: &L,
    force: &F,
    constraints: &C,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
    enforcement: Enforcement,
) -> Result<ConstrainedBvpSolution> {
    let n = lag.dim();
    check_len("force", n, force.dim())?;
    let forcing = Forcing::new(force, element, n);
    let problem = BvpParts {
        lag,
        con: constraints,
        element,
        bv,
        force: Some(&forcing),
    };
    solve_parts(&problem, guess, options, enforcement)
}
