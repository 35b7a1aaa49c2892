//! Steps of the gyroscopic fixed point whose mass divisor d varies from step to step
//! (`Lagrangian::gyroscopic_divisor`; the time-transformed Lagrangian of adaptive steps,
//! ∂L_g/∂q' = Mq'/g(q), takes d = g).
//!
//! The step equations do not depend on d: the momentum is split as Mv/d + A with
//! A = ∂L/∂v − Mv/d, and the iteration contracts like the largest |d/g(q(c_i)) − 1| over the
//! quadrature points, first order in the step. So d is g at the midpoint of the element
//! predicted from the last one (with d = g(q_k), 17.7 sweeps per step on Kepler e = 0.9,
//! degree 4, ds = 0.2; with the midpoint 12.5).
//!
//! The divisor multiplies u = M⁻¹p_k and the scaled matrix of the affine map once per step
//! (`mat_d`), so the sweeps take the terms times M⁻¹ as they come. The terms of earlier steps
//! belong to their own divisors, so the history keeps them in a form free of d: per point
//! the physical velocity W = M⁻¹∂L/∂v = M⁻¹A + v/d, the velocity v and M⁻¹∂L/∂q.
//! Extrapolated to the new stages they give the right-hand side (W − v/d, M⁻¹∂L/∂q) of the
//! first sweep.

use super::{GyroscopicStep, START_FROM_TERMS, TWO_STEP_POINTS};
use crate::error::{Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::step::fixed_point::affine;
use crate::step::solver::StepContext;
use crate::step::state::{LastElement, RunState};

impl GyroscopicStep {
    /// The start of a step with a varying divisor: the last element's polynomial, the
    /// divisor at its midpoint, and one sweep on the extrapolated terms when the history
    /// allows.
    pub(super) fn divided_start<L: Lagrangian>(
        &mut self,
        cx: &StepContext<'_, L>,
        state: &RunState,
        last: &LastElement,
        h: f64,
    ) -> Result<()> {
        let (element, n) = (cx.element, state.n);
        let (s, r) = (element.degree(), element.points());
        self.guess.predict(element, last, &state.v0, h);
        self.x.copy_from_slice(&self.guess.x[..s * n]);
        let one = [1.0];
        affine(1, n, &one, &state.q, &self.tab.mid, s, &self.x, &mut self.mid_q, false);
        let d = cx.lag.gyroscopic_divisor(state.t + 0.5 * h, &self.mid_q);
        if !(d.is_finite() && d > 0.0) {
            return Err(non_finite(state, d));
        }
        self.divisor = d;
        self.u.iter_mut().for_each(|u| *u *= d);
        for (md, m) in self.mat_d.iter_mut().zip(&self.scaled.mat) {
            *md = d * m;
        }
        // From the terms only where two steps are extrapolated: from one step (more points)
        // the sweeps per step stayed (Kepler e = 0.9, degree 4: 6.48 → 6.51 at ds = 0.05,
        // 12.49 → 12.56 at ds = 0.2), against 8.46 → 7.29 at degree 2.
        if START_FROM_TERMS && r <= TWO_STEP_POINTS && self.dhist.usable(last.valid, last.h, h) {
            self.dhist.extrapolate(&element.rule.nodes, h, &mut self.dterms);
            let inv_d = 1.0 / d;
            for (x, rhs) in self
                .dterms
                .chunks_exact(3 * n)
                .zip(self.weighted.chunks_exact_mut(2 * n))
            {
                let (w, rest) = x.split_at(n);
                let (v, g) = rest.split_at(n);
                let (ra, rg) = rhs.split_at_mut(n);
                for c in 0..n {
                    ra[c] = w[c] - v[c] * inv_d;
                    rg[c] = g[c];
                }
            }
            let sc = &self.scaled;
            affine(
                s,
                n,
                &sc.ha,
                &self.u,
                &self.mat_d,
                2 * r,
                &self.weighted,
                &mut self.x,
                false,
            );
        }
        Ok(())
    }

    /// After the iteration has stopped: one more sweep, then the terms at the stages of the
    /// final increments, from which the momentum update and the history are taken; returns
    /// the sweeps added (1), or the failure of a sweep that is not finite. Without it the
    /// update took the terms of the iterate before the last, and the last iterates approach
    /// the fixed point from one side, so the angular
    /// momentum and energy drifted ten times as fast as full Newton's (Kepler e = 0.9, order
    /// 8, ds = 0.3, 2 000 periods: L +2.4e-13, mean H +3.6e-12; with it +1.1e-13 and
    /// −7.9e-13 (−3.6e-13 in another build: a round-off draw); full Newton +4.3e-14 and
    /// +2.1e-13; at ds = 0.15 +3.8e-14 and +3.7e-14). The terms at the final increments alone
    /// left a third of the drift (L 1.6e-13, H 1.2e-12); three more sweeps, −2.1e-13 in H.
    pub(super) fn divided_finish<L: Lagrangian>(&mut self, cx: &StepContext<'_, L>, state: &RunState) -> Result<usize> {
        let (delta, _) = self.sweep(cx, state);
        if !delta.is_finite() {
            return Err(non_finite(state, delta));
        }
        let n = state.n;
        self.stages_from_x(cx, state);
        let (stage_q, stage_v) = self.stages.split_at(self.stage_t.len() * n);
        cx.lag
            .gyroscopic_terms_divided(self.divisor, &self.stage_t, stage_q, stage_v, &mut self.terms);
        if let Some(mass) = cx.lag.gyroscopic_mass() {
            if !mass.is_identity() {
                for (t, w) in self.terms.chunks_exact(n).zip(self.weighted.chunks_exact_mut(n)) {
                    mass.solve(t, w);
                }
            }
        }
        Ok(1)
    }

    /// Keeps the accepted step's terms in the divisor-free form (the module documentation).
    pub(super) fn accepted_divided(&mut self) {
        let (n, inv_d) = (self.u.len(), 1.0 / self.divisor);
        let vals = self.dhist.push_in_place(self.cur_h);
        // The last sweep's terms times M⁻¹ (`mass_solved`).
        let solved = if self.identity { &self.terms } else { &self.weighted };
        let stage_v = &self.stages[self.stage_t.len() * n..];
        let points = solved.chunks_exact(2 * n).zip(stage_v.chunks_exact(n));
        for ((rhs, v), out) in points.zip(vals.chunks_exact_mut(3 * n)) {
            let (ra, rg) = rhs.split_at(n);
            let (w, rest) = out.split_at_mut(n);
            let (vo, g) = rest.split_at_mut(n);
            for c in 0..n {
                w[c] = ra[c] + v[c] * inv_d;
                vo[c] = v[c];
                g[c] = rg[c];
            }
        }
    }
}

/// The failure of a step whose divisor or finishing sweep is not finite (or the divisor not
/// positive), with that value as its residual.
fn non_finite(state: &RunState, residual: f64) -> Error {
    Error::Step(StepError {
        step: state.k,
        t: state.t,
        residual,
        iterations: 0,
        failure: StepFailure::NonFinite,
    })
}
