//! [`solve_adaptive`]: a [`Problem`] in physical time integrated with fixed steps Δs in the
//! fictitious time of the Poincaré transformation (`lagrangian.rs`), driven by the library's
//! integrator and run driver ([`crate::step::drive`]) and recorded in physical time
//! (`record.rs`).

use super::borrowed::Borrowed;
use super::lagrangian::TimeTransformed;
use super::monitor::Monitor;
use super::record::Recorder;
use super::{AdaptiveOptions, AdaptiveSolution};
use crate::discrete::Element;
use crate::error::{check_len, invalid, Result};
use crate::lagrangian::{hamiltonian, Lagrangian, PointDerivatives};
use crate::solution::Problem;
use crate::step::{drive, Integrator, Method, SolverOptions, Start, TimeGrid};

/// The start as (q0, p0), as [`solve_adaptive`] takes it: from (q0, v0) by p0 = ∂L/∂v; the
/// start from (q0, q1) is refused (q1 would be at an unknown fictitious time).
///
/// # Errors
/// A start from (q0, q1), or wrong lengths.
///
/// ```
/// use femvi::adaptive::start_momentum;
/// let kepler = femvi::models::kepler(1.0)?;
/// let start = femvi::Start::Velocity { q: vec![1.0, 0.0], v: vec![0.0, 1.0] };
/// assert_eq!(start_momentum(&kepler, 0.0, &start)?.1, vec![0.0, 1.0]);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn start_momentum<L: Lagrangian>(lag: &L, t0: f64, start: &Start) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = lag.dim();
    match start {
        Start::Momentum { q, p } => {
            check_len("q0", n, q.len())?;
            check_len("p0", n, p.len())?;
            Ok((q.clone(), p.clone()))
        }
        Start::Velocity { q, v } => {
            check_len("q0", n, q.len())?;
            check_len("v0", n, v.len())?;
            let mut work = PointDerivatives::new(n);
            lag.first_derivatives(t0, q, v, false, &mut work);
            Ok((q.clone(), work.l_v().to_vec()))
        }
        Start::Positions { .. } => Err(invalid(
            "adaptive steps",
            "a start from (q0, q1) has no place in fictitious time: give (q0, v0) or (q0, p0)",
        )),
    }
}

/// Integrates `problem` (autonomous L, physical span [t0, t_end]) with fixed steps
/// `options.ds` in fictitious time s, dt/ds = `monitor`(q), and `element`, until the first
/// node at or past t_end. Returns the nodes with s, physical t, q, p (the physical momentum),
/// v and H, and the states at `options.saveat` (physical times).
///
/// A numerical failure during the run is not an `Err`: the solution then holds everything up
/// to the last good node and the error in [`AdaptiveSolution::error`].
///
/// # Errors
/// A non-autonomous L, a start from (q0, q1), wrong dimensions, Δs not positive and finite,
/// an invalid span, `saveat` not increasing, g(q0) not positive and finite, and the errors
/// of [`Integrator::new`].
///
/// # Example
///
/// ```
/// use femvi::adaptive::{solve_adaptive, AdaptiveOptions, KeplerMonitor};
/// use femvi::{models, Element, Problem, Start};
///
/// // Kepler, e = 0.9, one period (2π) with steps ds = 0.05 in s (g = r^{3/2}).
/// let e: f64 = 0.9;
/// let start = Start::Momentum { q: vec![1.0 - e, 0.0], p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()] };
/// let period = 2.0 * std::f64::consts::PI;
/// let problem = Problem::new(models::kepler(1.0)?, start, 0.0, 10.0);
/// let options = AdaptiveOptions { saveat: vec![period], ..AdaptiveOptions::step(0.05) };
/// let sol = solve_adaptive(&problem, KeplerMonitor, &Element::with_order(4)?, &options)?;
/// assert!(sol.error.is_none() && *sol.t.last().unwrap() >= 10.0);
/// // Back at pericentre after one period.
/// assert!((sol.saved.q[0] - 0.1).abs() < 1e-5 && sol.saved.q[1].abs() < 1e-4);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn solve_adaptive<L: Lagrangian, G: Monitor>(
    problem: &Problem<L>,
    monitor: G,
    element: &Element,
    options: &AdaptiveOptions,
) -> Result<AdaptiveSolution> {
    let run = setup(problem, monitor, options)?;
    let n = problem.lagrangian.dim();
    let mut it = Integrator::new(&run.lagrangian, element, run.grid, run.start, run.solver)?;
    let mut recorder = Recorder::new(element, n, problem.t0, problem.t_end, options);
    let report = drive(&mut it, &mut [&mut recorder]);
    let stopped = report.stopped && !recorder.reached;
    let rows = recorder.take();
    let statistics = (report.steps, it.mean_iterations(), stopped);
    Ok(AdaptiveSolution::from_rows(n, run.e0, rows, statistics, report.error))
}

/// The parts of an adaptive run of `problem` with `monitor` and `options` (the checks and
/// set-up of [`solve_adaptive`]): the time-transformed Lagrangian L_g on the problem's
/// Lagrangian, the grid in s (long enough for the step limit; a [`super::Recorder`] stops the
/// run at the physical end), the start (q0, p0), the step solver and the energy level E₀. A
/// streaming run builds its [`Integrator`] from them and drives it with a recorder.
///
/// # Errors
/// As [`solve_adaptive`].
///
/// # Example
///
/// ```
/// use femvi::adaptive::{setup, AdaptiveOptions, KeplerMonitor};
/// use femvi::{models, Problem, Start};
///
/// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
/// let problem = Problem::new(models::kepler(1.0)?, start, 0.0, 1.0);
/// let run = setup(&problem, KeplerMonitor, &AdaptiveOptions::step(0.1))?;
/// assert!((run.e0 + 0.5).abs() < 1e-15 && run.grid.nominal(0) == 0.1);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn setup<'l, L: Lagrangian, G: Monitor>(
    problem: &'l Problem<L>,
    monitor: G,
    options: &AdaptiveOptions,
) -> Result<AdaptiveSetup<'l, L, G>> {
    let lag = &problem.lagrangian;
    let (t0, t_end) = (problem.t0, problem.t_end);
    if !(t0.is_finite() && t_end.is_finite() && t_end > t0) {
        return Err(invalid(
            "time span",
            format!("need finite t0 < t_end, got [{t0}, {t_end}]"),
        ));
    }
    let ds = options.ds;
    if !(ds.is_finite() && ds > 0.0) {
        return Err(invalid("ds", format!("{ds} is not a positive finite number")));
    }
    let saveat = &options.saveat;
    if saveat.iter().any(|t| !t.is_finite()) || saveat.windows(2).any(|w| w[0] >= w[1]) {
        return Err(invalid("saveat", "times must be finite and strictly increasing"));
    }
    let n = lag.dim();
    let (q0, p0) = start_momentum(lag, t0, &problem.start)?;
    let mut v0 = vec![0.0; n];
    let mut e0 = hamiltonian(lag, t0, &q0, &p0, &mut v0, &mut PointDerivatives::new(n))?;
    if let Some(level) = options.energy_level {
        // Only a refinement of H(q0, p0): a level far from it would be another orbit.
        if !(level.is_finite() && (level - e0).abs() <= 1e-8 * (1.0 + e0.abs())) {
            return Err(invalid(
                "energy level",
                format!("E0 = {level} is not H(q0, p0) = {e0} up to rounding"),
            ));
        }
        e0 = level;
    }
    if monitor.dim() != 0 {
        check_len("monitor", n, monitor.dim())?;
    }
    let g0 = monitor.value(&q0);
    if !(g0.is_finite() && g0 > 0.0) {
        return Err(invalid("monitor", format!("g(q0) = {g0} is not positive and finite")));
    }
    let lg = TimeTransformed::new(Borrowed(lag), monitor, e0)?;
    let lg = if options.hand_derivatives { lg } else { lg.by_ad() };
    // A grid in s long enough for the step limit; the recorder stops at t_end.
    let s_end = ds * (options.max_steps as f64 + 1.0);
    let grid = TimeGrid::uniform(0.0, ds, s_end)?;
    // Auto is full Newton here: on the e = 0.9 Kepler orbit (order 8, ds 0.3) the simplified
    // iteration's energy slope over 10⁴ periods was −1.2e-16 per period against full Newton's
    // −2e-17 (measured, `examples/adaptive_drift`), for 0.85× the time per step. The fixed
    // point (`Method::FixedPoint`, mechanical L: `step/gyroscopic/divided.rs`) takes about a
    // third of full Newton's time per step with the same drift bounds
    // (`tests/all/adaptive_drift.rs`), but it contracts only for steps ds small enough (31
    // sweeps per step at ds = 0.6 on Kepler e = 0.9, order 8) and has no Newton fallback, so
    // it is asked for, not the default.
    let mut solver = options.solver;
    if solver.method == Method::Auto {
        solver.method = Method::FullNewton;
    }
    Ok(AdaptiveSetup {
        lagrangian: lg,
        grid,
        start: Start::Momentum { q: q0, p: p0 },
        solver,
        e0,
    })
}

/// The parts of an adaptive run ([`setup`]).
#[derive(Debug, Clone)]
pub struct AdaptiveSetup<'l, L, G> {
    /// L_g on the problem's Lagrangian.
    pub lagrangian: TimeTransformed<Borrowed<'l, L>, G>,
    /// Fixed steps ds in s.
    pub grid: TimeGrid,
    /// (q0, p0).
    pub start: Start,
    /// The step solver (`Method::Auto` made full Newton).
    pub solver: SolverOptions,
    /// The energy level E₀ of the transformation.
    pub e0: f64,
}
