//! `femvi chaos` for problems with `[forces]` (the library's
//! [`femvi::chaos::forced_indicators`]), `[constraints]`
//! ([`femvi::chaos::constrained_indicators`]: tangent vectors on the constraint manifold,
//! 2(n − m) of them, the initial vector projected onto its phase space's tangent space) or both
//! ([`femvi::chaos::forced_constrained_indicators`]): the
//! indicators of one orbit (printed, `--json`, `--out`'s chaos.json and summary.json) or of a
//! map (`--grid`), as for an unconstrained problem (`chaos.rs` calls [`Tables::of`] once and
//! [`Tables::indicators`] per point).

use crate::problem::capabilities::Use;
use crate::problem::forces::ProblemForce;
use crate::problem::Problem;
use femvi::chaos::{
    constrained_indicators, forced_constrained_indicators, forced_indicators, ChaosOptions, ChaosReport,
};
use femvi::constraints::{Enforcement, ExprConstraints};
use femvi::{Lagrangian, Start};

/// The `[forces]` or `[constraints]` table of a problem, if any.
pub enum Tables {
    /// Neither: the unconstrained indicators.
    None,
    /// `[forces]`.
    Forces(ProblemForce),
    /// `[constraints]` and where they are enforced.
    Constraints(Box<(ExprConstraints, Enforcement)>),
    /// Both tables.
    Both(Box<(ProblemForce, ExprConstraints, Enforcement)>),
}

impl Tables {
    /// The tables of `problem` (its parameters as loaded).
    ///
    /// # Errors
    /// A message (bad input, exit code 2): either table in energy mode
    /// ([`Use::ChaosInEnergyMode`]).
    pub fn of(problem: &Problem) -> Result<Self, String> {
        if problem.energy.is_some() {
            problem.refuse(Use::ChaosInEnergyMode, "femvi chaos")?;
        }
        let terms = &problem.terms;
        Ok(match (terms.force.clone(), terms.constraints.clone()) {
            (None, None) => Tables::None,
            (Some(f), Some((c, e))) => Tables::Both(Box::new((f, c, e))),
            (Some(f), None) => Tables::Forces(f),
            (None, Some(c)) => Tables::Constraints(Box::new(c)),
        })
    }

    /// Whether the problem has neither table.
    pub fn is_none(&self) -> bool {
        matches!(self, Tables::None)
    }

    /// The indicators of `problem` (its system as `lag`) from `start` under these tables; None
    /// for [`Tables::None`].
    pub fn indicators<L: Lagrangian + Clone + Sync>(
        &self,
        lag: &L,
        problem: &Problem,
        start: &Start,
        chaos: &ChaosOptions,
    ) -> Option<femvi::Result<ChaosReport>> {
        if self.is_none() {
            return None;
        }
        let library = || femvi::Problem::new(lag.clone(), start.clone(), problem.grid.t0(), problem.grid.end());
        let (element, options) = (&problem.element, problem.solve_options(0));
        match self {
            Tables::None => None,
            Tables::Forces(f) => Some(forced_indicators(&library(), f, element, &options, chaos)),
            Tables::Constraints(c) => Some(constrained_indicators(&library(), &c.0, element, &options, c.1, chaos)),
            Tables::Both(b) => Some(forced_constrained_indicators(
                &library(),
                &b.0,
                &b.1,
                element,
                &options,
                b.2,
                chaos,
            )),
        }
    }
}
