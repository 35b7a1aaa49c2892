//! `solve` of a problem file with rotations (issue 37: Python as for coordinates): the one
//! integrator of the problem's terms (`femvi_cli`'s `Problem::integrator`: the Lie-group
//! element, with the torques of `[forces]` if any) driven by the library's recorder
//! (`femvi::solution::solve_on`), so that `saveat`, dense output and events sample each
//! element's path on SO(3); with forces, [`WorkAtNodes`] adds the work and the energy balance
//! as for any forced run.

use crate::recorded::{Added, WorkAtNodes};
use crate::run::{run_on, Extras, Run};
use femvi::solution::solve_on;
use femvi::Lagrangian;
use femvi_cli::problem::Problem;
use std::path::Path;

/// Runs `problem` (which has rotations) with the Python side's `extras`.
///
/// # Errors
/// The library's refusal, as a message naming `path`.
// One arm of `with_system!` is a Copy type.
#[allow(clippy::clone_on_copy)]
pub fn run(problem: &Problem, path: &Path, extras: &Extras) -> Result<(Run, Added), String> {
    let mut added = Added::default();
    let r = run_on(
        problem,
        path,
        extras,
        |options| femvi_cli::with_system!(&problem.system, l => go(l.clone(), problem, options, &mut added)),
    )?;
    Ok((r, added))
}

fn go<L: Lagrangian + Sync>(
    lag: L,
    problem: &Problem,
    options: &femvi::SolveOptions,
    added: &mut Added,
) -> femvi::Result<Run> {
    let p = problem.library(lag);
    let element = &problem.element;
    let mut it = problem.integrator(&p.lagrangian, element, problem.grid.clone(), p.start.clone(), None)?;
    if problem.terms.force.is_none() {
        return Ok(Run::of(solve_on(&mut it, &p, element, options, &mut [])?));
    }
    // With forces the energy is tracked at every node, as `femvi run` does for the balance
    // (the inverse Legendre transform then starts from the same velocities: the same bits).
    let options = femvi::SolveOptions {
        energy_nodes: femvi::solution::EnergyNodes::Every,
        ..options.clone()
    };
    let mut work = WorkAtNodes::new(options.every);
    let sol = solve_on(&mut it, &p, element, &options, &mut [&mut work])?;
    added.work = Some(work.finish(&sol.step));
    Ok(Run::of(sol))
}
