//! Optimal control by discrete mechanics (DMOC: Ober-Blöbaum, Junge, Marsden, ESAIM COCV 17,
//! 2011; for Galerkin elements Campos, Ober-Blöbaum, Trélat, DCDS-A 35, 2015): the forced
//! discrete Euler–Lagrange equations of femvi's elements are the constraints, the cost is
//! integrated by the element's own quadrature, and Newton's method on the KKT system keeps
//! the block-banded structure of the boundary value solver ([`crate::bvp`]), so an iteration
//! costs O(N) for N elements.
//!
//! **The discrete problem.** Mesh t_k = t0 + k h, h = (t1 − t0)/N, elements of degree s with
//! nodal values Q (the paper's (2.24)–(2.27)) and an r-point quadrature (c_j, b_j). Controls
//! u ∈ Rᵐ live at the quadrature points: U_{k,j} is u(t_k + c_j h). They act through the
//! generalised force F(t, q, v, u) of the discrete Lagrange–d'Alembert principle (DESIGN §4):
//! with q_h the element polynomial, for every node a of element k the force contributes
//! f^a = h Σ_j b_j F(t_j, q_h, q̇_h, U_{k,j}) ℓ_a(c_j). The constraints c(Q, U) = 0 are
//! - at every interior node, the forced discrete Euler–Lagrange equation
//!   ∂L_d/∂Q^a + f^a = 0 summed over the elements sharing the node;
//! - at the ends, the boundary momenta (DESIGN §4): ∂L_d/∂Q^0 + f^0 + p_0 = 0 on the first
//!   element and ∂L_d/∂Q^s + f^s − p_N = 0 on the last, with p_0 = ∂L/∂v(t0, q0, v0) and
//!   p_N = ∂L/∂v(t1, q1, v1) (the given velocities enter through their momenta);
//! - and the positions at the ends are the given q0, q1.
//!
//! The objective is J = Σ_k h Σ_j b_j C(t_j, q_h, q̇_h, U_{k,j}) + Φ(t1, q_N, v_N) + w·t1
//! (DESIGN §5), with Φ the terminal cost.
//!
//! **Free ends.** A component of q1 or v1 may be left free. A free component of q_N is an
//! unknown; a free component of the end velocity v_N is one too, tied to the trajectory by
//! the end equation ∂L_d/∂Q^s + f^s = p(t1, q_N, v_N), which then defines it (the Legendre
//! map of a regular L is invertible). The end term of the KKT Lagrangian is
//! Φ(t1, q_N, v_N) − Λ_N·p(t1, q_N, v_N); at the optimum its stationarity in a free
//! component is the discrete transversality condition (e.g. Λ_N = ∂Φ/∂p for a free v_N when
//! p = M v). Coordinate bounds l ≤ Q ≤ u hold at every node and enter the barrier as the
//! control bounds do; for elements of degree s > 1 the polynomial between nodes may pass
//! them by O(h^2) of the curvature.
//!
//! **Holonomic constraints** g(q) = 0 ([`WithConstraints`], DESIGN §4) are held at every
//! node: node g's equation gains the constraint impulse −G(Q_g)ᵀν_g, with ν_g an unknown, and
//! g(Q_g) = 0 is a constraint wherever Q_g is unknown. ℒ gains the node terms
//! κ_g·g(Q_g) − ν_g·G(Q_g)Λ_g (and, for a free end velocity, κ'·G(q_N)v_N, the hidden
//! constraint), local to a node, so the KKT matrix stays banded. The given ends must lie on
//! the manifold with tangent velocities. The reported momenta are projected onto its
//! cotangent space, as in the initial value problem (`constraints::project`).
//!
//! **KKT.** With multipliers Λ at every node, ℒ = J + Λ·c. Interpolating Λ with the same
//! basis, Λ·c is a sum over quadrature points of h b_j [∂L/∂q·λ + ∂L/∂v·λ̇ + F·λ], so ℒ is a
//! sum of point terms Ψ (`point.rs`) and its Hessian over all unknowns (Q, U, Λ) is block
//! banded, one element wide (`layout.rs`). Newton's method on ∇ℒ = 0, with bounds by an
//! interior-point barrier and a merit line search, is in `solver.rs`.
//!
//! **Free final time.** t1 is one more unknown; every element is scaled with it,
//! t_k = t0 + (t1 − t0) k/N (DESIGN §5), so h is a variable of every point term. Its row and
//! column couple with all blocks; the KKT system is bordered and solved in O(N) by block
//! elimination (`kkt.rs`). With the time weight w (minimum time for C = 0, w = 1) the
//! stationarity in t1 is the discrete counterpart of the transversality condition H(t1) = −w
//! of the continuous problem.
//!
//! The discretisation and the dualisation commute for these elements (Campos et al.), so the
//! optimal cost converges with the integrator's order.

mod assemble;
mod constrained;
mod finish;
mod floor;
mod iterate;
mod kkt;
mod layout;
mod multipliers;
mod newton;
mod point;
mod refine;
mod search;
mod solver;
mod start;
mod system;
#[cfg(test)]
mod tests;

pub use system::{Controls, ExprControls, WithConstraints, WithForce};

use crate::discrete::Element;
use crate::error::{Error, Result};
use crate::lagrangian::Lagrangian;
use assemble::Model;
use layout::Layout;
use solver::Settings;
use start::{start, validate};

/// The final time: given, or an unknown between bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FinalTime {
    /// t1 is given.
    Fixed(f64),
    /// t1 is free in [min, max]; the iteration starts from `guess`.
    Free {
        /// Smallest t1.
        min: f64,
        /// Largest t1.
        max: f64,
        /// The starting value, strictly inside (min, max).
        guess: f64,
    },
}

/// An optimal control problem: boundary data, mesh, bounds on the controls and coordinates,
/// the weight of t1.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlProblem {
    /// Start time.
    pub t0: f64,
    /// Final time.
    pub t1: FinalTime,
    /// Positions at t0.
    pub q0: Vec<f64>,
    /// Velocities at t0.
    pub v0: Vec<f64>,
    /// Positions at t1, per component given (`Some`) or free (`None`: the optimiser's, with
    /// the terminal cost [`Controls::terminal_cost`] deciding).
    pub q1: Vec<Option<f64>>,
    /// Velocities at t1, per component given or free, as `q1`.
    pub v1: Vec<Option<f64>>,
    /// Number of elements N.
    pub elements: usize,
    /// Lower bounds of the controls (m entries; −∞ for none).
    pub lower: Vec<f64>,
    /// Upper bounds of the controls (m entries; +∞ for none).
    pub upper: Vec<f64>,
    /// Lower bounds of the coordinates, held at every node (n entries, −∞ for none; empty
    /// for no bounds). The given end positions must satisfy them.
    pub q_lower: Vec<f64>,
    /// Upper bounds of the coordinates, as `q_lower`.
    pub q_upper: Vec<f64>,
    /// The weight w of w·t1 in the objective.
    pub time_weight: f64,
}

/// A starting trajectory: positions (and optionally controls) at increasing times,
/// interpolated linearly; outside its times the end values are held.
#[derive(Debug, Clone, PartialEq)]
pub struct Guess {
    /// Times, increasing.
    pub t: Vec<f64>,
    /// Positions, row-major (a row of n per time).
    pub q: Vec<f64>,
    /// Controls, row-major (a row of m per time), or none (zero, moved inside the bounds).
    pub u: Option<Vec<f64>>,
}

/// Options of [`optimize`].
#[derive(Debug, Clone, PartialEq)]
pub struct OptimizeOptions {
    /// Stop when the constraint violation, the scaled optimality residual and the
    /// complementarity are at most this.
    pub tolerance: f64,
    /// Newton iterations at most.
    pub max_iterations: usize,
    /// The start; `None`: straight lines between the end positions, zero controls.
    pub guess: Option<Guess>,
    /// Coarser meshes solved first, in order (mesh refinement): each stage starts from the
    /// previous one's optimum (positions, controls and t1), the first from `guess`, and the
    /// last from `elements` starts from the finest of them. Each must have fewer elements
    /// than the next and than the problem. Empty: no refinement.
    pub coarse: Vec<usize>,
}

impl Default for OptimizeOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-9,
            max_iterations: 200,
            guess: None,
            coarse: Vec::new(),
        }
    }
}

/// The result of [`optimize`]: the optimum, or the best iterate with `error` set.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimum {
    /// J at the returned iterate.
    pub objective: f64,
    /// The final time.
    pub t1: f64,
    /// Newton iterations.
    pub iterations: usize,
    /// max |c|: the largest violation of the discrete equations (their momentum rows, and
    /// with constraints g(q) at the nodes and G(q_N)v_N).
    pub violation: f64,
    /// The optimality residual ‖∇ₓℒ − z‖∞ / h.
    pub optimality: f64,
    /// Times of the element end nodes t_0 … t_N.
    pub t: Vec<f64>,
    /// Positions at the element end nodes, (N + 1) rows of n.
    pub q: Vec<f64>,
    /// Discrete momenta at the element end nodes, (N + 1) rows of n.
    pub p: Vec<f64>,
    /// Times of the quadrature points, where the controls live (N·r).
    pub control_t: Vec<f64>,
    /// Controls at the quadrature points, N·r rows of m.
    pub u: Vec<f64>,
    /// The controls read off at the element end nodes, (N + 1) rows of m: in each element
    /// the polynomial through its quadrature values, evaluated at the element's ends; the
    /// mean of the two elements' values at an interior node; clamped into the bounds. An
    /// estimate beside the node positions and momenta: the optimiser's unknowns are `u`.
    pub u_nodes: Vec<f64>,
    /// The end velocity v_N: the given components, and the optimiser's for the free ones.
    pub v1: Vec<f64>,
    /// Why the iteration stopped short, if it did; the fields above are its best iterate.
    pub error: Option<Error>,
    /// The coarser stages of mesh refinement ([`OptimizeOptions::coarse`]): elements, Newton
    /// iterations and objective of each.
    pub stages: Vec<Stage>,
}

/// One coarser stage of mesh refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stage {
    /// Its number of elements.
    pub elements: usize,
    /// Its Newton iterations.
    pub iterations: usize,
    /// Its objective.
    pub objective: f64,
    /// Whether it converged (its best iterate is the next stage's start either way).
    pub converged: bool,
}

/// Solves the optimal control problem of the system `lag` with `controls` on the mesh of
/// `element`s.
///
/// # Errors
/// Invalid data (dimensions, non-finite values, t1 ≤ t0, bounds that exclude zero width,
/// a free t1 whose guess is not inside its finite bounds, a guess of the wrong shape, given
/// end positions outside the coordinate bounds or off the constraint manifold, given
/// velocities not tangent to it, coarse meshes that do not increase below `elements`), or
/// a mesh too large for memory. A run that does not converge is not an error: its best
/// iterate is returned with [`Optimum::error`] set (as is a node whose momentum cannot be
/// projected onto the constraint manifold: NaN there).
///
/// # Example
///
/// The double integrator x″ = u from rest at 0 to rest at 1 in unit time, minimising ∫u²:
/// the optimum is u = 6 − 12t with J = 12.
///
/// ```
/// use femvi::optimize::{optimize, ControlProblem, ExprControls, FinalTime, OptimizeOptions};
/// use femvi::expr::ExprLagrangian;
///
/// let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
/// let lag = ExprLagrangian::new("0.5*x_dot^2", &s(&["x"]), &[])?;
/// let ctl = ExprControls::new(&s(&["x"]), &s(&["u"]), &s(&["u"]), "u^2", &[])?;
/// let problem = ControlProblem {
///     t0: 0.0, t1: FinalTime::Fixed(1.0),
///     q0: vec![0.0], v0: vec![0.0], q1: vec![Some(1.0)], v1: vec![Some(0.0)],
///     elements: 20, lower: vec![f64::NEG_INFINITY], upper: vec![f64::INFINITY],
///     q_lower: vec![], q_upper: vec![], time_weight: 0.0,
/// };
/// let element = femvi::Element::with_order(4)?;
/// let best = optimize(&lag, &ctl, &element, &problem, &OptimizeOptions::default())?;
/// assert!(best.error.is_none());
/// assert!((best.objective - 12.0).abs() < 1e-9);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn optimize<L: Lagrangian + ?Sized, C: Controls>(
    lag: &L,
    controls: &C,
    element: &Element,
    problem: &ControlProblem,
    options: &OptimizeOptions,
) -> Result<Optimum> {
    validate(lag, controls, problem, options)?;
    if options.coarse.is_empty() {
        solve_once(lag, controls, element, problem, options)
    } else {
        refine::solve_refined(lag, controls, element, problem, options, solve_once)
    }
}

/// One solve on the problem's own mesh from `options.guess`.
fn solve_once<L: Lagrangian + ?Sized, C: Controls>(
    lag: &L,
    controls: &C,
    element: &Element,
    problem: &ControlProblem,
    options: &OptimizeOptions,
) -> Result<Optimum> {
    let (n, m) = (lag.dim(), controls.controls());
    let layout = Layout {
        n,
        m,
        s: element.degree(),
        r: element.points(),
        elements: problem.elements,
        free_q: problem.q1.iter().filter(|x| x.is_none()).count(),
        free_v: problem.v1.iter().filter(|x| x.is_none()).count(),
        mc: controls.constraint_count(),
        // A velocity at the end, where the position is left free, must be tangent to the
        // manifold there; a given zero velocity is, wherever the end lands.
        hidden: controls.constraint_count() > 0
            && (problem.v1.contains(&None)
                || (problem.q1.contains(&None) && problem.v1.iter().any(|v| v.is_some_and(|x| x != 0.0)))),
    };
    let slots = |end: &[Option<f64>], index: &dyn Fn(usize) -> usize| {
        let mut slot = 0;
        end.iter()
            .map(|x| {
                x.is_none().then(|| {
                    slot += 1;
                    index(slot - 1)
                })
            })
            .collect::<Vec<_>>()
    };
    let (free, t1) = match problem.t1 {
        FinalTime::Fixed(t1) => (false, t1),
        FinalTime::Free { guess, .. } => (true, guess),
    };
    let p0 = momentum(lag, problem.t0, &problem.q0, &problem.v0);
    let model = Model {
        lag,
        ctl: controls,
        element,
        layout,
        t0: problem.t0,
        free,
        q0: problem.q0.clone(),
        q1: problem.q1.iter().map(|x| x.unwrap_or(0.0)).collect(),
        v1: problem.v1.iter().map(|x| x.unwrap_or(0.0)).collect(),
        end_q: slots(&problem.q1, &|k| layout.end_q(k)),
        end_v: slots(&problem.v1, &|k| layout.end_v(k)),
        p0,
        time_weight: problem.time_weight,
    };
    let (start, bounds) = start(&model, problem, options.guess.as_ref(), t1)?;
    let settings = Settings {
        tolerance: options.tolerance,
        max_iterations: options.max_iterations,
    };
    let out = solver::solve(&model, &bounds, start, settings)?;
    Ok(finish::optimum(
        &model,
        &out,
        options.tolerance,
        (&problem.lower, &problem.upper),
    ))
}

fn momentum<L: Lagrangian + ?Sized>(lag: &L, t: f64, q: &[f64], v: &[f64]) -> Vec<f64> {
    use num_dual::Dual64;
    let qd: Vec<Dual64> = q.iter().map(|&x| Dual64::from(x)).collect();
    let mut vd: Vec<Dual64> = v.iter().map(|&x| Dual64::from(x)).collect();
    (0..q.len())
        .map(|i| {
            vd[i].eps = 1.0;
            let p = lag.value(Dual64::from(t), &qd, &vd).eps;
            vd[i].eps = 0.0;
            p
        })
        .collect()
}
