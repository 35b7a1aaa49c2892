//! The optimiser's round-off stop: on fine meshes the KKT residual, divided by h, stalls
//! above the tolerance at a floor that round-off sets, so the iteration ends at the smallest
//! barrier once the componentwise backward error is within the tolerance and Newton's full
//! steps no longer shrink (`solver.rs` applies it). Stopping on the backward error alone left
//! the cart-pole at 10⁵ elements, degree 2, 9.4e-10 off its optimal cost; waiting for the
//! steps brings it to 2e-14.

/// The sizes of the last two steps (max |Δxᵢ| / (1 + |xᵢ|), the final time's included) at
/// the current barrier, for the round-off stop: Newton's full steps shrink at least
/// quadratically until the round-off of the residual they correct is all that is left, then
/// they stay at its size. So a full step no smaller than half the full step before it
/// marks the floor; so do four iterations already taken in the noise (a floor that keeps
/// moving).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Floor {
    last: Option<(f64, bool)>,
    before: Option<(f64, bool)>,
    /// Iterations that went on at the smallest barrier with the backward error in the noise.
    pub(super) noisy: usize,
}

impl Floor {
    pub(super) fn push(&mut self, size: f64, full: bool) {
        self.before = self.last;
        self.last = Some((size, full));
    }

    pub(super) fn reached(&self) -> bool {
        let stalled = match (self.before, self.last) {
            (Some((a, true)), Some((b, true))) => b >= 0.5 * a,
            _ => false,
        };
        stalled || self.noisy >= 4
    }
}
