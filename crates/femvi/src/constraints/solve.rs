//! The constrained run: [`solve_constrained`] checks the start against the constraints,
//! projects the start momentum onto T*N (`start.rs`), then takes the steps of `step.rs` with the projection
//! of `project.rs` on a grid of fixed steps, keeping nodes as [`crate::solve()`] does, with the
//! multipliers and the constraint residuals per kept node.

use super::forced::Balance;
use super::jet::ConstraintJet;
use super::layout::Enforcement;
use super::project::state_multiplier;
use super::start::begin;
use super::stepper::Stepper;
use super::tangent::step_defect;
use super::Constraints;
use crate::discrete::Element;
use crate::error::{finite_energy, Result};
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, Solution, SolveOptions};

/// A start is accepted if ‖g(q0)‖∞ ≤ `START_TOLERANCE` · max(1, ‖q0‖∞²).
pub const START_TOLERANCE: f64 = 1e-10;

/// The most coordinates a constrained problem may have: the steps are solved by dense Newton
/// with constraint Hessians by hyper-dual numbers (m n² numbers per point), so memory and time
/// grow like n³.
pub const MAX_COORDINATES: usize = 200;

/// Below this ratio of the smallest to the largest singular value, G(q) counts as singular.
pub(super) const RANK_TOLERANCE: f64 = 1e-12;

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
pub fn solve_constrained<L: Lagrangian, C: Constraints>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
) -> Result<ConstrainedSolution> {
    solve_constrained_with(problem, constraints, element, options, Enforcement::default())
}

/// Solves a constrained problem: fixed steps (`Steps::Fixed` or `Steps::Cycle`), nodes kept
/// by `every`, up to `max_steps`. The start must satisfy the constraints
/// (‖g(q0)‖∞ ≤ [`START_TOLERANCE`] · max(1, ‖q0‖∞²)); its momentum (∂L/∂v of a start velocity,
/// or the start momentum) is projected onto the cotangent space of the manifold, and the size
/// of that change is reported ([`ConstrainedSolution::start_projection`]). A step that fails
/// ends the run with the error in `solution.error` (the nodes before it are kept).
///
/// # Errors
/// [`Error::Dimension`](crate::Error::Dimension) if the constraints and the Lagrangian disagree on n, or the start has
/// the wrong length; [`Error::Invalid`](crate::Error::Invalid) for m ≥ n or n > [`MAX_COORDINATES`], a start off the
/// manifold (naming the residual), a
/// start from (q0, q1), time steps as variables, `saveat`, `events` or `dense` (not
/// available with constraints), or invalid solver options; [`Error::SingularConstraints`](crate::Error::SingularConstraints) if
/// G(q0) is singular.
pub fn solve_constrained_with<L: Lagrangian, C: Constraints>(
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
pub(crate) fn run_constrained<L: Lagrangian, C: Constraints>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
    tangent: bool,
) -> Result<(ConstrainedSolution, Option<f64>)> {
    run_forced(problem, constraints, element, options, enforcement, tangent, None)
}

/// [`run_constrained`] with the discrete forces and the energy balance of `forcing`
/// (`forced.rs`), which holds the work and the balance at the end.
#[allow(clippy::too_many_arguments)]
pub(super) fn run_forced<L: Lagrangian, C: Constraints>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
    tangent: bool,
    forcing: Option<&mut Balance<'_>>,
) -> Result<(ConstrainedSolution, Option<f64>)> {
    let lag = &problem.lagrangian;
    let (n, m) = (lag.dim(), constraints.count());
    let start = begin(problem, constraints, element, options, enforcement)?;
    let stepper = Stepper::new(element, start.layout, (n, m), options.solver, lag, forcing.is_some())?;
    let mut run = Run::new(stepper, n, m, enforcement, options);
    run.defect = tangent.then_some(0.0);
    run.forcing = forcing;
    run.out.start_projection = start.on.projection;
    let (q0, p, v) = (start.on.q, start.on.p, start.on.v);
    if let Err(e) = run.keep(lag, constraints, 0, problem.t0, &q0, &p, &v) {
        // Node 0's energy is not finite: a failed run with nothing kept, as `solve`'s.
        run.out.solution.error = Some(e);
        return Ok((run.out, run.defect));
    }
    run.march(problem, constraints, element, &start.grid, q0, p, v)?;
    Ok((run.out, run.defect))
}

/// The state of a run: scratch and the solution being filled.
struct Run<'r, 'f> {
    stepper: Stepper,
    kept_jet: ConstraintJet,
    every: usize,
    max_steps: Option<usize>,
    iterations: usize,
    defect: Option<f64>,
    /// The forces and the energy balance of a forced run.
    forcing: Option<&'r mut Balance<'f>>,
    out: ConstrainedSolution,
}

impl Run<'_, '_> {
    fn new(stepper: Stepper, n: usize, m: usize, enforcement: Enforcement, options: &SolveOptions) -> Self {
        let solution = Solution::empty(n);
        Self {
            stepper,
            kept_jet: ConstraintJet::new(m, n),
            every: options.every,
            max_steps: options.max_steps,
            iterations: 0,
            defect: None,
            forcing: None,
            out: ConstrainedSolution {
                solution,
                m,
                multipliers: vec![],
                residual: vec![],
                hidden_residual: vec![],
                max_residual: 0.0,
                start_projection: 0.0,
                enforcement,
            },
        }
    }

    /// Appends node `k` to the kept arrays.
    #[allow(clippy::too_many_arguments)]
    fn keep<L: Lagrangian, C: Constraints>(
        &mut self,
        lag: &L,
        con: &C,
        k: usize,
        t: f64,
        q: &[f64],
        p: &[f64],
        v: &[f64],
    ) -> Result<()> {
        let n = q.len();
        // The energy first: a node whose energy is not finite is not recorded at all.
        let pv: f64 = p.iter().zip(v).map(|(a, b)| a * b).sum();
        let energy = finite_energy(pv - lag.value(t, q, v), k, t)?;
        self.kept_jet.eval(con, q, true);
        let sol = &mut self.out.solution;
        sol.step.push(k);
        sol.t.push(t);
        sol.q.extend_from_slice(q);
        sol.p.extend_from_slice(p);
        sol.v.extend_from_slice(v);
        sol.energy.push(energy);
        let jet = &self.kept_jet;
        let hidden = (0..jet.m)
            .map(|l| (0..n).map(|a| jet.jac[l * n + a] * v[a]).sum::<f64>().abs())
            .fold(0.0f64, f64::max);
        self.out.residual.push(jet.residual());
        self.out.hidden_residual.push(hidden);
        self.out.max_residual = self.out.max_residual.max(jet.residual());
        let force = match &mut self.forcing {
            Some(b) => {
                b.keep(energy);
                Some(b.force_at(t, q, v))
            }
            None => None,
        };
        self.out
            .multipliers
            .extend(state_multiplier(lag, jet, (t, q, v), force));
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn march<L: Lagrangian, C: Constraints>(
        &mut self,
        problem: &Problem<L>,
        con: &C,
        element: &Element,
        grid: &crate::step::TimeGrid,
        mut q: Vec<f64>,
        mut p: Vec<f64>,
        mut v: Vec<f64>,
    ) -> Result<()> {
        let lag = &problem.lagrangian;
        let (mut t, mut k) = (problem.t0, 0usize);
        let mut last_kept = 0usize;
        while let Some((h, t1)) = grid.next(k, t) {
            if self.max_steps.is_some_and(|cap| k >= cap) {
                self.out.solution.stopped = true;
                break;
            }
            let term = self.forcing.as_ref().map(|b| b.force.term());
            if let Err(e) = self
                .stepper
                .step(lag, con, element, (k, t, h, t1), &mut q, &mut p, &mut v, term)
            {
                self.out.solution.error = Some(e);
                break;
            }
            self.iterations += self.stepper.iterations;
            if let Some(b) = &mut self.forcing {
                let time_work = self.stepper.time_work(lag, element, t, h);
                let (qk, _) = self.stepper.previous();
                b.step(element, (t, h), qk, self.stepper.sys.increments(), time_work);
                let pv: f64 = p.iter().zip(&v).map(|(a, b)| a * b).sum();
                match finite_energy(pv - lag.value(t1, &q, &v), k + 1, t1) {
                    Ok(energy) => b.node(energy),
                    Err(e) => {
                        // The new node's energy is not finite: nothing of it is kept (nor
                        // the node before unless it was due: q, p, v have moved on).
                        self.out.solution.error = Some(e);
                        k += 1;
                        self.out.solution.steps = k;
                        last_kept = k;
                        break;
                    }
                }
            }
            if let Some(worst) = self.defect {
                let phi = self.stepper.tangent_map(lag, con, element, (t, h, t1), &q, &v, term);
                let (q0, p0) = self.stepper.previous();
                self.defect = Some(worst.max(step_defect(lag, con, phi, (t, q0, p0))));
            }
            self.out.max_residual = self.out.max_residual.max(self.stepper.sys.end.residual());
            k += 1;
            t = t1;
            self.out.solution.steps = k;
            let last = grid.next(k, t).is_none() || self.max_steps.is_some_and(|cap| k >= cap);
            if last || (self.every > 0 && k % self.every == 0) {
                last_kept = k;
                if let Err(e) = self.keep(lag, con, k, t, &q, &p, &v) {
                    // Node k's energy is not finite: nothing of it is kept, the run ends.
                    self.out.solution.error = Some(e);
                    break;
                }
            }
        }
        if last_kept != k {
            // The node the run ended on (a failed step starts from it, or the step limit).
            if let Err(e) = self.keep(lag, con, k, t, &q, &p, &v) {
                self.out.solution.error.get_or_insert(e);
            }
        }
        let sol = &mut self.out.solution;
        sol.mean_iterations = if k > 0 { self.iterations as f64 / k as f64 } else { 0.0 };
        Ok(())
    }
}
