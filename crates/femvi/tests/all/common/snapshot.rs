//! Bit-for-bit snapshots of an explicit run (the explicit loops' tests compare `advance`
//! against `step()` with them): a node, the last element and the checkpoint's words as bits;
//! the Störmer–Verlet element; the FPUT chain's lowest mode.

use femvi::{Element, Integrator, Lagrangian, NodeFamily, QuadratureKind, Start};

/// The bits of each number.
pub fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// A node (k, t, q, p), the last element (t, h, base, increments) and the checkpoint's
/// words, as bits.
pub type Snapshot = (
    usize,
    u64,
    Vec<u64>,
    Vec<u64>,
    Option<(u64, u64, Vec<u64>, Vec<u64>)>,
    Vec<u64>,
);

/// The snapshot of the node `it` is at.
pub fn snapshot<L: Lagrangian>(it: &Integrator<'_, L>) -> Snapshot {
    let n = it.node();
    let last = it
        .last_element()
        .map(|e| (e.t.to_bits(), e.h.to_bits(), bits(e.base), bits(e.incr)));
    (
        n.k,
        n.t.to_bits(),
        bits(n.q),
        bits(n.p),
        last,
        it.checkpoint("explicit").words,
    )
}

/// Degree 1 with the trapezoid rule: Störmer–Verlet.
pub fn verlet() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap()
}

/// A chain of n masses at rest position with the lowest mode's velocities.
pub fn chain_start(n: usize) -> Start {
    let v = (1..=n)
        .map(|i| (std::f64::consts::PI * i as f64 / (n + 1) as f64).sin())
        .collect();
    Start::Velocity { q: vec![0.0; n], v }
}
