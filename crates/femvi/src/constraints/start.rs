//! The start of a constrained run ([`super::solve_constrained_with`], the chaos run on the
//! manifold): the checks of the problem (sizes, options, the start on the manifold N within
//! [`START_TOLERANCE`], G(q0) regular) and the start momentum projected onto T*N
//! (`project.rs`); and the typed errors of a step.

use super::jet::ConstraintJet;
use super::limits::{MAX_COORDINATES, RANK_TOLERANCE, START_TOLERANCE};
use super::project::Projector;
use super::Constraints;
use crate::error::{check_len, invalid, Error, Result, StepError};
use crate::lagrangian::{velocity_from_momentum, Lagrangian, PointDerivatives};
use crate::solution::{SolveOptions, Steps};
use crate::solve::NewtonFailure;
use crate::step::Start;

/// A start on the manifold: q0, the momentum on T*N and its velocity.
pub(super) struct OnManifold {
    pub q: Vec<f64>,
    /// The start momentum projected onto T*N.
    pub p: Vec<f64>,
    pub v: Vec<f64>,
    /// ‖p0 − p̃0‖∞.
    pub projection: f64,
}

/// Checks a start against the constraints (sizes, finite g and G, on the manifold within
/// [`START_TOLERANCE`], G(q0) regular) and projects its momentum onto T*N.
pub(super) fn start_on_manifold<L: Lagrangian, C: Constraints>(
    lag: &L,
    constraints: &C,
    start: &Start,
    t0: f64,
    solver: crate::step::SolverOptions,
) -> Result<OnManifold> {
    let (n, m) = (lag.dim(), constraints.count());
    check_len("constraints' coordinates", n, constraints.dim())?;
    if n > MAX_COORDINATES || m >= n.max(1) {
        return Err(invalid(
            "constraints",
            format!("need fewer constraints than coordinates and at most {MAX_COORDINATES} coordinates, got {m} constraints on {n}"),
        ));
    }
    let (q0, p_tilde, mut v) = start_state(lag, start, t0, n)?;
    let mut jet = ConstraintJet::new(m, n);
    jet.eval(constraints, &q0, true);
    if let Some(l) = jet.first_not_finite() {
        return Err(invalid(
            "initial q",
            format!(
                "{} is not finite at q0 (g = {:e}; its gradient must be finite too): check the initial coordinates",
                constraints.name(l),
                jet.g.get(l).copied().unwrap_or(f64::NAN)
            ),
        ));
    }
    let qmax = q0.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
    let within = jet.residual() <= START_TOLERANCE * qmax * qmax;
    if !within {
        return Err(invalid(
            "initial q",
            format!(
                "violates the constraints: max |g(q0)| = {:.3e} (tolerance {:.1e} * max(1, |q0|^2))",
                jet.residual(),
                START_TOLERANCE
            ),
        ));
    }
    if jet.conditioning() <= RANK_TOLERANCE {
        return Err(singular(0, t0, &jet));
    }
    let mut p = vec![0.0; n];
    Projector::new(n, m)
        .project(
            lag,
            &jet,
            t0,
            &q0,
            &p_tilde,
            &mut v,
            &mut p,
            solver.tolerance,
            solver.max_iterations,
        )
        .map_err(|f| step_error(0, t0, f))?;
    let projection = p.iter().zip(&p_tilde).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
    Ok(OnManifold {
        q: q0,
        p,
        v,
        projection,
    })
}

pub(super) fn check_options(options: &SolveOptions) -> Result<()> {
    options.solver.validate()?;
    if matches!(options.steps, Steps::Energy { .. }) {
        return Err(invalid(
            "time mode",
            "time steps as variables are not available with constraints",
        ));
    }
    if !options.saveat.is_empty() || !options.events.is_empty() || options.dense {
        return Err(invalid(
            "output",
            "saveat, events and dense output are not available with constraints",
        ));
    }
    Ok(())
}

/// (q0, p̃0, v guess) from the start.
fn start_state<L: Lagrangian>(lag: &L, start: &Start, t0: f64, n: usize) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    match start {
        Start::Velocity { q, v } => {
            check_len("initial q", n, q.len())?;
            check_len("initial v", n, v.len())?;
            let mut pd = PointDerivatives::new(n);
            lag.first_derivatives(t0, q, v, false, &mut pd);
            Ok((q.clone(), pd.l_v().to_vec(), v.clone()))
        }
        Start::Momentum { q, p } => {
            check_len("initial q", n, q.len())?;
            check_len("initial p", n, p.len())?;
            let mut v = vec![0.0; n];
            velocity_from_momentum(lag, t0, q, p, &mut v, &mut PointDerivatives::new(n))?;
            Ok((q.clone(), p.clone(), v))
        }
        Start::Positions { .. } => Err(invalid(
            "initial data",
            "a start from (q0, q1) is not available with constraints; give q and v (or p)",
        )),
    }
}

pub(super) fn singular(step: usize, t: f64, jet: &ConstraintJet) -> Error {
    Error::SingularConstraints {
        step,
        t,
        ratio: jet.conditioning(),
    }
}

pub(super) fn step_error(step: usize, t: f64, f: NewtonFailure) -> Error {
    Error::Step(StepError {
        step,
        t,
        residual: f.residual,
        iterations: f.iterations,
        failure: f.failure,
    })
}
