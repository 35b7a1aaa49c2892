//! Start-up of a run: checking the initial data and turning it into the first node. From
//! (q0, v0) the momentum is p0 = ∂L/∂v; from (q0, p0) the velocity comes from the inverse
//! Legendre transform; from the paper's (q0, q1) the first element's internal equations are
//! solved with both ends fixed, which gives p0 = −∂L_d/∂Q^0 and p1 = ∂L_d/∂Q^s ((2.8)).

use super::element_work::{buffers, check_dense_newton};
use super::integrator::Integrator;
use super::newton_step::step_error;
use super::options::Start;
use crate::error::{check_len, invalid, Result};
use crate::lagrangian::{check_regular, velocity_from_momentum, Lagrangian, PointDerivatives};
use crate::solve::{newton_dense, DenseNewtonWork};

impl<L: Lagrangian> Integrator<'_, L> {
    pub(super) fn start(&mut self, start: Start) -> Result<()> {
        let n = self.state.n;
        let t0 = self.state.t;
        match start {
            Start::Positions { q0, q1 } => {
                check_len("initial q", n, q0.len())?;
                check_len("initial q1", n, q1.len())?;
                finite("initial q", &q0)?;
                finite("initial q1", &q1)?;
                let (h, t1) = self
                    .grid
                    .next(0, t0)
                    .ok_or_else(|| invalid("time span", "no first step"))?;
                let v: Vec<f64> = q0.iter().zip(&q1).map(|(a, b)| (b - a) / h).collect();
                check_regular(&*self.lag, t0, &q0, &v)?;
                let (p0, p1) = self.solve_first_element(h, &q0, &q1)?;
                self.state.q = q0;
                self.state.p = p0;
                self.state.v0 = v;
                self.pending = Some((t1, q1, p1));
            }
            start => {
                let (q, p, v) = initial_node(&*self.lag, t0, start)?;
                self.state.q = q;
                self.state.p = p;
                self.state.v0 = v;
            }
        }
        Ok(())
    }

    /// Solves element 0's internal equations with both ends fixed; returns (p0, p1).
    fn solve_first_element(&mut self, h: f64, q0: &[f64], q1: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.state.n;
        check_dense_newton(&self.element, n)?;
        let s = self.element.degree();
        let t0 = self.state.t;
        let incr = &mut self.inc.incr;
        incr.iter_mut().for_each(|x| *x = 0.0);
        for m in 1..=s {
            let tau = self.element.basis.nodes[m];
            for c in 0..n {
                incr[m * n + c] = tau * (q1[c] - q0[c]);
            }
        }
        let dim = (s - 1) * n;
        let mut x: Vec<f64> = incr[n..s * n].to_vec();
        let mut work = DenseNewtonWork::new(dim);
        let (lag, element, tol) = (&*self.lag, &*self.element, self.opts.tolerance);
        let (ework, grad, hess) = buffers(&mut self.bufs, element, n).with_hessian();
        let scale = q0.iter().chain(q1).fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
        let w = (s + 1) * n;
        newton_dense(
            &mut x,
            tol,
            self.opts.max_iterations,
            |_| scale,
            &mut work,
            |x, r, jac| {
                incr[n..s * n].copy_from_slice(x);
                match jac {
                    Some(jac) => {
                        element.hessian_in_place(lag, t0, h, q0, incr, ework, grad, hess);
                        for a in 0..dim {
                            for b in 0..dim {
                                jac[a * dim + b] = hess[(n + a) * w + n + b];
                            }
                        }
                    }
                    None => {
                        element.gradient_in_place(lag, t0, h, q0, incr, false, ework, grad);
                    }
                }
                r.copy_from_slice(&grad[n..s * n]);
            },
        )
        .map_err(|f| step_error(&self.state, f))?;
        incr[n..s * n].copy_from_slice(&x);
        element.gradient_in_place(lag, t0, h, q0, incr, false, ework, grad);
        let p0: Vec<f64> = grad[..n].iter().map(|g| -g).collect();
        let p1 = grad[s * n..].to_vec();
        self.last.remember(t0, h, q0, &self.inc.incr);
        Ok((p0, p1))
    }
}

/// The first node (q0, p0) and velocity v0 of a start from (q0, v0) (p0 = ∂L/∂v) or from
/// (q0, p0) (v0 by the inverse Legendre transform), after checking the data: what a run
/// starts from, also for the members of an ensemble taken in lanes ([`crate::ensemble`]).
///
/// # Errors
/// Lengths other than the dimension, non-finite numbers, a singular ∂²L/∂v², or a start
/// from two positions (which takes the first element's equations: [`Integrator::new`]).
pub(crate) fn initial_node<L: Lagrangian>(lag: &L, t0: f64, start: Start) -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
    let n = lag.dim();
    let mut work = PointDerivatives::new(n);
    match start {
        Start::Velocity { q, v } => {
            check_len("initial q", n, q.len())?;
            check_len("initial v", n, v.len())?;
            finite("initial q", &q)?;
            finite("initial v", &v)?;
            check_regular(lag, t0, &q, &v)?;
            let mut p = vec![0.0; n];
            if let Some(mass) = lag.mass_matrix() {
                // p = Mv, as first_derivatives computes it, without its force and
                // potential (O(N²) each for n bodies: a step's cost at set-up).
                mass.apply(&v, &mut p);
            } else {
                lag.first_derivatives(t0, &q, &v, false, &mut work);
                p.copy_from_slice(work.l_v());
            }
            Ok((q, p, v))
        }
        Start::Momentum { q, p } => {
            check_len("initial q", n, q.len())?;
            check_len("initial p", n, p.len())?;
            finite("initial q", &q)?;
            finite("initial p", &p)?;
            let mut v = vec![0.0; n];
            velocity_from_momentum(lag, t0, &q, &p, &mut v, &mut work)?;
            check_regular(lag, t0, &q, &v)?;
            Ok((q, p, v))
        }
        Start::Positions { .. } => Err(invalid("start", "from two positions it needs the first element")),
    }
}

/// Ok if every number of `x` is finite, else an error naming `what`.
fn finite(what: &str, x: &[f64]) -> Result<()> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(invalid(what, "contains a non-finite number"))
    }
}
