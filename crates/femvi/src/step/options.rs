//! What a user chooses about a run's solver and start: the method ([`Method`], resolved to a
//! solver by `solver::choose`), tolerance and iteration cap ([`SolverOptions`]), and the
//! initial data ([`Start`]: (q0, v0), (q0, p0), or the paper's (q0, q1)).

use crate::error::{invalid, Result};

/// Which solver takes the step equations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Explicit for degree 1 with the trapezoid rule on a mechanical Lagrangian, fixed-point
    /// iteration for other mechanical Lagrangians, the gyroscopic fixed point for gyroscopic
    /// ones, [`Method::Newton`] otherwise.
    Auto,
    /// Newton's method for the step equations of general Lagrangians: the simplified
    /// iteration (issue 15), the Jacobian factorised once and kept across iterations and
    /// steps while the iteration contracts fast, refreshed when it does not or when the step
    /// changes, falling back to full Newton with a line search when even a fresh Jacobian
    /// does not converge. Its iterates are correct to round-off like full Newton's, so
    /// conserved quantities do not drift over long runs (`tests/adaptive_drift.rs`).
    Newton,
    /// Full Newton with a line search: the element Hessian evaluated and factorised at every
    /// iteration (the solver of [`Method::Newton`] before issue 15, kept for comparisons).
    FullNewton,
    /// The same as [`Method::Newton`] (its name while it was opt-in).
    SimplifiedNewton,
    /// Fixed-point iteration on the forces (mechanical Lagrangians only).
    FixedPoint,
    /// Explicit stepping (degree 1, trapezoid rule, mechanical Lagrangians only).
    Explicit,
}

/// Tolerance, iteration cap and method of the step solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverOptions {
    /// Relative tolerance on the increments of the unknowns (relative to max |q|).
    pub tolerance: f64,
    /// Iteration cap per step.
    pub max_iterations: usize,
    /// The solver.
    pub method: Method,
    /// Fixed-point iteration only: once the tolerance is met, iterate on while the increments
    /// still decrease (at most three more sweeps) until the stages are correct to round-off.
    /// The error a truncated iteration leaves has the same sign every step, so without the
    /// polish it accumulates like a drift of about h·|∂f/∂q|·tolerance·max|q| per step; with
    /// it, only round-off remains. Off, the solver stops at the tolerance: fewer force
    /// evaluations (P3 with degree 6 at h = 1.25 and tolerance 1e-10: 4.6 sweeps per step
    /// against 7.1) for problems whose accuracy target is far above round-off.
    /// Default: true.
    pub polish: bool,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-14,
            max_iterations: 50,
            method: Method::Auto,
            polish: true,
        }
    }
}

impl SolverOptions {
    /// Checks the options.
    ///
    /// # Errors
    /// A tolerance that is not positive and finite, or a zero iteration cap.
    pub fn validate(&self) -> Result<()> {
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(invalid(
                "solver tolerance",
                format!("{} is not a positive finite number", self.tolerance),
            ));
        }
        if self.max_iterations == 0 {
            return Err(invalid("solver max_iterations", "must be at least 1"));
        }
        Ok(())
    }
}

/// Initial data of a run.
#[derive(Debug, Clone, PartialEq)]
pub enum Start {
    /// q0 and the velocity v0; p0 = ∂L/∂v(t0, q0, v0).
    Velocity {
        /// Position q0.
        q: Vec<f64>,
        /// Velocity v0.
        v: Vec<f64>,
    },
    /// q0 and the momentum p0.
    Momentum {
        /// Position q0.
        q: Vec<f64>,
        /// Momentum p0.
        p: Vec<f64>,
    },
    /// The paper's start from (q0, q1), q1 at the first grid node t1.
    Positions {
        /// Position q0.
        q0: Vec<f64>,
        /// Position q1.
        q1: Vec<f64>,
    },
}
