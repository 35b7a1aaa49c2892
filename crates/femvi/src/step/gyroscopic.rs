//! The step equations of a gyroscopic Lagrangian L = ½vᵀMv + A(t, q)·v − V(t, q) (constant
//! M: magnetic fields, rotating frames) by fixed-point iteration, without Hessians.
//!
//! With ∂L/∂v = Mv + A and g = ∂L/∂q = (∂A/∂q)ᵀv − ∇V, the element equations
//! p_k = −∂L_d/∂Q^0, ∂L_d/∂Q^j = 0 (0 < j < s) read, for the increments ΔQ^m = Q^m − q_k,
//!   (1/h) Σ_m K_jm M ΔQ^m + Σ_i b_i ℓ_j'(c_i) A_i + h Σ_i b_i ℓ_j(c_i) g_i = −δ_j0 p_k,
//! the velocity entering linearly as in the mechanical case (step/fixed_point.rs) and A as a
//! momentum. Inverting the stiffness block once gives
//!   ΔQ^m = h α_m u + h Σ_i γ_mi M⁻¹A_i + h² Σ_i β_mi M⁻¹g_i,   u = M⁻¹p_k,
//! with α, β the mechanical tables and γ_mi = −Σ_{j<s} (K⁻¹)_mj b_i ℓ_j'(c_i). A and g are
//! evaluated at q(c_i) = q_k + Σ_m ℓ_m(c_i) ΔQ^m and v(c_i) = (1/h) Σ_m ℓ_m'(c_i) ΔQ^m, so
//! the map contracts like h (the Lipschitz constants of A and of g in v) for small h.
//! The momentum update is the sum of all element equations, p_{k+1} = p_k + h Σ_i b_i g_i.
//! The iteration starts from the last element's polynomial (step/guess.rs) and stops as the
//! mechanical one does (converged, then polished while the increments still decrease).

use super::checkpoint::{Reader, Words};
use super::fixed_point::{affine, basis_dd, invert};
use super::guess::Guess;
use super::solver::StepContext;
use super::state::{Increments, LastElement, RunState};
use crate::discrete::Element;
use crate::error::{invalid, Error, Result, StepError, StepFailure};
use crate::fem::dd::Dd;
use crate::lagrangian::Lagrangian;

/// Whether steps start from earlier steps' terms extrapolated in time (else from the last
/// element's polynomial, as Newton does). Measured on the Arenstorf expression (h = T/10⁴,
/// uniform) with the last step's terms only: 4.02 → 4.01 sweeps per step at degree 2,
/// 2.26 → 2.04 at degree 4; 4 % and 6 % less time (medians of 7 alternating runs).
const START_FROM_TERMS: bool = true;

/// Rules with at most this many points extrapolate from the last two steps (2r points), the
/// others from the last step. Measured on the Arenstorf expression (h = T/10⁴, medians of 7
/// alternating runs): degree 2, 4.01 → 3.03 sweeps per step and 21 % less time; degree 4,
/// 2.04 → 2.03 sweeps and 9 % more time (the 8-point extrapolation costs more than it saves).
const TWO_STEP_POINTS: usize = 3;

/// The h-independent tables (double-double, rounded when scaled by h).
#[derive(Debug, Clone)]
struct Tables {
    /// α_m (m = 1 … s).
    alpha: Vec<Dd>,
    /// γ_mi and β_mi, row-major s×r.
    gamma: Vec<Dd>,
    beta: Vec<Dd>,
    /// ℓ_m(c_l) and ℓ_m'(c_l) for m = 1 … s, column-major r×s (entry (l, m) at m r + l,
    /// as [`affine`] takes them).
    pos: Vec<f64>,
    vel: Vec<Dd>,
}

impl Tables {
    fn new(element: &Element) -> Result<Self> {
        element.check_nondegenerate()?;
        let (s, r, w) = (element.degree(), element.points(), element.degree() + 1);
        let tau: Vec<Dd> = element.basis.nodes.iter().map(|&t| Dd::new(t)).collect();
        let (phi, dphi) = basis_dd(&tau, &element.rule.nodes);
        let bw: Vec<Dd> = element.rule.weights.iter().map(|&b| Dd::new(b)).collect();
        let mut k = vec![Dd::new(0.0); s * s];
        for j in 0..s {
            for m in 0..s {
                let mut acc = Dd::new(0.0);
                for i in 0..r {
                    acc = acc.add(bw[i].mul(dphi[i * w + j]).mul(dphi[i * w + m + 1]));
                }
                k[j * s + m] = acc;
            }
        }
        let inv = invert(s, k).ok_or_else(|| invalid("scheme", "the element stiffness is singular"))?;
        let alpha = (0..s).map(|m| inv[m * s].neg()).collect();
        let mut gamma = vec![Dd::new(0.0); s * r];
        let mut beta = vec![Dd::new(0.0); s * r];
        for m in 0..s {
            for i in 0..r {
                let (mut g, mut b) = (Dd::new(0.0), Dd::new(0.0));
                for j in 0..s {
                    g = g.add(inv[m * s + j].mul(bw[i]).mul(dphi[i * w + j]));
                    b = b.add(inv[m * s + j].mul(bw[i]).mul(phi[i * w + j]));
                }
                gamma[m * r + i] = g.neg();
                beta[m * r + i] = b.neg();
            }
        }
        let pos = (0..r * s).map(|k| phi[(k % r) * w + k / r + 1].round()).collect();
        let vel = (0..r * s).map(|k| dphi[(k % r) * w + k / r + 1]).collect();
        Ok(Self {
            alpha,
            gamma,
            beta,
            pos,
            vel,
        })
    }
}

/// The tables scaled by one step h.
#[derive(Debug, Clone)]
struct Scaled {
    h_bits: u64,
    /// h α_m.
    ha: Vec<f64>,
    /// Column-major 2r × s (column j contiguous): h γ_·i in column 2i, h² β_·i in column
    /// 2i + 1, so that the gyroscopic terms (A_i, g_i by point) are its right-hand side as
    /// they come.
    mat: Vec<f64>,
    /// ℓ_m'(c_l)/h, column-major as `Tables::vel`.
    vel: Vec<f64>,
    /// Ones (the stage positions are q_k + Σ_m ℓ_m(c_l) ΔQ^m) and zeros (velocities).
    ones: Vec<f64>,
    zeros: Vec<f64>,
    /// h b_i and its rounding error.
    hw: Vec<f64>,
    hw_lo: Vec<f64>,
}

impl Scaled {
    fn build(&mut self, tab: &Tables, weights: &[f64], h: f64) {
        let (s, r) = (tab.alpha.len(), weights.len());
        self.h_bits = h.to_bits();
        let (hd, h2) = (Dd::new(h), Dd::two_prod(h, h));
        for m in 0..s {
            self.ha[m] = hd.mul(tab.alpha[m]).round();
            for i in 0..r {
                self.mat[2 * i * s + m] = hd.mul(tab.gamma[m * r + i]).round();
                self.mat[(2 * i + 1) * s + m] = h2.mul(tab.beta[m * r + i]).round();
            }
        }
        for (v, d) in self.vel.iter_mut().zip(&tab.vel) {
            *v = d.divf(h).round();
        }
        for (i, &b) in weights.iter().enumerate() {
            let x = Dd::two_prod(h, b);
            self.hw[i] = x.round();
            self.hw_lo[i] = x.sub(Dd::new(self.hw[i])).round();
        }
    }
}

/// The gyroscopic fixed-point solver's tables and workspace.
#[derive(Debug, Clone)]
pub(crate) struct GyroscopicStep {
    tab: Tables,
    scaled: Scaled,
    guess: Guess,
    /// u = M⁻¹p_k.
    u: Vec<f64>,
    /// The unknowns ΔQ^m, row-major s×n.
    x: Vec<f64>,
    /// Positions, velocities and times at the quadrature points (r×n, r×n, r).
    stage_q: Vec<f64>,
    stage_v: Vec<f64>,
    stage_t: Vec<f64>,
    /// A_i and g_i by point (r × 2n), and M⁻¹ applied to each (unused for unit masses).
    terms: Vec<f64>,
    weighted: Vec<f64>,
    /// The terms of the last two accepted steps (the older first, r × 2n each), how many of
    /// them are valid, and their steps (older, last); the current step.
    hist: Vec<f64>,
    have: usize,
    hist_h: [f64; 2],
    cur_h: f64,
    /// Extrapolation of the history to the new stages, row-major r × (points used), for the
    /// key (older step, last step, new step, points used).
    extrap: Vec<f64>,
    key: [u64; 4],
}

impl GyroscopicStep {
    /// Tables and workspace for `element` in dimension n.
    ///
    /// Errors: a degenerate element (singular stiffness block).
    pub(crate) fn new(element: &Element, n: usize) -> Result<Self> {
        let (s, r) = (element.degree(), element.points());
        Ok(Self {
            tab: Tables::new(element)?,
            scaled: Scaled {
                h_bits: f64::NAN.to_bits(),
                ha: vec![0.0; s],
                mat: vec![0.0; 2 * r * s],
                vel: vec![0.0; r * s],
                ones: vec![1.0; r],
                zeros: vec![0.0; r],
                hw: vec![0.0; r],
                hw_lo: vec![0.0; r],
            },
            guess: Guess::new(s, n),
            u: vec![0.0; n],
            x: vec![0.0; s * n],
            stage_q: vec![0.0; r * n],
            stage_v: vec![0.0; r * n],
            stage_t: vec![0.0; r],
            terms: vec![0.0; 2 * r * n],
            weighted: vec![0.0; 2 * r * n],
            hist: vec![0.0; 4 * r * n],
            have: 0,
            hist_h: [f64::NAN; 2],
            cur_h: f64::NAN,
            extrap: vec![0.0; 2 * r * r],
            key: [0; 4],
        })
    }

    /// Solves the step from the current node with step h into `out`; returns the sweeps.
    pub(crate) fn solve<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        state: &RunState,
        last: &LastElement,
        h: f64,
        out: &mut Increments,
    ) -> Result<usize> {
        let Some(mass) = cx.lag.gyroscopic_mass() else {
            unreachable!("the gyroscopic solver is chosen for gyroscopic Lagrangians only")
        };
        let (element, n) = (cx.element, state.n);
        let (s, r) = (element.degree(), element.points());
        if self.scaled.h_bits != h.to_bits() {
            self.scaled.build(&self.tab, &element.rule.weights, h);
        }
        for (st, c) in self.stage_t.iter_mut().zip(&element.rule.nodes) {
            *st = state.t + c * h;
        }
        mass.solve(&state.p, &mut self.u);
        self.cur_h = h;
        let rho = h / last.h;
        if START_FROM_TERMS && self.have > 0 && last.valid && last.h == self.hist_h[1] && (0.5..=2.0).contains(&rho) {
            self.start_from_terms(cx, state, h);
        } else {
            self.guess.predict(element, last, &state.v0, h);
            self.x.copy_from_slice(&self.guess.x[..s * n]);
        }
        let iterations = self.iterate(cx, state)?;
        // The update from the last sweep's forces g_i (the ΔQ they gave is in x).
        out.incr[..n].iter_mut().for_each(|x| *x = 0.0);
        out.incr[n..(s + 1) * n].copy_from_slice(&self.x);
        out.dq.copy_from_slice(&self.x[(s - 1) * n..]);
        let sc = &self.scaled;
        for c in 0..n {
            let (mut hi, mut lo) = (0.0, 0.0);
            for i in 0..r {
                let g = self.terms[i * 2 * n + n + c];
                hi += sc.hw[i] * g;
                lo += sc.hw_lo[i] * g;
            }
            out.dp[c] = hi + lo;
        }
        Ok(iterations)
    }

    /// Starting increments from the terms of the last one or two steps extrapolated in time
    /// to the new stages (the polynomial through their stages).
    fn start_from_terms<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, state: &RunState, h: f64) {
        let (n, s, c) = (state.n, cx.element.degree(), &cx.element.rule.nodes);
        let r = c.len();
        let steps = if self.have >= 2 && r <= TWO_STEP_POINTS { 2 } else { 1 };
        let k = steps * r;
        let [h_old, h_last] = self.hist_h;
        let key = [h_old.to_bits(), h_last.to_bits(), h.to_bits(), k as u64];
        if key != self.key {
            self.key = key;
            // Times from the start of the last step: the older step's stages, the last
            // step's, then the new ones.
            let known: Vec<f64> = (0..k)
                .map(|i| match (steps, i < r) {
                    (2, true) => -h_old + c[i] * h_old,
                    (2, false) => c[i - r] * h_last,
                    _ => c[i] * h_last,
                })
                .collect();
            for l in 0..r {
                let x = h_last + c[l] * h;
                for i in 0..k {
                    self.extrap[l * k + i] = (0..k)
                        .filter(|&j| j != i)
                        .map(|j| (x - known[j]) / (known[i] - known[j]))
                        .product();
                }
            }
        }
        let w = 2 * n;
        let data = &self.hist[(2 - steps) * r * w..2 * r * w];
        for l in 0..r {
            for kk in 0..w {
                self.terms[l * w + kk] = (0..k).map(|i| self.extrap[l * k + i] * data[i * w + kk]).sum();
            }
        }
        let Some(mass) = cx.lag.gyroscopic_mass() else {
            return;
        };
        let rhs: &[f64] = if mass.is_identity() {
            &self.terms
        } else {
            for (t, w) in self.terms.chunks_exact(n).zip(self.weighted.chunks_exact_mut(n)) {
                mass.solve(t, w);
            }
            &self.weighted
        };
        let sc = &self.scaled;
        affine(s, n, &sc.ha, &self.u, &sc.mat, 2 * r, rhs, &mut self.x, false);
    }

    /// The step was accepted: its terms start the next one.
    pub(crate) fn accepted(&mut self) {
        let half = self.hist.len() / 2;
        self.hist.copy_within(half.., 0);
        self.hist[half..].copy_from_slice(&self.terms);
        self.hist_h = [self.hist_h[1], self.cur_h];
        self.have = (self.have + 1).min(2);
    }

    /// The data the next step's start depends on (checkpoints).
    pub(crate) fn save(&self, w: &mut Words) {
        w.u(self.have);
        w.fs(&self.hist_h);
        w.fs(&self.hist);
    }

    pub(crate) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.have = r.u()?.min(2);
        r.fs(&mut self.hist_h)?;
        r.fs(&mut self.hist)
    }

    /// Sweeps until the increments stop changing; returns the number of sweeps.
    fn iterate<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, state: &RunState) -> Result<usize> {
        let qscale = state.qscale();
        let (tol, opts) = (cx.opts.tolerance, cx.opts);
        let mut prev = f64::INFINITY;
        let (mut non_decreasing, mut iterations, mut polish) = (0, 0, 0);
        loop {
            iterations += 1;
            let (delta, xmax) = self.sweep(cx, state);
            let scale = qscale.max(xmax);
            let fail = |failure| {
                Error::Step(StepError {
                    step: state.k,
                    t: state.t,
                    residual: delta,
                    iterations,
                    failure,
                })
            };
            if !delta.is_finite() {
                return Err(fail(StepFailure::NonFinite));
            }
            if delta <= tol * scale {
                // Polish as the mechanical fixed point does (step/fixed_point_step.rs).
                if !opts.polish || delta == 0.0 || delta >= prev || polish >= 3 || delta <= f64::EPSILON * scale {
                    break;
                }
                polish += 1;
            } else if delta >= prev {
                if delta <= 64.0 * f64::EPSILON * scale {
                    break;
                }
                non_decreasing += 1;
                if non_decreasing >= 3 {
                    return Err(fail(StepFailure::Stalled));
                }
            }
            if iterations >= opts.max_iterations {
                if delta > tol * scale {
                    return Err(fail(StepFailure::NotConverged));
                }
                break;
            }
            prev = delta;
        }
        Ok(iterations)
    }

    /// One sweep: stage positions and velocities from x, the gyroscopic terms there, and x
    /// from them by [`affine`]. Returns (max |Δx|, max |x|), NaN if a value is not finite.
    fn sweep<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, state: &RunState) -> (f64, f64) {
        let (n, s, r) = (state.n, cx.element.degree(), cx.element.points());
        let sc = &self.scaled;
        affine(
            r,
            n,
            &sc.ones,
            &state.q,
            &self.tab.pos,
            s,
            &self.x,
            &mut self.stage_q,
            false,
        );
        affine(r, n, &sc.zeros, &state.q, &sc.vel, s, &self.x, &mut self.stage_v, false);
        cx.lag
            .gyroscopic_terms(&self.stage_t, &self.stage_q, &self.stage_v, &mut self.terms);
        let Some(mass) = cx.lag.gyroscopic_mass() else {
            return (f64::NAN, f64::NAN);
        };
        // The right-hand side: rows (A_0, g_0, A_1, g_1, …) times M⁻¹.
        let rhs: &[f64] = if mass.is_identity() {
            &self.terms
        } else {
            for (t, w) in self.terms.chunks_exact(n).zip(self.weighted.chunks_exact_mut(n)) {
                mass.solve(t, w);
            }
            &self.weighted
        };
        let (delta, xmax, probe) = affine(s, n, &sc.ha, &self.u, &sc.mat, 2 * r, rhs, &mut self.x, true);
        if probe.is_nan() {
            return (f64::NAN, f64::NAN);
        }
        (delta, xmax)
    }
}
