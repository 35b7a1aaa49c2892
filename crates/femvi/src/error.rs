//! Typed errors of the library. Every failure a user can cause (bad input) or meet
//! (a step that does not converge) is a variant here; nothing in the library panics on
//! user input. The command-line tool turns these into messages and exit codes.

use thiserror::Error;

/// Why the solve of one step failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepFailure {
    /// The iteration cap was reached before the tolerance.
    NotConverged,
    /// The increments stopped decreasing above the tolerance (the iteration stalls).
    Stalled,
    /// A NaN or an infinity appeared in the unknowns, the residual or the Lagrangian.
    NonFinite,
    /// The linear system of a Newton iteration is singular.
    Singular,
    /// No admissible (positive, bounded) time step solves the discrete energy equation.
    NoAdmissibleStep,
    /// A moving mesh folded: an element's step became zero or negative.
    MeshFolded,
}

impl std::fmt::Display for StepFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StepFailure::NotConverged => "did not converge within the iteration cap",
            StepFailure::Stalled => "stalled: the increments stopped decreasing above the tolerance",
            StepFailure::NonFinite => "met a non-finite value",
            StepFailure::Singular => "met a singular linear system",
            StepFailure::NoAdmissibleStep => "found no admissible time step for the energy equation",
            StepFailure::MeshFolded => "moved the mesh until it folded (an element's step is not positive)",
        })
    }
}

/// A step of an integrator (or a boundary value solve) that failed, with where and how.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("step {step} at t = {t}: the solver {failure} (residual {residual:.3e}, {iterations} iterations)")]
pub struct StepError {
    /// Index of the step that failed (the step from node `step` to node `step + 1`).
    pub step: usize,
    /// Time at the start of the failed step.
    pub t: f64,
    /// Infinity norm of the residual (or the last increment) when the solver gave up.
    pub residual: f64,
    /// Iterations spent on the step.
    pub iterations: usize,
    /// What went wrong.
    pub failure: StepFailure,
}

/// Every error the library returns.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Error {
    /// A vector or matrix has the wrong length.
    #[error("{what} has length {got}, expected {expected}")]
    Dimension {
        /// What has the wrong length.
        what: String,
        /// The length expected.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// A parameter is out of its admissible range.
    #[error("invalid {what}: {reason}")]
    Invalid {
        /// Which parameter.
        what: String,
        /// Why it is rejected.
        reason: String,
    },
    /// The mass matrix of a mechanical Lagrangian is not symmetric positive definite.
    #[error("the mass matrix is not symmetric positive definite")]
    MassNotPositiveDefinite,
    /// ∂²L/∂v² is singular, not finite, or has a condition number above
    /// [`crate::lagrangian::DEGENERATE_CONDITION`], so the Legendre transform (and the
    /// discrete flow) is not defined there.
    #[error("the Lagrangian is degenerate at t = {t}: the Hessian d2L/dv2 is singular or ill-conditioned (condition number {condition:.3e}, the limit is 1e12), so the Legendre transform is not invertible")]
    DegenerateLagrangian {
        /// Where it was detected.
        t: f64,
        /// The condition number of ∂²L/∂v² there (infinite if singular or not finite).
        condition: f64,
    },
    /// The inverse Legendre transform (v from p = ∂L/∂v) did not converge though ∂²L/∂v² is
    /// regular where it stopped: the guess was too far, or L is not convex enough in v on
    /// the way.
    #[error("the inverse Legendre transform (v from p = dL/dv) did not converge at t = {t}: residual {residual:.3e} after {iterations} Newton iterations, though d2L/dv2 is regular there (condition number {condition:.3e})")]
    LegendreNotConverged {
        /// Where it was attempted.
        t: f64,
        /// Newton iterations made.
        iterations: usize,
        /// max |p − ∂L/∂v| at the last iterate.
        residual: f64,
        /// The condition number of ∂²L/∂v² at the last iterate.
        condition: f64,
    },
    /// The constraint Jacobian G(q) = ∂g/∂q lost rank at a node: the constraints are dependent
    /// there (or the step that led there failed on a singular Newton system).
    #[error("the constraint Jacobian is singular at node {step} (t = {t}): its smallest singular value is {ratio:.3e} of its largest")]
    SingularConstraints {
        /// Index of the node (0 is the start).
        step: usize,
        /// Time of the node.
        t: f64,
        /// Smallest over largest singular value of G.
        ratio: f64,
    },
    /// The energy H = p·v − L at a node where the run computes it is not finite (L or its
    /// derivatives are not finite there though the steps were, or the state overflowed):
    /// the run stopped there and recorded nothing of that node, neither in the arrays nor in
    /// the energy report.
    #[error(
        "non-finite energy at step {step}, t = {t}: H = p·v − L is not finite at this node; the run ends before it"
    )]
    NonFiniteEnergy {
        /// Index of the node (0 is the start).
        step: usize,
        /// Time of the node (the physical time, also in adaptive runs).
        t: f64,
    },
    /// An iteration stopped before it converged (the optimal control solver); the caller
    /// keeps its best iterate.
    #[error("{what} did not converge after {iterations} iterations (residual {residual:.3e}): {reason}")]
    NotConverged {
        /// What was iterated.
        what: String,
        /// Iterations made.
        iterations: usize,
        /// The largest residual at the best iterate.
        residual: f64,
        /// Why it stopped.
        reason: String,
    },
    /// A step failed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// An observer of a run (an output being written) failed; the run stopped there.
    #[error("{0}")]
    Observer(String),
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Whether `error` is a non-finite energy at node `step`: the observers' `finish` then keeps
/// nothing of that node (a second try at its energy, from another start, could succeed).
pub(crate) fn energy_failed_at(error: Option<&Error>, step: usize) -> bool {
    matches!(error, Some(Error::NonFiniteEnergy { step: k, .. }) if *k == step)
}

/// `h` if finite, else [`Error::NonFiniteEnergy`] at node `step` (time t): the check every
/// solver makes before it records a node's energy, as `femvi run` writes no non-finite value.
pub(crate) fn finite_energy(h: f64, step: usize, t: f64) -> Result<f64> {
    if h.is_finite() {
        Ok(h)
    } else {
        Err(Error::NonFiniteEnergy { step, t })
    }
}

pub(crate) fn invalid(what: &str, reason: impl Into<String>) -> Error {
    Error::Invalid {
        what: what.to_string(),
        reason: reason.into(),
    }
}

pub(crate) fn check_len(what: &str, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(Error::Dimension {
            what: what.to_string(),
            expected,
            got,
        })
    }
}
