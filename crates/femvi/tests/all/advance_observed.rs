//! `Integrator::advance_observed` (issue 15, item 4: the command drives its runs in chunks and
//! does its per-node work inside the explicit fast loop): the nodes it shows are those that
//! `step()` reaches, bit for bit, on the explicit fast path (uniform and variable grids, unit
//! and non-unit masses) and on the solvers without a fast path; a false from the callback
//! stops the run after that node. And `EnergyTracker`, which keeps the largest |H − H0| and
//! divides once, reports the largest of the per-node relative errors bit for bit, also across
//! a save and restore of its state.

use femvi::lagrangian::MassMatrix;
use femvi::solution::EnergyTracker;
use femvi::{
    models, Element, Integrator, Lagrangian, Mechanical, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid,
};

type Nodes = Vec<(usize, u64, Vec<u64>, Vec<u64>)>;

fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// Every node of a run by `step()`.
fn by_step<L: Lagrangian>(lag: &L, el: &Element, grid: &TimeGrid, start: &Start) -> Nodes {
    let mut it = Integrator::new(lag, el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
    let mut nodes = vec![];
    while it.step().unwrap() {
        let n = it.node();
        nodes.push((n.k, n.t.to_bits(), bits(n.q), bits(n.p)));
    }
    nodes
}

/// Every node of a run by `advance_observed` in chunks of `chunk` steps, checking that the
/// integrator's node after each chunk is the last node shown.
fn by_chunks<L: Lagrangian>(lag: &L, el: &Element, grid: &TimeGrid, start: &Start, chunk: usize) -> Nodes {
    let mut it = Integrator::new(lag, el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
    let mut nodes: Nodes = vec![];
    loop {
        let done = it
            .advance_observed(chunk, |n| {
                nodes.push((n.k, n.t.to_bits(), bits(n.q), bits(n.p)));
                true
            })
            .unwrap();
        if done == 0 {
            break;
        }
        let n = it.node();
        assert_eq!(nodes.last(), Some(&(n.k, n.t.to_bits(), bits(n.q), bits(n.p))));
    }
    nodes
}

#[test]
fn advance_observed_shows_the_nodes_of_step_bit_for_bit() {
    let kepler = models::kepler(1.0).unwrap();
    let heavy = Mechanical::new(
        femvi::models::KeplerPotential { mu: 1.0 },
        MassMatrix::diagonal(vec![2.0, 0.5]).unwrap(),
    )
    .unwrap();
    let verlet = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let gauss2 = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2)).unwrap();
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    let uniform = TimeGrid::uniform(0.0, 0.01, 3.0).unwrap();
    let variable = TimeGrid::steps(0.0, vec![0.01, 0.017, 0.006], 3.0).unwrap();
    for grid in [&uniform, &variable] {
        for el in [&verlet, &gauss2] {
            let want = by_step(&kepler, el, grid, &start);
            assert!(want.len() >= 200);
            for chunk in [1, 7, 1000] {
                assert_eq!(by_chunks(&kepler, el, grid, &start, chunk), want, "chunk {chunk}");
            }
        }
        let want = by_step(&heavy, &verlet, grid, &start);
        assert_eq!(by_chunks(&heavy, &verlet, grid, &start, 13), want, "M = diag(2, 0.5)");
    }
}

#[test]
fn a_false_from_the_callback_stops_after_that_node() {
    let kepler = models::kepler(1.0).unwrap();
    let start = Start::Momentum {
        q: vec![1.0, 0.0],
        p: vec![0.0, 1.0],
    };
    let grid = TimeGrid::uniform(0.0, 0.01, 10.0).unwrap();
    for el in [
        Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap(),
        Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2)).unwrap(),
    ] {
        let mut it = Integrator::new(&kepler, &el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
        let mut shown = 0;
        let done = it
            .advance_observed(usize::MAX, |n| {
                shown += 1;
                n.k < 37
            })
            .unwrap();
        assert_eq!((done, shown, it.node().k), (37, 37, 37));
        // The run goes on from there as if it had not stopped.
        while it.step().unwrap() {}
        let want = by_step(&kepler, &el, &grid, &start);
        let end = want.last().unwrap();
        assert_eq!(
            (it.node().k, bits(it.node().q), bits(it.node().p)),
            (end.0, end.2.clone(), end.3.clone())
        );
    }
}

#[test]
fn the_tracker_reports_the_largest_relative_error_bit_for_bit() {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let start = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    let el = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let grid = TimeGrid::uniform(0.0, 0.3, 60.0).unwrap();
    let mut it = Integrator::new(&lag, &el, grid, start.clone(), SolverOptions::default()).unwrap();
    let mut tracker = EnergyTracker::new(1, &start, true);
    let (mut e0, mut max_rel) = (f64::NAN, 0.0f64);
    let mut saved = None;
    let mut node = 0;
    loop {
        let n = it.node();
        let e = tracker.node(&lag, n.t, n.q, n.p).unwrap();
        // The relative error as the tracker defined it before: one division per node.
        let h = n.p[0] * n.p[0] - lag.value(n.t, n.q, n.p);
        assert_eq!(e.h.to_bits(), h.to_bits());
        if e0.is_nan() {
            e0 = h;
        }
        let rel = ((h - e0) / e0).abs();
        assert_eq!(e.rel.to_bits(), rel.to_bits());
        max_rel = max_rel.max(rel);
        assert_eq!(tracker.report().max_rel_error.to_bits(), max_rel.to_bits());
        node += 1;
        if node == 50 {
            saved = Some(tracker.words());
        }
        if !it.step().unwrap() {
            break;
        }
    }
    assert!(
        max_rel > 1e-3,
        "the step is large: the error must be visible ({max_rel})"
    );
    // Restored at node 50 and shown the same later nodes again, a tracker ends the same.
    let mut it = Integrator::new(
        &lag,
        &el,
        TimeGrid::uniform(0.0, 0.3, 60.0).unwrap(),
        start.clone(),
        SolverOptions::default(),
    )
    .unwrap();
    let mut again = EnergyTracker::new(1, &start, true);
    again.restore_words(&saved.unwrap()).unwrap();
    it.advance(49).unwrap();
    while it.step().unwrap() {
        let n = it.node();
        again.node(&lag, n.t, n.q, n.p).unwrap();
    }
    assert_eq!(again.words(), tracker.words());
}
