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
//!
//! A Lagrangian may divide the mass by a positive d(t, q) ([`Lagrangian::gyroscopic_divisor`],
//! frozen over a step): the momentum is then Mv/d + A with A from
//! [`Lagrangian::gyroscopic_terms_divided`], u and the matrix of the map are multiplied by d,
//! and the start and the history of terms are those of `divided.rs` (the time-transformed
//! Lagrangian of adaptive steps, ∂L_g/∂q' = Mq'/g). `tables.rs` holds the tables.

mod divided;
mod tables;

use super::checkpoint::{Reader, Words};
use super::fixed_point::affine;
use super::guess::Guess;
use super::solver::StepContext;
use super::state::{Increments, LastElement, RunState};
use super::term_history::{TermHistory, TWO_STEP_POINTS};
use crate::discrete::Element;
use crate::error::{Error, Result, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, MassMatrix};
use tables::{Scaled, Tables};

/// Whether steps start from earlier steps' terms extrapolated in time (else from the last
/// element's polynomial, as Newton does). Measured on the Arenstorf expression (h = T/10⁴,
/// uniform) with the last step's terms only: 4.02 → 4.01 sweeps per step at degree 2,
/// 2.26 → 2.04 at degree 4; 4 % and 6 % less time (medians of 7 alternating runs).
const START_FROM_TERMS: bool = true;

/// The gyroscopic fixed-point solver's tables and workspace.
#[derive(Debug, Clone)]
pub(crate) struct GyroscopicStep {
    tab: Tables,
    scaled: Scaled,
    guess: Guess,
    /// u = d M⁻¹p_k.
    u: Vec<f64>,
    /// The divisor d of the mass for this step (`Lagrangian::gyroscopic_divisor`; 1 for
    /// gyroscopic Lagrangians).
    divisor: f64,
    /// The unknowns ΔQ^m, row-major s×n.
    x: Vec<f64>,
    /// Positions, velocities and times at the quadrature points (r×n, r×n, r).
    /// (the positions, then the velocities: `stages`, 2r × n)
    stages: Vec<f64>,
    stage_t: Vec<f64>,
    /// The predicted midpoint of the element (steps with a varying divisor).
    mid_q: Vec<f64>,
    /// A_i and g_i by point (r × 2n), and M⁻¹ applied to each (unused for unit masses).
    terms: Vec<f64>,
    weighted: Vec<f64>,
    /// The terms of the last two accepted steps (A_i, g_i: 2n per point), for steps with a
    /// varying divisor (W_i, v_i, M⁻¹g_i: 3n per point, `divided.rs`), and the current step.
    hist: TermHistory,
    dhist: TermHistory,
    /// The terms extrapolated to the stages (r × 3n) of a step with a varying divisor.
    dterms: Vec<f64>,
    /// The scaled matrix times the divisor (steps with a varying divisor).
    mat_d: Vec<f64>,
    /// Whether the mass is the identity (the terms are then their own M⁻¹ image).
    identity: bool,
    cur_h: f64,
}

impl GyroscopicStep {
    /// Tables and workspace for `element` in dimension n.
    ///
    /// Errors: a degenerate element (singular stiffness block).
    pub(crate) fn new(element: &Element, n: usize) -> Result<Self> {
        let (s, r) = (element.degree(), element.points());
        Ok(Self {
            tab: Tables::new(element)?,
            scaled: Scaled::new(s, r),
            guess: Guess::new(s, n),
            u: vec![0.0; n],
            divisor: 1.0,
            x: vec![0.0; s * n],
            stages: vec![0.0; 2 * r * n],
            stage_t: vec![0.0; r],
            mid_q: vec![0.0; n],
            terms: vec![0.0; 2 * r * n],
            weighted: vec![0.0; 2 * r * n],
            hist: TermHistory::new(r, 2 * n),
            dhist: TermHistory::new(r, 3 * n),
            dterms: vec![0.0; 3 * r * n],
            mat_d: vec![0.0; 2 * r * s],
            identity: true,
            cur_h: f64::NAN,
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
        self.identity = mass.is_identity();
        self.cur_h = h;
        self.divisor = cx.lag.gyroscopic_divisor(state.t, &state.q);
        if self.divisor == 1.0 {
            if START_FROM_TERMS && self.hist.usable(last.valid, last.h, h) {
                self.start_from_terms(cx, state, h);
            } else {
                self.guess.predict(element, last, &state.v0, h);
                self.x.copy_from_slice(&self.guess.x[..s * n]);
            }
        } else {
            self.divided_start(cx, state, last, h)?;
        }
        let iterations = self.iterate(cx, state)?;
        let iterations = if self.divisor == 1.0 {
            iterations
        } else {
            iterations + self.divided_finish(cx, state)?
        };
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
        let (n, s) = (state.n, cx.element.degree());
        let r = cx.element.points();
        self.hist.extrapolate(&cx.element.rule.nodes, h, &mut self.terms);
        let Some(mass) = cx.lag.gyroscopic_mass() else {
            return;
        };
        let rhs = mass_solved(mass, n, &self.terms, &mut self.weighted);
        let sc = &self.scaled;
        affine(s, n, &sc.ha, &self.u, &sc.mat, 2 * r, rhs, &mut self.x, false);
    }

    /// The step was accepted: its terms start the next one.
    pub(crate) fn accepted(&mut self) {
        if self.divisor == 1.0 {
            self.hist.push(&self.terms, self.cur_h);
        } else if self.stage_t.len() <= TWO_STEP_POINTS {
            // Only these start from the history (`divided.rs`).
            self.accepted_divided();
        }
    }

    /// The data the next step's start depends on (checkpoints).
    pub(crate) fn save(&self, w: &mut Words) {
        self.hist.save(w);
        self.dhist.save(w);
    }

    pub(crate) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.hist.load(r)?;
        self.dhist.load(r)
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

    /// Stage positions and velocities from the increments x, in one affine map (the same
    /// operations per stage as two).
    fn stages_from_x<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, state: &RunState) {
        let (n, s, r) = (state.n, cx.element.degree(), cx.element.points());
        let sc = &self.scaled;
        affine(
            2 * r,
            n,
            &sc.stage_a,
            &state.q,
            &sc.stage_tab,
            s,
            &self.x,
            &mut self.stages,
            false,
        );
    }

    /// One sweep: stage positions and velocities from x, the gyroscopic terms there, and x
    /// from them by [`affine`]. Returns (max |Δx|, max |x|), NaN if a value is not finite.
    fn sweep<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, state: &RunState) -> (f64, f64) {
        let (n, s, r) = (state.n, cx.element.degree(), cx.element.points());
        self.stages_from_x(cx, state);
        let (stage_q, stage_v) = self.stages.split_at(self.stage_t.len() * n);
        cx.lag
            .gyroscopic_terms_divided(self.divisor, &self.stage_t, stage_q, stage_v, &mut self.terms);
        let Some(mass) = cx.lag.gyroscopic_mass() else {
            return (f64::NAN, f64::NAN);
        };
        // The right-hand side: rows (A_0, g_0, A_1, g_1, …) times M⁻¹.
        let rhs = mass_solved(mass, n, &self.terms, &mut self.weighted);
        // Steps with a varying divisor take the matrix times d (`divided.rs`).
        let sc = &self.scaled;
        let mat = if self.divisor == 1.0 { &sc.mat } else { &self.mat_d };
        let (delta, xmax, probe) = affine(s, n, &sc.ha, &self.u, mat, 2 * r, rhs, &mut self.x, true);
        if probe.is_nan() {
            return (f64::NAN, f64::NAN);
        }
        (delta, xmax)
    }
}

/// The right-hand side of the affine map: the terms by point times M⁻¹ (the terms themselves
/// for unit masses).
fn mass_solved<'a>(mass: &MassMatrix, n: usize, terms: &'a [f64], weighted: &'a mut [f64]) -> &'a [f64] {
    if mass.is_identity() {
        return terms;
    }
    for (t, w) in terms.chunks_exact(n).zip(weighted.chunks_exact_mut(n)) {
        mass.solve(t, w);
    }
    weighted
}
