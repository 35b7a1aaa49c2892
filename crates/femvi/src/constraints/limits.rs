//! The limits of constrained problems: how far a start may be off the manifold, how many
//! coordinates the dense steps take, and when G(q) counts as singular. Every part of a
//! constrained run (the checked start, `start.rs`; the steps, `stepper.rs`) reads them here.

/// A start is accepted if ‖g(q0)‖∞ ≤ `START_TOLERANCE` · max(1, ‖q0‖∞²).
pub const START_TOLERANCE: f64 = 1e-10;

/// The most coordinates a constrained problem may have: the steps are solved by dense Newton
/// with constraint Hessians by hyper-dual numbers (m n² numbers per point), so memory and time
/// grow like n³.
pub const MAX_COORDINATES: usize = 200;

/// Below this ratio of the smallest to the largest singular value, G(q) counts as singular.
pub(super) const RANK_TOLERANCE: f64 = 1e-12;
