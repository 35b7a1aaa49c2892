//! `solve` of problem files with `[forces]` or `[constraints]` or both: the runs `femvi run`
//! makes of them (the library's `forces::solve_forced`, `constraints::solve_constrained_with`
//! and `constraints::solve_constrained_forced` with the file's element, grid and solver), and
//! what they add to the solution — the discrete work W at the kept nodes and the energy
//! balance max |H − H0 − W| for forces; the multipliers (constraint force −Gᵀλ) and the
//! residual max |g(q)| at the kept nodes for constraints. A forced or constrained run at fixed
//! steps with `saveat`, dense output or events goes through the recorder of every run
//! (`recorded.rs`). A Python potential takes the place of the file's system with the same
//! terms ([`Tables::run_lagrangian`]). What these runs do not do yet (events, `saveat` and
//! dense output with forces in energy mode) is refused with a message rather than dropped, by
//! the table of `femvi_cli::problem::capabilities`.

use crate::recorded::Added;
use crate::run::{Extras, Run};
use femvi::constraints::{solve_constrained_forced, solve_constrained_with, ConstrainedSolution};
use femvi::constraints::{Enforcement, ExprConstraints};
use femvi::forces::solve_forced;
use femvi::{Lagrangian, Solution};
use femvi_cli::problem::capabilities::Use;
use femvi_cli::problem::forces::ProblemForce;
use femvi_cli::problem::Problem;
use std::path::Path;

/// The tables of a loaded problem.
pub struct Tables {
    force: Option<ProblemForce>,
    constraints: Option<(ExprConstraints, Enforcement)>,
}

impl Tables {
    /// The `[forces]` and `[constraints]` terms of `problem`; None if it has neither.
    pub fn of(problem: &Problem) -> Option<Self> {
        let (force, constraints) = (problem.terms.force.clone(), problem.terms.constraints.clone());
        (force.is_some() || constraints.is_some()).then_some(Self { force, constraints })
    }

    /// Runs `problem` under these tables with the Python side's `extras`.
    ///
    /// # Errors
    /// Options these runs do not take, or the library's refusal, as a message naming `path`.
    // One arm of `with_system!` is a Copy type.
    #[allow(clippy::clone_on_copy)]
    pub fn run(&self, problem: &Problem, path: &Path, extras: &Extras) -> Result<(Run, Added), String> {
        femvi_cli::with_system!(&problem.system, l => self.run_lagrangian(l.clone(), problem, path, extras))
    }

    /// [`Tables::run`] with the Lagrangian `lag` in place of the file's system (a Python
    /// potential: the terms are the file's all the same).
    ///
    /// # Errors
    /// As [`Tables::run`].
    pub fn run_lagrangian<L: Lagrangian + Sync>(
        &self,
        lag: L,
        problem: &Problem,
        path: &Path,
        extras: &Extras,
    ) -> Result<(Run, Added), String> {
        let named = |e: String| format!("{}: {e}", path.display());
        let samples = !extras.saveat.is_empty() || extras.dense;
        let events = !problem.events.is_empty() || !extras.events.is_empty();
        if events {
            // The command's row (constraints, forces in energy mode), then Python's.
            problem.refuse(Use::Events, "femvi.solve").map_err(named)?;
        }
        if samples || events {
            problem.refuse(Use::SaveatOrDense, "femvi.solve").map_err(named)?;
            // Fixed steps: the run of the integrator with the terms, through the recorder.
            let terms = (self.force.as_ref(), self.constraints.as_ref());
            return crate::recorded::run(lag, terms, problem, path, extras);
        }
        let mut options = problem.solve_options(extras.every.unwrap_or(problem.every));
        options.max_steps = extras.max_steps;
        self.run_with(lag, problem, &options)
            .map_err(|e| format!("{}: {e}", path.display()))
    }

    fn run_with<L: Lagrangian + Sync>(
        &self,
        lag: L,
        problem: &Problem,
        options: &femvi::SolveOptions,
    ) -> femvi::Result<(Run, Added)> {
        let p = problem.library(lag);
        let element = &problem.element;
        let mut added = Added::default();
        let sol = match (&self.force, &self.constraints) {
            (Some(f), None) => {
                let r = solve_forced(&p, f, element, options)?;
                added.work = Some((r.work, r.balance.max_abs, r.balance.max_rel));
                r.solution
            }
            (None, Some(c)) => {
                let r = solve_constrained_with(&p, &c.0, element, options, c.1)?;
                constrained(r, &mut added)
            }
            (Some(f), Some(c)) => {
                let r = solve_constrained_forced(&p, f, &c.0, element, options, c.1)?;
                added.work = Some((r.work, r.balance.max_abs, r.balance.max_rel));
                constrained(r.constrained, &mut added)
            }
            (None, None) => {
                return Err(femvi::Error::Invalid {
                    what: "tables".into(),
                    reason: "the problem has neither [forces] nor [constraints]".into(),
                })
            }
        };
        Ok((Run::of(sol), added))
    }
}

/// The solution of a constrained run, its additions moved into `added`.
fn constrained(r: ConstrainedSolution, added: &mut Added) -> Solution {
    added.constraints = Some((r.m, r.multipliers, r.residual, r.max_residual));
    r.solution
}
