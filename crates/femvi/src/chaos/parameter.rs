//! The sensitivity of a run's final state to a parameter θ of the Lagrangian, in forward mode
//! through each step. The parameter is written as one more coordinate of an augmented
//! Lagrangian A(t, (q, θ), (v, θ̇)) that ignores θ̇; [`Frozen`] is A at a fixed θ, the
//! Lagrangian that is run. Automatic differentiation of A's element Hessian then gives the
//! mixed derivatives ∂²L_d/∂Q^j∂θ exactly (θ carried as a dual number, like the coordinates).
//!
//! Per step, the step equations R_j = δ_j0 p_k + ∂L_d/∂Q^j = 0 (j < s; (2.40)–(2.42)) at
//! fixed (q_k, p_k) give J ∂X/∂θ = −∂R/∂θ with J the step Jacobian, so
//!   ∂q_{k+1}/∂θ = ∂X^s/∂θ,  ∂p_{k+1}/∂θ = Σ_m ∂²L_d/∂Q^s∂Q^m ∂X^m/∂θ + Σ_m ∂²L_d/∂Q^s∂Θ^m,
//! and the run's derivative follows d(q, p)_{k+1}/dθ = M_k d(q, p)_k/dθ + ∂(q, p)_{k+1}/∂θ with
//! M_k the step's tangent map.

use super::FinalNode;
use crate::discrete::{Element, ElementWork};
use crate::error::{invalid, Error, Result, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, Scalar};
use crate::solution::{Problem, SolveOptions, Steps};
use crate::step::{Integrator, Start};

/// An augmented Lagrangian A(t, (q, θ), (v, θ̇)) of dimension n + 1 at a fixed parameter θ:
/// the Lagrangian L(t, q, v) = A(t, (q, θ), (v, 0)) of dimension n.
///
/// # Example
///
/// ```
/// use femvi::chaos::Frozen;
/// use femvi::expr::ExprLagrangian;
/// use femvi::Lagrangian;
///
/// // The pendulum with g as the last coordinate.
/// let coords = ["x".to_string(), "g".to_string()];
/// let aug = ExprLagrangian::new("0.5*x_dot^2 + g*cos(x)", &coords, &[])?;
/// let lag = Frozen::new(&aug, 9.81)?;
/// assert_eq!(lag.dim(), 1);
/// assert!((lag.value(0.0f64, &[0.0], &[1.0]) - 10.31).abs() < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Frozen<'a, A> {
    aug: &'a A,
    theta: f64,
}

impl<'a, A: Lagrangian> Frozen<'a, A> {
    /// A at the parameter value `theta`.
    ///
    /// # Errors
    /// An augmented Lagrangian of dimension 0 (it needs at least the parameter) or a
    /// non-finite `theta`.
    pub fn new(aug: &'a A, theta: f64) -> Result<Self> {
        if aug.dim() == 0 {
            return Err(invalid(
                "augmented Lagrangian",
                "needs the parameter as its last coordinate",
            ));
        }
        if !theta.is_finite() {
            return Err(invalid("parameter", format!("{theta} is not finite")));
        }
        Ok(Self { aug, theta })
    }
}

impl<A: Lagrangian> Lagrangian for Frozen<'_, A> {
    fn dim(&self) -> usize {
        self.aug.dim() - 1
    }

    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        // Called at every quadrature point of every solver iteration: small systems use
        // stack buffers, larger ones allocate.
        const STACK: usize = 16;
        let n = q.len();
        if n < STACK && v.len() == n {
            let (mut qa, mut va) = ([D::zero(); STACK], [D::zero(); STACK]);
            qa[..n].copy_from_slice(q);
            qa[n] = D::from(self.theta);
            va[..n].copy_from_slice(v);
            return self.aug.value(t, &qa[..=n], &va[..=n]);
        }
        let qa: Vec<D> = q.iter().copied().chain([D::from(self.theta)]).collect();
        let va: Vec<D> = v.iter().copied().chain([D::zero()]).collect();
        self.aug.value(t, &qa, &va)
    }

    fn is_autonomous(&self) -> bool {
        self.aug.is_autonomous()
    }
}

/// d(q_N, p_N)/dθ (2n entries: q then p) of the run of `problem` with `element`, where
/// `problem.lagrangian` is the augmented Lagrangian A (dimension n + 1, the parameter last) and
/// the run uses A at `theta` ([`Frozen`]); with the final node (t, q, p). The start is a
/// momentum start in the n coordinates (it then does not depend on θ). `options.max_steps`
/// stops the run after that many steps.
///
/// # Errors
/// A start other than [`Start::Momentum`], energy mode, bad input as for [`crate::solve()`],
/// a failed step, or a singular step Jacobian.
///
/// # Example
///
/// ```
/// use femvi::chaos::parameter_sensitivity;
/// use femvi::expr::ExprLagrangian;
/// use femvi::{Element, Problem, SolveOptions, Start};
///
/// // The harmonic oscillator q'' = −k q from (1, 0): q(T) = cos(√k T), so
/// // dq(T)/dk = −T sin(√k T) / (2√k).
/// let coords = ["x".to_string(), "k".to_string()];
/// let aug = ExprLagrangian::new("0.5*x_dot^2 - 0.5*k*x^2", &coords, &[])?;
/// let problem = Problem::new(aug, Start::Momentum { q: vec![1.0], p: vec![0.0] }, 0.0, 2.0);
/// let (d, _) = parameter_sensitivity(&problem, 1.5, &Element::with_order(8)?, &SolveOptions::step(0.01))?;
/// let w = 1.5f64.sqrt();
/// assert!((d[0] + 2.0 * (w * 2.0).sin() / (2.0 * w)).abs() < 1e-10);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn parameter_sensitivity<A: Lagrangian>(
    problem: &Problem<A>,
    theta: f64,
    element: &Element,
    options: &SolveOptions,
) -> Result<(Vec<f64>, FinalNode)> {
    let frozen = Frozen::new(&problem.lagrangian, theta)?;
    let n = frozen.dim();
    if !matches!(problem.start, Start::Momentum { .. }) {
        return Err(invalid(
            "parameter sensitivity",
            "needs a momentum start (q0, p0), which does not depend on the parameter",
        ));
    }
    if let Steps::Energy { .. } = options.steps {
        return Err(invalid(
            "parameter sensitivity",
            "energy mode is not supported (use steps as parameters)",
        ));
    }
    let grid = crate::solution::grid(problem, &options.steps)?;
    let mut it = Integrator::new(&frozen, element, grid, problem.start.clone(), options.solver)?;
    let mut column = ParameterColumn::new(element, n);
    let (mut d, mut tmp) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
    let mut steps = 0;
    while options.max_steps.is_none_or(|m| steps < m) && it.step()? {
        steps += 1;
        let m = it.tangent_map()?;
        let b = column.at_last_element(&it, element, &problem.lagrangian, theta)?;
        for (i, x) in tmp.iter_mut().enumerate() {
            *x = m[i * 2 * n..(i + 1) * 2 * n]
                .iter()
                .zip(&d)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                + b[i];
        }
        d.copy_from_slice(&tmp);
    }
    let node = it.node();
    Ok((d, (node.t, node.q.to_vec(), node.p.to_vec())))
}

/// Buffers for ∂(q, p)_{k+1}/∂θ at fixed (q_k, p_k).
struct ParameterColumn {
    n: usize,
    work: ElementWork,
    base: Vec<f64>,
    incr: Vec<f64>,
    grad: Vec<f64>,
    hess: Vec<f64>,
}

impl ParameterColumn {
    fn new(element: &Element, n: usize) -> Self {
        let w = element.nodes() * (n + 1);
        Self {
            n,
            work: ElementWork::new(element, n + 1),
            base: vec![0.0; n + 1],
            incr: vec![0.0; w],
            grad: vec![0.0; w],
            hess: vec![0.0; w * w],
        }
    }

    fn at_last_element<L: Lagrangian, A: Lagrangian>(
        &mut self,
        it: &Integrator<'_, L>,
        element: &Element,
        aug: &A,
        theta: f64,
    ) -> Result<Vec<f64>> {
        let n = self.n;
        let na = n + 1;
        let last = it
            .last_element()
            .ok_or_else(|| invalid("parameter sensitivity", "no step has been taken"))?;
        let s = element.degree();
        self.base[..n].copy_from_slice(last.base);
        self.base[n] = theta;
        for j in 0..=s {
            self.incr[j * na..j * na + n].copy_from_slice(&last.incr[j * n..(j + 1) * n]);
            self.incr[j * na + n] = 0.0;
        }
        element.hessian_in_place(
            aug,
            last.t,
            last.h,
            &self.base,
            &self.incr,
            &mut self.work,
            &mut self.grad,
            &mut self.hess,
        );
        let w = (s + 1) * na;
        let h = |row: (usize, usize), col: (usize, usize)| self.hess[(row.0 * na + row.1) * w + col.0 * na + col.1];
        // Σ_m ∂²L_d/∂Q^j_c ∂Θ^m: θ moves every node's parameter coordinate.
        let mixed = |j: usize, c: usize| (0..=s).map(|m| h((j, c), (m, n))).sum::<f64>();
        let dim = s * n;
        let jac = nalgebra::DMatrix::from_fn(dim, dim, |a, b| h((a / n, a % n), (b / n + 1, b % n)));
        let rhs = nalgebra::DVector::from_fn(dim, |a, _| -mixed(a / n, a % n));
        let dx = jac.lu().solve(&rhs).ok_or_else(|| {
            Error::Step(StepError {
                step: it.node().k.saturating_sub(1),
                t: last.t,
                residual: f64::NAN,
                iterations: 0,
                failure: StepFailure::Singular,
            })
        })?;
        let mut out = vec![0.0; 2 * n];
        for c in 0..n {
            out[c] = dx[(s - 1) * n + c];
            let through_nodes: f64 = (1..=s)
                .flat_map(|m| (0..n).map(move |e| (m, e)))
                .map(|(m, e)| h((s, c), (m, e)) * dx[(m - 1) * n + e])
                .sum();
            out[n + c] = through_nodes + mixed(s, c);
        }
        Ok(out)
    }
}
