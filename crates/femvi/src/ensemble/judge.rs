//! The stopping rule of the fixed-point iteration ([`Judge`], `step/fixed_point_step.rs`)
//! for [`LANES`] members at once, written as selects over the lanes so that it is a few
//! vector operations per sweep instead of [`LANES`] branchy scalar calls (which cost the
//! Hénon–Heiles lanes more than their sweeps did). Each lane's verdicts and memory are those
//! of [`Judge::sweep`] on the same inputs: the test below drives both with random sequences,
//! including numbers that are not finite, zero changes and the cap of sweeps.

use crate::lagrangian::{Lanes, LANES};
#[cfg(test)]
use crate::step::{Judge, Verdict};
use crate::step::{SolverOptions, ROUNDOFF_ULPS};

// The verdicts as numbers in a vector register (compared lane by lane at vector speed).
/// A lane sweeps again.
pub(super) const CONTINUE: f64 = 0.0;
/// A lane's stages are converged (`Verdict::Converged`).
pub(super) const CONVERGED: f64 = 1.0;
/// A lane's iteration failed: its change is not finite (`StepFailure::NonFinite`).
pub(super) const NON_FINITE: f64 = 2.0;
/// … stopped decreasing (`StepFailure::Stalled`).
pub(super) const STALLED: f64 = 3.0;
/// … reached the cap of sweeps above the tolerance (`StepFailure::NotConverged`).
pub(super) const NOT_CONVERGED: f64 = 4.0;

/// One step's memory of the stopping rule in every lane.
#[derive(Clone, Copy)]
pub(super) struct LaneJudge {
    tol: f64,
    max_iterations: usize,
    polish_on: bool,
    prev: Lanes,
    non_decreasing: Lanes,
    polish: Lanes,
}

impl LaneJudge {
    /// Before the first sweep of a step (`Judge::new`).
    #[inline(always)]
    pub(super) fn new(opts: &SolverOptions) -> Self {
        Self {
            tol: opts.tolerance,
            max_iterations: opts.max_iterations,
            polish_on: opts.polish,
            prev: [f64::INFINITY; LANES],
            non_decreasing: [0.0; LANES],
            polish: [0.0; LANES],
        }
    }

    /// Every lane's verdict after sweep number `iterations` (one of the codes above), as
    /// `Judge::sweep(delta, ymax, qscale, iterations)` gives it lane by lane, with the memory
    /// of each lane moved on as there (a lane's memory is not read after a verdict other than
    /// [`CONTINUE`]).
    #[inline(always)]
    pub(super) fn sweep(&mut self, delta: &Lanes, ymax: &Lanes, qscale: &Lanes, iterations: usize) -> Lanes {
        let capped = iterations >= self.max_iterations;
        let mut out = [CONTINUE; LANES];
        // Bitwise `&` and `|`, not `&&` and `||`: no branches, so that the loop vectorises.
        for l in 0..LANES {
            let (d, prev) = (delta[l], self.prev[l]);
            // qscale.max(ymax): qscale is never NaN.
            let scale = if ymax[l] > qscale[l] { ymax[l] } else { qscale[l] };
            let within = d <= self.tol * scale;
            let polished = !self.polish_on
                | (d == 0.0)
                | (d >= prev)
                | (self.polish[l] >= 3.0)
                | (d <= ROUNDOFF_ULPS * f64::EPSILON * scale);
            let rising = !within & (d >= prev);
            let roundoff = d <= 64.0 * f64::EPSILON * scale;
            let stalls = rising & !roundoff & (self.non_decreasing[l] + 1.0 >= 3.0);
            let converged = (within & polished) | (rising & roundoff) | (capped & within);
            let mut verdict = CONTINUE;
            verdict = if capped & !within { NOT_CONVERGED } else { verdict };
            verdict = if converged { CONVERGED } else { verdict };
            verdict = if stalls & !converged { STALLED } else { verdict };
            verdict = if d.is_finite() { verdict } else { NON_FINITE };
            out[l] = verdict;
            self.polish[l] += if within & !polished { 1.0 } else { 0.0 };
            self.non_decreasing[l] += if rising & !roundoff { 1.0 } else { 0.0 };
            self.prev[l] = if verdict == CONTINUE { d } else { prev };
        }
        out
    }
}

/// The scalar rule's verdict as a code.
#[cfg(test)]
fn code(v: Verdict) -> f64 {
    use crate::error::StepFailure;
    match v {
        Verdict::Continue => CONTINUE,
        Verdict::Converged => CONVERGED,
        Verdict::Failed(StepFailure::NonFinite) => NON_FINITE,
        Verdict::Failed(StepFailure::Stalled) => STALLED,
        Verdict::Failed(_) => NOT_CONVERGED,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random sequences of sweeps in every lane (changes that shrink, grow, stall, reach
    /// zero, round-off or infinity or NaN; small caps; polish on and off) give the verdicts
    /// of the scalar rule, lane by lane, until each lane's first verdict other than continue.
    #[test]
    fn lanes_judge_as_the_single_run_does() {
        let mut rand = crate::testing::uniform(0x9e37_79b9_7f4a_7c15);
        let mut seen = [0usize; 5];
        for case in 0..4000 {
            let opts = SolverOptions {
                tolerance: [1e-14, 1e-10, 0.0][case % 3],
                max_iterations: 1 + (rand() * 12.0) as usize,
                polish: case % 2 == 0,
                ..SolverOptions::default()
            };
            let mut lanes = LaneJudge::new(&opts);
            let mut single = [Judge::new(&opts); LANES];
            let mut done = [false; LANES];
            let qscale: Lanes = std::array::from_fn(|_| if rand() < 0.1 { f64::MIN_POSITIVE } else { 0.5 + rand() });
            let mut last: Lanes = std::array::from_fn(|_| 1e-3 * rand());
            for it in 1..=opts.max_iterations {
                let mut delta = [0.0; LANES];
                let mut ymax = [0.0; LANES];
                for l in 0..LANES {
                    let x = rand();
                    delta[l] = match (x * 20.0) as usize {
                        0 => f64::NAN,
                        1 => f64::INFINITY,
                        2 => 0.0,
                        3 => last[l],
                        4 => last[l] * 1.5,
                        5 => 30.0 * f64::EPSILON * rand(),
                        6 => 0.5 * f64::EPSILON * rand(),
                        _ => last[l] * rand() * 0.3,
                    };
                    last[l] = delta[l];
                    ymax[l] = if rand() < 0.05 { f64::NAN } else { 2.0 * rand() };
                }
                let got = lanes.sweep(&delta, &ymax, &qscale, it);
                for l in 0..LANES {
                    if done[l] {
                        continue;
                    }
                    let want = code(single[l].sweep(delta[l], ymax[l], qscale[l], it));
                    assert_eq!(got[l], want, "case {case}, sweep {it}, lane {l}: {delta:?}");
                    seen[want as usize] += 1;
                    done[l] = want != CONTINUE;
                }
            }
        }
        // Every verdict occurred.
        assert!(seen.iter().all(|&n| n > 50), "{seen:?}");
    }
}
