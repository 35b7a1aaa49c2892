//! Adaptive steps that stay symplectic, by the Poincaré time transformation (issue 21;
//! DESIGN.md §4; Hairer, Lubich, Wanner, *Geometric Numerical Integration*, §VIII.2).
//!
//! For an autonomous L and a monitor g(q) > 0, fictitious time s with dt/ds = g(q):
//! L_g(q, q') = g(q)·(L(q, q'/g(q)) + E₀), E₀ = H(q₀, p₀) ([`TimeTransformed`]). Fixed steps Δs
//! of any femvi element on L_g are steps g·Δs in t, small where g is small, and the map
//! (q, p) ↦ (q, p) is symplectic with the physical momentum p. The physical time t(s) is
//! the element quadrature of g (`clock.rs`); [`solve_adaptive`] records nodes and requested
//! physical times. Monitors: [`KeplerMonitor`] (|q|^{3/2}), [`NBodyMonitor`], [`ExprMonitor`],
//! or any [`Monitor`].
//!
//! # Choosing Δs
//!
//! With [`KeplerMonitor`], one orbit of semi-major axis a and eccentricity e takes
//! S(e) = ∫₀^{2π} (1 − e cos E)^{−1/2} dE / √μ in s (dt = r dE·√(a/μ) and r = a(1 − e cos E)),
//! whatever a: S = 2π (e = 0), 6.63 (0.5), 8.37 (0.9), 11.45 (0.99), 14.7 (0.999), so a run
//! takes S(e)/Δs steps per orbit (measured: 83.7 and 114.5 per orbit at Δs = 0.1 for e = 0.9
//! and 0.99). The position error after N orbits is about N·C·Δs^{2s} for degree s, with C
//! nearly independent of e: C ≈ 0.02 (order 4) and C ≈ 6e-6 (order 8), measured on Kepler
//! e = 0.9 and 0.99 over 1 000 orbits (`examples/adaptive_kepler.rs`; e.g. order 8, Δs = 0.3:
//! 3.7e-7 and 2.5e-7). So Δs ≈ (ε/(N C))^{1/(2s)} for an error ε, relative to a; below
//! about 1e-11·N (order 8, e = 0.9) round-off dominates. For very eccentric orbits E₀ in f64
//! is the floor (an E₀ off by δ shifts the mean motion by about δ/E; `energy.rs`): at
//! e = 0.99 over 1 000 orbits 7e-9 with H(q₀, p₀) in f64, 1.3e-10 with
//! [`AdaptiveOptions::energy_level`] from [`kepler_energy`] (benches/peers/eccentric.md).
//! For N bodies, [`NBodyMonitor`] gives the same rule with the closest pair's orbits.

mod borrowed;
mod clock;
mod derivatives;
mod energy;
mod events;
mod lagrangian;
mod monitor;
mod record;
mod solve;

pub use borrowed::Borrowed;
pub use energy::{kepler_energy, nbody_energy};
pub use lagrangian::TimeTransformed;
pub use monitor::{ExprMonitor, KeplerMonitor, Monitor, NBodyMonitor};
pub use record::{AdaptiveRows, Recorder};
pub use solve::{setup, solve_adaptive, start_momentum, AdaptiveSetup};

use crate::error::Error;
use crate::solution::{Event, EventRecord, Saved};
use crate::step::SolverOptions;

/// What [`solve_adaptive`] computes and keeps.
#[derive(Debug, Clone)]
pub struct AdaptiveOptions {
    /// The step Δs in fictitious time.
    pub ds: f64,
    /// Tolerance, iteration cap and method of the step solver (Newton: L_g has a
    /// position-dependent mass matrix). `Method::Auto` is full Newton (`Method::FullNewton`),
    /// whose energy drifts least; `Method::Newton` takes the simplified iteration (0.85× the
    /// time per step on adaptive Kepler); `Method::FixedPoint`, for a mechanical L, the
    /// fixed point with the divisor g (`step/gyroscopic/divided.rs`: about a third of full
    /// Newton's time per step; it contracts only for small enough ds and has no Newton
    /// fallback; `docs/src/adaptive.md`).
    pub solver: SolverOptions,
    /// Keep every `every`-th node (the first and the last always); 0 keeps only those two.
    pub every: usize,
    /// Physical times at which to report the state (increasing; inside the span).
    pub saveat: Vec<f64>,
    /// Events g(t, q, v) located on the dense output: the element polynomial in s, its
    /// velocity divided by g(q) and the physical time t(σ) of the clock (`record.rs`).
    pub events: Vec<Event>,
    /// Stop after this many steps (the run then ends there, `stopped`), so that a monitor
    /// that sends the physical step to zero cannot hang a run. Default 10⁸.
    pub max_steps: usize,
    /// Hand-coded derivatives of L_g for a mechanical L (default true; false: automatic
    /// differentiation of L_g, to compare).
    pub hand_derivatives: bool,
    /// The energy level E₀ if known more accurately than H(q₀, p₀) in f64 (None: that),
    /// e.g. by [`kepler_energy`] or [`nbody_energy`] of [`start_momentum`]'s (q₀, p₀): an E₀
    /// off by δ shifts the mean motion by about δ/E (`energy.rs`).
    pub energy_level: Option<f64>,
}

impl AdaptiveOptions {
    /// Steps Δs = `ds`, every node kept, default solver.
    ///
    /// ```
    /// let options = femvi::adaptive::AdaptiveOptions { every: 10, ..femvi::adaptive::AdaptiveOptions::step(0.01) };
    /// assert_eq!((options.ds, options.max_steps), (0.01, 100_000_000));
    /// ```
    pub fn step(ds: f64) -> Self {
        Self {
            ds,
            solver: SolverOptions::default(),
            every: 1,
            saveat: vec![],
            events: vec![],
            max_steps: 100_000_000,
            hand_derivatives: true,
            energy_level: None,
        }
    }
}

/// The result of [`solve_adaptive`]: the kept nodes (row-major, n per node) in fictitious
/// time s with their physical time t.
#[derive(Debug, Clone)]
pub struct AdaptiveSolution {
    /// Dimension n.
    pub n: usize,
    /// The energy level E₀ = H(q₀, p₀) of the transformation.
    pub e0: f64,
    /// Fictitious times s of the kept nodes.
    pub s: Vec<f64>,
    /// Physical times t(s).
    pub t: Vec<f64>,
    /// Positions.
    pub q: Vec<f64>,
    /// Momenta p = ∂L/∂v (the same for L and L_g).
    pub p: Vec<f64>,
    /// Physical velocities v = dq/dt (inverse Legendre transform of L).
    pub v: Vec<f64>,
    /// H(q, p) of the physical Lagrangian (E₀ up to the method's error, without drift).
    pub energy: Vec<f64>,
    /// States at the `saveat` times.
    pub saved: Saved,
    /// Located events, in time order per step (t, q, the physical v and p = ∂L/∂v).
    pub events: Vec<EventRecord>,
    /// Steps taken.
    pub steps: usize,
    /// Mean solver iterations per step.
    pub mean_iterations: f64,
    /// Whether the step limit or a stopping event stopped the run before t_end.
    pub stopped: bool,
    /// The error that stopped the run; the arrays hold everything before it.
    pub error: Option<Error>,
}

impl AdaptiveSolution {
    /// The solution of dimension n at energy level `e0` from the `rows` a [`Recorder`]
    /// recorded, with the run's statistics: (steps, mean iterations, stopped) and its error.
    ///
    /// ```
    /// use femvi::adaptive::{AdaptiveRows, AdaptiveSolution};
    /// let rows = AdaptiveRows { t: vec![0.0, 0.5], energy: vec![-0.5, -0.5], ..AdaptiveRows::default() };
    /// let sol = AdaptiveSolution::from_rows(2, -0.5, rows, (1, 3.0, false), None);
    /// assert_eq!((sol.t.len(), sol.steps), (2, 1));
    /// ```
    pub fn from_rows(
        n: usize,
        e0: f64,
        rows: AdaptiveRows,
        (steps, mean_iterations, stopped): (usize, f64, bool),
        error: Option<Error>,
    ) -> Self {
        AdaptiveSolution {
            n,
            e0,
            s: rows.s,
            t: rows.t,
            q: rows.q,
            p: rows.p,
            v: rows.v,
            energy: rows.energy,
            saved: rows.saved,
            events: rows.events,
            steps,
            mean_iterations,
            stopped,
            error,
        }
    }
}
