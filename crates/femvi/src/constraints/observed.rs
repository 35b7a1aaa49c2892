//! Constrained runs through the recorder of every run ([`crate::solution::solve_with`]): the one
//! integrator with the constraints as its term (`term.rs`) driven with `saveat`, dense output,
//! events and the caller's observers, so that the samples, the dense output and the event
//! times come from the constrained element polynomials. The nodes are those of
//! [`super::solve_constrained_with`] (and, with a force, [`super::solve_constrained_forced`]) bit
//! for bit; the multipliers and residuals at a node are
//! [`Integrator::node_constraints`](crate::Integrator::node_constraints), which an observer
//! reads.

use super::layout::Enforcement;
use super::term::Constrained;
use super::Constraints;
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::forces::Force;
use crate::lagrangian::Lagrangian;
use crate::solution::{grid, solve_on, Problem, Solution, SolveOptions, Steps};
use crate::step::{Integrator, Observer};

/// Solves a constrained problem as [`super::solve_constrained_with`] does, through the
/// recorder of [`crate::solution::solve_with`]: `saveat`, `dense` and `events` of `options` are sampled
/// and located on the constrained element polynomials, and `observers` see every node.
///
/// # Errors
/// As [`super::solve_constrained_with`], but for `saveat`, events and dense output, which are
/// taken here; time steps as variables.
///
/// # Example
///
/// The spherical pendulum's crossings of the plane x = 0, located on the element polynomials:
///
/// ```
/// use femvi::constraints::{solve_constrained_observed, Enforcement, ExprConstraints};
/// use femvi::expr::ExprLagrangian;
/// use femvi::solution::Event;
/// use femvi::{Element, Problem, SolveOptions, Start};
///
/// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
/// let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z", &xyz, &[])?;
/// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[])?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 1.0, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 3.0);
/// let options = SolveOptions {
///     events: vec![Event::new("x = 0", |_t, q: &[f64], _v: &[f64]| q[0])],
///     dense: true,
///     ..SolveOptions::step(0.01)
/// };
/// let sol = solve_constrained_observed(&problem, &sphere, &Element::with_order(4)?, &options, Enforcement::Weak, &mut [])?;
/// assert!(!sol.events.is_empty() && sol.events[0].q[0].abs() < 1e-10);
/// assert!(sol.dense.is_some());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn solve_constrained_observed<L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
    observers: &mut [&mut dyn Observer<L>],
) -> Result<Solution> {
    let parts = Constrained::new(constraints, enforcement, None);
    observed(problem, element, options, parts, observers)
}

/// [`solve_constrained_observed`] under the non-conservative force `force`: the nodes of
/// [`super::solve_constrained_forced`], with [`Integrator::work`](crate::Integrator::work)
/// the discrete work at each node for the observers.
///
/// # Errors
/// As [`solve_constrained_observed`]; a force of another dimension.
#[allow(clippy::too_many_arguments)]
pub fn solve_constrained_forced_observed<L: Lagrangian + Sync, F: Force + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    force: &F,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
    observers: &mut [&mut dyn Observer<L>],
) -> Result<Solution> {
    crate::error::check_len("force", problem.lagrangian.dim(), force.dim())?;
    let parts = Constrained::new(
        constraints,
        enforcement,
        Some(Box::new(super::forcing::Forcing::new(
            force,
            element,
            problem.lagrangian.dim(),
        ))),
    );
    observed(problem, element, options, parts, observers)
}

fn observed<'a, L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &'a Problem<L>,
    element: &'a Element,
    options: &SolveOptions,
    parts: Constrained<'a, C>,
    observers: &mut [&mut dyn Observer<L>],
) -> Result<Solution> {
    if let Steps::Energy { .. } = options.steps {
        return Err(invalid(
            "time mode",
            "time steps as variables with constraints: the energy equation that sets each step is not derived for the augmented action with multipliers; use fixed steps",
        ));
    }
    let grid = grid(problem, &options.steps)?;
    let lag = &problem.lagrangian;
    let mut it = Integrator::constrained(lag, element, grid, problem.start.clone(), options.solver, parts)?;
    solve_on(&mut it, problem, element, options, observers)
}
