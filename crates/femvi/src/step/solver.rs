//! The one interface between the integrator and the ways of solving a step's equations:
//! [`choose`] resolves [`Method`] for a Lagrangian and element, and [`Solver`] dispatches
//! statically (an enum, no virtual calls) to the explicit, fixed-point or Newton solver. Each
//! solver reads the node from the [`RunState`], the previous element from [`LastElement`],
//! and leaves the solved element in [`Increments`], which the integrator commits.

use super::element_work::ElementBuffers;
use super::explicit::ExplicitStep;
use super::fixed_point_step::FixedPointStep;
use super::gyroscopic::GyroscopicStep;
use super::newton_step::NewtonStep;
use super::options::{Method, SolverOptions};
use super::state::{Increments, LastElement, RunState};
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::fem::QuadratureKind;
use crate::lagrangian::Lagrangian;

/// What every solver reads besides the state: the Lagrangian, the element and the options.
pub(crate) struct StepContext<'a, L: Lagrangian> {
    pub(crate) lag: &'a L,
    pub(crate) element: &'a Element,
    pub(crate) opts: SolverOptions,
}

/// The solver a [`Method`] resolves to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Newton,
    FixedPoint,
    Explicit,
    Gyroscopic,
}

/// Resolves `method` for `lag` and `element`: explicit for degree 1 with the trapezoid rule on
/// a mechanical Lagrangian, fixed point for other mechanical Lagrangians, the gyroscopic fixed
/// point for gyroscopic ones (`Lagrangian::gyroscopic_mass`), Newton otherwise.
///
/// Errors: a method that does not fit the Lagrangian or the element.
pub(crate) fn choose<L: Lagrangian>(method: Method, lag: &L, element: &Element) -> Result<Kind> {
    let mechanical = lag.mass_matrix().is_some();
    let gyroscopic = !mechanical && lag.gyroscopic_mass().is_some();
    let explicit_fits = element.degree() == 1 && element.rule.kind == QuadratureKind::Trapezoid;
    Ok(match method {
        Method::Auto if mechanical && explicit_fits => Kind::Explicit,
        Method::Auto if mechanical => Kind::FixedPoint,
        Method::Auto | Method::FixedPoint if gyroscopic => Kind::Gyroscopic,
        Method::Auto | Method::Newton | Method::FullNewton | Method::SimplifiedNewton => Kind::Newton,
        Method::FixedPoint if mechanical => Kind::FixedPoint,
        Method::Explicit if mechanical && explicit_fits => Kind::Explicit,
        Method::FixedPoint => {
            return Err(invalid(
                "solver method",
                "fixed-point iteration needs a mechanical Lagrangian (L = 1/2 v'Mv - V)",
            ))
        }
        Method::Explicit => {
            return Err(invalid(
                "solver method",
                "explicit stepping needs degree 1 with the trapezoid rule and a mechanical Lagrangian",
            ))
        }
    })
}

/// A step solver with its own workspace and caches.
// One solver per run, made once: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub(crate) enum Solver {
    Explicit(ExplicitStep),
    FixedPoint(Box<FixedPointStep>),
    Newton(Box<NewtonStep>),
    Gyroscopic(Box<GyroscopicStep>),
}

impl Solver {
    /// The solver of `kind` for `element` in dimension n.
    pub(crate) fn new(kind: Kind, element: &Element, n: usize) -> Result<Self> {
        Ok(match kind {
            Kind::Explicit => Solver::Explicit(ExplicitStep::new(n)),
            Kind::FixedPoint => Solver::FixedPoint(Box::new(FixedPointStep::new(element, n)?)),
            Kind::Newton => Solver::Newton(Box::new(NewtonStep::new(element, n)?)),
            Kind::Gyroscopic => Solver::Gyroscopic(Box::new(GyroscopicStep::new(element, n)?)),
        })
    }

    #[inline]
    pub(crate) fn kind(&self) -> Kind {
        match self {
            Solver::Explicit(_) => Kind::Explicit,
            Solver::FixedPoint(_) => Kind::FixedPoint,
            Solver::Newton(_) => Kind::Newton,
            Solver::Gyroscopic(_) => Kind::Gyroscopic,
        }
    }

    /// Solves the step equations from the current node with step h into `out`, without
    /// moving the state; returns the iterations spent (0 for explicit steps).
    pub(crate) fn solve<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        state: &RunState,
        last: &mut LastElement,
        bufs: &mut Option<ElementBuffers>,
        h: f64,
        out: &mut Increments,
    ) -> Result<usize> {
        match self {
            Solver::Explicit(e) => {
                let Some(mass) = cx.lag.mass_matrix() else {
                    unreachable!("explicit steps are chosen for mechanical Lagrangians only")
                };
                e.step(cx.lag, mass, state, h, out);
                Ok(0)
            }
            Solver::FixedPoint(f) => f.solve(cx, state, last, h, out),
            Solver::Newton(nw) => nw.solve(cx, state, last, bufs, h, out),
            Solver::Gyroscopic(g) => g.solve(cx, state, last, h, out),
        }
    }

    /// The solved step was rejected (its node is not finite): what the solve carried over
    /// to the next step is dropped (the explicit step's force at the failed point).
    pub(crate) fn rejected(&mut self) {
        if let Solver::Explicit(e) = self {
            e.rejected();
        }
    }

    /// The solved step was accepted (called once the state has moved).
    pub(crate) fn accepted<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, n: usize) {
        match self {
            Solver::FixedPoint(f) => {
                let identity = cx.lag.mass_matrix().is_some_and(|m| m.is_identity());
                f.accepted(identity, cx.element.points(), n);
            }
            Solver::Gyroscopic(g) => g.accepted(),
            _ => {}
        }
    }
}
