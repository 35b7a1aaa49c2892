//! [`solve`]: builds the integrator for a [`Problem`], drives it with the recorder
//! (`record.rs`) and any observers the caller adds, and gathers the [`Solution`].

use super::record::Recorder;
use super::{Problem, Solution, SolveOptions, Steps};
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::lagrangian::Lagrangian;
use crate::step::{drive, Integrator, Observer, TimeGrid};

/// Integrates `problem` with `element` as `options` ask and returns the [`Solution`].
///
/// A numerical failure during the run is not an `Err`: the solution then holds everything up
/// to the last good node and the error in [`Solution::error`]. See the module documentation
/// ([`crate::solution`]) for an example.
///
/// # Errors
/// Bad input: an invalid span or step, wrong dimensions, options that do not fit (as
/// [`Integrator::new`]), `saveat` times not increasing; and a failure of the first element
/// of a start from (q0, q1).
pub fn solve<L: Lagrangian>(problem: &Problem<L>, element: &Element, options: &SolveOptions) -> Result<Solution> {
    solve_with(problem, element, options, &mut [])
}

/// [`solve`] with further observers of the run (called after the built-in recorder at every
/// node).
///
/// # Errors
/// As [`solve`].
///
/// # Example
///
/// ```
/// use femvi::solution::solve_with;
/// use femvi::step::Observer;
/// use femvi::{models, Element, Integrator, Lagrangian, Problem, SolveOptions, Start};
///
/// /// The largest |q| over all nodes, whatever is kept.
/// struct Largest(f64);
/// impl<L: Lagrangian> Observer<L> for Largest {
///     fn node(&mut self, it: &Integrator<'_, L>, _last: bool) -> femvi::Result<()> {
///         self.0 = self.0.max(it.node().q[0].abs());
///         Ok(())
///     }
/// }
///
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, Start::Velocity { q: vec![1.0], v: vec![0.0] }, 0.0, 10.0);
/// let options = SolveOptions { every: 0, ..SolveOptions::step(0.01) };
/// let mut largest = Largest(0.0);
/// let sol = solve_with(&problem, &Element::midpoint(), &options, &mut [&mut largest])?;
/// assert_eq!(sol.len(), 2); // the first and the last node
/// assert!((largest.0 - 1.0).abs() < 1e-4);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn solve_with<L: Lagrangian>(
    problem: &Problem<L>,
    element: &Element,
    options: &SolveOptions,
    observers: &mut [&mut dyn Observer<L>],
) -> Result<Solution> {
    let grid = grid(problem, &options.steps)?;
    let start = problem.start.clone();
    let lag = &problem.lagrangian;
    let mut it = match &options.steps {
        Steps::Energy { options: e, .. } => Integrator::with_energy(lag, element, grid, start, options.solver, *e)?,
        _ => Integrator::new(lag, element, grid, start, options.solver)?,
    };
    solve_on(&mut it, problem, element, options, observers)
}

/// Drives `it`, a run of `problem` set up by the caller (plain, energy mode, or with a term
/// such as [`Integrator::with_force`] or [`Integrator::with_rotations`]), with the recorder
/// of `options` before `observers`, and returns its [`Solution`]: kept nodes, `saveat`, dense
/// output and events on the elements of whatever the integrator solved (for rotations, each
/// element's path R_k exp(ζ̂(τ)) on SO(3)). The steps are the integrator's: `options.steps`
/// is not read.
///
/// # Errors
/// The recorder's refusal of the options (`saveat` not increasing).
///
/// # Example
///
/// ```
/// use femvi::rotation::{embedded_velocity, so3::orthogonality_defect, Rotations};
/// use femvi::solution::solve_on;
/// use femvi::{models::RigidBody, Element, Integrator, Problem, SolveOptions, Start, TimeGrid};
/// let body = RigidBody::free([1.0, 2.0, 3.0])?;
/// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
/// let problem = Problem::new(body, start, 0.0, 1.0);
/// let element = Element::with_order(4)?;
/// let grid = TimeGrid::uniform(0.0, 0.1, 1.0)?;
/// let layout = Rotations::new(9, &[0])?;
/// let mut it = Integrator::with_rotations(&problem.lagrangian, &element, grid, problem.start.clone(), Default::default(), layout)?;
/// let options = SolveOptions { dense: true, ..SolveOptions::step(0.1) };
/// let sol = solve_on(&mut it, &problem, &element, &options, &mut [])?;
/// // Between nodes R is the element's path, a rotation.
/// let mut q = [0.0; 9];
/// sol.dense.as_ref().expect("asked for").q_at(0.55, &mut q)?;
/// assert!(orthogonality_defect(&q) < 1e-14);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn solve_on<L: Lagrangian>(
    it: &mut Integrator<'_, L>,
    problem: &Problem<L>,
    element: &Element,
    options: &SolveOptions,
    observers: &mut [&mut dyn Observer<L>],
) -> Result<Solution> {
    let lag = &problem.lagrangian;
    let kind = (&problem.start, lag.is_autonomous(), options.energy_nodes.resolve(lag));
    let mut recorder = Recorder::new(options, &element.basis, lag.dim(), kind)?;
    let report = {
        let mut all: Vec<&mut dyn Observer<L>> = Vec::with_capacity(observers.len() + 1);
        all.push(&mut recorder);
        for o in observers.iter_mut() {
            all.push(&mut **o);
        }
        drive(it, &mut all)
    };
    Ok(Solution {
        n: lag.dim(),
        step: std::mem::take(&mut recorder.step),
        t: std::mem::take(&mut recorder.t),
        q: std::mem::take(&mut recorder.q),
        p: std::mem::take(&mut recorder.p),
        v: std::mem::take(&mut recorder.v),
        energy: std::mem::take(&mut recorder.energy),
        saved: std::mem::take(&mut recorder.saved),
        events: std::mem::take(&mut recorder.events),
        dense: recorder.dense.take(),
        steps: report.steps,
        mean_iterations: it.mean_iterations(),
        energy_stats: it.energy_stats(),
        energy_report: recorder.tracker.as_ref().map(|t| t.report()),
        stopped: report.stopped,
        error: report.error,
    })
}

/// The time grid of the problem's span with the steps asked for.
pub(crate) fn grid<L>(problem: &Problem<L>, steps: &Steps) -> Result<TimeGrid> {
    let (t0, end) = (problem.t0, problem.t_end);
    if !(t0.is_finite() && end.is_finite() && end > t0) {
        return Err(invalid(
            "time span",
            format!("need finite t0 < t_end, got [{t0}, {end}]"),
        ));
    }
    match steps {
        Steps::Fixed(h) => TimeGrid::uniform(t0, *h, end),
        Steps::Cycle(list) => TimeGrid::steps(t0, list.clone(), end),
        Steps::Energy { step, .. } => TimeGrid::uniform(t0, *step, end),
    }
}
