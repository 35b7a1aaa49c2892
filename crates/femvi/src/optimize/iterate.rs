//! The optimiser's unknowns as its iteration holds them: the iterate (banded unknowns, final
//! time, the bounds' duals) and the bounds on some of its entries, shared by the iteration
//! (`solver.rs`), its step (`newton.rs`, `search.rs`), its start (`start.rs`) and the
//! least-squares multipliers.

/// A bounded unknown: a banded index or the final time, with its bounds (infinite when
/// absent).
#[derive(Debug, Clone, Copy)]
pub(super) struct Bound {
    pub(super) var: Option<usize>,
    pub(super) lo: f64,
    pub(super) up: f64,
}

/// The iterate: banded unknowns (positions, controls, multipliers), final time, bound duals.
#[derive(Debug, Clone)]
pub(super) struct Iterate {
    pub(super) x: Vec<f64>,
    pub(super) t1: f64,
    pub(super) zl: Vec<f64>,
    pub(super) zu: Vec<f64>,
}

/// The value of a bounded unknown in `it`.
pub(super) fn value_of(it: &Iterate, b: &Bound) -> f64 {
    b.var.map_or(it.t1, |i| it.x[i])
}
