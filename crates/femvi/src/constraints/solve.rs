//! The constrained run: [`solve_constrained`] checks the problem and its start against the
//! constraints (`start.rs`), then drives the one integrator with the constraints as its term
//! ([`crate::Integrator::with_constraints`], `term.rs`) on a grid of fixed steps
//! ([`crate::step::drive()`] with one observer), keeping nodes
//! as [`crate::solve()`] does, with the multipliers, the projection's velocity and the
//! constraint residuals per kept node, and with a force the discrete work and the energy
//! balance (`forced.rs`).

use super::forcing::NodeForce;
use super::layout::Enforcement;
use super::start::check_options;
use super::term::Constrained;
use super::Constraints;
use crate::discrete::Element;
use crate::error::{finite_energy, Error, Result};
use crate::forces::EnergyBalance;
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, Solution, SolveOptions};
use crate::step::{Integrator, Observer};

/// The result of [`solve_constrained`]: the usual [`Solution`] plus, per kept node, the
/// multipliers and the residuals of the constraints.
#[derive(Debug, Clone)]
pub struct ConstrainedSolution {
    /// Nodes, momenta (on T*N), velocities, energies, statistics and error, as for an
    /// unconstrained run (`saved`, `events` and `dense` stay empty).
    pub solution: Solution,
    /// Number of constraints m.
    pub m: usize,
    /// The multipliers λ at each kept node, m per row: those of the exact flow at the node
    /// state (module `project`); −G(q)ᵀλ is the constraint force.
    pub multipliers: Vec<f64>,
    /// ‖g(q)‖∞ at each kept node.
    pub residual: Vec<f64>,
    /// ‖G(q) v‖∞ (the hidden constraint) at each kept node.
    pub hidden_residual: Vec<f64>,
    /// Largest ‖g(q)‖∞ over every node of the run (kept or not).
    pub max_residual: f64,
    /// ‖p0 − p̃0‖∞: how much the projection of the start momentum onto T*N changed it (0 for
    /// a start velocity tangent to the manifold, up to round-off).
    pub start_projection: f64,
    /// Where the constraints were enforced inside the elements.
    pub enforcement: Enforcement,
}

/// Solves a constrained problem with the default [`Enforcement`] (see
/// [`solve_constrained_with`]).
///
/// # Errors
/// As [`solve_constrained_with`].
///
/// # Example
///
/// A spherical pendulum in Cartesian coordinates, |q| = 1, degree 2 (order 4):
///
/// ```
/// use femvi::constraints::{solve_constrained, ExprConstraints};
/// use femvi::expr::ExprLagrangian;
/// use femvi::{Element, Problem, SolveOptions, Start};
///
/// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
/// let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z", &xyz, &[])?;
/// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[])?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 1.0, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 1.0);
/// let run = solve_constrained(&problem, &sphere, &Element::with_order(4)?, &SolveOptions::step(0.01))?;
/// assert!(run.solution.error.is_none());
/// assert!(run.max_residual < 1e-13);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn solve_constrained<L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
) -> Result<ConstrainedSolution> {
    solve_constrained_with(problem, constraints, element, options, Enforcement::default())
}

/// Solves a constrained problem: fixed steps (`Steps::Fixed` or `Steps::Cycle`), nodes kept
/// by `every`, up to `max_steps`. The start must satisfy the constraints
/// (‖g(q0)‖∞ ≤ [`START_TOLERANCE`](super::START_TOLERANCE) · max(1, ‖q0‖∞²)); its momentum (∂L/∂v of a start velocity,
/// or the start momentum) is projected onto the cotangent space of the manifold, and the size
/// of that change is reported ([`ConstrainedSolution::start_projection`]). A step that fails
/// ends the run with the error in `solution.error` (the nodes before it are kept).
///
/// # Errors
/// [`Error::Dimension`](crate::Error::Dimension) if the constraints and the Lagrangian disagree on n, or the start has
/// the wrong length; [`Error::Invalid`](crate::Error::Invalid) for m ≥ n or n > [`MAX_COORDINATES`](super::MAX_COORDINATES), a start off the
/// manifold (naming the residual), a
/// start from (q0, q1), time steps as variables, `saveat`, `events` or `dense` (not
/// available with constraints), or invalid solver options; [`Error::SingularConstraints`](crate::Error::SingularConstraints) if
/// G(q0) is singular.
pub fn solve_constrained_with<L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
) -> Result<ConstrainedSolution> {
    Ok(run_constrained(problem, constraints, element, options, enforcement, false)?.0)
}

/// The run behind [`solve_constrained_with`], and with `tangent` also the largest
/// symplecticity defect of the steps on the manifold (`tangent.rs`).
pub(crate) fn run_constrained<L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
    tangent: bool,
) -> Result<(ConstrainedSolution, Option<f64>)> {
    let run = run_terms(problem, constraints, element, options, (enforcement, tangent), None)?;
    Ok((run.constrained, run.defect))
}

/// A constrained run with what a force adds.
pub(super) struct Ran {
    pub constrained: ConstrainedSolution,
    pub defect: Option<f64>,
    /// W at the kept nodes (empty without a force).
    pub work: Vec<f64>,
    /// max |H_k − H_0 − W_k| over every node (with a force).
    pub balance: EnergyBalance,
    /// max |H_k − H_0| / |H_0| over every node (with a force).
    pub max_rel_change: f64,
}

/// The constrained run on the one integrator with the force of `forcing`, if any: the
/// nodes kept by `every` (and the last), with their multipliers, projection velocities and
/// residuals; with a force, the work at the kept nodes and the energy balance over every node.
pub(super) fn run_terms<'a, L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &'a Problem<L>,
    constraints: &'a C,
    element: &'a Element,
    options: &SolveOptions,
    (enforcement, tangent): (Enforcement, bool),
    forcing: Option<Box<dyn NodeForce + Send + 'a>>,
) -> Result<Ran> {
    check_options(options)?;
    let grid = crate::solution::grid(problem, &options.steps)?;
    let forced = forcing.is_some();
    let parts = Constrained {
        constraints,
        enforcement,
        forcing,
        tangent,
    };
    let lag = &problem.lagrangian;
    let mut it = Integrator::constrained(lag, element, grid, problem.start.clone(), options.solver, parts)?;
    let mut kept = Kept::new(lag.dim(), constraints.count(), enforcement, forced);
    kept.every = options.every;
    kept.max_steps = options.max_steps;
    let report = crate::step::drive(&mut it, &mut [&mut kept]);
    // The run's first error (a step's, or a node's energy), else one of keeping its last node.
    if let Some(e) = report.error {
        kept.out.solution.error = Some(e);
    }
    kept.out.solution.stopped = report.stopped;
    Ok(kept.done(&it))
}

/// The kept nodes of a constrained run and its energy balance.
///
/// It is the observer of the run: node 0 and every `every`-th node are kept (and the node the
/// run ends on), with a force the energy balance is taken at every node, and the step limit
/// stops the run.
struct Kept {
    out: ConstrainedSolution,
    work: Vec<f64>,
    h0: f64,
    balance: EnergyBalance,
    max_rel_change: f64,
    forced: bool,
    every: usize,
    max_steps: Option<usize>,
    /// The node last seen, the node last kept (or whose energy failed), and whether the node
    /// last seen is the grid's final one.
    k: usize,
    last_kept: usize,
    last: bool,
}

impl<L: Lagrangian + Sync> Observer<L> for Kept {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> Result<()> {
        let k = it.node().k;
        (self.k, self.last) = (k, last);
        if k == 0 {
            // Node 0's energy not finite: a failed run with nothing kept, as `solve`'s.
            return self.keep(it);
        }
        self.out.solution.steps = k;
        if self.forced {
            match it.energy().and_then(|h| finite_energy(h, k, it.node().t)) {
                Ok(energy) => self.balance_at(energy, it.work()),
                Err(e) => {
                    // The new node's energy is not finite: nothing of it is kept.
                    self.last_kept = k;
                    return Err(e);
                }
            }
        }
        let at_cap = self.max_steps.is_some_and(|cap| k >= cap);
        if last || at_cap || (self.every > 0 && k.is_multiple_of(self.every)) {
            self.last_kept = k;
            self.keep(it)?;
        }
        Ok(())
    }

    fn finish(&mut self, it: &Integrator<'_, L>, _error: Option<&Error>) -> Result<()> {
        if self.last_kept != self.k {
            // The node the run ended on (a failed step starts from it, or the step limit).
            if let Err(e) = self.keep(it) {
                self.out.solution.error.get_or_insert(e);
            }
        }
        Ok(())
    }

    fn stop(&self) -> bool {
        !self.last && self.max_steps.is_some_and(|cap| self.k >= cap)
    }
}

impl Kept {
    fn new(n: usize, m: usize, enforcement: Enforcement, forced: bool) -> Self {
        Self {
            out: ConstrainedSolution {
                solution: Solution::empty(n),
                m,
                multipliers: vec![],
                residual: vec![],
                hidden_residual: vec![],
                max_residual: 0.0,
                start_projection: 0.0,
                enforcement,
            },
            work: vec![],
            h0: f64::NAN,
            balance: EnergyBalance::default(),
            max_rel_change: 0.0,
            forced,
            every: 1,
            max_steps: None,
            k: 0,
            last_kept: 0,
            last: false,
        }
    }

    /// Appends the integrator's current node.
    fn keep<L: Lagrangian + Sync>(&mut self, it: &Integrator<'_, L>) -> Result<()> {
        let node = it.node();
        // The energy first: a node whose energy is not finite is not recorded at all.
        let energy = finite_energy(it.energy()?, node.k, node.t)?;
        let Some(at) = it.node_constraints() else {
            return Ok(());
        };
        let sol = &mut self.out.solution;
        sol.step.push(node.k);
        sol.t.push(node.t);
        sol.q.extend_from_slice(node.q);
        sol.p.extend_from_slice(node.p);
        sol.v.extend_from_slice(&at.velocity);
        sol.energy.push(energy);
        self.out.residual.push(at.residual);
        self.out.hidden_residual.push(at.hidden_residual);
        self.out.multipliers.extend_from_slice(&at.multipliers);
        if self.forced {
            if self.h0.is_nan() {
                self.h0 = energy;
            }
            self.work.push(it.work());
        }
        Ok(())
    }

    /// The energy balance at a node of energy H after the work W.
    fn balance_at(&mut self, energy: f64, work: f64) {
        let scale = if self.h0 != 0.0 { self.h0.abs() } else { 1.0 };
        let gap = (energy - self.h0 - work).abs();
        self.balance.max_abs = self.balance.max_abs.max(gap);
        self.balance.max_rel = self.balance.max_rel.max(gap / scale);
        self.max_rel_change = self.max_rel_change.max((energy - self.h0).abs() / scale);
    }

    fn done<L: Lagrangian + Sync>(mut self, it: &Integrator<'_, L>) -> Ran {
        if let Some(at) = it.node_constraints() {
            self.out.max_residual = at.max_residual;
            self.out.start_projection = at.start_projection;
        }
        self.out.solution.mean_iterations = it.mean_iterations();
        Ran {
            constrained: self.out,
            defect: it.term_defect(),
            work: self.work,
            balance: self.balance,
            max_rel_change: self.max_rel_change,
        }
    }
}
