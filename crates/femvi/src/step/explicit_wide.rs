//! Explicit stepping of large systems (issue 15: per-step cost per degree of freedom from
//! n = 10³ to 10⁶): Störmer–Verlet with M = I for any n, the step of [`ExplicitStep::step`]
//! followed by the compensated update of `RunState::commit`, with the same operations on
//! each element in the same order, so the same bits. At large n a step is memory-bound;
//! the step and the commit go through 11 arrays of n numbers in four passes (drift, force,
//! momentum increment, update), where this loop makes two per step: the force, and one pass
//! that updates q and p with their compensation terms and at once drifts to the next step's
//! force point (dq_{k+1} = h P_{k+1} + ½h² f_{k+1}, y = q_{k+1} + dq_{k+1}). The last
//! element's increment (the step's dq) is kept in one of two buffers that alternate and
//! copied into place when the call returns.

use super::ExplicitStep;
use crate::error::{Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;
use crate::step::grid::TimeGrid;
use crate::step::state::{LastElement, Node, RunState};

impl ExplicitStep {
    /// Up to `max_steps` steps with M = I (the caller checks), showing every node reached to
    /// `at_node` (false stops after that node): the nodes, the state, the last element and
    /// the carried force of as many calls of [`ExplicitStep::step`] and `RunState::commit`,
    /// bit for bit, also after a non-finite node (the same error, the state as `commit`
    /// leaves it).
    pub(crate) fn advance_wide<L: Lagrangian, F: FnMut(Node<'_>) -> bool>(
        &mut self,
        lag: &L,
        grid: &TimeGrid,
        state: &mut RunState,
        last: &mut LastElement,
        max_steps: usize,
        at_node: &mut F,
    ) -> Result<usize> {
        let n = state.n;
        let Some((mut h, mut t_next)) = (max_steps > 0).then(|| grid.next(state.k, state.t)).flatten() else {
            return Ok(0);
        };
        let Self {
            force,
            fsal_slot,
            force0_valid,
            y,
            u: dq,
            tmp: dq_next,
            ..
        } = self;
        let (lo, hi) = force.split_at_mut(n);
        let (mut f0, mut f1) = if *fsal_slot == 0 { (lo, hi) } else { (hi, lo) };
        if !*force0_valid {
            lag.force(state.t, &state.q, f0);
        }
        drift(h, &state.p, f0, &state.q, dq, y);
        let mut done = 0;
        loop {
            lag.force(state.t + h, &y[..n], f1);
            *fsal_slot ^= 1;
            *force0_valid = true;
            let next = if done + 1 < max_steps {
                grid.next(state.k + 1, t_next)
            } else {
                None
            };
            last.valid = true;
            last.t = state.t;
            last.h = h;
            std::mem::swap(&mut state.q, &mut last.base);
            let carried = Carried {
                base: &last.base,
                q: &mut state.q,
                cq: &mut state.comp_q,
                p: &mut state.p,
                cp: &mut state.comp_p,
            };
            let finite = match next {
                Some((h2, _)) => update_and_drift(carried, [h, h2], [&*f0, &*f1], dq, dq_next, y),
                None => update(carried, h, [&*f0, &*f1], dq),
            };
            if !finite {
                last.incr[n..2 * n].copy_from_slice(dq);
                return Err(Error::Step(StepError {
                    step: state.k,
                    t: state.t,
                    residual: f64::NAN,
                    iterations: 0,
                    failure: StepFailure::NonFinite,
                }));
            }
            state.k += 1;
            state.t = t_next;
            state.steps += 1;
            done += 1;
            let go = at_node(state.node());
            match next {
                Some((h2, t2)) if go => {
                    (h, t_next) = (h2, t2);
                    std::mem::swap(dq, dq_next);
                    std::mem::swap(&mut f0, &mut f1);
                }
                _ => {
                    last.incr[n..2 * n].copy_from_slice(dq);
                    return Ok(done);
                }
            }
        }
    }
}

/// The state a step updates: q goes from `base` (q_k) into `q`, the others in place.
struct Carried<'a> {
    base: &'a [f64],
    q: &'a mut [f64],
    cq: &'a mut [f64],
    p: &'a mut [f64],
    cp: &'a mut [f64],
}

/// The drift of `ExplicitStep::step`: dq = h p + ½h² f, y = q + dq.
fn drift(h: f64, p: &[f64], f: &[f64], q: &[f64], dq: &mut [f64], y: &mut [f64]) {
    let n = dq.len();
    let (p, f, q, y) = (&p[..n], &f[..n], &q[..n], &mut y[..n]);
    let half_h2 = 0.5 * h * h;
    for c in 0..n {
        dq[c] = h * p[c] + half_h2 * f[c];
        y[c] = q[c] + dq[c];
    }
}

/// `RunState::commit` of a step of size h with the increments dq and ½h(f0 + f1), and the
/// drift of the next step (size h2, force f1) into `dq_next` and `y`. Whether the new node
/// is finite.
#[inline(always)]
fn update_and_drift(
    s: Carried<'_>,
    [h, h2]: [f64; 2],
    [f0, f1]: [&[f64]; 2],
    dq: &[f64],
    dq_next: &mut [f64],
    y: &mut [f64],
) -> bool {
    let n = dq.len();
    let (base, q, cq, p, cp) = (
        &s.base[..n],
        &mut s.q[..n],
        &mut s.cq[..n],
        &mut s.p[..n],
        &mut s.cp[..n],
    );
    let (f0, f1, dq_next, y) = (&f0[..n], &f1[..n], &mut dq_next[..n], &mut y[..n]);
    let half_h2 = 0.5 * h2 * h2;
    let mut finite = true;
    for c in 0..n {
        let dp = 0.5 * h * (f0[c] + f1[c]);
        let (tq, tp) = commit_one(base[c], dq[c], dp, (&mut q[c], &mut cq[c]), (&mut p[c], &mut cp[c]));
        finite &= tp.is_finite() & tq.is_finite();
        dq_next[c] = h2 * tp + half_h2 * f1[c];
        y[c] = tq + dq_next[c];
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

/// `RunState::commit` alone (the last step of a call). Whether the new node is finite.
fn update(s: Carried<'_>, h: f64, [f0, f1]: [&[f64]; 2], dq: &[f64]) -> bool {
    let n = dq.len();
    let (base, q, cq, p, cp) = (
        &s.base[..n],
        &mut s.q[..n],
        &mut s.cq[..n],
        &mut s.p[..n],
        &mut s.cp[..n],
    );
    let (f0, f1) = (&f0[..n], &f1[..n]);
    let mut finite = true;
    for c in 0..n {
        let dp = 0.5 * h * (f0[c] + f1[c]);
        let (tq, tp) = commit_one(base[c], dq[c], dp, (&mut q[c], &mut cq[c]), (&mut p[c], &mut cp[c]));
        finite &= tp.is_finite() & tq.is_finite();
    }
    finite
}
