//! The constrained run: [`solve_constrained`] checks the start against the constraints,
//! projects the start momentum onto T*N, then takes the steps of `step.rs` with the projection
//! of `project.rs` on a grid of fixed steps, keeping nodes as [`crate::solve()`] does, with the
//! multipliers and the constraint residuals per kept node.

use super::jet::ConstraintJet;
use super::layout::{Enforcement, Layout};
use super::project::{state_multiplier, Projector};
use super::step::StepSystem;
use super::tangent::{step_defect, StepEnds};
use super::Constraints;
use crate::discrete::Element;
use crate::error::{check_len, invalid, Error, Result, StepError, StepFailure};
use crate::lagrangian::{velocity_from_momentum, Lagrangian, PointDerivatives};
use crate::solution::{Problem, Solution, SolveOptions, Steps};
use crate::solve::{newton_dense, DenseNewtonWork, NewtonFailure};
use crate::step::Start;

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
/// [`Error::Dimension`] if the constraints and the Lagrangian disagree on n, or the start has
/// the wrong length; [`Error::Invalid`] for m ≥ n or n > [`MAX_COORDINATES`], a start off the
/// manifold (naming the residual), a
/// start from (q0, q1), time steps as variables, `saveat`, `events` or `dense` (not
/// available with constraints), or invalid solver options; [`Error::SingularConstraints`] if
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
    let lag = &problem.lagrangian;
    let (n, m) = (lag.dim(), constraints.count());
    check_len("constraints' coordinates", n, constraints.dim())?;
    if n > MAX_COORDINATES || m >= n.max(1) {
        return Err(invalid(
            "constraints",
            format!("need fewer constraints than coordinates and at most {MAX_COORDINATES} coordinates, got {m} constraints on {n}"),
        ));
    }
    check_options(options)?;
    element.check_nondegenerate()?;
    let layout = Layout::new(element, enforcement)?;
    let grid = crate::solution::grid(problem, &options.steps)?;
    let (q0, p_tilde, mut v) = start_state(lag, &problem.start, problem.t0, n)?;
    let mut jet = ConstraintJet::new(m, n);
    jet.eval(constraints, &q0, true);
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
        return Err(singular(0, problem.t0, &jet));
    }
    let mut run = Run::new(element, layout, n, m, enforcement, options);
    run.defect = tangent.then_some(0.0);
    let mut p = vec![0.0; n];
    run.projector
        .project(
            lag,
            &jet,
            problem.t0,
            &q0,
            &p_tilde,
            &mut v,
            &mut p,
            options.solver.tolerance,
            options.solver.max_iterations,
        )
        .map_err(|f| step_error(0, problem.t0, f))?;
    run.out.start_projection = p.iter().zip(&p_tilde).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
    run.keep(lag, constraints, 0, problem.t0, &q0, &p, &v)?;
    run.march(problem, constraints, element, &grid, q0, p, v)?;
    Ok((run.out, run.defect))
}

fn check_options(options: &SolveOptions) -> Result<()> {
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

fn singular(step: usize, t: f64, jet: &ConstraintJet) -> Error {
    Error::SingularConstraints {
        step,
        t,
        ratio: jet.conditioning(),
    }
}

fn step_error(step: usize, t: f64, f: NewtonFailure) -> Error {
    Error::Step(StepError {
        step,
        t,
        residual: f.residual,
        iterations: f.iterations,
        failure: f.failure,
    })
}

/// The state of a run: scratch and the solution being filled.
struct Run {
    sys: StepSystem,
    projector: Projector,
    newton: DenseNewtonWork,
    kept_jet: ConstraintJet,
    every: usize,
    max_steps: Option<usize>,
    tol: f64,
    max_iterations: usize,
    iterations: usize,
    defect: Option<f64>,
    out: ConstrainedSolution,
}

impl Run {
    fn new(
        element: &Element,
        layout: Layout,
        n: usize,
        m: usize,
        enforcement: Enforcement,
        options: &SolveOptions,
    ) -> Self {
        let sys = StepSystem::new(element, layout, n, m);
        let newton = DenseNewtonWork::new(sys.unknowns());
        let solution = Solution::empty(n);
        Self {
            sys,
            projector: Projector::new(n, m),
            newton,
            kept_jet: ConstraintJet::new(m, n),
            every: options.every,
            max_steps: options.max_steps,
            tol: options.solver.tolerance,
            max_iterations: options.solver.max_iterations,
            iterations: 0,
            defect: None,
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
        self.kept_jet.eval(con, q, true);
        let sol = &mut self.out.solution;
        sol.step.push(k);
        sol.t.push(t);
        sol.q.extend_from_slice(q);
        sol.p.extend_from_slice(p);
        sol.v.extend_from_slice(v);
        let pv: f64 = p.iter().zip(v).map(|(a, b)| a * b).sum();
        sol.energy.push(pv - lag.value(t, q, v));
        let jet = &self.kept_jet;
        let hidden = (0..jet.m)
            .map(|l| (0..n).map(|a| jet.jac[l * n + a] * v[a]).sum::<f64>().abs())
            .fold(0.0f64, f64::max);
        self.out.residual.push(jet.residual());
        self.out.hidden_residual.push(hidden);
        self.out.max_residual = self.out.max_residual.max(jet.residual());
        self.out.multipliers.extend(state_multiplier(lag, jet, t, q, v));
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
        let (n, s) = (q.len(), element.degree());
        let mut x = vec![0.0; self.sys.unknowns()];
        let mut comp = vec![0.0; n];
        let (mut q1, mut p1) = (vec![0.0; n], vec![0.0; n]);
        let (mut t, mut k) = (problem.t0, 0usize);
        let mut last_kept = 0usize;
        while let Some((h, t1)) = grid.next(k, t) {
            if self.max_steps.is_some_and(|cap| k >= cap) {
                self.out.solution.stopped = true;
                break;
            }
            // Guess: straight line with the node velocity; multipliers from the last step.
            for j in 1..=s {
                let tau = element.basis.nodes[j];
                for c in 0..n {
                    x[(j - 1) * n + c] = tau * h * v[c];
                }
            }
            self.sys.start.eval(con, &q, true);
            let scale = q.iter().fold(1.0f64, |a, &b| a.max(b.abs()));
            let sys = &mut self.sys;
            let solved = newton_dense(
                &mut x,
                self.tol,
                self.max_iterations,
                |_| scale,
                &mut self.newton,
                |xx, r, jac| {
                    sys.eval(element, lag, con, t, h, &q, &p, xx, jac.is_some());
                    sys.newton_residual(r);
                    if let Some(jac) = jac {
                        sys.newton_jacobian(jac);
                    }
                },
            );
            let report = match solved {
                Ok(rep) => rep,
                Err(f) => {
                    let err = if f.failure == StepFailure::Singular && self.sys.start.conditioning() <= RANK_TOLERANCE {
                        singular(k, t, &self.sys.start)
                    } else {
                        step_error(k, t, f)
                    };
                    self.out.solution.error = Some(err);
                    break;
                }
            };
            self.iterations += report.iterations;
            // q_{k+1} = q_k + ΔQ^s with compensated summation.
            for c in 0..n {
                let y = x[(s - 1) * n + c] + comp[c];
                let sum = q[c] + y;
                comp[c] = y - (sum - q[c]);
                q1[c] = sum;
            }
            let p_tilde = self.sys.momentum_before_projection();
            if self.sys.end.conditioning() <= RANK_TOLERANCE {
                self.out.solution.error = Some(singular(k + 1, t1, &self.sys.end));
                break;
            }
            let projected = self.projector.project(
                lag,
                &self.sys.end,
                t1,
                &q1,
                p_tilde,
                &mut v,
                &mut p1,
                self.tol,
                self.max_iterations,
            );
            let mu = match projected {
                Ok(mu) => mu,
                Err(f) => {
                    self.out.solution.error = Some(step_error(k, t, f));
                    break;
                }
            };
            if let Some(worst) = self.defect {
                self.sys.eval(element, lag, con, t, h, &q, &p, &x, true);
                let ends = StepEnds {
                    t0: t,
                    q0: &q,
                    p0: &p,
                    t1,
                    q1: &q1,
                    v1: &v,
                    mu,
                };
                self.defect = Some(worst.max(step_defect(lag, con, &self.sys, &ends)));
            }
            std::mem::swap(&mut q, &mut q1);
            std::mem::swap(&mut p, &mut p1);
            self.out.max_residual = self.out.max_residual.max(self.sys.end.residual());
            k += 1;
            t = t1;
            self.out.solution.steps = k;
            let last = grid.next(k, t).is_none() || self.max_steps.is_some_and(|cap| k >= cap);
            if last || (self.every > 0 && k % self.every == 0) {
                self.keep(lag, con, k, t, &q, &p, &v)?;
                last_kept = k;
            }
        }
        if last_kept != k {
            self.keep(lag, con, k, t, &q, &p, &v)?;
        }
        let sol = &mut self.out.solution;
        sol.mean_iterations = if k > 0 { self.iterations as f64 / k as f64 } else { 0.0 };
        Ok(())
    }
}
