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

use super::energy::{end_at, start_failed, Energy, NodeEnergy};
use super::MemberEnd;
use crate::error::{Error, StepError, StepFailure};
use crate::lagrangian::{Lagrangian, Lanes, LANES};
use crate::step::TimeGrid;

/// The lanes' starts: q0 and p0 per coordinate.
pub(super) struct Starts<const N: usize> {
    pub(super) q: [Lanes; N],
    pub(super) p: [Lanes; N],
    /// v0 (the fixed-point loop's first guess; the same as p0 where M = I).
    pub(super) v: [Lanes; N],
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
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Scratch<const N: usize> {
    dq: [Lanes; N],
    y: [Lanes; N],
    f1: [Lanes; N],
    probe: Lanes,
}

/// The drift of one group: dq = (h P + a f_{k−1}) + b f_k with P = p + cp, the force point
/// y = q + dq, and the compensated momentum with the last increment added (into `n`).
#[inline(always)]
fn drift<const N: usize>(c: &Carry<N>, n: &mut Carry<N>, s: &mut Scratch<N>, [h, a, b]: [f64; 3]) {
    for i in 0..N {
        for l in 0..LANES {
            s.dq[i][l] = (h * (c.p[i][l] + c.cp[i][l]) + a * c.fprev[i][l]) + b * c.f0[i][l];
            s.y[i][l] = c.q[i][l] + s.dq[i][l];
        }
    }
    n.fprev = c.f0;
    for i in 0..N {
        for l in 0..LANES {
            let yp = c.pending[i][l] + c.cp[i][l];
            n.p[i][l] = c.p[i][l] + yp;
            n.cp[i][l] = (c.p[i][l] - n.p[i][l]) + yp;
        }
    }
}

/// The rest of one group's step once the force f1 at y is in `s`: the momentum increment,
/// the compensated update of q, and the single run's finiteness probe (dp·0 + q·0 summed,
/// NaN where the node is not finite). True if some lane's probe is NaN.
#[inline(always)]
fn update<const N: usize>(c: &Carry<N>, n: &mut Carry<N>, s: &mut Scratch<N>, half_h: f64) -> bool {
    s.probe = [0.0; LANES];
    for i in 0..N {
        for l in 0..LANES {
            n.pending[i][l] = half_h * (c.f0[i][l] + s.f1[i][l]);
            let yq = s.dq[i][l] + c.cq[i][l];
            n.q[i][l] = c.q[i][l] + yq;
            n.cq[i][l] = (c.q[i][l] - n.q[i][l]) + yq;
            s.probe[l] += n.pending[i][l] * 0.0 + n.q[i][l] * 0.0;
        }
    }
    n.f0 = s.f1;
    // Not `any`, whose early exit tests lane after lane: one reduction of the whole register.
    s.probe.iter().fold(false, |a, x| a | x.is_nan())
}

/// The lanes of group `g` whose probe says their new node is not finite end at the node
/// before it, (k, t), unless they ended already. The group's values come as copies: a
/// reference to the loop's own would keep them in memory (no register promotion of a
/// value whose address is taken), which cost every step its stores.
#[cold]
#[inline(never)]
fn record<const N: usize>(
    ends: &mut [Option<MemberEnd>],
    g: usize,
    (c, energy, s): (Carry<N>, Energy, Scratch<N>),
    at: (usize, f64),
) {
    for l in 0..LANES {
        if let Some(end) = ends.get_mut(g * LANES + l) {
            if s.probe[l].is_nan() && end.is_none() {
                *end = Some(failed(&c, &energy, l, at));
            }
        }
    }
}

/// The lanes of group `g` whose energy at the new node (k + 1, t_next) is not finite end
/// at the node before it, (k, t), as a run does ([`Error::NonFiniteEnergy`]), unless they
/// ended already. Copies, as [`record`] takes them.
#[cold]
#[inline(never)]
fn energy_failed<const N: usize>(
    ends: &mut [Option<MemberEnd>],
    g: usize,
    (c, energy, hs): (Carry<N>, Energy, NodeEnergy),
    ((k, t), (k1, t1)): ((usize, f64), (usize, f64)),
) {
    let bad = hs.bad();
    for l in 0..LANES {
        if let Some(end) = ends.get_mut(g * LANES + l) {
            if bad[l] && end.is_none() {
                let mut e = reached(&c, &energy, l, (k, t));
                e.steps = k1;
                e.error = Some(Error::NonFiniteEnergy { step: k1, t: t1 });
                *end = Some(e);
            }
        }
    }
}

/// Lane l of a group that reached the end of the grid at node (k, t).
fn reached<const N: usize>(c: &Carry<N>, energy: &Energy, l: usize, at: (usize, f64)) -> MemberEnd {
    end_at(&c.q, &c.momentum(), energy, l, at)
}

/// The members of `starts` (G groups of [`LANES`]) from t0 to the end of `grid`: one
/// [`MemberEnd`] per lane, group by group (those of unused lanes are dropped by the
/// caller). The groups are independent and each step goes through all of them, so that the
/// processor overlaps one group's chain of dependent operations (the force's square root
/// and division, then the update that the next force needs) with the others'. Nothing of
/// the loop's values is borrowed by a call that is not inlined (the cold paths take
/// copies): a value whose address escapes stays in memory, and every step paid its stores
/// (Kepler, AVX-512: 4.7 ns per member-step with the borrows, 3.3–3.5 without). Inlined
/// into each instruction-set variant (`ensemble/mod.rs`).
#[inline(always)]
pub(super) fn run<L: Lagrangian, const N: usize, const G: usize>(
    lag: &L,
    grid: &TimeGrid,
    starts: &[Starts<N>; G],
) -> Vec<MemberEnd> {
    let t0 = grid.t0();
    let zero = [[0.0; LANES]; N];
    let mut c: [Carry<N>; G] = std::array::from_fn(|g| {
        let mut c = Carry {
            q: starts[g].q,
            cq: zero,
            p: starts[g].p,
            cp: zero,
            pending: zero,
            fprev: zero,
            f0: zero,
        };
        lag.force_lanes(t0, &c.q, &mut c.f0);
        c
    });
    let mut e = [Energy::blank(); G];
    let mut ends: Vec<Option<MemberEnd>> = vec![None; G * LANES];
    // A start whose energy is not finite ends there, with no node.
    for (g, ends) in ends.chunks_mut(LANES).enumerate().take(G) {
        let at_start = e[g].node(lag, t0, &c[g].q, &c[g].p);
        start_failed::<N>(ends, (e[g], at_start), t0);
    }
    let (mut k, mut t, mut hprev) = (0usize, t0, 0.0);
    let mut k1 = 1.0;
    let uniform = grid.uniform_rule();
    let mut w = [Scratch {
        dq: zero,
        y: zero,
        f1: zero,
        probe: [0.0; LANES],
    }; G];
    loop {
        let next = match &uniform {
            Some(u) => u.next(k1, t),
            None => grid.next(k, t),
        };
        let Some((h, t_next)) = next else { break };
        let half_h = 0.5 * h;
        let (a, b) = (half_h * hprev, half_h * (hprev + h));
        let mut n = c;
        for g in 0..G {
            drift(&c[g], &mut n[g], &mut w[g], [h, a, b]);
        }
        for g in 0..G {
            lag.force_lanes(t + h, &w[g].y, &mut w[g].f1);
        }
        let mut bad = false;
        for g in 0..G {
            bad |= update(&c[g], &mut n[g], &mut w[g], half_h);
        }
        if bad {
            for g in 0..G {
                record(&mut ends, g, (c[g], e[g], w[g]), (k, t));
            }
        }
        let mut hs = [NodeEnergy::blank(); G];
        let mut bad = false;
        for g in 0..G {
            hs[g] = e[g].node(lag, t_next, &n[g].q, &n[g].momentum());
            bad |= hs[g].any_bad();
        }
        if bad {
            let at = ((k, t), (k + 1, t_next));
            for g in 0..G {
                energy_failed(&mut ends, g, (c[g], e[g], hs[g]), at);
            }
        }
        c = n;
        hprev = h;
        k += 1;
        k1 += 1.0;
        t = t_next;
    }
    // Copies (a closure that borrowed them would keep the loop's values in memory).
    let last: Vec<(Carry<N>, Energy)> = c.into_iter().zip(e).collect();
    ends.into_iter()
        .enumerate()
        .map(|(m, end)| {
            let (c, e) = &last[(m / LANES).min(G - 1)];
            end.unwrap_or_else(|| reached(c, e, m % LANES, (k, t)))
        })
        .collect()
}

/// Lane l's end at its last good node (k, t), before the step that was not finite: the
/// state and error of its single run (`ExplicitStep::advance`), the momentum materialised as
/// there (also at k = 0, where −0 becomes +0).
#[inline(never)]
fn failed<const N: usize>(c: &Carry<N>, energy: &Energy, l: usize, (k, t): (usize, f64)) -> MemberEnd {
    let mut end = reached(c, energy, l, (k, t));
    end.error = Some(Error::Step(StepError {
        step: k,
        t,
        residual: f64::NAN,
        iterations: 0,
        failure: StepFailure::NonFinite,
    }));
    end
}
