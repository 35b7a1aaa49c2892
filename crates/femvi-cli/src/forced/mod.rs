//! Problems with a `[forces]` table (issue 19) beside the one run: `femvi run` drives them on
//! the integrator with the force as a term (`Integrator::with_force`, and with `[time] mode =
//! "energy"` `Integrator::with_force_energy`, whose steps come from the forced energy equation;
//! `crate::run`), writing trajectory.csv with a `work` column (the accumulated discrete work W
//! of the forces, so that `energy` − energy₀ − `work` is the balance error) and in the energy
//! mode a `discrete_energy` column Ẽ whose balance Ẽ − Ẽ₀ − W is round-off
//! (summary.json's `max_rel_discrete_energy_balance_error`). Here: `femvi bvp` under a force
//! ([`solve_bvp`], the library's [`femvi::forces::solve_forced_bvp`]), `femvi check`, which
//! reports the energy balance instead of symplecticity (`check.rs`), and the forced models.
//! Commands and options that cannot handle forces refuse them through the table of
//! [`crate::problem::capabilities`].

mod check;
pub mod models;

pub use check::{check, print, ForcedCheck};

use crate::problem::forces::ProblemForce;
use femvi::bvp::{BoundaryValues, BvpOptions, BvpSolution};
use femvi::{Element, Lagrangian};

/// The boundary value problem's solve under `force` if it has one, else the conservative
/// [`femvi::bvp::solve`].
///
/// # Errors
/// As the library's solvers.
pub fn solve_bvp<L: Lagrangian>(
    lag: &L,
    force: Option<&ProblemForce>,
    element: &Element,
    bv: &BoundaryValues,
    guess: &[f64],
    options: BvpOptions,
) -> femvi::Result<BvpSolution> {
    match force {
        Some(f) => femvi::forces::solve_forced_bvp(lag, f, element, bv, guess, options),
        None => femvi::bvp::solve(lag, element, bv, guess, options),
    }
}
