//! Störmer–Verlet across lanes: [`LANES`] members of one run (the same Lagrangian and time
//! grid, other starts) advanced a step at a time together, each lane doing the operations of
//! the single run's fast loop (`step/explicit.rs`, `verlet_loop` with M = I: the lazy
//! compensated momentum, the drift from the carried forces, the compensated update of q)
//! and of the energy tracker at every node (`EnergyTracker::node`: H = p·p − (p·p·½ − V)),
//! in the same order, so every lane has the bits of its member's single run. The step size
//! and the time are shared; what differs from lane to lane is data only, so a loop over the
//! lanes of one coordinate is a vector operation.
//!
//! A lane whose new node is not finite fails as its single run does (the node before it is
//! its last, with the step error of `ExplicitStep::advance`); its numbers are kept at that
//! point and the lane goes on computing without being read, so the other lanes are not
//! held up.

use super::MemberEnd;
use crate::error::{Error, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, Lanes, LANES};
use crate::step::TimeGrid;

/// The lanes' starts: q0 and p0 per coordinate.
pub(super) struct Starts<const N: usize> {
    pub(super) q: [Lanes; N],
    pub(super) p: [Lanes; N],
}

/// The energy tracker of every lane (`EnergyTracker` with every node shown, M = I). Aligned
/// to a vector register, like the carried values: a register spilled to the stack across a
/// cache line costs a split load (`femvi ensemble` measured 6.4 against 3.9 ns per
/// member-step when its frame happened to be misaligned).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Energy {
    e0: Lanes,
    max_dev: Lanes,
}

impl Energy {
    /// Records the nodes (q, p) of every lane: H = p·p − (p·p·½ − V(q)), its first finite
    /// value H0, and the largest |H − H0| over the finite ones.
    #[inline(always)]
    fn node<L: Lagrangian, const N: usize>(&mut self, lag: &L, t: f64, q: &[Lanes; N], p: &[Lanes; N]) {
        let v = lag.potential_lanes(t, q).unwrap_or([f64::NAN; LANES]);
        let mut pv = [0.0; LANES];
        for c in 0..N {
            for l in 0..LANES {
                pv[l] += p[c][l] * p[c][l];
            }
        }
        // Selects, not branches, so that the loop is one of vector operations.
        for l in 0..LANES {
            let h = pv[l] - (pv[l] * 0.5 - v[l]);
            let e0 = if self.e0[l].is_nan() { h } else { self.e0[l] };
            let dev = if h.is_finite() { (h - e0).abs() } else { 0.0 };
            self.e0[l] = e0;
            self.max_dev[l] = self.max_dev[l].max(dev);
        }
    }

    /// The largest relative error of lane l, as `EnergyTracker::report` gives it.
    fn max_rel(&self, l: usize) -> f64 {
        let (e0, dev) = (self.e0[l], self.max_dev[l]);
        let rel = if e0 != 0.0 { dev / e0.abs() } else { dev };
        0.0f64.max(rel)
    }
}

/// The carried values of the fast loop (`Carry` in `step/explicit.rs`), lane by lane.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Carry<const N: usize> {
    q: [Lanes; N],
    cq: [Lanes; N],
    p: [Lanes; N],
    cp: [Lanes; N],
    pending: [Lanes; N],
    fprev: [Lanes; N],
    f0: [Lanes; N],
}

impl<const N: usize> Carry<N> {
    /// The node's momentum as the single run materialises it, p + (pending + cp).
    #[inline(always)]
    fn momentum(&self) -> [Lanes; N] {
        let mut m = [[0.0; LANES]; N];
        for c in 0..N {
            for l in 0..LANES {
                m[c][l] = self.p[c][l] + (self.pending[c][l] + self.cp[c][l]);
            }
        }
        m
    }
}

/// The step's intermediate values, aligned as [`Carry`].
#[repr(C, align(64))]
struct Scratch<const N: usize> {
    dq: [Lanes; N],
    y: [Lanes; N],
    f1: [Lanes; N],
    probe: Lanes,
}

/// The members of `starts` from t0 to the end of `grid`: one [`MemberEnd`] per lane (those
/// of unused lanes are dropped by the caller). Inlined into each instruction-set variant
/// (`ensemble/mod.rs`).
#[inline(always)]
pub(super) fn run<L: Lagrangian, const N: usize>(lag: &L, grid: &TimeGrid, starts: &Starts<N>) -> Vec<MemberEnd> {
    let t0 = grid.t0();
    let zero = [[0.0; LANES]; N];
    let mut c = Carry {
        q: starts.q,
        cq: zero,
        p: starts.p,
        cp: zero,
        pending: zero,
        fprev: zero,
        f0: zero,
    };
    lag.force_lanes(t0, &c.q, &mut c.f0);
    let mut energy = Energy {
        e0: [f64::NAN; LANES],
        max_dev: [0.0; LANES],
    };
    energy.node(lag, t0, &c.q, &c.p);
    let mut ends: Vec<Option<MemberEnd>> = vec![None; LANES];
    let (mut k, mut t, mut hprev) = (0usize, t0, 0.0);
    let mut k1 = 1.0;
    let uniform = grid.uniform_rule();
    let mut tmp = Scratch {
        dq: zero,
        y: zero,
        f1: zero,
        probe: [0.0; LANES],
    };
    let Scratch { dq, y, f1, probe } = &mut tmp;
    loop {
        let next = match &uniform {
            Some(u) => u.next(k1, t),
            None => grid.next(k, t),
        };
        let Some((h, t_next)) = next else { break };
        let half_h = 0.5 * h;
        let (a, b) = (half_h * hprev, half_h * (hprev + h));
        for i in 0..N {
            for l in 0..LANES {
                dq[i][l] = (h * (c.p[i][l] + c.cp[i][l]) + a * c.fprev[i][l]) + b * c.f0[i][l];
                y[i][l] = c.q[i][l] + dq[i][l];
            }
        }
        let mut n = Carry { fprev: c.f0, ..c };
        for i in 0..N {
            for l in 0..LANES {
                let yp = c.pending[i][l] + c.cp[i][l];
                n.p[i][l] = c.p[i][l] + yp;
                n.cp[i][l] = (c.p[i][l] - n.p[i][l]) + yp;
            }
        }
        lag.force_lanes(t + h, y, f1);
        *probe = [0.0; LANES];
        for i in 0..N {
            for l in 0..LANES {
                n.pending[i][l] = half_h * (c.f0[i][l] + f1[i][l]);
                let yq = dq[i][l] + c.cq[i][l];
                n.q[i][l] = c.q[i][l] + yq;
                n.cq[i][l] = (c.q[i][l] - n.q[i][l]) + yq;
                probe[l] += n.pending[i][l] * 0.0 + n.q[i][l] * 0.0;
            }
        }
        if probe.iter().zip(&ends).any(|(x, e)| x.is_nan() && e.is_none()) {
            for l in 0..LANES {
                if probe[l].is_nan() && ends[l].is_none() {
                    ends[l] = Some(failed(&c, &energy, l, (k, t)));
                }
            }
        }
        n.f0 = *f1;
        c = n;
        hprev = h;
        k += 1;
        k1 += 1.0;
        t = t_next;
        energy.node(lag, t, &c.q, &c.momentum());
    }
    let p = c.momentum();
    ends.into_iter()
        .enumerate()
        .map(|(l, e)| {
            e.unwrap_or_else(|| MemberEnd {
                k,
                t,
                q: (0..N).map(|i| c.q[i][l]).collect(),
                p: (0..N).map(|i| p[i][l]).collect(),
                steps: k,
                energy_error: energy.max_rel(l),
                error: None,
            })
        })
        .collect()
}

/// Lane l's end at its last good node (k, t), before the step that was not finite: the
/// state and error of its single run (`ExplicitStep::advance`), the momentum materialised as
/// there (also at k = 0, where −0 becomes +0).
#[inline(never)]
fn failed<const N: usize>(c: &Carry<N>, energy: &Energy, l: usize, (k, t): (usize, f64)) -> MemberEnd {
    let p = c.momentum();
    MemberEnd {
        k,
        t,
        q: (0..N).map(|i| c.q[i][l]).collect(),
        p: (0..N).map(|i| p[i][l]).collect(),
        steps: k,
        energy_error: energy.max_rel(l),
        error: Some(Error::Step(StepError {
            step: k,
            t,
            residual: f64::NAN,
            iterations: 0,
            failure: StepFailure::NonFinite,
        })),
    }
}
