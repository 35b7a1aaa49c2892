//! The discrete flow (paper §2 and §3): one step maps (q_k, p_k) to (q_{k+1}, p_{k+1}) by
//! solving p_k = −∂L_d/∂Q^0 and ∂L_d/∂Q^j = 0 (0 < j < s) for the internal and end nodes
//! together ((2.40)–(2.42), generalised to any degree), then p_{k+1} = ∂L_d/∂Q^s. Uniform or
//! variable grids (generalised Veselov mechanics, (2.3)); time steps as variables (§3).
//!
//! # Where a step's data goes
//!
//! A run is a pipeline; each stage is one file:
//!
//! 1. [`options`]: what the user chose — [`Method`], [`SolverOptions`], [`Start`].
//! 2. `first.rs`: the start turns into the first node (and, from (q0, q1), the first element).
//! 3. `state.rs`: the run's state apart from any solver — the node (k, t_k, q_k, p_k) with the
//!    compensation terms of its sums, counters, and the last solved element.
//! 4. [`grid`]: the next step h_k (or, in energy mode, `energy.rs` searches it, (3.3)).
//! 5. `solver.rs`: `choose` resolves the method; `Solver` dispatches statically to one of
//!    `explicit.rs` (Störmer–Verlet, with a fixed-size fast loop), `fixed_point_step.rs`
//!    (iteration on forces, tables from [`fixed_point`], start from `start.rs`) or
//!    `newton_step.rs` (any Lagrangian, starting values from `guess.rs`), or `gyroscopic/`
//!    (L = ½vᵀMv + A·v − V, fixed point on the vector potential and ∂L/∂q; with a mass
//!    divisor for the time-transformed L_g of adaptive steps). A solver owns only
//!    its workspace and caches; it reads the state and the last element and writes the
//!    solved element's increments (`Increments`).
//! 6. `state.rs` again: the increments are committed to the node with compensated sums.
//! 7. [`drive()`]: steps to the end and hands every accepted node to the [`Observer`]s, which
//!    record it (the CLI's CSV, NPY, plots and summary are observers); `tangent.rs` gives
//!    the step's tangent map for diagnostics.
//!
//! # How extensions plug in
//!
//! The step equations are the element's residual R_j(X) = δ_j0 p_k + ∂L_d/∂Q^j and, for the
//! fixed-point and explicit solvers, the force form of the same equations. Planned
//! extensions add terms or unknowns here without touching the solvers' loops:
//! - *Non-conservative forces* (discrete Lagrange–d'Alembert): a term
//!   h Σ_i b_i F(t_i, q_h(c_i), q̇_h(c_i)) ℓ_j(c_i) added to R_j; for the fixed-point solver
//!   the force at the stages gains F (the `Lagrangian::forces` call becomes forces + F). Done
//!   as a term (`term.rs`): `Integrator::with_force` (`forces/term.rs`) hands each step's
//!   solve to the term and keeps the rest of the run.
//! - *Holonomic constraints* g(q) = 0: multipliers λ as extra unknowns of the Newton solver
//!   (R_j gains −∇g(Q^j)ᵀλ and the system gains g(Q^s) = 0), and a projection of p; a new
//!   `Solver` variant owning the enlarged workspace, selected by `choose`.
//! - *Time transformations* (adaptive steps): a transformed Lagrangian L_g(q, q') that is
//!   itself a `Lagrangian`, integrated with fixed steps in fictitious time; only an observer
//!   maps s to t.
//! - *Tangent propagation* (chaos indicators, sensitivities): the linearisation of the
//!   committed step (`tangent.rs`) applied to tangent vectors, an observer of each node.

pub mod auto;
pub(crate) mod checkpoint;
pub mod drive;
mod element_work;
mod energy;
mod energy_search;
mod explicit;
mod first;
pub mod fixed_point;
mod fixed_point_judge;
pub(crate) mod fixed_point_step;
pub mod grid;
mod guess;
mod guess_correction;
mod gyroscopic;
pub mod integrator;
mod integrator_views;
mod newton_residual;
mod newton_step;
pub mod options;
pub(crate) mod solver;
mod start;
pub(crate) mod state;
mod tangent;
pub(crate) mod tangent_apply;
mod tangent_mechanical;
pub(crate) mod term;
mod term_history;
mod term_tangent;

pub use checkpoint::Checkpoint;
pub use drive::{drive, DriveReport, Observer};
pub(crate) use element_work::check_dense_newton;
pub use element_work::MAX_DENSE_NEWTON;
pub(crate) use energy::check_bounds as energy_bounds;
pub use energy::{Degenerate, EnergyOptions, EnergyStats};
pub(crate) use first::initial_node;
#[cfg(test)]
pub(crate) use fixed_point_judge::{Judge, Verdict};
pub(crate) use fixed_point_step::{COEFFICIENT_ROUNDING, RICH_START_POINTS, ROUNDOFF_ULPS, START_MAX_POINTS};
pub use grid::{TimeGrid, UniformRule};
pub(crate) use guess::Guess;
pub use integrator::Integrator;
pub use options::{Method, SolverOptions, Start};
pub(crate) use start::StageStart;
pub(crate) use state::LastElement;
pub use state::{ElementNodes, Node};
