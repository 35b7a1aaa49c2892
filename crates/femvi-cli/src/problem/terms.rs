//! The terms of a problem beside its Lagrangian (issue 33, item 1): the non-conservative force
//! of `[forces]`, the holonomic constraints of `[constraints]` and the time transformation of
//! `[time] mode = "adaptive"`, compiled once by the loader and carried by the loaded problem.
//! Every command and the Python package read them here; none parses the problem's text again.
//! Which uses each term goes through is the table of [`super::capabilities`].

use super::forces::ProblemForce;
use super::time::AdaptiveTime;
use femvi::constraints::{Enforcement, ExprConstraints};

/// The optional terms of a problem, checked and compiled.
///
/// # Example
///
/// ```
/// let text = "[system]\nmodel = \"pendulum\"\n[initial]\nq = [1.0]\np = [0.0]\n\
///             [time]\nstep = 0.1\nend = 1.0\n[forces]\ngeneralized = [\"-0.1*theta_dot\"]\n";
/// let problem = femvi_cli::problem::load_text(std::path::Path::new("damped.toml"), text, &[])?;
/// assert!(problem.terms.force.is_some());
/// assert!(problem.terms.constraints.is_none() && problem.terms.adaptive.is_none());
/// # Ok::<(), femvi_cli::problem::InputError>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct Terms {
    /// `[forces]`: the generalized force F(t, q, v) (discrete Lagrange–d'Alembert).
    pub force: Option<ProblemForce>,
    /// `[constraints]`: g(q) = 0 and where the elements enforce it.
    pub constraints: Option<(ExprConstraints, Enforcement)>,
    /// `[time] mode = "adaptive"`: the step in fictitious time and the monitor.
    pub adaptive: Option<AdaptiveTime>,
    /// `[time] mode = "energy"`: time steps as variables (the energy equation sets each step).
    pub energy_mode: bool,
    /// `[system] rotations` (or a rigid-body model): the rotation blocks, stepped by the
    /// Lie-group element (`femvi::Integrator::with_rotations`).
    pub rotations: Option<femvi::rotation::Rotations>,
}
