//! The step equations by Newton's method, for any Lagrangian: unknowns the node increments
//! X^1 … X^s of the element from (t_k, q_k), residuals R_0 = p_k + ∂L_d/∂Q^0 and
//! R_j = ∂L_d/∂Q^j (0 < j < s) ((2.40)–(2.42) for any degree), Jacobian the element Hessian
//! ∂²L_d/∂Q∂Q by automatic differentiation. Then Δq = X^s and Δp = h Σ_i b_i ∂L/∂q(c_i) (the
//! sum of the residual rows). R_0 is evaluated as p_k + Δp − Σ_{j≥1} ∂L_d/∂Q^j, so that
//! p_k + Δp is exactly the p_{k+1} the equations solve for (issue 21: with row 0 itself, a
//! linear drift of energy and angular momentum).
//!
//! `Method::Newton` (and `Auto` for a general Lagrangian) solves by the simplified iteration
//! ([`simplified_newton`], issue 15 item 2): the Jacobian is evaluated at the predicted start
//! and factorised, and kept for the next steps while the iteration contracts with
//! θ ≤ [`THETA_KEEP`] and h stays the same (bit for bit); a step that is too slow refreshes
//! it at its current iterate (and the next steps, up to [`MAX_SKIP`] after repeated
//! failures, evaluate their own), and one that fails even so is solved again from the
//! prediction by full Newton with a line search ([`newton_dense`], what `Method::FullNewton`
//! always uses), so that whatever converged before still does. Its residual rows are
//! assembled with the arithmetic of full Newton's (`newton_residual.rs`) and it iterates to
//! the round-off of the unknowns: without both, its iterates carried a bias that drifted the
//! angular momentum and energy of long runs (issue 15). Checkpoints keep the point at which
//! the kept Jacobian was evaluated, the last θ, the refresh back-off and the predictor's
//! corrections ([`GuessCorrection`]), and a restored run evaluates the Jacobian there
//! again: resumed runs equal uninterrupted ones bit for bit.

use super::checkpoint::{Reader, Words};
use super::element_work::{buffers, check_dense_newton, ElementBuffers};
use super::guess::Guess;
use super::guess_correction::GuessCorrection;
use super::newton_residual::{simplified_residual, ResidualTables};
use super::options::Method;
use super::solver::StepContext;
use super::state::{Increments, LastElement, RunState};
use crate::discrete::ElementWork;
use crate::error::{invalid, Error, Result, StepError};
use crate::lagrangian::Lagrangian;
use crate::solve::{newton_dense, simplified_newton, DenseNewtonWork, FrozenJacobian, NewtonFailure, Simplified};

/// The largest contraction θ of a step after which its Jacobian is kept for the next step
/// (above it, the next step evaluates a fresh one at its predicted start).
pub(crate) const THETA_KEEP: f64 = 0.003;

/// The longest run of steps that evaluate a fresh Jacobian without trying the kept one,
/// after kept Jacobians failed again and again (the adaptive Kepler orbit: a Jacobian from
/// one step off by a third at the next).
const MAX_SKIP: usize = 16;

/// Iterations of the simplified iteration before the Jacobian is refreshed (also capped by
/// the options' `max_iterations`).
const BUDGET: usize = 12;

/// Newton's workspace, the kept Jacobian and the predictor of its starting values.
#[derive(Debug, Clone)]
pub(crate) struct NewtonStep {
    guess: Guess,
    /// Full Newton's buffers: empty until first used (fallback or `Method::FullNewton`).
    newton: DenseNewtonWork,
    frozen: FrozenJacobian,
    /// The basis tables of the residual for the current step size.
    tables: ResidualTables,
    /// Where the kept Jacobian was evaluated: (t_k, h, q_k, X) (empty: none kept).
    at: Vec<f64>,
    /// The kept Jacobian must be evaluated again at `at` (after a checkpoint restore).
    rebuild: bool,
    /// The largest θ of the last step solved by the simplified iteration.
    theta: f64,
    /// The starting values, for a fallback to full Newton.
    start: Vec<f64>,
    /// Steps left that evaluate a fresh Jacobian without trying the kept one.
    skip: usize,
    /// The correction of the guess by the extrapolation's errors at the last steps.
    correction: GuessCorrection,
    /// Whether the last step converged with the kept Jacobian (not a fresh one, nor full
    /// Newton): the step's own, not checkpointed.
    kept_solved: bool,
    /// The skip set after the next failure of a kept Jacobian (doubles up to [`MAX_SKIP`],
    /// 0 again after a kept Jacobian converges).
    backoff: usize,
}

/// A failed Newton solve as the step error at the current node.
pub(crate) fn step_error(state: &RunState, f: NewtonFailure) -> Error {
    Error::Step(StepError {
        step: state.k,
        t: state.t,
        residual: f.residual,
        iterations: f.iterations,
        failure: f.failure,
    })
}

/// The residual R(X) into `r` and, with `jac`, the Jacobian ∂R/∂X (row-major) into it (full
/// Newton's evaluation: the element gradient and Hessian of `discrete.rs`).
#[allow(clippy::too_many_arguments)]
fn evaluate<L: Lagrangian>(
    cx: &StepContext<'_, L>,
    bufs: &mut ElementBuffers,
    (t0, h): (f64, f64),
    q: &[f64],
    p: Option<&[f64]>,
    incr: &mut [f64],
    x: &[f64],
    r: &mut [f64],
    jac: Option<&mut [f64]>,
) {
    let (lag, element, n) = (cx.lag, cx.element, q.len());
    let dim = x.len();
    let w = dim + n;
    let (ework, grad, hess) = bufs.with_hessian();
    incr[..n].iter_mut().for_each(|v| *v = 0.0);
    incr[n..].copy_from_slice(x);
    match jac {
        Some(jac) => {
            element.hessian_in_place(lag, t0, h, q, incr, ework, grad, hess);
            for a in 0..dim {
                jac[a * dim..(a + 1) * dim].copy_from_slice(&hess[a * w + n..a * w + w]);
            }
        }
        None => {
            element.gradient_in_place(lag, t0, h, q, incr, false, ework, grad);
        }
    }
    residual_from_rows(cx, ework, grad, h, p, r);
}

/// R from the element gradient ∂L_d/∂Q in `grad` and the point derivatives in `ework`: the
/// rows j < s, with row 0 replaced, given p_k, by its issue-21 form.
fn residual_from_rows<L: Lagrangian>(
    cx: &StepContext<'_, L>,
    ework: &ElementWork,
    grad: &[f64],
    h: f64,
    p: Option<&[f64]>,
    r: &mut [f64],
) {
    let element = cx.element;
    r.copy_from_slice(&grad[..r.len()]);
    if let Some(p) = p {
        // Issue 21: R_0 = p_k + Δp − Σ_{j≥1} ∂L_d/∂Q^j, not p_k + row 0. Equal in exact
        // arithmetic, but row 0's rounded coefficients (b_i ℓ_0'(c_i) etc.) do not make the
        // rows sum to Δp exactly, and the bias (≈ 1e-16·p_k, the same every step) drifted E
        // and L linearly; this way p_k + Δp (the step's update) is the solved p_{k+1}.
        let (s, n) = (element.degree(), p.len());
        for (c, (rc, pc)) in r.iter_mut().zip(p).enumerate().take(n) {
            let dp = h
                * (0..element.points())
                    .map(|i| element.rule.weights[i] * ework.pts[i].l_q()[c])
                    .sum::<f64>();
            let rows: f64 = (1..=s).map(|j| grad[j * n + c]).sum();
            *rc = pc + (dp - rows);
        }
    }
}

/// The Jacobian ∂R/∂X (row-major, dim = s·n) at X: the block of the element Hessian
/// ∂²L_d/∂Q^j∂Q^m (j < s, m ≥ 1) that [`Element::hessian_in_place`] assembles, by the same
/// arithmetic (same bits), without its other rows and columns and the gradient.
///
/// [`Element::hessian_in_place`]: crate::discrete::Element::hessian_in_place
fn jacobian<L: Lagrangian>(
    cx: &StepContext<'_, L>,
    bufs: &mut ElementBuffers,
    (t0, h): (f64, f64),
    q: &[f64],
    incr: &mut [f64],
    x: &[f64],
    jac: &mut [f64],
) {
    let (lag, element, n) = (cx.lag, cx.element, q.len());
    let (s, dim, m) = (element.degree(), x.len(), 2 * q.len() + 1);
    incr[..n].iter_mut().for_each(|v| *v = 0.0);
    incr[n..].copy_from_slice(x);
    let work = &mut bufs.ework;
    element.points_in_place(t0, h, q, incr, work);
    jac.iter_mut().for_each(|v| *v = 0.0);
    for i in 0..element.points() {
        let pd = &mut work.pts[i];
        lag.second_derivatives(
            work.tc[i],
            &work.qc[i * n..(i + 1) * n],
            &work.vc[i * n..(i + 1) * n],
            false,
            pd,
        );
        let hs = &pd.hess;
        if hs.len() != m * m {
            jac.iter_mut().for_each(|v| *v = f64::NAN);
            return;
        }
        let b = element.rule.weights[i];
        for j in 0..s {
            let (aj, dj) = (element.phi(i, j), element.dphi(i, j));
            for col in 1..=s {
                let (am, dm) = (element.phi(i, col), element.dphi(i, col));
                let (qq, qv, vq, vv) = (b * h * aj * am, b * aj * dm, b * dj * am, b * dj * dm / h);
                for c in 0..n {
                    let (hq, hv) = (&hs[(1 + c) * m..(2 + c) * m], &hs[(1 + n + c) * m..(2 + n + c) * m]);
                    let row = &mut jac[(j * n + c) * dim + (col - 1) * n..(j * n + c) * dim + col * n];
                    for (e, r) in row.iter_mut().enumerate() {
                        *r += qq * hq[1 + e] + qv * hq[1 + n + e] + vq * hv[1 + e] + vv * hv[1 + n + e];
                    }
                }
            }
        }
    }
}

impl NewtonStep {
    /// The workspace for `element` in dimension n.
    ///
    /// # Errors
    /// Dense matrices past [`super::element_work::MAX_DENSE_NEWTON`] (checked before they are
    /// allocated).
    pub(crate) fn new(element: &crate::Element, n: usize) -> Result<Self> {
        check_dense_newton(element, n)?;
        let s = element.degree();
        Ok(Self {
            guess: Guess::new(s, n),
            newton: DenseNewtonWork::new(0),
            frozen: FrozenJacobian::new(s * n),
            tables: ResidualTables::new(),
            at: Vec::new(),
            rebuild: false,
            theta: f64::INFINITY,
            start: vec![0.0; s * n],
            skip: 0,
            backoff: 1,
            correction: GuessCorrection::new(s * n),
            kept_solved: false,
        })
    }

    /// Evaluates and factorises the Jacobian at (t0, h, q, x) and remembers the point.
    fn refresh<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        bufs: &mut ElementBuffers,
        (t0, h): (f64, f64),
        q: &[f64],
        incr: &mut [f64],
        x: &[f64],
    ) -> bool {
        let f = &mut self.frozen;
        jacobian(cx, bufs, (t0, h), q, incr, x, &mut f.jac);
        self.at.clear();
        self.at.extend([t0, h].iter().chain(q).chain(x));
        self.rebuild = false;
        f.factor()
    }

    /// Solves the step from the current node with step h into `out`; returns the iterations.
    pub(crate) fn solve<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        state: &RunState,
        last: &LastElement,
        bufs: &mut Option<ElementBuffers>,
        h: f64,
        out: &mut Increments,
    ) -> Result<usize> {
        let (element, n) = (cx.element, state.n);
        self.guess.predict(element, last, &state.v0, h);
        let s = element.degree();
        let bufs = buffers(bufs, element, n);
        let iterations = if cx.opts.method != Method::FullNewton {
            self.correction.apply(&mut self.guess.x, last, h);
            let iterations = self.simplified(cx, state, bufs, h, &mut out.incr)?;
            self.correction.keep(&self.guess.x, state.t, h, self.kept_solved);
            iterations
        } else {
            self.full(cx, state, bufs, h, &mut out.incr)?
        };
        // The last evaluation (residual only) was at the converged x or, for the simplified
        // iteration, one correction below round-off before it: the points hold ∂L/∂q there,
        // and Δp is taken from them (a fraction hω of p's round-off apart, `solve/simplified.rs`;
        // `examples/newton_drift` measured the same energy and angular-momentum drift as with
        // one more evaluation at x: 10⁶ steps of relativistic Kepler at degrees 2 and 4).
        let x = &self.guess.x;
        out.incr[..n].iter_mut().for_each(|v| *v = 0.0);
        out.incr[n..].copy_from_slice(x);
        out.dq.copy_from_slice(&x[(s - 1) * n..]);
        let ework = &bufs.ework;
        for c in 0..n {
            out.dp[c] = h
                * (0..element.points())
                    .map(|i| element.rule.weights[i] * ework.pts[i].l_q()[c])
                    .sum::<f64>();
        }
        Ok(iterations)
    }

    /// Full Newton with a line search from the guess.
    fn full<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        state: &RunState,
        bufs: &mut ElementBuffers,
        h: f64,
        incr: &mut [f64],
    ) -> Result<usize> {
        let (q, p, t0) = (&state.q, &state.p, state.t);
        let qscale = state.qscale();
        let scale = |x: &[f64]| x.iter().fold(qscale, |m, v| m.max(v.abs()));
        let report = newton_dense(
            &mut self.guess.x,
            cx.opts.tolerance,
            cx.opts.max_iterations,
            scale,
            &mut self.newton,
            |x, r, jac| evaluate(cx, bufs, (t0, h), q, Some(p), incr, x, r, jac),
        )
        .map_err(|f| step_error(state, f))?;
        Ok(report.iterations)
    }

    /// The simplified iteration with the kept Jacobian, refreshed when needed, and full
    /// Newton from the guess if even a fresh Jacobian does not converge.
    fn simplified<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        state: &RunState,
        bufs: &mut ElementBuffers,
        h: f64,
        incr: &mut [f64],
    ) -> Result<usize> {
        let (q, p, t0) = (&state.q, &state.p, state.t);
        let qscale = state.qscale();
        let scale = |x: &[f64]| x.iter().fold(qscale, |m, v| m.max(v.abs()));
        let budget = BUDGET.min(cx.opts.max_iterations);
        if self.rebuild {
            // After a restore: the Jacobian the uninterrupted run holds, evaluated again.
            let at = std::mem::take(&mut self.at);
            let (head, rest) = at.split_at(2);
            let (aq, ax) = rest.split_at(state.n);
            self.refresh(cx, bufs, (head[0], head[1]), aq, incr, ax);
        }
        self.start.copy_from_slice(&self.guess.x);
        let kept_h = self.at.get(1).map(|x| x.to_bits());
        let mut fresh = false;
        let kept_fast = self.theta <= THETA_KEEP;
        if !self.frozen.is_factored() || kept_h != Some(h.to_bits()) || !kept_fast || self.skip > 0 {
            self.skip = self.skip.saturating_sub(1);
            let x = std::mem::take(&mut self.start);
            self.refresh(cx, bufs, (t0, h), q, incr, &x);
            self.start = x;
            fresh = true;
        }
        let mut spent = 0;
        loop {
            let out = simplified_newton(
                &mut self.guess.x,
                cx.opts.tolerance,
                budget,
                scale,
                &mut self.frozen,
                |x, r| {
                    let (work, grad) = (&mut bufs.ework, &mut bufs.grad);
                    simplified_residual(cx.lag, cx.element, &mut self.tables, work, grad, (t0, h), (q, p), x, r)
                },
            );
            match out {
                Simplified::Converged { iterations, theta } => {
                    self.theta = theta;
                    self.kept_solved = !fresh;
                    if !fresh {
                        self.backoff = 1;
                    }
                    return Ok(spent + iterations);
                }
                Simplified::Slow { iterations } | Simplified::Failed { iterations, .. } => {
                    spent += iterations;
                    if fresh {
                        break;
                    }
                    // The kept Jacobian failed: the next steps evaluate their own.
                    self.skip = self.backoff;
                    self.backoff = (2 * self.backoff).min(MAX_SKIP);
                    if !self.guess.x.iter().all(|v| v.is_finite()) {
                        self.guess.x.copy_from_slice(&self.start);
                    }
                    let x = self.guess.x.clone();
                    fresh = true;
                    if !self.refresh(cx, bufs, (t0, h), q, incr, &x) {
                        break;
                    }
                }
            }
        }
        // Fallback: full Newton from the prediction; the next step evaluates a fresh Jacobian.
        self.kept_solved = false;
        self.frozen.clear();
        self.theta = f64::INFINITY;
        self.guess.x.copy_from_slice(&self.start);
        Ok(spent + self.full(cx, state, bufs, h, incr)?)
    }

    /// Writes the point of the kept Jacobian, the last θ, the refresh back-off and the
    /// predictor's correction (nothing else is kept).
    pub(crate) fn save(&self, w: &mut Words) {
        let kept = self.frozen.is_factored() || self.rebuild;
        w.b(kept);
        if kept {
            w.fs(&self.at);
        }
        w.f(self.theta);
        w.u(self.skip);
        w.u(self.backoff);
        self.correction.save(w);
    }

    /// Reads what [`NewtonStep::save`] wrote; the Jacobian is evaluated again at the next step.
    pub(crate) fn load(&mut self, r: &mut Reader<'_>, n: usize) -> Result<()> {
        self.frozen.clear();
        self.rebuild = r.b()?;
        self.at.clear();
        if self.rebuild {
            let len = 2 + n + self.frozen.dim();
            self.at.resize(len, 0.0);
            r.fs(&mut self.at)?;
            if !self.at.iter().all(|v| v.is_finite()) {
                return Err(invalid("checkpoint", "a non-finite Newton Jacobian point"));
            }
        }
        self.theta = r.f()?;
        self.skip = r.u()?.min(MAX_SKIP);
        self.backoff = r.u()?.clamp(1, MAX_SKIP);
        self.correction.load(r)
    }
}
