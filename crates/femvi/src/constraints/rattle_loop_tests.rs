//! The RATTLE loop against the step-at-a-time path: the same nodes bit for bit, in chunks of
//! any length, across a checkpoint, with a step that fails mid-run, for every compiled size
//! and for constraints with and without compiled g and G.

use super::LOOP_STEPS;
use crate::constraints::{Constraints, Enforcement, ExprConstraints};
use crate::expr::ExprLagrangian;
use crate::{
    models, Element, Error, Integrator, Lagrangian, Method, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid,
};

fn trapezoid() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).expect("the trapezoid element")
}

fn names(n: &[&str]) -> Vec<String> {
    n.iter().map(|s| s.to_string()).collect()
}

fn loop_steps() -> usize {
    LOOP_STEPS.with(|s| s.get())
}

/// The nodes (k, t, q, p as bits), the last node's constraint quantities and the mean
/// iterations of a run, or its error.
type Run = (Vec<Vec<u64>>, Option<Error>, String, u64);

fn bits(k: usize, t: f64, q: &[f64], p: &[f64]) -> Vec<u64> {
    let mut b = vec![k as u64, t.to_bits()];
    b.extend(q.iter().chain(p).map(|x| x.to_bits()));
    b
}

fn finish<L: Lagrangian + Sync>(it: &Integrator<'_, L>, nodes: Vec<Vec<u64>>, error: Option<Error>) -> Run {
    let at_end = format!("{:?}", it.node_constraints());
    (nodes, error, at_end, it.mean_iterations().to_bits())
}

/// A step at a time (the stepper's path).
fn one_at_a_time<L: Lagrangian + Sync>(mut it: Integrator<'_, L>) -> Run {
    let mut nodes = vec![];
    let error = loop {
        match it.step() {
            Ok(true) => {
                let n = it.node();
                nodes.push(bits(n.k, n.t, n.q, n.p));
            }
            Ok(false) => break None,
            Err(e) => break Some(e),
        }
    };
    finish(&it, nodes, error)
}

/// In chunks of growing length through `advance_observed` (the loop), with a checkpoint
/// restored into `fresh` after the third chunk.
fn in_chunks<'a, L: Lagrangian + Sync>(mut it: Integrator<'a, L>, mut fresh: Integrator<'a, L>) -> Run {
    let mut nodes = vec![];
    let mut error = None;
    for (chunk, len) in [1, 2, 5, 97, 1000, usize::MAX].into_iter().enumerate() {
        let advanced = it.advance_observed(len, |n| {
            nodes.push(bits(n.k, n.t, n.q, n.p));
            true
        });
        if let Err(e) = advanced {
            error = Some(e);
            break;
        }
        if chunk == 2 {
            let saved = it.checkpoint("loop");
            fresh.restore(&saved, "loop").expect("the checkpoint restores");
            it = fresh;
            break;
        }
    }
    if error.is_none() && nodes.len() == 8 {
        let advanced = it.advance_observed(usize::MAX, |n| {
            nodes.push(bits(n.k, n.t, n.q, n.p));
            true
        });
        error = advanced.err();
    }
    finish(&it, nodes, error)
}

/// Both paths on one problem; returns the nodes of the run and whether it failed.
fn both<L: Lagrangian + Sync, C: Constraints + Sync>(
    lag: &L,
    con: &C,
    start: Start,
    (h, end): (f64, f64),
    max_iterations: usize,
) -> (usize, bool) {
    let element = trapezoid();
    let opts = SolverOptions {
        method: Method::Explicit,
        max_iterations,
        ..SolverOptions::default()
    };
    let make = || {
        let grid = TimeGrid::uniform(0.0, h, end).expect("a grid");
        Integrator::with_constraints(lag, &element, grid, start.clone(), opts, con, Enforcement::Weak)
            .expect("a RATTLE run")
    };
    let before = loop_steps();
    let slow = one_at_a_time(make());
    assert_eq!(loop_steps(), before, "step() takes the stepper's path");
    let fast = in_chunks(make(), make());
    assert!(
        loop_steps() > before + fast.0.len() / 2,
        "the loop took the steps: {} of {}",
        loop_steps() - before,
        fast.0.len()
    );
    assert_eq!(fast.0.len(), slow.0.len(), "the same number of nodes");
    for (k, (a, b)) in fast.0.iter().zip(&slow.0).enumerate() {
        assert_eq!(a, b, "node {}", k + 1);
    }
    assert_eq!(format!("{:?}", fast.1), format!("{:?}", slow.1), "the same failure");
    assert_eq!(fast.2, slow.2, "the same constraint quantities at the end");
    assert_eq!(fast.3, slow.3, "the same mean iterations");
    (slow.0.len(), slow.1.is_some())
}

/// The spherical pendulum as expressions with the potential `potential`, and its start.
fn spherical_pendulum(potential: &str) -> (ExprLagrangian, ExprConstraints, Start) {
    let xyz = names(&["x", "y", "z"]);
    let l = format!("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - {potential}");
    let lag = ExprLagrangian::new(&l, &xyz, &[]).expect("L");
    let sphere = ExprConstraints::new(&names(&["x^2 + y^2 + z^2 - 1"]), &xyz, &[]).expect("g");
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.3, 1.5, 0.225],
    };
    (lag, sphere, start)
}

#[test]
fn the_loop_takes_the_stepper_s_steps_on_every_compiled_size() {
    // Compiled g and G: the spherical pendulum (3, 1) and a point on a circle in space (3, 2).
    let (lag, sphere, start) = spherical_pendulum("9.81*z");
    assert_eq!(both(&lag, &sphere, start, (0.01, 30.0), 50), (3000, false));
    let xyz = names(&["x", "y", "z"]);
    let tilted = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*x", &xyz, &[]).expect("L");
    let circle = ExprConstraints::new(&names(&["x^2 + y^2 + z^2 - 1", "z - 0.3"]), &xyz, &[]).expect("g");
    let start = Start::Velocity {
        q: vec![0.91f64.sqrt(), 0.0, 0.3],
        v: vec![0.0, 2.0, 0.0],
    };
    assert_eq!(both(&tilted, &circle, start, (0.01, 30.0), 50), (3000, false));
    // Constraints differentiated by dual numbers: the pendulum in the plane (2, 1) and the
    // planar double pendulum (4, 2).
    let (pendulum, rod) = models::chain(2, 1, 1.0, 9.81, 1.0).expect("a pendulum");
    let start = Start::Velocity {
        q: vec![0.6, -0.8],
        v: vec![1.6, 1.2],
    };
    assert_eq!(both(&pendulum, &rod, start, (0.01, 30.0), 50), (3000, false));
    let (double, rods) = models::chain(2, 2, 1.0, 9.81, 1.0).expect("a double pendulum");
    let (a, c): (f64, f64) = (0.5, 1.2);
    let start = Start::Velocity {
        q: vec![a.sin(), -a.cos(), a.sin() + c.sin(), -a.cos() - c.cos()],
        v: vec![0.4, 0.3, -1.0, 0.2],
    };
    assert_eq!(both(&double, &rods, start, (0.01, 30.0), 50), (3000, false));
    assert!(rods.count() == 2 && double.dim() == 4);
}

#[test]
fn a_step_that_fails_mid_run_fails_as_the_stepper_s_does() {
    // A time-dependent L whose force is not a number from t = 5 on: the run stops there,
    // after the same nodes and with the same error on both paths.
    let (lag, sphere, start) = spherical_pendulum("9.81*z*sqrt(5 - t)");
    let (nodes, failed) = both(&lag, &sphere, start, (0.01, 30.0), 50);
    assert!(failed, "a step failed");
    assert!((495..=500).contains(&nodes), "at t = 5: {nodes} nodes");
}
