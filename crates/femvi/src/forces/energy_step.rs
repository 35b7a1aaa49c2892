//! One element of the forced energy mode (`energy.rs`) at a trial step h: the forced step
//! equations R_0 = p_k + ∂L_d/∂Q^0 + F_d^0, R_j = ∂L_d/∂Q^j + F_d^j (module docs of
//! [`crate::forces`]) by dense Newton, then the element's discrete energies E⁻, E⁺
//! ([`Element::energies`]) and the two shares W⁻, W⁺ of its discrete work.
//!
//! The arithmetic is that of the conservative Newton step (`step/newton_step.rs`): the same
//! predictor ([`Guess`], from the last *accepted* element, which trial solves do not move),
//! the same residual and Jacobian with F_d added, the same update Δp = h Σ b_i ∂L/∂q + Σ_j F_d^j.
//! So a zero force gives the conservative energy-mode run with `Method::FullNewton` bit for
//! bit (`tests/forces_energy.rs`; the conservative `Method::Newton` is the simplified iteration).

use super::element::element_forces;
use super::step::{delta_p, newton_forced};
use super::Force;
use crate::discrete::{Element, ElementWork};
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solve::DenseNewtonWork;
use crate::step::{check_dense_newton, Guess, LastElement, SolverOptions};

/// What an element solved at a trial step gives the energy equation (E⁻, E⁺, W⁻, W⁺, W and
/// the magnitude of the terms of E⁻ − W⁻).
pub(super) type ElementEnergy = crate::step::term::ElementEnergies;

/// The forced Newton step with the conservative step's predictor and workspace.
pub(super) struct EnergyStep<'a, L, F> {
    lag: &'a L,
    force: &'a F,
    element: &'a Element,
    opts: SolverOptions,
    n: usize,
    guess: Guess,
    newton: DenseNewtonWork,
    /// The last accepted element (the predictor's source).
    pub(super) last: LastElement,
    ework: ElementWork,
    grad: Vec<f64>,
    hess: Vec<f64>,
    fd: Vec<f64>,
    fjac: Vec<f64>,
    /// The solved element's nodal increments Q^j − q_k, row 0 zero.
    pub(super) incr: Vec<f64>,
    /// q_{k+1} − q_k and p_{k+1} − p_k of the solved element.
    pub(super) dq: Vec<f64>,
    pub(super) dp: Vec<f64>,
    /// (q, v, F) at one quadrature point.
    point: Vec<f64>,
}

impl<'a, L: Lagrangian, F: Force> EnergyStep<'a, L, F> {
    /// The workspace; errors as the dense Newton limit.
    pub(super) fn new(lag: &'a L, force: &'a F, element: &'a Element, opts: SolverOptions, t0: f64) -> Result<Self> {
        let n = lag.dim();
        check_dense_newton(element, n)?;
        let (s, w) = (element.degree(), element.nodes() * n);
        Ok(Self {
            lag,
            force,
            element,
            opts,
            n,
            guess: Guess::new(s, n),
            newton: DenseNewtonWork::new(s * n),
            last: LastElement::new(s, n, t0),
            ework: ElementWork::new(element, n),
            grad: vec![0.0; w],
            hess: vec![0.0; w * w],
            fd: vec![0.0; w],
            fjac: vec![0.0; w * w],
            incr: vec![0.0; w],
            dq: vec![0.0; n],
            dp: vec![0.0; n],
            point: vec![0.0; 3 * n],
        })
    }

    /// Solves the element of step `k` from (t0, q, p) with step h (`v0`: the initial velocity,
    /// the predictor of the first step) into `incr`, `dq`, `dp`; returns the iterations.
    ///
    /// # Errors
    /// A failed Newton solve as [`Error::Step`] naming step k and t0.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn solve(&mut self, k: usize, t0: f64, h: f64, q: &[f64], p: &[f64], v0: &[f64]) -> Result<usize> {
        let (lag, force, element, n) = (self.lag, self.force, self.element, self.n);
        self.guess.predict(element, &self.last, v0, h);
        let s = element.degree();
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
            &mut self.guess.x,
            (&self.opts, &mut self.newton),
        )?;
        // The last evaluation (residual only) was at the converged x: the points hold ∂L/∂q
        // and `fd` the discrete forces there.
        let x = &self.guess.x;
        self.incr[n..].copy_from_slice(x);
        self.dq.copy_from_slice(&x[(s - 1) * n..]);
        for c in 0..n {
            self.dp[c] = delta_p(element, &self.ework, &self.fd, h, n, c);
        }
        Ok(iterations)
    }

    /// E⁻, E⁺, W⁻, W⁺, W and the magnitude of the element solved last, from (t0, q) with step h.
    pub(super) fn energies(&mut self, t0: f64, h: f64, q: &[f64]) -> ElementEnergy {
        let (lag, element, n) = (self.lag, self.element, self.n);
        let with_t = !lag.is_autonomous();
        let ework = &mut self.ework;
        element.gradient_in_place(lag, t0, h, q, &self.incr, with_t, ework, &mut self.grad);
        let (minus, plus) = element.energies(h, ework);
        let mut mag = 0.0;
        for (i, pd) in ework.pts.iter().enumerate() {
            let vlv: f64 = ework.vc[i * n..(i + 1) * n]
                .iter()
                .zip(pd.l_v())
                .map(|(a, b)| (a * b).abs())
                .sum();
            mag += element.rule.weights[i] * (vlv + pd.value.abs());
        }
        let work = element_forces(element, self.force, t0, h, q, &self.incr, &mut self.fd);
        let (w_minus, w_plus, w_abs) = self.work_shares(t0, h, q);
        ElementEnergy {
            minus,
            plus,
            w_minus,
            w_plus,
            work,
            magnitude: (mag + w_abs).max(minus.abs()).max(f64::MIN_POSITIVE),
        }
    }

    /// (W⁻, W⁺, h Σ b_i |F_i·q̇_i|) of the element solved last: the power F·q̇ along the
    /// element polynomial at the quadrature points, weighted by (1 − c_i) and c_i.
    fn work_shares(&mut self, t0: f64, h: f64, q: &[f64]) -> (f64, f64, f64) {
        let (element, n) = (self.element, self.n);
        let (qp, rest) = self.point.split_at_mut(n);
        let (vp, fp) = rest.split_at_mut(n);
        let (mut wm, mut wp, mut wa) = (0.0, 0.0, 0.0);
        for i in 0..element.points() {
            qp.copy_from_slice(q);
            vp.iter_mut().for_each(|v| *v = 0.0);
            for j in 0..element.nodes() {
                let (a, d) = (element.phi(i, j), element.dphi(i, j) / h);
                for c in 0..n {
                    qp[c] += self.incr[j * n + c] * a;
                    vp[c] += self.incr[j * n + c] * d;
                }
            }
            let c = element.rule.nodes[i];
            self.force.force(t0 + c * h, qp, vp, fp);
            let power: f64 = fp.iter().zip(vp.iter()).map(|(f, v)| f * v).sum();
            let bh = element.rule.weights[i] * h;
            wm += bh * (1.0 - c) * power;
            wp += bh * c * power;
            wa += bh * power.abs();
        }
        (wm, wp, wa)
    }

    /// The solved element becomes the last accepted one (the predictor's source).
    pub(super) fn accept(&mut self, t0: f64, h: f64, q: &[f64]) {
        self.last.valid = true;
        self.last.t = t0;
        self.last.h = h;
        self.last.base.copy_from_slice(q);
        self.last.incr.copy_from_slice(&self.incr);
    }
}
