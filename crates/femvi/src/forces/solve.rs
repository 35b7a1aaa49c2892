//! [`solve_forced`]: a run with non-conservative forces on the one integrator
//! ([`Integrator::with_force`], `term.rs`: the forced Newton step of `step.rs` or, for a
//! constant mass matrix and a force independent of v, the fixed-point solver of
//! `fixed_point.rs`; in the energy mode [`Integrator::with_force_energy`]), driven by
//! [`crate::step::drive()`] with one observer that keeps the nodes, returning the usual
//! [`Solution`] with the accumulated discrete work and the energy balance
//! max |H_k − H_0 − W_k| (module docs of [`crate::forces`]).

use super::Force;
use crate::discrete::Element;
use crate::error::{check_len, finite_energy, invalid, Error, Result};
use crate::lagrangian::{hamiltonian, Lagrangian, PointDerivatives};
use crate::solution::{grid, EnergyReport, Problem, Solution, SolveOptions, Steps};
use crate::step::{Integrator, Method, Observer, Start};

/// How well the energy balance H(t_k) − H(t_0) = W_k holds over a run (every node).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EnergyBalance {
    /// max_k |H_k − H_0 − W_k|.
    pub max_abs: f64,
    /// The same relative to |H_0| (absolute where H_0 = 0).
    pub max_rel: f64,
}

/// A forced run: the usual solution, the discrete work at its kept nodes, and the balance.
#[derive(Debug, Clone)]
pub struct ForcedSolution {
    /// The nodes (t, q, p, v, H) as [`crate::solve()`] returns them; `energy_report` holds the
    /// largest relative change of H and, as `max_rel_balance`, the balance's relative error.
    pub solution: Solution,
    /// W_k at the kept nodes: the work of F along the element polynomials (and −∫∂L/∂t for a
    /// time-dependent L), by the element's quadrature, accumulated from t0.
    pub work: Vec<f64>,
    /// max |H_k − H_0 − W_k| over every node.
    pub balance: EnergyBalance,
    /// Energy mode only (else empty): the discrete energy Ẽ_k at the kept nodes, measured on
    /// the solved elements (`forces/energy_term.rs`).
    pub discrete_energy: Vec<f64>,
    /// Energy mode only: max |Ẽ_k − Ẽ_0 − W_k| over every node (round-off where every
    /// energy equation was solved).
    pub discrete_balance: Option<EnergyBalance>,
}

/// Integrates `problem` under the force `force` with `element` (discrete Lagrange–d'Alembert).
///
/// The step solver: with `Method::Auto` (the default), fixed-point iteration
/// (`forces/fixed_point.rs`) when L has a constant mass matrix ([`Lagrangian::mass_matrix`])
/// and the force is independent of v ([`Force::depends_on_velocity`] false), Newton's method
/// with the exact Jacobian otherwise; `Method::Newton` always takes Newton, and
/// `Method::FixedPoint` (or `Explicit`) asks for the fixed point. Both solve the same
/// equations and agree to round-off (`tests/forces_fixed_point.rs`).
///
/// Supported options: fixed or cyclic steps, time steps as variables ([`Steps::Energy`]: the
/// forced energy equation of `forces/energy_term.rs`, solved by Newton; the result then carries
/// [`ForcedSolution::discrete_energy`], [`ForcedSolution::discrete_balance`] and
/// `energy_stats`), `every`, `max_steps`, the solver's tolerance and iteration cap. A numerical failure is not an `Err`: the solution then ends at the last good
/// node with [`Solution::error`] naming the step and time.
///
/// # Errors
/// Bad input: `Method::FixedPoint` or `Explicit` for a Lagrangian without a mass matrix or
/// a velocity-dependent force, the force's dimension differs from the Lagrangian's, wrong start lengths, an
/// invalid span or step, a degenerate element, energy-mode step bounds that do not hold the
/// first step or `Method::FixedPoint`/`Explicit` in the energy mode, or options that are not
/// supported with forces (`saveat`, `dense`, `events`, a start from (q0, q1)).
///
/// # Example
///
/// ```
/// use femvi::forces::{solve_forced, LinearForce};
/// use femvi::{models, Element, Problem, SolveOptions, Start};
///
/// // The damped oscillator x'' = −x − 0.2 x': the energy decays by the work of the friction.
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, Start::Velocity { q: vec![1.0], v: vec![0.0] }, 0.0, 10.0);
/// let sol = solve_forced(&problem, &LinearForce::damping(1, 0.2), &Element::with_order(4)?, &SolveOptions::step(0.05))?;
/// let s = &sol.solution;
/// assert!(s.error.is_none() && s.energy.last().unwrap() < &0.2);
/// assert!(sol.balance.max_abs < 1e-7);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn solve_forced<L: Lagrangian + Sync, F: Force + Sync>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    options: &SolveOptions,
) -> Result<ForcedSolution> {
    let lag = &problem.lagrangian;
    let n = lag.dim();
    check_options(options)?;
    check_len("force", n, force.dim())?;
    element.check_nondegenerate()?;
    options.solver.validate()?;
    let grid = grid(problem, &options.steps)?;
    let (q0, p0, v0) = start(lag, &problem.start, problem.t0)?;
    let start_at = problem.start.clone();
    let energy_mode = matches!(options.steps, Steps::Energy { .. });
    let mut it = match &options.steps {
        Steps::Energy { options: energy, .. } => {
            Integrator::with_force_energy(lag, element, grid, start_at, options.solver, force, *energy)?
        }
        _ => Integrator::with_force(lag, element, grid, start_at, options.solver, force)?,
    };
    let mut recorder = Recorder {
        run: Run::new(n, options.every),
        node: Node {
            k: 0,
            t: problem.t0,
            q: q0,
            p: p0,
            work: 0.0,
        },
        v: v0,
        energy_mode,
        discrete: Vec::new(),
        max_steps: options.max_steps,
        last: false,
    };
    let report = crate::step::drive(&mut it, &mut [&mut recorder]);
    let k = recorder.node.k;
    let iterations = (it.mean_iterations() * k as f64).round() as usize;
    let mut sol = recorder.run.finish(k, iterations, report.stopped, report.error);
    if energy_mode {
        sol.solution.energy_stats = it.energy_stats();
        sol.discrete_energy = recorder.discrete;
        sol.discrete_balance = it.discrete_balance();
    }
    Ok(sol)
}

/// The observer of [`solve_forced`]'s run: H and the energy balance at every node, the kept
/// nodes with their work, in the energy mode the discrete energy Ẽ at the kept nodes (node
/// 0's is known once element 0 is solved), and the step limit.
struct Recorder {
    run: Run,
    /// The node last recorded (node 0 as the start gives it).
    node: Node,
    /// The velocity at the node (the warm start of the next inverse Legendre transform).
    v: Vec<f64>,
    energy_mode: bool,
    discrete: Vec<f64>,
    max_steps: Option<usize>,
    /// The node last recorded is the grid's final one.
    last: bool,
}

impl Recorder {
    /// Keeps the node the run ended on, after a stop or a failure (its H was recorded).
    fn keep_last<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) {
        let kept = self.run.kept();
        self.run.keep_last(&self.node, &self.v);
        if self.energy_mode && self.run.kept() > kept {
            self.discrete.push(it.discrete_energy().unwrap_or(f64::NAN));
        }
    }
}

impl<L: Lagrangian> Observer<L> for Recorder {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> Result<()> {
        if it.node().k > 0 {
            self.node.copy_from(it);
        }
        if self.node.k == 1 {
            if let (Some(d), Some(first)) = (self.discrete.first_mut(), it.term_discrete_energy()) {
                *d = first.first;
            }
        }
        let kept = self.run.kept();
        self.last = last;
        self.run.record(it.lagrangian(), &self.node, &mut self.v, last)?;
        if self.energy_mode && self.run.kept() > kept {
            self.discrete.push(it.discrete_energy().unwrap_or(f64::NAN));
        }
        Ok(())
    }

    fn finish(&mut self, it: &Integrator<'_, L>, error: Option<&Error>) -> Result<()> {
        if error.is_some() || Observer::<L>::stop(self) {
            self.keep_last(it);
        }
        Ok(())
    }

    fn stop(&self) -> bool {
        !self.last && self.max_steps.is_some_and(|m| self.node.k >= m)
    }
}

/// [`crate::solution::solve_with`] under the force `force`: the run of
/// [`Integrator::with_force`] (the nodes of [`solve_forced`], bit for bit) recorded by the
/// same recorder, so that `saveat`, dense output and events work on the forced element
/// polynomials, and `observers` see every node (with [`Integrator::work`]). The energies are
/// H at the nodes; the energy balance is [`solve_forced`]'s.
///
/// # Errors
/// As [`solve_forced`], and time steps as variables (the forced energy equation runs in
/// [`solve_forced`] only).
///
/// # Example
///
/// ```
/// use femvi::forces::{solve_forced_with, LinearForce};
/// use femvi::solution::{Event, SolveOptions};
/// use femvi::{models, Element, Problem, Start};
///
/// // The damped oscillator crosses x = 0 going down near t = π/2 (ω ≈ 1).
/// let problem = Problem::new(models::harmonic(1.0, 1.0)?, Start::Velocity { q: vec![1.0], v: vec![0.0] }, 0.0, 3.0);
/// let options = SolveOptions { events: vec![Event::new("x = 0", |_t, q: &[f64], _v: &[f64]| q[0])], ..SolveOptions::step(0.01) };
/// let sol = solve_forced_with(&problem, &LinearForce::damping(1, 0.1), &Element::with_order(4)?, &options, &mut [])?;
/// let t = sol.events[0].t;
/// // x'' + 0.1 x' + x = 0 from (1, 0): x = e^{-0.05 t}(cos ωt + 0.05/ω sin ωt), ω² = 1 − 0.0025.
/// let w = (1.0f64 - 0.0025).sqrt();
/// assert!(((w * t).cos() + 0.05 / w * (w * t).sin()).abs() < 1e-8);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn solve_forced_with<L: Lagrangian + Sync, F: Force + Sync>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    options: &SolveOptions,
    observers: &mut [&mut dyn crate::step::Observer<L>],
) -> Result<Solution> {
    let grid = grid(problem, &options.steps)?;
    let (lag, start_at) = (&problem.lagrangian, problem.start.clone());
    let mut it = match &options.steps {
        Steps::Energy { options: energy, .. } => {
            Integrator::with_force_energy(lag, element, grid, start_at, options.solver, force, *energy)?
        }
        _ => Integrator::with_force(lag, element, grid, start_at, options.solver, force)?,
    };
    crate::solution::solve_on(&mut it, problem, element, options, observers)
}

/// Whether the run goes by fixed-point iteration: for `Method::Auto` when L has a constant
/// mass matrix and F does not depend on v, for `Method::FixedPoint` and `Method::Explicit`
/// (no explicit forced step: the fixed point, which for degree 1 with the trapezoid rule
/// converges in two sweeps) when they fit, never for `Method::Newton`.
///
/// Errors: fixed point or explicit asked for where it does not fit.
pub(super) fn fixed_point_fits<L: Lagrangian, F: Force>(lag: &L, force: &F, method: Method) -> Result<bool> {
    let fits = lag.mass_matrix().is_some() && !force.depends_on_velocity();
    match method {
        Method::Newton | Method::FullNewton | Method::SimplifiedNewton => Ok(false),
        Method::Auto => Ok(fits),
        Method::FixedPoint | Method::Explicit if fits => Ok(true),
        Method::FixedPoint | Method::Explicit => Err(invalid(
            "solver method",
            "fixed-point iteration with forces needs a mechanical Lagrangian (L = 1/2 v'Mv - V) and a force independent of the velocities",
        )),
    }
}

/// Rejects the options a forced run does not support.
pub(super) fn check_options(options: &SolveOptions) -> Result<()> {
    let unsupported = |what: &str| {
        Err(invalid(
            what,
            "not supported with non-conservative forces (femvi::forces::solve_forced)",
        ))
    };
    if !options.saveat.is_empty() {
        return unsupported("saveat");
    }
    if options.dense {
        return unsupported("dense output");
    }
    if !options.events.is_empty() {
        return unsupported("events");
    }
    Ok(())
}

/// (q0, p0, v0) from the start.
pub(super) fn start<L: Lagrangian>(lag: &L, start: &Start, t0: f64) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let n = lag.dim();
    if n == 0 {
        return Err(invalid("dimension", "the system has no coordinates (dimension 0)"));
    }
    let mut work = PointDerivatives::new(n);
    match start {
        Start::Velocity { q, v } => {
            check_len("q0", n, q.len())?;
            check_len("v0", n, v.len())?;
            crate::lagrangian::check_regular(lag, t0, q, v)?;
            lag.first_derivatives(t0, q, v, false, &mut work);
            Ok((q.clone(), work.l_v().to_vec(), v.clone()))
        }
        Start::Momentum { q, p } => {
            check_len("q0", n, q.len())?;
            check_len("p0", n, p.len())?;
            let mut v = vec![0.0; n];
            crate::lagrangian::velocity_from_momentum(lag, t0, q, p, &mut v, &mut work)?;
            Ok((q.clone(), p.clone(), v))
        }
        Start::Positions { .. } => Err(invalid(
            "start",
            "a start from (q0, q1) is not supported with forces; give [initial] v or p",
        )),
    }
}

/// The current node of a forced run on the integrator, as the recorder reads it.
pub(super) struct Node {
    pub(super) k: usize,
    pub(super) t: f64,
    pub(super) q: Vec<f64>,
    pub(super) p: Vec<f64>,
    pub(super) work: f64,
}

impl Node {
    /// The integrator's current node and work.
    fn copy_from<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) {
        let at = it.node();
        self.k = at.k;
        self.t = at.t;
        self.q.copy_from_slice(at.q);
        self.p.copy_from_slice(at.p);
        self.work = it.work();
    }
}

/// The kept nodes and the energy balance over all nodes.
pub(super) struct Run {
    every: usize,
    sol: Solution,
    work: Vec<f64>,
    ld: PointDerivatives,
    h0: f64,
    balance: EnergyBalance,
    max_rel: f64,
    last_kept: Option<usize>,
    /// (node index, H) of the last node recorded.
    last_h: Option<(usize, f64)>,
}

impl Run {
    pub(super) fn new(n: usize, every: usize) -> Self {
        Self {
            every,
            sol: Solution::empty(n),
            work: vec![],
            ld: PointDerivatives::new(n),
            h0: f64::NAN,
            balance: EnergyBalance::default(),
            max_rel: 0.0,
            last_kept: None,
            last_h: None,
        }
    }

    /// H at the node (v: warm start in, velocity out), the balance, and the node if kept.
    pub(super) fn record<L: Lagrangian>(&mut self, lag: &L, node: &Node, v: &mut [f64], last: bool) -> Result<()> {
        let h = finite_energy(
            hamiltonian(lag, node.t, &node.q, &node.p, v, &mut self.ld)?,
            node.k,
            node.t,
        )?;
        self.last_h = Some((node.k, h));
        if self.h0.is_nan() {
            self.h0 = h;
        }
        let scale = if self.h0 != 0.0 { self.h0.abs() } else { 1.0 };
        let gap = (h - self.h0 - node.work).abs();
        self.balance.max_abs = self.balance.max_abs.max(gap);
        self.balance.max_rel = self.balance.max_rel.max(gap / scale);
        self.max_rel = self.max_rel.max((h - self.h0).abs() / scale);
        let keep = node.k == 0 || last || (self.every > 0 && node.k.is_multiple_of(self.every));
        if keep {
            self.push(node, v, h);
        }
        Ok(())
    }

    fn push(&mut self, node: &Node, v: &[f64], h: f64) {
        if self.last_kept == Some(node.k) {
            return;
        }
        self.last_kept = Some(node.k);
        let s = &mut self.sol;
        s.step.push(node.k);
        s.t.push(node.t);
        s.q.extend_from_slice(&node.q);
        s.p.extend_from_slice(&node.p);
        s.v.extend_from_slice(v);
        s.energy.push(h);
        self.work.push(node.work);
    }

    /// How many nodes are kept so far.
    pub(super) fn kept(&self) -> usize {
        self.work.len()
    }

    /// After a stop or a failure, the last good node is kept (its H was recorded).
    pub(super) fn keep_last(&mut self, node: &Node, v: &[f64]) {
        if let Some((k, h)) = self.last_h {
            if k == node.k {
                self.push(node, v, h);
            }
        }
    }

    pub(super) fn finish(
        mut self,
        steps: usize,
        iterations: usize,
        stopped: bool,
        error: Option<Error>,
    ) -> ForcedSolution {
        self.sol.steps = steps;
        self.sol.mean_iterations = if steps > 0 {
            iterations as f64 / steps as f64
        } else {
            0.0
        };
        self.sol.stopped = stopped;
        self.sol.error = error;
        self.sol.energy_report = Some(EnergyReport {
            max_rel_error: self.max_rel,
            max_rel_balance: Some(self.balance.max_rel),
            nodes: crate::solution::EnergyNodes::Every,
        });
        ForcedSolution {
            solution: self.sol,
            work: self.work,
            balance: self.balance,
            discrete_energy: Vec::new(),
            discrete_balance: None,
        }
    }
}
