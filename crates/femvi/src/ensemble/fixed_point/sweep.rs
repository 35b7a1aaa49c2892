//! One sweep of the fixed-point lanes and its verdicts: the forces at the stage points of
//! every lane, the affine map of the stages (`fixed_point_sweep` of the single run), and the
//! stopping rule in lanes (`ensemble/judge.rs`); lanes whose iteration fails end.

use super::super::judge::{LaneJudge, CONTINUE, CONVERGED, NON_FINITE, NOT_CONVERGED, STALLED};
use super::{Group, Iteration};
use crate::error::{Error, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, Lanes, LANES};
use crate::step::fixed_point::StepTables;
use crate::step::SolverOptions;

impl<const N: usize> Group<N> {
    /// The iteration of the step from the current node, before its first sweep.
    #[inline(always)]
    pub(super) fn iteration(&self, opts: &SolverOptions) -> Iteration {
        // max(m, |q|) as `RunState::qscale` folds it: a select, which vectorises (the same
        // value, m being positive and |q| never −0).
        let mut qscale = [f64::MIN_POSITIVE; LANES];
        for c in 0..N {
            for l in 0..LANES {
                let a = self.node.q[c][l].abs();
                qscale[l] = if a > qscale[l] { a } else { qscale[l] };
            }
        }
        Iteration {
            judge: LaneJudge::new(opts),
            active: self.alive.map(|a| if a { 1.0 } else { 0.0 }),
            sweeps: 0,
            qscale,
        }
    }

    /// One sweep of the lanes still iterating (`FixedPointStep::iterate`), judged: a lane that
    /// stops keeps this sweep's forces; one whose iteration fails ends at node (k, t) with
    /// its single run's error.
    #[inline(always)]
    pub(super) fn sweep_judged<L: Lagrangian>(
        &mut self,
        lag: &L,
        tables: &StepTables,
        stage_t: &[f64],
        it: &mut Iteration,
        at: (usize, f64),
    ) {
        it.sweeps += 1;
        let (mut delta, mut ymax, probe) = self.sweep(lag, tables, stage_t);
        for l in 0..LANES {
            if probe[l].is_nan() {
                (delta[l], ymax[l]) = (f64::NAN, f64::NAN);
            }
        }
        let verdicts = it.judge.sweep(&delta, &ymax, &it.qscale, it.sweeps);
        // Masks as numbers (1 or 0), so that these loops are vector compares and selects.
        let (mut take, mut fails) = ([0.0; LANES], [0.0; LANES]);
        for l in 0..LANES {
            let (v, a) = (verdicts[l], it.active[l] != 0.0);
            take[l] = if a & (v <= CONVERGED) { 1.0 } else { 0.0 };
            fails[l] = if a & (v > CONVERGED) { 1.0 } else { 0.0 };
            it.active[l] = if a & (v == CONTINUE) { 1.0 } else { 0.0 };
        }
        if fails.iter().fold(0.0, |a, &b| a + b) > 0.0 {
            self.iteration_failed(&fails, &verdicts, &delta, (it.sweeps, at));
        }
        for i in 0..stage_t.len() {
            for c in 0..N {
                for l in 0..LANES {
                    self.f[i][c][l] = if take[l] != 0.0 {
                        self.fnew[i][c][l]
                    } else {
                        self.f[i][c][l]
                    };
                }
            }
        }
    }

    /// The lanes that `fails` marks (1: a lane that was sweeping, whose verdict is a
    /// failure; not one that stopped at an earlier sweep, whose later verdicts are not read)
    /// end at node (k, t) with their single run's error (the change `delta` as its residual,
    /// after `sweeps` sweeps).
    #[inline(never)]
    pub(super) fn iteration_failed(
        &mut self,
        fails: &Lanes,
        verdicts: &Lanes,
        delta: &Lanes,
        (sweeps, (k, t)): (usize, (usize, f64)),
    ) {
        for l in 0..LANES {
            if fails[l] == 0.0 {
                continue;
            }
            let failure = match verdicts[l] {
                v if v == NON_FINITE => StepFailure::NonFinite,
                v if v == STALLED => StepFailure::Stalled,
                v if v == NOT_CONVERGED => StepFailure::NotConverged,
                _ => continue,
            };
            if self.alive[l] {
                let error = StepError {
                    step: k,
                    t,
                    residual: delta[l],
                    iterations: sweeps,
                    failure,
                };
                self.end(l, (k, t), k, Error::Step(error));
            }
        }
    }

    /// One sweep in every lane (`fixed_point_sweep`): the forces at q_k + Y_l, then
    /// Y_l ← h a_l u + h² Σ_i B_li f_i. Returns per lane the largest |ΔY|, the largest |Y| and
    /// the finiteness probe (Σ Y·0, NaN where a value is not finite).
    #[inline(always)]
    fn sweep<L: Lagrangian>(&mut self, lag: &L, tables: &StepTables, stage_t: &[f64]) -> (Lanes, Lanes, Lanes) {
        let r = stage_t.len();
        for i in 0..r {
            for c in 0..N {
                for l in 0..LANES {
                    self.pos[i][c][l] = self.node.q[c][l] + self.y[i][c][l];
                }
            }
            lag.force_lanes(stage_t[i], &self.pos[i], &mut self.fnew[i]);
        }
        let (ha, h2b) = (&tables.ha, &tables.h2b);
        let (mut delta, mut ymax, mut probe) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for c in 0..N {
            for (i, &hai) in ha.iter().enumerate().take(r) {
                let mut z = [0.0; LANES];
                for l in 0..LANES {
                    z[l] = hai * self.node.p[c][l];
                }
                for j in 0..r {
                    let m = h2b[j * r + i];
                    for l in 0..LANES {
                        z[l] += m * self.fnew[j][c][l];
                    }
                }
                for l in 0..LANES {
                    let d = (z[l] - self.y[i][c][l]).abs();
                    delta[l] = if d > delta[l] { d } else { delta[l] };
                    ymax[l] = if z[l].abs() > ymax[l] { z[l].abs() } else { ymax[l] };
                    probe[l] += z[l] * 0.0;
                }
                self.y[i][c] = z;
            }
        }
        (delta, ymax, probe)
    }
}
