//! The chaos indicators and the sensitivities of forced runs ([`crate::forces`]: discrete
//! Lagrange–d'Alembert): the run is the one integrator with its force term
//! ([`Integrator::with_force`], the steps of `femvi run`), its tangent vectors carried by the
//! forced step's tangent map (implicit differentiation of the forced step equations,
//! `step/term_tangent.rs`) and accumulated as for a conservative run (`drive.rs`,
//! `accumulate.rs`). The forced flow is not symplectic: a
//! dissipative run's spectrum sums to the mean of ln det of the step maps per unit time (for
//! linear damping −c v on a mass m, −c/m), not to 0.

use super::{ChaosOptions, ChaosReport, FinalNode};
use crate::discrete::Element;
use crate::error::Result;
use crate::forces::Force;
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions, Steps};
use crate::step::Integrator;

/// [`super::indicators`] for `problem` under the non-conservative force `force`: MEGNO, FLI,
/// the largest Lyapunov exponent and, if asked, the spectrum of the forced discrete flow.
///
/// The steps are those of [`crate::forces::solve_forced`] (of [`Integrator::with_force`]:
/// dense Newton, or for a constant mass matrix and a force independent of v the fixed point,
/// as `options.solver` asks); each step's tangent map comes from one more element Hessian,
/// force Jacobian and LU of the s n Newton matrix at the converged step, whichever solver took
/// it (`step/term_tangent.rs`). `options.max_steps` stops the run after that many steps.
///
/// # Errors
/// As [`crate::forces::solve_forced`]; time steps as variables (the forced energy
/// equation's tangent map is not derived); an initial vector of the wrong length or zero.
///
/// # Example
///
/// ```
/// use femvi::chaos::{forced_indicators, ChaosOptions};
/// use femvi::forces::LinearForce;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // The damped oscillator x'' = −x − 0.2 x': both exponents are −0.1, their sum −c/m = −0.2
/// // (here to the method's O(h⁴) error in ln det of the step).
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, Start::Momentum { q: vec![1.0], p: vec![0.0] }, 0.0, 200.0);
/// let chaos = ChaosOptions { spectrum: true, ..ChaosOptions::default() };
/// let force = LinearForce::damping(1, 0.2);
/// let r = forced_indicators(&problem, &force, &Element::with_order(4)?, &SolveOptions::step(0.1), &chaos)?;
/// let s = r.spectrum.unwrap();
/// assert!((s[0] + s[1] + 0.2).abs() < 1e-6);
/// assert!((r.last.lyapunov + 0.1).abs() < 0.01);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn forced_indicators<L: Lagrangian + Sync, F: Force + Sync>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    options: &SolveOptions,
    chaos: &ChaosOptions,
) -> Result<ChaosReport> {
    let mut it = forced_integrator(problem, force, element, options)?;
    super::indicators_limited(&mut it, chaos, options.max_steps)
}

/// The sensitivity of the final state of a forced run to the initial one,
/// ∂(q_N, p_N)/∂(q_0, p_0) (row-major 2n×2n), with the final node; as
/// [`super::sensitivity`] (`options.max_steps` stops the run after that many steps).
///
/// # Errors
/// As [`crate::forces::solve_forced`]; a step that fails is an error here.
///
/// # Example
///
/// ```
/// use femvi::chaos::forced_sensitivity;
/// use femvi::forces::LinearForce;
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // Linear damping: det of the flow over time T is e^{−cT/m} (to the method's error).
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, Start::Momentum { q: vec![1.0], p: vec![0.0] }, 0.0, 2.0);
/// let (m, _) = forced_sensitivity(&problem, &LinearForce::damping(1, 0.3), &Element::with_order(6)?, &SolveOptions::step(0.1))?;
/// assert!((m[0] * m[3] - m[1] * m[2] - (-0.6f64).exp()).abs() < 1e-9);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn forced_sensitivity<L: Lagrangian + Sync, F: Force + Sync>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    options: &SolveOptions,
) -> Result<(Vec<f64>, FinalNode)> {
    let mut it = forced_integrator(problem, force, element, options)?;
    super::sensitivity_on(&mut it, options.max_steps)
}

/// The forced run of `problem` as `femvi run` takes it: the integrator with its force term.
fn forced_integrator<'a, L: Lagrangian + Sync, F: Force + Sync>(
    problem: &'a Problem<L>,
    force: &'a F,
    element: &'a Element,
    options: &SolveOptions,
) -> Result<Integrator<'a, L>> {
    if matches!(options.steps, Steps::Energy { .. }) {
        // The capability table's refusal (forces, chaos in energy mode), with its reason.
        return Err(crate::error::invalid(
            "time steps as variables (energy mode)",
            "the tangent map of the forced energy equation is not derived (with forces the step \
             size depends on the state through the energy balance); use steps as parameters",
        ));
    }
    let grid = crate::solution::grid(problem, &options.steps)?;
    let start = problem.start.clone();
    Integrator::with_force(&problem.lagrangian, element, grid, start, options.solver, force)
}
