//! Explicit stepping of large systems (issue 15: per-step cost per degree of freedom from
//! n = 10³ to 10⁶): Störmer–Verlet with M = I for any n, the step of [`ExplicitStep::step`]
//! followed by the compensated update of `RunState::commit`, with the same operations on
//! each element in the same order, so the same bits. At large n a step is memory-bound;
//! `step` and `commit` go through 11 arrays of n numbers in four passes (drift, force,
//! momentum increment, update), where this loop makes two per step: the force, and one pass
//! that updates q and p with their compensation terms in place and at once drifts to the
//! next step's force point (y = q_{k+1} + h P_{k+1} + ½h² f_{k+1}). That pass reads six
//! arrays (q, p, their compensations, the two forces) and writes five (the four in place and
//! y, over the force f_k it has just read: three buffers take turns as y, f_k and f_{k+1},
//! so no array is fetched only to be overwritten); the step's increment
//! dq = h p_k + ½h² f_k is recomputed from p_k and f_k where it is needed (the same
//! expression, so the same bits) instead of being stored. A call ends with the two forces
//! in the slots `step()` leaves them in (at most two copies of n numbers per call).
//!
//! Updating q in place loses q_k, the base of the last element, which the run must show
//! after every call. The last step of a call is therefore taken out of place (q_{k+1} into
//! the last element's buffer, the buffers then swapped, as `commit` does), and a call of
//! more than one step first keeps its start (q, p, their compensations and the carried
//! force, in `start`). When a call ends
//! after a step taken in place (the callback said stop, or the node is not finite), it goes
//! back to that start and replays the steps without the callback, the last of them out of
//! place: the same operations, so the same bits, and the last element of the step that
//! ended the call. A step whose node is not finite moves nothing, as `commit` does: the
//! call ends at the last good node, with that node's element.

use super::ExplicitStep;
use crate::error::{Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::step::grid::TimeGrid;
use crate::step::state::{LastElement, Node, RunState};

/// How a run of steps ended.
enum End {
    /// After a step taken out of place: the last element is that step's.
    Kept,
    /// The callback said stop after a step taken in place.
    Stopped,
    /// A step taken in place gave a node that is not finite.
    NonFinite,
}

/// Where a call started: what [`ExplicitStep::restore`] puts back (the rest is in
/// `ExplicitStep::start`).
#[derive(Clone, Copy)]
struct Start {
    k: usize,
    t: f64,
    steps: usize,
    slot: usize,
}

impl ExplicitStep {
    /// Up to `max_steps` steps with M = I (the caller checks), showing every node reached to
    /// `at_node` (false stops after that node): the nodes, the state, the last element and
    /// the carried force of as many calls of [`ExplicitStep::step`] and `RunState::commit`,
    /// bit for bit, also after a non-finite node (the same error, the state as `commit`
    /// leaves it). With `radius` (of a force to take in blocks, `blocked::block_radius`, for
    /// callers that look at no node: `at_node` is not shown the nodes taken in blocks), all
    /// but the last step in blocks of space and time (`explicit_blocked.rs`), the same bits.
    #[allow(clippy::too_many_arguments)] // the integrator's parts, borrowed apart
    pub(crate) fn advance_wide<L: Lagrangian, F: FnMut(Node<'_>) -> bool>(
        &mut self,
        lag: &L,
        grid: &TimeGrid,
        state: &mut RunState,
        last: &mut LastElement,
        max_steps: usize,
        at_node: &mut F,
        radius: Option<usize>,
    ) -> Result<usize> {
        let n = state.n;
        let Some((_, t_next)) = first_step(grid, state, max_steps) else {
            return Ok(0);
        };
        if !self.force0_valid {
            let (lo, hi) = self.force.split_at_mut(n);
            lag.force(state.t, &state.q, if self.fsal_slot == 0 { lo } else { hi });
            self.force0_valid = true;
        }
        // One step, or the grid's last: out of place, nothing to keep.
        if max_steps == 1 || grid.next(state.k + 1, t_next).is_none() {
            return match self.run(lag, grid, state, last, 1, at_node)? {
                (_, End::NonFinite) => {
                    self.rejected();
                    Err(non_finite(state))
                }
                (done, _) => Ok(done),
            };
        }
        let start = self.keep(state);
        // Steps in blocks when nobody looks at the nodes in between and the force is local;
        // after a node that is not finite, the steps again from the start, unblocked.
        let mut blocked = 0;
        if let Some(r) = radius.filter(|_| max_steps > 2) {
            match self.run_blocked(lag, grid, state, max_steps, r) {
                Some(done) => blocked = done,
                None => self.restore(start, state),
            }
        }
        match self.run(lag, grid, state, last, max_steps - blocked, at_node)? {
            (done, End::Kept) => Ok(blocked + done),
            (done, End::Stopped) => {
                self.restore(start, state);
                self.run(lag, grid, state, last, blocked + done, &mut |_| true)
                    .map(|(d, _)| d)
            }
            (done, End::NonFinite) => {
                // The good steps again, the last of them out of place (the last element is
                // that step's), then the failing step alone, out of place: its error, and
                // nothing moved (as `commit`).
                self.restore(start, state);
                if blocked + done > 0 {
                    self.run(lag, grid, state, last, blocked + done, &mut |_| true)?;
                }
                self.run(lag, grid, state, last, 1, &mut |_| true)?;
                self.rejected();
                Err(non_finite(state))
            }
        }
    }

    /// Keeps the start of a call in `start`: q, the compensations, p and the carried force.
    fn keep(&mut self, state: &RunState) -> Start {
        let n = state.n;
        let Self {
            force,
            fsal_slot,
            start,
            ..
        } = self;
        start.resize(5 * n, 0.0);
        let [cq, p, cp, f, b] = [0, 1, 2, 3, 4].map(|i| i * n);
        start[cq..p].copy_from_slice(&state.comp_q);
        start[p..cp].copy_from_slice(&state.p);
        start[cp..f].copy_from_slice(&state.comp_p);
        start[f..b].copy_from_slice(&force[*fsal_slot * n..(*fsal_slot + 1) * n]);
        start[b..].copy_from_slice(&state.q);
        Start {
            k: state.k,
            t: state.t,
            steps: state.steps,
            slot: self.fsal_slot,
        }
    }

    /// Puts back what [`Self::keep`] kept.
    fn restore(&mut self, s: Start, state: &mut RunState) {
        let n = state.n;
        let [cq, p, cp, f, b] = [0, 1, 2, 3, 4].map(|i| i * n);
        state.q.copy_from_slice(&self.start[b..]);
        state.comp_q.copy_from_slice(&self.start[cq..p]);
        state.p.copy_from_slice(&self.start[p..cp]);
        state.comp_p.copy_from_slice(&self.start[cp..f]);
        (state.k, state.t, state.steps) = (s.k, s.t, s.steps);
        self.fsal_slot = s.slot;
        self.force[s.slot * n..(s.slot + 1) * n].copy_from_slice(&self.start[f..b]);
    }

    /// Up to `max_steps` steps (the carried force valid), all but the last of the call in
    /// place; how many, and how the run ended ([`End::NonFinite`]: a step's node is not
    /// finite; after one taken in place the state is spoilt, after the last nothing moved).
    /// (One function: with the commit of a step moved into a helper, even an
    /// `#[inline(always)]` one, the FPU step at n = 10⁴ … 10⁶ measured 8–10 % slower.)
    fn run<L: Lagrangian, F: FnMut(Node<'_>) -> bool>(
        &mut self,
        lag: &L,
        grid: &TimeGrid,
        state: &mut RunState,
        last: &mut LastElement,
        max_steps: usize,
        at_node: &mut F,
    ) -> Result<(usize, End)> {
        let n = state.n;
        let Some((mut h, mut t_next)) = first_step(grid, state, max_steps) else {
            return Ok((0, End::Kept));
        };
        let Self {
            force, fsal_slot, y, ..
        } = self;
        let (lo, hi) = force.split_at_mut(n);
        // Three buffers of n numbers take turns as the force point y, the force f0 of the
        // step and f1 of the next (`ids`: 0, 1 the carried-force slots, 2 the y buffer). The
        // fused pass writes the next y over f0, which it has just read, rather than into a
        // buffer of its own: one array fewer to fetch per step at large n.
        let (mut f0, mut f1, mut yb) = if *fsal_slot == 0 {
            (lo, hi, &mut y[..n])
        } else {
            (hi, lo, &mut y[..n])
        };
        let mut ids = if *fsal_slot == 0 { [0, 1, 2] } else { [1, 0, 2] };
        drift(h, &state.p, f0, &state.q, yb);
        let mut done = 0;
        // The slot `step()` would leave the carried force in: it alternates every step.
        let mut slot = *fsal_slot;
        loop {
            lag.force(state.t + h, &yb[..n], f1);
            slot ^= 1;
            let next = if done + 1 < max_steps {
                grid.next(state.k + 1, t_next)
            } else {
                None
            };
            let finite = match next {
                Some((h2, _)) => {
                    let s = InPlace {
                        q: &mut state.q,
                        cq: &mut state.comp_q,
                        p: &mut state.p,
                        cp: &mut state.comp_p,
                    };
                    update_and_drift(s, [h, h2], [f0, f1])
                }
                // A last step whose node is not finite moves nothing (as `commit`): the run
                // stays at its last good node.
                None if !update_is_finite(state, h, [&*f0, &*f1]) => false,
                None => {
                    last.valid = true;
                    last.t = state.t;
                    last.h = h;
                    std::mem::swap(&mut state.q, &mut last.base);
                    let s = InPlace {
                        q: &mut state.q,
                        cq: &mut state.comp_q,
                        p: &mut state.p,
                        cp: &mut state.comp_p,
                    };
                    update(s, &last.base, h, [&*f0, &*f1], &mut last.incr[n..2 * n])
                }
            };
            if !finite {
                *fsal_slot = carry(ids, slot, [f0, f1, yb]);
                return Ok((done, End::NonFinite));
            }
            state.k += 1;
            state.t = t_next;
            state.steps += 1;
            done += 1;
            let go = at_node(state.node());
            match next {
                Some((h2, t2)) if go => {
                    (h, t_next) = (h2, t2);
                    // f0 holds the next y; f1 is the next step's f0; y's buffer is free.
                    (yb, f0, f1) = (f0, f1, yb);
                    ids = [ids[1], ids[2], ids[0]];
                }
                Some(_) => {
                    *fsal_slot = carry(ids, slot, [f0, f1, yb]);
                    return Ok((done, End::Stopped));
                }
                None => {
                    *fsal_slot = carry(ids, slot, [f0, f1, yb]);
                    return Ok((done, End::Kept));
                }
            }
        }
    }
}

/// The size and end time of a call's first step: None if the call may take none or the
/// grid has ended.
fn first_step(grid: &TimeGrid, state: &RunState, max_steps: usize) -> Option<(f64, f64)> {
    (max_steps > 0).then(|| grid.next(state.k, state.t)).flatten()
}

/// Puts the two forces where `step()` leaves them at the end of a run: the carried force f1
/// (in buffer `ids[1]`) in `slot` of `force` and the last step's f0 (buffer `ids[0]`, intact
/// after a step out of place) in the other slot, the checkpoint holding both. At most two
/// copies of n numbers per call (the y buffer, id 2, is free then). Returns the slot.
fn carry(ids: [usize; 3], slot: usize, [f0, f1, yb]: [&mut [f64]; 3]) -> usize {
    let other = slot ^ 1;
    match ids {
        [a, b, _] if a == other && b == slot => {}
        [a, b, _] if a == slot && b == other => f0.swap_with_slice(f1),
        [2, b, _] if b == slot => yb.copy_from_slice(f0),
        [2, _, _] => {
            yb.copy_from_slice(f1);
            f1.copy_from_slice(f0);
        }
        [a, _, _] if a == other => yb.copy_from_slice(f1),
        _ => {
            yb.copy_from_slice(f0);
            f0.copy_from_slice(f1);
        }
    }
    slot
}

/// The state a step updates in place (q from `base` in [`update`]).
pub(super) struct InPlace<'a> {
    pub(super) q: &'a mut [f64],
    pub(super) cq: &'a mut [f64],
    pub(super) p: &'a mut [f64],
    pub(super) cp: &'a mut [f64],
}

/// The drift of `ExplicitStep::step`: y = q + (h p + ½h² f).
pub(super) fn drift(h: f64, p: &[f64], f: &[f64], q: &[f64], y: &mut [f64]) {
    let n = y.len().min(q.len());
    let (p, f, q, y) = (&p[..n], &f[..n], &q[..n], &mut y[..n]);
    let half_h2 = 0.5 * h * h;
    for c in 0..n {
        y[c] = q[c] + (h * p[c] + half_h2 * f[c]);
    }
}

/// `RunState::commit` of a step of size h in place, with the increments dq = h p + ½h² f0
/// and ½h(f0 + f1), and the drift of the next step (size h2, force f1) written over f0 (each
/// element after it is read). Whether the new node is finite.
#[inline(always)]
pub(super) fn update_and_drift(s: InPlace<'_>, [h, h2]: [f64; 2], [f0, f1]: [&mut [f64]; 2]) -> bool {
    let n = s.q.len();
    let (q, cq, p, cp) = (&mut s.q[..n], &mut s.cq[..n], &mut s.p[..n], &mut s.cp[..n]);
    let (f0, f1) = (&mut f0[..n], &f1[..n]);
    let half_h2 = 0.5 * h * h;
    let half_h2_next = 0.5 * h2 * h2;
    let mut finite = true;
    for c in 0..n {
        let dq = h * p[c] + half_h2 * f0[c];
        let dp = 0.5 * h * (f0[c] + f1[c]);
        let (tq, tp) = commit_one(q[c], dq, dp, (&mut q[c], &mut cq[c]), (&mut p[c], &mut cp[c]));
        finite &= tp.is_finite() & tq.is_finite();
        f0[c] = tq + (h2 * tp + half_h2_next * f1[c]);
    }
    finite
}

/// One component of `RunState::commit`: q = base + dq and p += dp by compensated summation
/// (the compensation terms cq, cp); returns the new (q, p).
#[inline(always)]
fn commit_one(base: f64, dq: f64, dp: f64, (q, cq): (&mut f64, &mut f64), (p, cp): (&mut f64, &mut f64)) -> (f64, f64) {
    let yq = dq + *cq;
    let tq = base + yq;
    *cq = (base - tq) + yq;
    *q = tq;
    let yp = dp + *cp;
    let tp = *p + yp;
    *cp = (*p - tp) + yp;
    *p = tp;
    (tq, tp)
}

/// The error of a step from the node `state` is at whose new node is not finite.
fn non_finite(state: &RunState) -> Error {
    Error::Step(StepError {
        step: state.k,
        t: state.t,
        residual: f64::NAN,
        iterations: 0,
        failure: StepFailure::NonFinite,
    })
}

/// Whether [`update`] from `state` (its q as the base) would give a finite node: the same
/// sums, nothing written.
fn update_is_finite(state: &RunState, h: f64, [f0, f1]: [&[f64]; 2]) -> bool {
    let n = state.q.len();
    let half_h2 = 0.5 * h * h;
    let mut finite = true;
    for c in 0..n {
        let (p, base) = (state.p[c], state.q[c]);
        let dq = h * p + half_h2 * f0[c];
        let dp = 0.5 * h * (f0[c] + f1[c]);
        let tq = base + (dq + state.comp_q[c]);
        let tp = p + (dp + state.comp_p[c]);
        finite &= tp.is_finite() & tq.is_finite();
    }
    finite
}

/// `RunState::commit` alone (the last step of a call), q from `base`, the step's dq into
/// `incr` (the last element's end increment). Whether the new node is finite.
fn update(s: InPlace<'_>, base: &[f64], h: f64, [f0, f1]: [&[f64]; 2], incr: &mut [f64]) -> bool {
    let n = s.q.len();
    let (q, cq, p, cp) = (&mut s.q[..n], &mut s.cq[..n], &mut s.p[..n], &mut s.cp[..n]);
    let (base, f0, f1, incr) = (&base[..n], &f0[..n], &f1[..n], &mut incr[..n]);
    let half_h2 = 0.5 * h * h;
    let mut finite = true;
    for c in 0..n {
        let dq = h * p[c] + half_h2 * f0[c];
        incr[c] = dq;
        let dp = 0.5 * h * (f0[c] + f1[c]);
        let (tq, tp) = commit_one(base[c], dq, dp, (&mut q[c], &mut cq[c]), (&mut p[c], &mut cp[c]));
        finite &= tp.is_finite() & tq.is_finite();
    }
    finite
}
