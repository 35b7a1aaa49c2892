//! One step of the forced discrete Euler–Lagrange equations (module docs of
//! [`crate::forces`]) by dense Newton ([`newton_dense`]): unknowns the node increments
//! X^m = Q^m − q_k (m = 1 … s), residuals R_0 = p_k + ∂L_d/∂Q^0 + F_d^0 (evaluated as
//! p_k + Δp − Σ_{j≥1} (∂L_d/∂Q^j + F_d^j), [`summed_row_zero`]) and
//! R_j = ∂L_d/∂Q^j + F_d^j (0 < j < s), Jacobian the element Hessian plus ∂F_d/∂Q (automatic
//! differentiation of the generic force). Starting values: the last element's polynomial
//! extrapolated, or the initial velocity.

use super::element::{element_forces, element_forces_jacobian};
use super::Force;
use crate::discrete::{Element, ElementWork};
use crate::error::{invalid, Error, Result, StepError};
use crate::lagrangian::Lagrangian;
use crate::solve::{newton_dense, DenseNewtonWork};
use crate::step::{SolverOptions, MAX_DENSE_NEWTON};

/// What a solved step adds to the node.
#[derive(Debug, Clone, Default)]
pub(super) struct Taken {
    /// q_{k+1} − q_k.
    pub(super) dq: Vec<f64>,
    /// p_{k+1} − p_k = h Σ b_i (∂L/∂q + F)(c_i).
    pub(super) dp: Vec<f64>,
    /// The element's work of F.
    pub(super) work: f64,
    /// The element's −h Σ b_i ∂L/∂t(c_i) (0 for autonomous L).
    pub(super) time_work: f64,
    /// Newton iterations.
    pub(super) iterations: usize,
}

/// The workspace of the forced Newton step.
pub(super) struct ForcedStep<'a, L, F> {
    lag: &'a L,
    force: &'a F,
    element: &'a Element,
    opts: SolverOptions,
    n: usize,
    ework: ElementWork,
    grad: Vec<f64>,
    hess: Vec<f64>,
    fd: Vec<f64>,
    fjac: Vec<f64>,
    incr: Vec<f64>,
    x: Vec<f64>,
    newton: DenseNewtonWork,
    /// The last element's increments and step, for the predictor.
    last: Option<(Vec<f64>, f64)>,
    basis_buf: Vec<f64>,
}

impl<'a, L: Lagrangian, F: Force> ForcedStep<'a, L, F> {
    /// The workspace for `lag`, `force` and `element`.
    ///
    /// # Errors
    /// Dense matrices past [`MAX_DENSE_NEWTON`], checked before they are allocated.
    pub(super) fn new(lag: &'a L, force: &'a F, element: &'a Element, opts: SolverOptions) -> Result<Self> {
        let n = lag.dim();
        let w = element
            .nodes()
            .checked_mul(n)
            .filter(|&w| w <= MAX_DENSE_NEWTON)
            .ok_or_else(|| {
                invalid(
                    "Newton's method",
                    format!(
                        "an element of {} nodes in dimension {n} exceeds the dense limit (s+1) n <= {MAX_DENSE_NEWTON}",
                        element.nodes()
                    ),
                )
            })?;
        let s = element.degree();
        Ok(Self {
            lag,
            force,
            element,
            opts,
            n,
            ework: ElementWork::new(element, n),
            grad: vec![0.0; w],
            hess: vec![0.0; w * w],
            fd: vec![0.0; w],
            fjac: vec![0.0; w * w],
            incr: vec![0.0; w],
            x: vec![0.0; s * n],
            newton: DenseNewtonWork::new(s * n),
            last: None,
            basis_buf: vec![0.0; s + 1],
        })
    }

    /// Sets the unknowns' starting values for the step h (`v0`: the velocity at the node, used
    /// on the first step).
    fn predict(&mut self, v0: &[f64], h: f64) {
        let (n, s) = (self.n, self.element.degree());
        let nodes = &self.element.basis.nodes;
        match &self.last {
            None => {
                for m in 1..=s {
                    for c in 0..n {
                        self.x[(m - 1) * n + c] = nodes[m] * h * v0[c];
                    }
                }
            }
            Some((incr, last_h)) => {
                let end = &incr[s * n..];
                for m in 1..=s {
                    self.element
                        .basis
                        .values_in_place(1.0 + nodes[m] * h / last_h, &mut self.basis_buf);
                    for c in 0..n {
                        let mut acc = 0.0;
                        for (j, l) in self.basis_buf.iter().enumerate() {
                            acc += l * (incr[j * n + c] - end[c]);
                        }
                        self.x[(m - 1) * n + c] = acc;
                    }
                }
            }
        }
    }

    /// Solves the step `k` from (t0, q, p) with step h; `v0` is the velocity at the node (the
    /// predictor of the first step).
    ///
    /// # Errors
    /// A failed Newton solve as [`Error::Step`] naming step k and t0.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn step(
        &mut self,
        k: usize,
        t0: f64,
        h: f64,
        q: &[f64],
        p: &[f64],
        v0: &[f64],
        out: &mut Taken,
    ) -> Result<()> {
        self.predict(v0, h);
        let (lag, force, element) = (self.lag, self.force, self.element);
        let bufs = (
            &mut self.ework,
            &mut self.grad[..],
            &mut self.hess[..],
            &mut self.fd[..],
            &mut self.fjac[..],
            &mut self.incr[..],
        );
        let iterations = newton_forced(
            (lag, force, element),
            (k, t0, h),
            (q, p),
            bufs,
            &mut self.x,
            (&self.opts, &mut self.newton),
        )?;
        self.finish(t0, h, q, iterations, out);
        Ok(())
    }

    /// Sets the predictor's previous element (node increments `incr`, step `h`): a run
    /// restored from a checkpoint continues with the starting values it would have had.
    pub(super) fn set_previous(&mut self, incr: &[f64], h: f64) {
        match &mut self.last {
            Some((last, last_h)) => {
                last.copy_from_slice(incr);
                *last_h = h;
            }
            None => self.last = Some((incr.to_vec(), h)),
        }
    }

    /// The last solved element's node increments Q^j − q_k (j = 0 … s, the first block zero),
    /// which the integrator keeps for the step's tangent map (`step/term_tangent.rs`).
    pub(super) fn increments(&self) -> &[f64] {
        &self.incr
    }

    /// The node update from the converged unknowns (evaluated once more, with ∂L/∂t).
    fn finish(&mut self, t0: f64, h: f64, q: &[f64], iterations: usize, out: &mut Taken) {
        let (n, s) = (self.n, self.element.degree());
        let (lag, element) = (self.lag, self.element);
        self.incr[n..].copy_from_slice(&self.x);
        let with_t = !lag.is_autonomous();
        element.gradient_in_place(lag, t0, h, q, &self.incr, with_t, &mut self.ework, &mut self.grad);
        out.work = element_forces(element, self.force, t0, h, q, &self.incr, &mut self.fd);
        out.dq.clear();
        out.dq.extend_from_slice(&self.x[(s - 1) * n..]);
        out.dp.clear();
        out.time_work = 0.0;
        for c in 0..n {
            let mut lq = 0.0;
            for i in 0..element.points() {
                lq += element.rule.weights[i] * self.ework.pts[i].l_q()[c];
            }
            let f: f64 = (0..=s).map(|j| self.fd[j * n + c]).sum();
            out.dp.push(h * lq + f);
        }
        if with_t {
            for i in 0..element.points() {
                out.time_work -= h * element.rule.weights[i] * self.ework.pts[i].l_t();
            }
        }
        out.iterations = iterations;
        match &mut self.last {
            Some((incr, last_h)) => {
                incr.copy_from_slice(&self.incr);
                *last_h = h;
            }
            None => self.last = Some((self.incr.clone(), h)),
        }
    }
}

/// The buffers of a forced Newton solve: element work, gradient, Hessian, discrete forces,
/// their Jacobian, and the increments (0, X).
pub(super) type ForcedBuffers<'b> = (
    &'b mut ElementWork,
    &'b mut [f64],
    &'b mut [f64],
    &'b mut [f64],
    &'b mut [f64],
    &'b mut [f64],
);

/// Solves the forced step equations of step `k` (element [t0, t0 + h] from (q, p)) for the
/// unknowns `x` (starting from their value) by dense Newton: rows [`forced_rows`], row 0 in the
/// form [`summed_row_zero`]. Returns the iterations; on return the buffers hold the last
/// evaluation, a residual-only one at the converged `x`. Shared by the fixed-step and the
/// energy-mode forced steps.
///
/// # Errors
/// A failed Newton solve as [`Error::Step`] naming step k and t0.
pub(super) fn newton_forced<L: Lagrangian, F: Force>(
    (lag, force, element): (&L, &F, &Element),
    (k, t0, h): (usize, f64, f64),
    (q, p): (&[f64], &[f64]),
    (ework, grad, hess, fd, fjac, incr): ForcedBuffers<'_>,
    x: &mut [f64],
    (opts, newton): (&SolverOptions, &mut DenseNewtonWork),
) -> Result<usize> {
    let n = q.len();
    incr[..n].iter_mut().for_each(|x| *x = 0.0);
    let qscale = q.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
    let scale = |x: &[f64]| x.iter().fold(qscale, |m, v| m.max(v.abs()));
    let report = newton_dense(x, opts.tolerance, opts.max_iterations, scale, newton, |x, r, jac| {
        let bufs = (&mut *ework, &mut grad[..], &mut hess[..], &mut fd[..], &mut fjac[..]);
        forced_rows(lag, force, element, (t0, h), q, incr, bufs, x, r, jac);
        summed_row_zero(element, ework, grad, fd, h, p, r);
    })
    .map_err(|f| {
        Error::Step(StepError {
            step: k,
            t: t0,
            residual: f.residual,
            iterations: f.iterations,
            failure: f.failure,
        })
    })?;
    Ok(report.iterations)
}

/// The forced step's rows at increments `x` (node 0's increment is zero): r = ∂L_d/∂Q^j + the
/// discrete forces for j < s (without p_k, which the caller adds in its own form), and with
/// `jac` the Jacobian of those rows, the element Hessian plus the forces' Jacobian. The
/// buffers are (element work, gradient, Hessian, discrete forces, their Jacobian); `incr`
/// receives (0, x). Shared by the fixed-step and the energy-mode forced steps.
#[allow(clippy::too_many_arguments)]
fn forced_rows<L: Lagrangian, F: Force>(
    lag: &L,
    force: &F,
    element: &Element,
    (t0, h): (f64, f64),
    q: &[f64],
    incr: &mut [f64],
    (ework, grad, hess, fd, fjac): (&mut ElementWork, &mut [f64], &mut [f64], &mut [f64], &mut [f64]),
    x: &[f64],
    r: &mut [f64],
    jac: Option<&mut [f64]>,
) {
    let (n, dim) = (q.len(), x.len());
    let w = dim + n;
    incr[n..].copy_from_slice(x);
    match jac {
        Some(jac) => {
            element.hessian_in_place(lag, t0, h, q, incr, ework, grad, hess);
            element_forces_jacobian(element, force, t0, h, q, incr, fd, fjac);
            for a in 0..dim {
                for b in 0..dim {
                    jac[a * dim + b] = hess[a * w + n + b] + fjac[a * w + n + b];
                }
            }
        }
        None => {
            element.gradient_in_place(lag, t0, h, q, incr, false, ework, grad);
            element_forces(element, force, t0, h, q, incr, fd);
        }
    }
    for a in 0..dim {
        r[a] = grad[a] + fd[a];
    }
}

/// Node row 0 of the forced step in the form of the conservative Newton step (issue 21):
/// r_0 = p_k + (Δp − Σ_{j≥1} (∂L_d/∂Q^j + F_d^j)) with Δp = h Σ_i b_i ∂L/∂q(c_i) + Σ_j F_d^j,
/// equal to p_k + ∂L_d/∂Q^0 + F_d^0 in exact arithmetic (the basis functions sum to 1), so that
/// p_k + Δp, the update the step makes, is the solved p_{k+1}; with p_k + row 0 the rounding of
/// the row terms, of one sign step after step, drifts like a bias. `ework`, `grad` and `fd` are
/// those [`forced_rows`] just filled.
fn summed_row_zero(element: &Element, ework: &ElementWork, grad: &[f64], fd: &[f64], h: f64, p: &[f64], r: &mut [f64]) {
    let (n, s) = (p.len(), element.degree());
    for c in 0..n {
        let rows: f64 = (1..=s).map(|j| grad[j * n + c] + fd[j * n + c]).sum();
        r[c] = p[c] + (delta_p(element, ework, fd, h, n, c) - rows);
    }
}

/// Component c of the forced step's momentum update Δp = h Σ_i b_i ∂L/∂q(c_i) + Σ_j F_d^j, from
/// the points of `ework` and the discrete forces `fd` of the last evaluation.
pub(super) fn delta_p(element: &Element, ework: &ElementWork, fd: &[f64], h: f64, n: usize, c: usize) -> f64 {
    let lq = h
        * (0..element.points())
            .map(|i| element.rule.weights[i] * ework.pts[i].l_q()[c])
            .sum::<f64>();
    let f: f64 = (0..=element.degree()).map(|j| fd[j * n + c]).sum();
    lq + f
}
