//! Explicit stepping of large chains in blocks of space and time (issue 15: per-step cost
//! per degree of freedom from n = 10³ to 10⁶). At large n the loop of `explicit_wide.rs`
//! is memory-bound: every step streams the state (q, p and their compensations) and the
//! force buffers through main memory. When the force is local with radius r
//! ([`Lagrangian::force_radius`]), component i of step k + 1 needs only components
//! i − r … i + r of step k, so a tile of the chain can be taken through several steps while
//! it stays in cache: temporal blocking with skewed (parallelogram) tiles, as for stencil
//! codes. The operations on each element are those of the wide loop, in the same order, so
//! the bits are those of [`ExplicitStep::step`]; only the order in which elements and steps
//! are visited changes.
//!
//! A band of `d` steps is swept tile by tile from left to right; tile t covers elements
//! [tW − m r, (t + 1)W − m r) at the band's step m (clipped to the chain). The buffers are
//! the wide loop's three, which take turns as the force point y, the force f0 of the step
//! and f1 of the next, by step. Why no element is overwritten before its last reader (for
//! W ≥ 2r): at step m a tile reads y of its left neighbour at [a − (m+1) r, a − m r); the
//! neighbour wrote them at step m − 1, and writes that buffer again only at steps ≥ m + 1,
//! over elements below a − (m+1) r. The force f1 at [a − m r − r, a − m r) that the tile's
//! step m + 1 reads as f0 is likewise the neighbour's, from its step m, and is overwritten
//! only by its step m + 1, below a − (m+1) r. On the right a tile only reads what it wrote
//! itself at the step before, or (at m = 0) what the last band left.

use super::wide::{drift, update_and_drift, InPlace};
use super::ExplicitStep;
use crate::lagrangian::Lagrangian;
use crate::step::grid::TimeGrid;
use crate::step::state::RunState;

/// Elements per tile: the seven arrays of the loop (the state with its two compensations and
/// the three force buffers) take 7 · 8 · 4096 B = 224 KiB of a tile, within a core's L2.
const TILE: usize = 4096;
/// Steps per band (the tile's depth in time): each band fetches the chain from memory once.
/// FPUT at n = 10⁶ (before its force was made faster), ns per step per element: in calls of
/// 100 steps 3.59 / 3.46 / 3.32 / 3.11 at depth 2 / 4 / 8 / 16 against 3.48 unblocked; in
/// calls of 300, 2.76 at depth 64 against 3.33.
const DEPTH: usize = 64;
/// Below this many elements the seven arrays fit in L2 anyway and whole steps are cheaper.
const MIN_BLOCKED: usize = 1 << 15;

/// The radius r of `lag`'s force if the steps from (t, q) are to be taken in blocks: the
/// force is local and computed in parts (`force_range` answers the empty range), the chain is
/// long enough, and a band's skew (r per step) is small against a tile.
pub(crate) fn block_radius<L: Lagrangian>(lag: &L, t: f64, q: &[f64]) -> Option<usize> {
    let r = lag.force_radius()?;
    let pays = q.len() >= MIN_BLOCKED && r.saturating_mul(4 * DEPTH) <= TILE;
    (pays && lag.force_range(t, q, 0..0, &mut [])).then_some(r)
}

/// One step of a band: its size h, its start time and the time it ends at.
#[derive(Clone, Copy, Default)]
struct Sched {
    h: f64,
    t: f64,
    t_end: f64,
}

impl ExplicitStep {
    /// Up to `max_steps − 1` steps with M = I and a force of radius `r` (the carried force
    /// valid; r from [`block_radius`]), in bands of [`DEPTH`] steps swept in tiles of
    /// [`TILE`] elements, the last step of the call left to the caller (it is taken out of place). Returns the
    /// steps taken, the state, `k`, `t`, `steps` and the carried force where `step()` would
    /// leave them; None as soon as a node is not finite (the state is then spoilt: the
    /// caller restores its start), so that the force never sees non-finite positions, as
    /// with `step()`.
    pub(super) fn run_blocked<L: Lagrangian>(
        &mut self,
        lag: &L,
        grid: &TimeGrid,
        state: &mut RunState,
        max_steps: usize,
        r: usize,
    ) -> Option<usize> {
        let n = state.n;
        // `block_radius` keeps 4 DEPTH r ≤ TILE: a tile spans at least 2r (see the module docs).
        let tile = TILE.max(2 * r);
        let Some((h0, t1)) = grid.next(state.k, state.t) else {
            return Some(0);
        };
        let mut cur = Sched {
            h: h0,
            t: state.t,
            t_end: t1,
        };
        let slot0 = self.fsal_slot;
        let (lo, hi) = self.force.split_at_mut(n);
        let (mut f0, mut f1, mut yb) = if slot0 == 0 {
            (lo, hi, &mut self.y[..n])
        } else {
            (hi, lo, &mut self.y[..n])
        };
        let mut ids = if slot0 == 0 { [0, 1, 2] } else { [1, 0, 2] };
        let mut done = 0;
        let mut sched = [Sched::default(); DEPTH + 1];
        let mut drifted = false;
        loop {
            // The band's steps and the one after it (its size enters the last drift).
            sched[0] = cur;
            let mut d = 0;
            while d < DEPTH && done + d + 2 <= max_steps {
                let prev = sched[d];
                let Some((h, t_end)) = grid.next(state.k + d + 1, prev.t_end) else {
                    break;
                };
                d += 1;
                sched[d] = Sched {
                    h,
                    t: prev.t_end,
                    t_end,
                };
            }
            if d == 0 {
                break;
            }
            if !drifted {
                drift(cur.h, &state.p, f0, &state.q, yb);
                drifted = true;
            }
            let tiles = (n + (d - 1) * r).div_ceil(tile);
            for k in 0..tiles {
                let (mut a0, mut a1, mut a2) = (&mut *f0, &mut *f1, &mut *yb);
                for (m, s) in sched[..d].iter().enumerate() {
                    let from = (k * tile).saturating_sub(m * r).min(n);
                    let to = ((k + 1) * tile).saturating_sub(m * r).min(n);
                    if from < to {
                        let range = from..to;
                        lag.force_range(s.t + s.h, a2, range.clone(), &mut a1[range.clone()]);
                        let st = InPlace {
                            q: &mut state.q[range.clone()],
                            cq: &mut state.comp_q[range.clone()],
                            p: &mut state.p[range.clone()],
                            cp: &mut state.comp_p[range.clone()],
                        };
                        let next_h = sched[m + 1].h;
                        if !update_and_drift(st, [s.h, next_h], [&mut a0[range.clone()], &mut a1[range]]) {
                            // Stop at once: the force is not to see non-finite positions.
                            return None;
                        }
                    }
                    (a2, a0, a1) = (a0, a1, a2);
                }
            }
            for _ in 0..d {
                (yb, f0, f1) = (f0, f1, yb);
                ids = [ids[1], ids[2], ids[0]];
            }
            done += d;
            state.k += d;
            state.steps += d;
            state.t = sched[d - 1].t_end;
            cur = sched[d];
        }
        // The carried force (f0 now, buffer ids[0]) into the slot `step()` would leave it in.
        let slot = slot0 ^ (done & 1);
        if ids[0] != slot {
            let target = if ids[1] == slot { f1 } else { yb };
            target.swap_with_slice(f0);
        }
        self.fsal_slot = slot;
        Some(done)
    }
}
