//! Non-conservative forces by the discrete Lagrange–d'Alembert principle (Marsden–West 2001,
//! §3.2; Kane–Marsden–Ortiz–West 2000): friction, drag, forcing that is not a potential.
//!
//! # The step equations and their signs
//!
//! The Lagrange–d'Alembert principle asks that δ∫L(t, q, q̇) dt + ∫F(t, q, q̇)·δq dt = 0 for
//! all variations δq vanishing at the ends. On an element [t_k, t_k + h] the path is
//! q_h(τ) = Σ_j Q^j ℓ_j(τ) and a variation is δq_h(τ) = Σ_j δQ^j ℓ_j(τ), so the virtual work,
//! integrated with the element's own quadrature, is Σ_j F_d^j·δQ^j with the discrete forces
//!
//!   F_d^j = h Σ_i b_i F(t_k + c_i h, q_h(c_i), q̇_h(c_i)) ℓ_j(c_i)   (j = 0 … s).
//!
//! With δL_d = Σ_j ∂L_d/∂Q^j·δQ^j, collecting the coefficient of each nodal variation:
//! an internal node Q^j (0 < j < s) belongs to one element only, so ∂L_d/∂Q^j + F_d^j = 0; the
//! node q_k is the last node of element k − 1 and the first of element k, so
//! [∂L_d/∂Q^s + F_d^s]_{k−1} + [∂L_d/∂Q^0 + F_d^0]_k = 0. Naming the first bracket the momentum
//! p_k (the forced discrete Legendre transform F⁺L_d, which reduces to ∂L_d/∂Q^s without
//! forces), one step from (q_k, p_k) solves
//!
//!   p_k + ∂L_d/∂Q^0 + F_d^0 = 0,  ∂L_d/∂Q^j + F_d^j = 0 (0 < j < s),
//!
//! for Q^1 … Q^s and sets p_{k+1} = ∂L_d/∂Q^s + F_d^s. Since Σ_j ℓ_j = 1 and Σ_j ℓ_j' = 0,
//! summing all rows gives p_{k+1} − p_k = h Σ_i b_i (∂L/∂q + F)(c_i), which is how the new
//! momentum is accumulated. Without forces these are femvi's step equations ([`crate::step`]).
//!
//! # Work and the energy balance
//!
//! Along a solution dH/dt = F·q̇ − ∂L/∂t. The discrete work of element k is the same
//! quadrature of the power along the element polynomial,
//!
//!   ΔW_k = h Σ_i b_i F(t_i, q_h(c_i), q̇_h(c_i))·q̇_h(c_i),
//!
//! (and for a time-dependent L the explicit-time term −h Σ_i b_i ∂L/∂t(c_i)); W_k is their sum
//! over the elements before node k. The Galerkin element with Gauss quadrature is a
//! partitioned Runge–Kutta method whose stages are q_h(c_i), q̇_h(c_i); W is then that method
//! applied to the extra equation Ẇ = F·q̇, so H(t_k) − H(0) − W_k → 0 with the nodal order 2s
//! (measured in `tests/forces.rs`).
//!
//! # Files
//!
//! [`Force`] (this file) is the trait, generic over the scalar like [`crate::Lagrangian`] so
//! that Newton's Jacobian ∂F_d/∂Q comes from automatic differentiation; `expr.rs` holds forces
//! from expressions ([`ExprForces`]), `rayleigh.rs` a Rayleigh dissipation function
//! ([`Rayleigh`], F = −∂R/∂v), `sum.rs` the sum of two forces, `linear.rs` a linear damping and
//! harmonic drive for the models; `element.rs` the discrete forces of an element, `step.rs`
//! the Newton step, `fixed_point.rs` the fixed-point run for a constant mass matrix and a force
//! independent of v, `solve.rs` the run ([`solve_forced`]), `energy.rs` (derivation and run)
//! and `energy_step.rs` the energy mode (time steps from the forced energy equation, so that
//! the discrete energy changes by exactly the discrete work), `term.rs` the force as a term of
//! the one integrator (whose tangent map, for [`crate::chaos::forced_indicators`], is in
//! `step/term_tangent.rs`) and `bvp.rs` boundary value problems
//! with forces ([`solve_forced_bvp`]).

mod bvp;
mod element;
mod energy_step;
mod energy_term;
mod expr;
mod fixed_point;
mod linear;
mod rayleigh;
mod solve;
mod step;
mod sum;
mod term;

pub use bvp::solve_forced_bvp;
pub(crate) use bvp::ForceTerm;
pub use element::{element_forces, element_forces_jacobian};
pub use expr::ExprForces;
pub use linear::LinearForce;
pub use rayleigh::Rayleigh;
pub use solve::{solve_forced, solve_forced_with, EnergyBalance, ForcedSolution};
pub use sum::Sum;

use crate::lagrangian::Scalar;

/// A generalised force F(t, q, v) on Rⁿ, the non-conservative part of the dynamics
/// d/dt ∂L/∂v − ∂L/∂q = F.
///
/// # Example
///
/// ```
/// use femvi::forces::Force;
/// use femvi::Scalar;
///
/// /// Linear friction −c v.
/// struct Friction { c: f64 }
/// impl Force for Friction {
///     fn dim(&self) -> usize { 1 }
///     fn force<D: Scalar>(&self, _t: D, _q: &[D], v: &[D], out: &mut [D]) {
///         out[0] = v[0] * (-self.c);
///     }
/// }
/// let mut f = [0.0];
/// Friction { c: 0.5 }.force(0.0, &[1.0], &[2.0], &mut f);
/// assert_eq!(f, [-1.0]);
/// ```
pub trait Force {
    /// Dimension n of the configuration space.
    fn dim(&self) -> usize;

    /// F(t, q, v) into `out`, for any scalar type (f64 or dual numbers). The library calls it
    /// with slices of length [`Force::dim`] only.
    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], out: &mut [D]);

    /// Whether F depends on v (default true). If false, and L has a constant mass matrix,
    /// [`solve_forced`] solves the steps by fixed-point iteration instead of Newton (unless
    /// `Method::Newton` is asked for); a force answering false must not read `v`.
    fn depends_on_velocity(&self) -> bool {
        true
    }
}

impl<F: Force> Force for &F {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], out: &mut [D]) {
        (**self).force(t, q, v, out)
    }
    fn depends_on_velocity(&self) -> bool {
        (**self).depends_on_velocity()
    }
}
