//! Evaluations across SIMD lanes (issue 39 item 2): the force and the potential at
//! [`LANES`] points at once, stored coordinate by coordinate (structure of arrays: `q[c][l]`
//! is coordinate c of point l), so that a loop over the lanes of one coordinate is a vector
//! operation. Ensembles ([`crate::ensemble`]) advance [`LANES`] members a step at a time
//! through [`crate::Lagrangian::force_lanes`] and [`crate::Lagrangian::potential_lanes`].
//! The defaults here evaluate lane by lane through the scalar methods, so any Lagrangian
//! has them with the scalar bits; a model that writes its own (Kepler, Hénon–Heiles) does
//! the same IEEE operations in the same order on every lane, so the same bits, in vector
//! registers.

use super::{Lagrangian, Potential};

/// Members an ensemble advances at once: eight doubles, one AVX-512 register (two AVX2
/// registers, four SSE2 ones).
pub const LANES: usize = 8;

/// One number per lane.
pub type Lanes = [f64; LANES];

/// The largest dimension the per-lane defaults take without allocating.
const STACK: usize = 16;

/// [`Lagrangian::force_lanes`] lane by lane through [`Lagrangian::force`]: the scalar bits.
pub(crate) fn force_per_lane<L: Lagrangian + ?Sized>(lag: &L, t: f64, q: &[Lanes], out: &mut [Lanes]) {
    per_lane(q, out, |x, f| lag.force(t, x, f));
}

/// [`Potential::force_lanes`] lane by lane through [`Potential::force`].
pub(crate) fn potential_force_per_lane<P: Potential + ?Sized>(pot: &P, t: f64, q: &[Lanes], out: &mut [Lanes]) {
    per_lane(q, out, |x, f| pot.force(t, x, f));
}

/// Two scratch slices of n numbers: on the stack up to [`STACK`], else allocated.
fn with_scratch<R>(n: usize, body: impl FnOnce(&mut [f64], &mut [f64]) -> R) -> R {
    if n <= STACK {
        let (mut a, mut b) = ([0.0; STACK], [0.0; STACK]);
        body(&mut a[..n], &mut b[..n])
    } else {
        body(&mut vec![0.0; n], &mut vec![0.0; n])
    }
}

/// Gathers each lane's point, calls `eval(point, out)` and scatters its output.
fn per_lane(q: &[Lanes], out: &mut [Lanes], mut eval: impl FnMut(&[f64], &mut [f64])) {
    with_scratch(q.len().min(out.len()), |x, f| {
        for l in 0..LANES {
            for (xc, qc) in x.iter_mut().zip(q) {
                *xc = qc[l];
            }
            eval(x, f);
            for (oc, fc) in out.iter_mut().zip(f.iter()) {
                oc[l] = *fc;
            }
        }
    });
}

/// V lane by lane through `value` (a point per lane, gathered).
pub(crate) fn value_per_lane(q: &[Lanes], mut value: impl FnMut(&[f64]) -> Option<f64>) -> Option<Lanes> {
    let n = q.len();
    let mut xs = [0.0; STACK];
    let mut xh = Vec::new();
    let x: &mut [f64] = if n <= STACK {
        &mut xs[..n]
    } else {
        xh.resize(n, 0.0);
        &mut xh
    };
    let mut v = [0.0; LANES];
    for (l, vl) in v.iter_mut().enumerate() {
        for (xc, qc) in x.iter_mut().zip(q) {
            *xc = qc[l];
        }
        *vl = value(x)?;
    }
    Some(v)
}

/// [`Lagrangian::value_lanes`] lane by lane through [`Lagrangian::value`] in f64: the scalar
/// bits.
pub(crate) fn lagrangian_per_lane<L: Lagrangian + ?Sized>(lag: &L, t: f64, q: &[Lanes], v: &[Lanes]) -> Lanes {
    with_scratch(q.len().min(v.len()), |x, w| {
        let mut out = [0.0; LANES];
        for (l, o) in out.iter_mut().enumerate() {
            for ((xc, wc), (qc, vc)) in x.iter_mut().zip(w.iter_mut()).zip(q.iter().zip(v)) {
                *xc = qc[l];
                *wc = vc[l];
            }
            *o = lag.value(t, x, w);
        }
        out
    })
}
