//! Problem → solve → solution: [`solve`] runs a [`Problem`] (a Lagrangian, a start and a
//! span) with an element and [`SolveOptions`] to a [`Solution`] that owns its arrays — the
//! kept nodes (`every`), values at requested times (`saveat`, from the dense output),
//! located [`Event`]s, optionally the whole [`DenseOutput`], the solver statistics and the
//! error that stopped the run, if any (what was computed before it is kept).
//!
//! # Example
//!
//! ```
//! use femvi::{models, solve, Element, Problem, SolveOptions, Start};
//!
//! // Kepler, eccentricity 0.5, ten periods with degree 4 (order 8).
//! let e: f64 = 0.5;
//! let start = Start::Momentum { q: vec![1.0 - e, 0.0], p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()] };
//! let problem = Problem::new(models::kepler(1.0)?, start, 0.0, 20.0 * std::f64::consts::PI);
//! let sol = solve(&problem, &Element::with_order(8)?, &SolveOptions::step(0.05))?;
//! assert!(sol.error.is_none());
//! let (first, last) = (sol.energy[0], *sol.energy.last().unwrap());
//! assert!(((last - first) / first).abs() < 1e-10);
//! # Ok::<(), femvi::Error>(())
//! ```

mod dense;
mod energy;
mod energy_nodes;
mod events;
mod located;
mod record;
mod solve;

pub(crate) use solve::grid;

pub use dense::DenseOutput;
pub use energy::{EnergyReport, EnergyTracker, NodeEnergy};
pub use energy_nodes::EnergyNodes;
pub use events::{Condition, Direction, Event, EventRecord};
pub(crate) use events::{Detector, Piece};
pub use located::EventLocator;
pub use solve::{solve, solve_on, solve_with};

use crate::error::Error;
use crate::step::{EnergyOptions, EnergyStats, SolverOptions, Start};

/// A Lagrangian, its initial data and the time span [t0, t_end].
#[derive(Debug, Clone)]
pub struct Problem<L> {
    /// The system.
    pub lagrangian: L,
    /// Initial data at t0.
    pub start: Start,
    /// Start time.
    pub t0: f64,
    /// End time (the run stops at the first node at or past it in energy mode).
    pub t_end: f64,
}

impl<L> Problem<L> {
    /// The problem of `lagrangian` from `start` at `t0` to `t_end`.
    ///
    /// ```
    /// use femvi::{models, Problem, Start};
    /// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
    /// let problem = Problem::new(models::kepler(1.0)?, start, 0.0, 100.0);
    /// assert_eq!(problem.t_end, 100.0);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn new(lagrangian: L, start: Start, t0: f64, t_end: f64) -> Self {
        Self {
            lagrangian,
            start,
            t0,
            t_end,
        }
    }
}

/// How the steps are chosen.
#[derive(Debug, Clone, PartialEq)]
pub enum Steps {
    /// A uniform step (the last one shortened to land on t_end).
    Fixed(f64),
    /// Steps used in turn, cyclically.
    Cycle(Vec<f64>),
    /// Time steps as variables (paper §3): the first step, then steps that keep the discrete
    /// energy.
    Energy {
        /// The first step.
        step: f64,
        /// Bounds and policy.
        options: EnergyOptions,
    },
}

/// What [`solve`] computes and keeps.
#[derive(Debug, Clone)]
pub struct SolveOptions {
    /// The steps.
    pub steps: Steps,
    /// Tolerance, iteration cap and method of the step solver.
    pub solver: SolverOptions,
    /// Keep every `every`-th node (the first and the last always); 0 keeps only those two.
    pub every: usize,
    /// Times at which to report the state, from the dense output (increasing, inside the span;
    /// at node times the nodes themselves).
    pub saveat: Vec<f64>,
    /// Stop after this many steps (the solution then ends there, without an error).
    pub max_steps: Option<usize>,
    /// Keep the dense output of the whole run (memory: (s + 3)·n numbers per step).
    pub dense: bool,
    /// Events to locate.
    pub events: Vec<Event>,
    /// Compute H at every node and report its largest relative error
    /// ([`Solution::energy_report`]; default true). Off, H is computed only at the kept nodes
    /// (cheaper where H needs a Newton solve per node: general Lagrangians with `every` > 1).
    pub track_energy: bool,
    /// Which nodes the energy report covers with [`SolveOptions::track_energy`] (default
    /// [`EnergyNodes::Auto`]: every node where H is cheap, the kept nodes where it needs a
    /// Newton solve; [`EnergyReport::nodes`] says which).
    pub energy_nodes: EnergyNodes,
}

impl SolveOptions {
    /// Uniform steps h, every node kept, default solver, nothing else.
    ///
    /// ```
    /// use femvi::{SolveOptions, Steps};
    /// // Every tenth node and the values at t = 0.5 and 1.5, with a looser solver.
    /// let mut options = SolveOptions { every: 10, saveat: vec![0.5, 1.5], ..SolveOptions::step(0.01) };
    /// options.solver.tolerance = 1e-12;
    /// assert_eq!(options.steps, Steps::Fixed(0.01));
    /// ```
    pub fn step(h: f64) -> Self {
        Self {
            steps: Steps::Fixed(h),
            solver: SolverOptions::default(),
            every: 1,
            saveat: vec![],
            max_steps: None,
            dense: false,
            events: vec![],
            track_energy: true,
            energy_nodes: EnergyNodes::Auto,
        }
    }
}

/// States at requested times (row-major arrays, `t.len()` rows of n).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Saved {
    /// The requested times reached.
    pub t: Vec<f64>,
    /// q there.
    pub q: Vec<f64>,
    /// v there (q̇ of the interpolant).
    pub v: Vec<f64>,
    /// p there (the node's at node times, ∂L/∂v of the interpolant between them).
    pub p: Vec<f64>,
}

/// The result of [`solve`]: arrays of the kept nodes (row-major, one row of n per node).
#[derive(Debug, Clone)]
pub struct Solution {
    /// Dimension n.
    pub n: usize,
    /// Node indices of the kept nodes.
    pub step: Vec<usize>,
    /// Times of the kept nodes.
    pub t: Vec<f64>,
    /// Positions.
    pub q: Vec<f64>,
    /// Momenta (discrete Legendre transforms).
    pub p: Vec<f64>,
    /// Velocities from the momenta (inverse Legendre transform).
    pub v: Vec<f64>,
    /// H(t, q, p) = p·v − L at the kept nodes (conserved only for autonomous L).
    pub energy: Vec<f64>,
    /// States at the `saveat` times.
    pub saved: Saved,
    /// Located events, in time order.
    pub events: Vec<EventRecord>,
    /// The dense output, if asked for.
    pub dense: Option<DenseOutput>,
    /// Steps taken.
    pub steps: usize,
    /// Mean solver iterations per step.
    pub mean_iterations: f64,
    /// Energy mode statistics.
    pub energy_stats: Option<EnergyStats>,
    /// The energy over the nodes of the run [`EnergyReport::nodes`] names (with
    /// [`SolveOptions::track_energy`]).
    pub energy_report: Option<EnergyReport>,
    /// Whether an event or the step limit stopped the run before t_end.
    pub stopped: bool,
    /// The error that stopped the run (a step that failed, or a node whose energy is not
    /// finite: [`Error::NonFiniteEnergy`]); the arrays hold everything before it, all finite.
    pub error: Option<Error>,
}

impl Solution {
    /// A solution of dimension n with nothing recorded yet (the solvers of other equations,
    /// `forces` and `constraints`, fill it as they go).
    pub(crate) fn empty(n: usize) -> Self {
        Self {
            n,
            step: vec![],
            t: vec![],
            q: vec![],
            p: vec![],
            v: vec![],
            energy: vec![],
            saved: Saved::default(),
            events: vec![],
            dense: None,
            steps: 0,
            mean_iterations: 0.0,
            energy_stats: None,
            energy_report: None,
            stopped: false,
            error: None,
        }
    }

    /// Number of kept nodes.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether no node was kept.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// q of kept node i.
    ///
    /// ```
    /// use femvi::{models, solve, Element, Problem, SolveOptions, Start};
    /// let problem = Problem::new(models::harmonic(1.0, 4.0)?, Start::Velocity { q: vec![1.0], v: vec![0.0] }, 0.0, 1.0);
    /// let sol = solve(&problem, &Element::with_order(6)?, &SolveOptions::step(0.1))?;
    /// let last = sol.len() - 1;
    /// assert!((sol.q_row(last).unwrap()[0] - 2f64.cos()).abs() < 1e-7); // ω = 2
    /// assert!(sol.q_row(last + 1).is_none());
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn q_row(&self, i: usize) -> Option<&[f64]> {
        self.q.get(i * self.n..(i + 1) * self.n)
    }

    /// p of kept node i.
    pub fn p_row(&self, i: usize) -> Option<&[f64]> {
        self.p.get(i * self.n..(i + 1) * self.n)
    }
}
