//! The chaos indicators and sensitivities of constrained runs under non-conservative forces
//! ([`crate::constraints::solve_constrained_forced`]): the steps of the discrete
//! Lagrange–d'Alembert principle on the augmented action, each step's tangent map by implicit
//! differentiation of those equations (the discrete forces' derivatives in the nodal values
//! included, as in `forced.rs`), the vectors in the symplectic coordinates of T*N as in
//! `constrained.rs`. A forced flow is not symplectic, so the spectrum need not come in ± pairs:
//! under linear friction −c q̇ near a stable equilibrium every exponent tends to −c/2.

use super::constrained::{indicators_on, sensitivity_of};
use super::{ChaosOptions, ChaosReport, FinalNode};
use crate::constraints::{Constraints, Enforcement, ManifoldRun};
use crate::discrete::Element;
use crate::error::{check_len, Result};
use crate::forces::Force;
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions};

/// [`super::constrained_indicators`] for the forced constrained run of `problem` under
/// `force` (the nodes of [`crate::constraints::solve_constrained_forced`] with the same
/// arguments, bit for bit).
///
/// # Errors
/// As [`crate::constraints::solve_constrained_forced`]; an initial vector of the wrong
/// length, zero, or normal to the manifold.
///
/// # Example
///
/// ```
/// use femvi::chaos::{forced_constrained_indicators, ChaosOptions};
/// use femvi::constraints::Enforcement;
/// use femvi::forces::LinearForce;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // The spherical pendulum with friction −0.4 q̇ settles at the bottom: its largest
/// // exponent tends to −0.2 (the damped oscillations' rate −c/2).
/// let (lag, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0)?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 0.7, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 200.0);
/// let friction = LinearForce::damping(3, 0.4);
/// let r = forced_constrained_indicators(&problem, &friction, &sphere, &Element::with_order(4)?, &SolveOptions::step(0.1), Enforcement::default(), &ChaosOptions::default())?;
/// assert!((r.last.lyapunov + 0.2).abs() < 0.02, "{}", r.last.lyapunov);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn forced_constrained_indicators<L: Lagrangian + Sync, F: Force + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    force: &F,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
    chaos: &ChaosOptions,
) -> Result<ChaosReport> {
    let n = problem.lagrangian.dim();
    forced_run(problem, force, constraints, element, (options, enforcement), |run| {
        indicators_on(run, n, chaos)
    })
}

/// [`super::constrained_sensitivity`] for the forced constrained run of `problem` under
/// `force`: the derivative of its end along start directions tangent to T*N.
///
/// # Errors
/// As [`crate::constraints::solve_constrained_forced`]; a step that fails is an error here.
///
/// # Example
///
/// ```
/// use femvi::chaos::forced_constrained_sensitivity;
/// use femvi::constraints::Enforcement;
/// use femvi::forces::LinearForce;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// let (lag, sphere) = models::chain(3, 1, 1.0, 1.0, 1.0)?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 0.7, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 1.0);
/// let friction = LinearForce::damping(3, 0.4);
/// let (m, (_, q, _)) = forced_constrained_sensitivity(&problem, &friction, &sphere, &Element::with_order(4)?, &SolveOptions::step(0.1), Enforcement::default())?;
/// // Every image is tangent to the sphere at the end: q·δq = 0.
/// for col in 0..6 {
///     let dot: f64 = (0..3).map(|i| q[i] * m[i * 6 + col]).sum();
///     assert!(dot.abs() < 1e-12);
/// }
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn forced_constrained_sensitivity<L: Lagrangian + Sync, F: Force + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    force: &F,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
) -> Result<(Vec<f64>, FinalNode)> {
    forced_run(
        problem,
        force,
        constraints,
        element,
        (options, enforcement),
        sensitivity_of,
    )
}

/// `go` applied to the constrained run of `problem` under `force` (the force's dimension
/// checked).
fn forced_run<L: Lagrangian + Sync, F: Force + Sync, C: Constraints + Sync, R>(
    problem: &Problem<L>,
    force: &F,
    constraints: &C,
    element: &Element,
    (options, enforcement): (&SolveOptions, Enforcement),
    go: impl FnOnce(ManifoldRun<'_, L, C>) -> Result<R>,
) -> Result<R> {
    check_len("force", problem.lagrangian.dim(), force.dim())?;
    go(ManifoldRun::forced(
        problem,
        constraints,
        element,
        (options, enforcement),
        force,
    )?)
}
