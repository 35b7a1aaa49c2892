//! Which uses each term of a problem goes through (issue 33, item 4): one table, [`REFUSED`],
//! of the pairs (term, use) that stay refused, each with its reason. Every command, run
//! option and the Python package ask it through [`check`] (or [`Problem::refuse`]); the
//! combinations that no command can run (a term with another term, or with a time mode) are
//! refused when the problem is loaded ([`check_terms`]). A pair that is not in the table works.
//!
//! The reasons are mathematical: a step or tangent map whose equations are not derived for
//! the pair, or a study that refines a step the pair does not have.

use super::terms::Terms;
use super::Problem;

/// A term of a problem beside its Lagrangian.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Term {
    /// `[forces]`.
    Forces,
    /// `[constraints]`.
    Constraints,
    /// `[time] mode = "adaptive"`.
    Adaptive,
    /// `[forces]` in `[time] mode = "energy"` (time steps as variables): the forced energy
    /// equation sets each step (`Integrator::with_force_energy`).
    ForcesInEnergyMode,
    /// `[system] rotations` (or a rigid-body model): Lie-group elements
    /// (`Integrator::with_rotations`).
    Rotations,
    /// `[forces]` with rotations: torques on the Lie-group element
    /// (`Integrator::with_rotations_and_force`).
    ForcedRotations,
}

impl Term {
    /// How messages name the term.
    pub fn label(self) -> &'static str {
        match self {
            Term::Forces => "[forces]",
            Term::Constraints => "[constraints]",
            Term::Adaptive => "[time] mode = \"adaptive\"",
            Term::ForcesInEnergyMode => "[forces] in [time] mode = \"energy\"",
            Term::Rotations => "[system] rotations",
            Term::ForcedRotations => "[forces] on [system] rotations",
        }
    }
}

/// What a user asks of a problem: a command, a run option, or another term with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Use {
    /// `femvi convergence`.
    Convergence,
    /// `femvi convergence --l2`: the L² error of each run's element polynomials.
    ConvergenceL2,
    /// `femvi ensemble` and Python's `femvi.ensemble`.
    Ensemble,
    /// `femvi chaos`.
    Chaos,
    /// `femvi chaos` in `[time] mode = "energy"`.
    ChaosInEnergyMode,
    /// `femvi check`.
    Check,
    /// `[[events]]` located during a run (the command or Python's `events=`).
    Events,
    /// `femvi run --resume`.
    Resume,
    /// Plots (`--plot`, `[output] plots = true`).
    Plots,
    /// trajectory.npy (`--format npy`).
    Npy,
    /// Python's `saveat=`, `dense=True` and `events=` (or `[[events]]` in a file it solves):
    /// what the Python package samples from a run's element polynomials.
    SaveatOrDense,
    /// `[time] mode = "energy"` (time steps as variables).
    EnergyMode,
    /// A Python potential (`femvi.solve(..., potential=...)`).
    PythonPotential,
    /// A problem file solved from Python (`femvi.solve`, `femvi.ensemble`, `femvi.load`).
    Python,
    /// `[time] accuracy`: femvi chooses h from an estimate of the element's error.
    AccuracyStep,
    /// `[initial] q1`: the start from two positions (the first element solved with both ends
    /// fixed).
    TwoPositionStart,
    /// Another term in the same problem.
    With(Term),
}

impl Use {
    /// The subject of a refusal of an option ("… is not available with …"); None for a
    /// command, which the caller names.
    fn subject(self) -> Option<&'static str> {
        Some(match self {
            Use::Convergence | Use::Ensemble | Use::Chaos | Use::Check => return None,
            Use::ConvergenceL2 => "`femvi convergence --l2` is",
            Use::ChaosInEnergyMode => "`femvi chaos` in [time] mode = \"energy\" is",
            Use::Events => "[[events]] are",
            Use::Resume => "--resume is",
            Use::Plots => "plots are",
            Use::Npy => "trajectory.npy (--format npy) is",
            Use::SaveatOrDense => "saveat, dense output and events in Python are",
            Use::EnergyMode => "[time] mode = \"energy\" is",
            Use::PythonPotential => "a Python potential is",
            Use::Python => "solving it from Python is",
            Use::AccuracyStep => "`[time] accuracy` is",
            Use::TwoPositionStart => "a start from two positions ([initial] q1) is",
            Use::With(t) => match t {
                Term::Forces => "[forces] are",
                Term::Constraints => "[constraints] are",
                Term::Adaptive => "[time] mode = \"adaptive\" is",
                Term::ForcesInEnergyMode => "[forces] in [time] mode = \"energy\" are",
                Term::Rotations => "[system] rotations are",
                Term::ForcedRotations => "[forces] on [system] rotations are",
            },
        })
    }
}

/// The pairs (term present, use) that are refused, with the reason.
pub const REFUSED: &[(Term, Use, &str)] = &[
    (
        Term::Adaptive,
        Use::With(Term::Forces),
        "the time transformation of femvi::adaptive is derived for a conservative system (its \
         extended Hamiltonian is constant); with forces that is no longer so and the transformed \
         step is not derived; use mode = \"fixed\"",
    ),
    (
        Term::Adaptive,
        Use::With(Term::Constraints),
        "the time-transformed step with multipliers is not derived; use mode = \"fixed\"",
    ),
    (
        Term::Constraints,
        Use::EnergyMode,
        "the energy equation that sets each step is not derived for the augmented action with \
         multipliers; use mode = \"fixed\"",
    ),
    (
        Term::Adaptive,
        Use::Convergence,
        "the study refines fixed steps h, and adaptive steps follow the monitor; use mode = \"fixed\"",
    ),
    (
        Term::ForcesInEnergyMode,
        Use::Convergence,
        "the study refines fixed steps h, and in energy mode the energy equation sets each step; use mode = \"fixed\"",
    ),
    (
        Term::Adaptive,
        Use::Chaos,
        "the indicators (MEGNO, Lyapunov exponents) are rates in physical time, and the tangent map of an adaptive step lives in the fictitious time s: their reparametrisation is not derived; use mode = \"fixed\"",
    ),
    (
        Term::Forces,
        Use::ChaosInEnergyMode,
        "the tangent map of the forced energy equation is not derived; use mode = \"fixed\"",
    ),
    (
        Term::ForcedRotations,
        Use::Chaos,
        "the tangent map of a forced Lie-group step (the torques' derivatives in the step's \
         unknowns, which its Newton iteration leaves out) is not derived",
    ),
    (
        Term::Rotations,
        Use::AccuracyStep,
        "the step is chosen from the local error constant of the element on coordinates (its \
         derivatives of the solution in R^n); that of the Lie-group element, whose error lives \
         in the algebra along R_k exp(xi), is not derived; give `step` or `steps`",
    ),
    (
        Term::Rotations,
        Use::TwoPositionStart,
        "the start from (R0, R1) is the two-point problem of the first element on SO(3) (its \
         internal nodes and both ends' momenta with R1 = R0 exp(xi) fixed), which the Lie-group \
         element does not solve yet; give each rotation X its X_w or p_X",
    ),
];

/// Why a use is in [`ROTATIONS_REFUSED`]: its steps would take the nine entries of each
/// rotation as free coordinates, off SO(3).
const ON_COORDINATES: &str = "this use still steps the nine entries of a rotation as free coordinates, off SO(3); \
     the Lie-group element runs through `femvi run`, `check`, `chaos`, `convergence`, `ensemble` and Python (issue 37)";

/// The uses that a problem with rotations does not go through yet, with their reasons.
pub const ROTATIONS_REFUSED: &[(Use, &str)] = &[
    (Use::ChaosInEnergyMode, ON_COORDINATES),
    (Use::EnergyMode, ON_COORDINATES),
    (Use::PythonPotential, ON_COORDINATES),
    (Use::With(Term::Constraints), ON_COORDINATES),
    (Use::With(Term::Adaptive), ON_COORDINATES),
];

/// The terms of `terms` that are present.
fn present(terms: &Terms) -> impl Iterator<Item = Term> + '_ {
    [
        (Term::Forces, terms.force.is_some()),
        (Term::Constraints, terms.constraints.is_some()),
        (Term::Adaptive, terms.adaptive.is_some()),
        (Term::ForcesInEnergyMode, terms.force.is_some() && terms.energy_mode),
        (Term::Rotations, terms.rotations.is_some()),
        (
            Term::ForcedRotations,
            terms.rotations.is_some() && terms.force.is_some(),
        ),
    ]
    .into_iter()
    .filter_map(|(t, on)| on.then_some(t))
}

/// Err if `terms` refuse `what` (named `name` in the message when it is a command).
///
/// # Errors
/// The refusal, with its reason: "`name` does not support \[forces\] (reason)" for a command,
/// "plots are not available with \[forces\]: reason" for an option.
///
/// # Example
///
/// ```
/// use femvi_cli::problem::capabilities::{check, Use};
/// let text = "[system]\nmodel = \"pendulum\"\n[initial]\nq = [1.0]\np = [0.0]\n\
///             [time]\nstep = 0.1\nend = 1.0\n[forces]\ngeneralized = [\"-0.1*theta_dot\"]\n";
/// let problem = femvi_cli::problem::load_text(std::path::Path::new("damped.toml"), text, &[])?;
/// assert!(check(&problem.terms, Use::Ensemble, "femvi ensemble").is_ok());
/// let refused = check(&problem.terms, Use::ChaosInEnergyMode, "femvi chaos").unwrap_err();
/// assert!(refused.starts_with("`femvi chaos` in [time] mode = \"energy\" is not available with [forces]"));
/// # Ok::<(), femvi_cli::problem::InputError>(())
/// ```
pub fn check(terms: &Terms, what: Use, name: &str) -> Result<(), String> {
    for term in present(terms) {
        let rotations = ROTATIONS_REFUSED
            .iter()
            .find(|(u, _)| term == Term::Rotations && *u == what)
            .map(|r| r.1);
        let listed = REFUSED.iter().find(|(t, u, _)| *t == term && *u == what).map(|r| r.2);
        if let Some(why) = rotations.or(listed) {
            return Err(match what.subject() {
                Some(subject) => format!("{subject} not available with {}: {why}", term.label()),
                None => format!("{name} does not support {} ({why})", term.label()),
            });
        }
    }
    Ok(())
}

/// Err for the combinations that no command runs: a term with another, or
/// `[time] mode = "energy"` (`energy_mode`) with a term that has no energy equation.
///
/// # Errors
/// The refusal with its reason.
pub fn check_terms(terms: &Terms, energy_mode: bool) -> Result<(), String> {
    for other in present(terms) {
        check(terms, Use::With(other), "")?;
    }
    if energy_mode {
        check(terms, Use::EnergyMode, "")?;
    }
    Ok(())
}

impl Problem {
    /// [`check`] on this problem's terms.
    ///
    /// # Errors
    /// The refusal with its reason.
    pub fn refuse(&self, what: Use, name: &str) -> Result<(), String> {
        check(&self.terms, what, name)
    }
}
