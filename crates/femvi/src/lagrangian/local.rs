//! Local forces (component i of the force depends on q_j only for |i − j| ≤ r): the default
//! of `force_range` for a force that does not say it is local, so that the method is correct
//! for every Lagrangian. The blocked explicit loop (`step/explicit_blocked.rs`) only calls
//! `force_range` of Lagrangians with a `force_radius`, which override it.

use std::ops::Range;

/// Components `range` of a whole force of n components, which `force` writes into the
/// buffer it is given, copied into `out` (as many as both have; nothing out of bounds).
pub(super) fn whole_force_range(force: impl FnOnce(&mut [f64]), n: usize, range: Range<usize>, out: &mut [f64]) {
    let mut all = vec![0.0; n];
    force(&mut all);
    if let Some(part) = all.get(range.start.min(n)..range.end.min(n)) {
        out.iter_mut().zip(part).for_each(|(o, x)| *o = *x);
    }
}
