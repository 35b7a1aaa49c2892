//! The explicit path for sizes without a fixed-size loop (issue 15: per-step cost per degree
//! of freedom at large n): `Integrator::advance_observed` fuses the commit of a step with the
//! drift of the next (`step/explicit_wide.rs`). Its nodes, last element and checkpoint (the
//! carried force and its slot included) are those of `step()`, bit for bit, for any split of a
//! run into calls, on uniform and variable grids; a false from the callback stops after that
//! node and the run goes on from there; a run that overflows fails at the same step and
//! stays at its last good node, with that node's element, as `step()` does.

use crate::common::snapshot::{bits, chain_start, snapshot, verlet, Snapshot};
use femvi::{models, Integrator, Lagrangian, SolverOptions, Start, TimeGrid};

/// A node shown to the callback, as bits.
type Shown = (usize, Vec<u64>, Vec<u64>);

/// The state after every step of a run by `step()`, and its error if it failed.
fn by_step<L: Lagrangian>(lag: &L, grid: &TimeGrid, start: &Start) -> (Vec<Snapshot>, Option<String>) {
    let el = verlet();
    let mut it = Integrator::new(lag, &el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
    let mut all = vec![];
    loop {
        match it.step() {
            Ok(true) => all.push(snapshot(&it)),
            Ok(false) => return (all, None),
            Err(e) => {
                all.push(snapshot(&it));
                return (all, Some(e.to_string()));
            }
        }
    }
}

/// The same run by `advance_observed` in calls of `chunk` steps: the nodes shown, the state
/// after each call (which must be the state `step()` reached there) and the error.
fn by_chunks<L: Lagrangian>(
    lag: &L,
    grid: &TimeGrid,
    start: &Start,
    chunk: usize,
    want: &[Snapshot],
) -> (Vec<Shown>, Option<String>) {
    let el = verlet();
    let mut it = Integrator::new(lag, &el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
    let mut shown = vec![];
    loop {
        let done = it.advance_observed(chunk, |n| {
            shown.push((n.k, bits(n.q), bits(n.p)));
            true
        });
        let snap = snapshot(&it);
        match done {
            Ok(0) => return (shown, None),
            Ok(_) => assert_eq!(&snap, &want[snap.0 - 1], "chunk {chunk}, after node {}", snap.0),
            Err(e) => {
                assert_eq!(&snap, want.last().unwrap(), "chunk {chunk}, after the failure");
                return (shown, Some(e.to_string()));
            }
        }
    }
}

fn check<L: Lagrangian>(lag: &L, grid: &TimeGrid, start: &Start) -> Option<String> {
    let (want, error) = by_step(lag, grid, start);
    assert!(want.len() >= 20, "{} steps", want.len());
    if error.is_some() {
        // A failed step moves nothing: the run stays at its last good node, with that
        // node's element (only the solver's carried forces have changed).
        let (failed, good) = (&want[want.len() - 1], &want[want.len() - 2]);
        assert_eq!(
            (failed.0, failed.1, &failed.2, &failed.3, &failed.4),
            (good.0, good.1, &good.2, &good.3, &good.4),
            "the state after the failure"
        );
    }
    let nodes: Vec<_> = want
        .iter()
        .take(want.len() - usize::from(error.is_some()))
        .map(|s| (s.0, s.2.clone(), s.3.clone()))
        .collect();
    for chunk in [1, 2, 7, 1000] {
        let (shown, e) = by_chunks(lag, grid, start, chunk, &want);
        assert_eq!(shown, nodes, "chunk {chunk}");
        assert_eq!(e, error, "chunk {chunk}");
    }
    error
}

#[test]
fn advance_gives_the_steps_of_step_bit_for_bit() {
    // n = 9 and 5: no fixed-size loop; the FPUT chain and three bodies in 3-D (M = I).
    let chain = models::fpu(9, 0.25, 0.1).unwrap();
    let bodies = models::n_body(1.0, vec![1.0; 3], 3).unwrap();
    let planar = models::fpu(5, 0.25, 0.0).unwrap();
    let uniform = TimeGrid::uniform(0.0, 0.1, 30.0).unwrap();
    let variable = TimeGrid::steps(0.0, vec![0.1, 0.17, 0.06], 30.0).unwrap();
    let three = Start::Velocity {
        q: vec![1.0, 0.0, 0.0, -0.5, 0.8, 0.1, -0.5, -0.8, -0.1],
        v: vec![0.0, 0.5, 0.0, -0.45, -0.25, 0.05, 0.45, -0.25, -0.05],
    };
    for grid in [&uniform, &variable] {
        assert_eq!(check(&chain, grid, &chain_start(9)), None);
        assert_eq!(check(&planar, grid, &chain_start(5)), None);
    }
    let close = TimeGrid::uniform(0.0, 0.01, 3.0).unwrap();
    assert_eq!(check(&bodies, &close, &three), None);
}

#[test]
fn a_run_that_overflows_fails_where_step_fails() {
    // A chain thrown hard with a cubic force and a long step: it overflows within a few
    // dozen steps.
    let chain = models::fpu(7, 0.0, 10.0).unwrap();
    let start = Start::Velocity {
        q: vec![0.0; 7],
        v: vec![1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0],
    };
    let grid = TimeGrid::uniform(0.0, 0.2, 1000.0).unwrap();
    let error = check(&chain, &grid, &start);
    assert!(error.is_some_and(|e| e.contains("finite")));
}

#[test]
fn a_false_from_the_callback_stops_after_that_node() {
    let chain = models::fpu(9, 0.25, 0.0).unwrap();
    let grid = TimeGrid::uniform(0.0, 0.1, 20.0).unwrap();
    let start = chain_start(9);
    let (want, _) = by_step(&chain, &grid, &start);
    let el = verlet();
    let mut it = Integrator::new(&chain, &el, grid, start, SolverOptions::default()).unwrap();
    let mut shown = 0;
    let done = it
        .advance_observed(usize::MAX, |n| {
            shown += 1;
            n.k < 37
        })
        .unwrap();
    assert_eq!((done, shown), (37, 37));
    assert_eq!(snapshot(&it), want[36]);
    // The run goes on from there as if it had not stopped.
    while it.advance(5).unwrap() > 0 {}
    assert_eq!(&snapshot(&it), want.last().unwrap());
}
