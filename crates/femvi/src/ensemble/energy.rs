//! What the lane loops share about how members end: the energy tracker of every lane
//! (`EnergyTracker::node` with every node shown, M = I: a node whose energy is not finite
//! ends the member before it), and a member's end at a node.

use super::MemberEnd;
use crate::error::Error;
use crate::lagrangian::{Lagrangian, Lanes, LANES};

/// The energy tracker of every lane (`EnergyTracker` with every node shown, M = I). Aligned
/// to a vector register, like the carried values: a register spilled to the stack across a
/// cache line costs a split load (`femvi ensemble` measured 6.4 against 3.9 ns per
/// member-step when its frame happened to be misaligned).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct Energy {
    e0: Lanes,
    max_dev: Lanes,
}

/// H of every lane at one node ([`Energy::node`]), to find the lanes where it is not finite.
#[derive(Clone, Copy)]
pub(super) struct NodeEnergy(Lanes);

impl NodeEnergy {
    /// No node yet.
    pub(super) fn blank() -> Self {
        NodeEnergy([0.0; LANES])
    }

    /// Whether some lane's H is not finite: one reduction of the whole register (`update` in
    /// `verlet.rs`), not a flag per lane.
    #[inline(always)]
    pub(super) fn any_bad(&self) -> bool {
        self.0.iter().fold(false, |a, h| a | !h.is_finite())
    }

    /// The lanes whose H is not finite.
    pub(super) fn bad(&self) -> [bool; LANES] {
        self.0.map(|h| !h.is_finite())
    }
}

impl Energy {
    /// Nothing recorded yet.
    pub(super) fn blank() -> Self {
        Energy {
            e0: [f64::NAN; LANES],
            max_dev: [0.0; LANES],
        }
    }

    /// Records the nodes (q, p) of every lane: H = p·p − (p·p·½ − V(q)), its first value
    /// that is not NaN as H0, and the largest |H − H0| over the finite ones. Returns H, to
    /// find the lanes where it is not finite (where a run ends, before that node). Not kept
    /// in `self`, whose every field costs a register in the loops.
    #[inline(always)]
    pub(super) fn node<L: Lagrangian, const N: usize>(
        &mut self,
        lag: &L,
        t: f64,
        q: &[Lanes; N],
        p: &[Lanes; N],
    ) -> NodeEnergy {
        let mut pv = [0.0; LANES];
        for c in 0..N {
            for l in 0..LANES {
                pv[l] += p[c][l] * p[c][l];
            }
        }
        // L at v = p (M = I): p·p·½ − V as `Mechanical::value` forms it where V is known,
        // else L itself at v = p ([`Lagrangian::value_lanes`]; `EnergyTracker::node`'s
        // mechanical case, pv − L).
        let lagrangian = match lag.potential_lanes(t, q) {
            Some(v) => {
                let mut l = [0.0; LANES];
                for i in 0..LANES {
                    l[i] = pv[i] * 0.5 - v[i];
                }
                l
            }
            None => lag.value_lanes(t, q, p),
        };
        // Selects, not branches, so that the loop is one of vector operations.
        let mut hs = [0.0; LANES];
        for l in 0..LANES {
            let h = pv[l] - lagrangian[l];
            let e0 = if self.e0[l].is_nan() { h } else { self.e0[l] };
            let dev = if h.is_finite() { (h - e0).abs() } else { 0.0 };
            self.e0[l] = e0;
            self.max_dev[l] = self.max_dev[l].max(dev);
            hs[l] = h;
        }
        NodeEnergy(hs)
    }

    /// The largest relative error of lane l, as `EnergyTracker::report` gives it.
    pub(super) fn max_rel(&self, l: usize) -> f64 {
        let (e0, dev) = (self.e0[l], self.max_dev[l]);
        let rel = if e0 != 0.0 { dev / e0.abs() } else { dev };
        0.0f64.max(rel)
    }
}

/// Lane l's end at node (k, t) of a group whose positions and momenta there are `q` and `p`
/// (the steps taken: k; no error).
pub(super) fn end_at<const N: usize>(
    q: &[Lanes; N],
    p: &[Lanes; N],
    energy: &Energy,
    l: usize,
    (k, t): (usize, f64),
) -> MemberEnd {
    MemberEnd {
        k,
        t,
        q: (0..N).map(|i| q[i][l]).collect(),
        p: (0..N).map(|i| p[i][l]).collect(),
        steps: k,
        energy_error: energy.max_rel(l),
        error: None,
    }
}

/// The lanes of one group (`ends`, up to [`LANES`] members) whose energy at the start is not
/// finite (`at_start`) end there, with no node (NaN state), as a run does. The energy
/// tracker comes as a copy, so that the loop's own is not kept in memory for a reference to
/// it (no register promotion of a value whose address is taken).
#[cold]
#[inline(never)]
pub(super) fn start_failed<const N: usize>(
    ends: &mut [Option<MemberEnd>],
    (energy, at_start): (Energy, NodeEnergy),
    t0: f64,
) {
    let bad = at_start.bad();
    for (l, end) in ends.iter_mut().enumerate() {
        if bad.get(l).copied().unwrap_or(false) {
            *end = Some(MemberEnd {
                k: 0,
                t: t0,
                q: vec![f64::NAN; N],
                p: vec![f64::NAN; N],
                steps: 0,
                energy_error: energy.max_rel(l),
                error: Some(Error::NonFiniteEnergy { step: 0, t: t0 }),
            });
        }
    }
}
