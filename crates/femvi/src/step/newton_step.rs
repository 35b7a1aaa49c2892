//! The step equations by Newton's method with a line search, for any Lagrangian: unknowns the
//! node increments X^1 … X^s of the element from (t_k, q_k), residuals
//! R_0 = p_k + ∂L_d/∂Q^0 and R_j = ∂L_d/∂Q^j (0 < j < s) ((2.40)–(2.42) for any degree),
//! Jacobian the element Hessian ∂²L_d/∂Q∂Q by automatic differentiation. Then
//! Δq = X^s and Δp = h Σ_i b_i ∂L/∂q(c_i) (the sum of the residual rows). R_0 is evaluated
//! as p_k + Δp − Σ_{j≥1} ∂L_d/∂Q^j, so that p_k + Δp is exactly the p_{k+1} the equations
//! solve for (issue 21: with row 0 itself, a linear drift of energy and angular momentum).

use super::element_work::{buffers, check_dense_newton, ElementBuffers};
use super::guess::Guess;
use super::solver::StepContext;
use super::state::{Increments, LastElement, RunState};
use crate::error::{Error, Result, StepError};
use crate::lagrangian::Lagrangian;
use crate::solve::{newton_dense, DenseNewtonWork, NewtonFailure};

/// Newton's workspace and the predictor of its starting values.
#[derive(Debug, Clone)]
pub(crate) struct NewtonStep {
    guess: Guess,
    newton: DenseNewtonWork,
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
            newton: DenseNewtonWork::new(s * n),
        })
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
        let (lag, element, n) = (cx.lag, cx.element, state.n);
        self.guess.predict(element, last, &state.v0, h);
        let s = element.degree();
        let dim = s * n;
        let w = (s + 1) * n;
        let t0 = state.t;
        let (q, p) = (&state.q, &state.p);
        let (ework, grad, hess) = buffers(bufs, element, n).with_hessian();
        let incr = &mut out.incr;
        incr[..n].iter_mut().for_each(|x| *x = 0.0);
        let qscale = state.qscale();
        let scale = |x: &[f64]| x.iter().fold(qscale, |m, v| m.max(v.abs()));
        let report = newton_dense(
            &mut self.guess.x,
            cx.opts.tolerance,
            cx.opts.max_iterations,
            scale,
            &mut self.newton,
            |x, r, jac| {
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
                r.copy_from_slice(&grad[..dim]);
                // Issue 21: R_0 = p_k + Δp − Σ_{j≥1} ∂L_d/∂Q^j, not p_k + row 0. Equal in exact
                // arithmetic, but row 0's rounded coefficients (b_i ℓ_0'(c_i) etc.) do not
                // make the rows sum to Δp exactly, and the bias (≈ 1e-16·p_k, the same every
                // step) drifted E and L linearly; this way p_k + Δp below is the solved p_{k+1}.
                for c in 0..n {
                    let dp = h
                        * (0..element.points())
                            .map(|i| element.rule.weights[i] * ework.pts[i].l_q()[c])
                            .sum::<f64>();
                    let rows: f64 = (1..=s).map(|j| grad[j * n + c]).sum();
                    r[c] = p[c] + (dp - rows);
                }
            },
        )
        .map_err(|f| step_error(state, f))?;
        // The last evaluation (residual only) was at the converged x: the points hold ∂L/∂q.
        let x = &self.guess.x;
        out.incr[n..].copy_from_slice(x);
        out.dq.copy_from_slice(&x[(s - 1) * n..]);
        for c in 0..n {
            out.dp[c] = h
                * (0..element.points())
                    .map(|i| element.rule.weights[i] * ework.pts[i].l_q()[c])
                    .sum::<f64>();
        }
        Ok(report.iterations)
    }
}
