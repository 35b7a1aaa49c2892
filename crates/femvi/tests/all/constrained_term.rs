//! Issue 33: the constraints as a term of the one integrator (`Integrator::with_constraints`).
//! When it was written (commit 3cab812) the reference was the constrained run's own loop
//! (`solve_constrained_with` before it moved onto the integrator): positions and momenta bit for
//! bit, node by node (RATTLE, dense Newton at degrees 1, 2 and 4, every enforcement, a
//! time-dependent Lagrangian), the energy and the node multipliers too. Since then
//! `solve_constrained_with` drives this integrator, and the bits of that loop are kept by the
//! golden runs (`golden/terms.txt`, "constrained: …", unchanged by the move); here the test
//! checks the stepping API against the library run (a step at a time against the kept
//! nodes), and that a run stopped, written to a checkpoint and restored ends on the same
//! bits as one run through.

use femvi::constraints::{solve_constrained_with, ConstrainedSolution, Constraints, Enforcement, ExprConstraints};
use femvi::expr::ExprLagrangian;
use femvi::{
    models, Element, Integrator, Lagrangian, Method, NodeFamily, Problem, QuadratureKind, SolveOptions, Start, TimeGrid,
};

fn trapezoid() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap()
}

fn sphere_start() -> Start {
    Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.3, 1.5, 0.225],
    }
}

/// The spherical pendulum with a time-dependent gravity (a non-autonomous L).
fn driven_sphere() -> (ExprLagrangian, ExprConstraints) {
    let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - (9.81 + 0.5*sin(3*t))*z", &xyz, &[]).unwrap();
    let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[]).unwrap();
    (lag, sphere)
}

fn bits(xs: &[f64]) -> Vec<u64> {
    xs.iter().map(|x| x.to_bits()).collect()
}

/// Runs the integrator over the reference's grid and compares every node with it.
fn compare<L: Lagrangian + Clone + Sync, C: Constraints + Sync>(
    label: &str,
    lag: &L,
    con: &C,
    element: &Element,
    (h, t_end, method, enforcement): (f64, f64, Method, Enforcement),
) {
    let mut options = SolveOptions::step(h);
    options.solver.method = method;
    let problem = Problem::new(lag.clone(), sphere_start(), 0.0, t_end);
    let reference: ConstrainedSolution = solve_constrained_with(&problem, con, element, &options, enforcement).unwrap();
    let sol = &reference.solution;
    assert!(sol.error.is_none(), "{label}: {:?}", sol.error);
    let grid = TimeGrid::uniform(0.0, h, t_end).unwrap();
    let mut it =
        Integrator::with_constraints(lag, element, grid, sphere_start(), options.solver, con, enforcement).unwrap();
    let (n, m) = (3, 1);
    for k in 0..sol.len() {
        if k > 0 {
            assert!(it.step().unwrap(), "{label}: the integrator ended early at {k}");
        }
        let node = it.node();
        assert_eq!(node.t.to_bits(), sol.t[k].to_bits(), "{label}: t at node {k}");
        assert_eq!(bits(node.q), bits(&sol.q[k * n..(k + 1) * n]), "{label}: q at node {k}");
        assert_eq!(bits(node.p), bits(&sol.p[k * n..(k + 1) * n]), "{label}: p at node {k}");
        let energy = it.energy().unwrap();
        assert_eq!(energy.to_bits(), sol.energy[k].to_bits(), "{label}: energy at node {k}");
        let at = it.node_constraints().unwrap();
        assert_eq!(
            bits(&at.multipliers),
            bits(&reference.multipliers[k * m..(k + 1) * m]),
            "{label}: λ at {k}"
        );
        assert_eq!(
            at.residual.to_bits(),
            reference.residual[k].to_bits(),
            "{label}: residual at {k}"
        );
        assert_eq!(
            at.hidden_residual.to_bits(),
            reference.hidden_residual[k].to_bits(),
            "{label}: hidden at {k}"
        );
    }
    assert!(
        !it.step().unwrap(),
        "{label}: the integrator goes on past the reference"
    );
    let end = it.node_constraints().unwrap();
    assert_eq!(
        end.max_residual.to_bits(),
        reference.max_residual.to_bits(),
        "{label}: max residual"
    );
    assert_eq!(
        end.start_projection.to_bits(),
        reference.start_projection.to_bits(),
        "{label}: start projection"
    );
    assert_eq!(
        it.mean_iterations().to_bits(),
        sol.mean_iterations.to_bits(),
        "{label}: mean iterations"
    );
}

#[test]
fn the_integrator_takes_the_constrained_runs_nodes_bit_for_bit() {
    let (lag, sphere) = models::chain(3, 1, 1.0, 9.81, 1.0).unwrap();
    let weak = Enforcement::Weak;
    compare("rattle", &lag, &sphere, &trapezoid(), (0.01, 5.0, Method::Auto, weak));
    compare(
        "degree 1, newton",
        &lag,
        &sphere,
        &trapezoid(),
        (0.01, 2.0, Method::Newton, weak),
    );
    for (label, enforcement) in [
        ("degree 2, weak", Enforcement::Weak),
        ("degree 2, nodes", Enforcement::Nodes),
        ("degree 2, ends", Enforcement::Ends),
        ("degree 2, points", Enforcement::Points),
    ] {
        compare(
            label,
            &lag,
            &sphere,
            &Element::with_order(4).unwrap(),
            (0.02, 2.0, Method::Auto, enforcement),
        );
    }
    compare(
        "degree 4",
        &lag,
        &sphere,
        &Element::with_order(8).unwrap(),
        (0.05, 2.0, Method::Auto, weak),
    );
    let (driven, sphere) = driven_sphere();
    compare(
        "time-dependent, degree 2",
        &driven,
        &sphere,
        &Element::with_order(4).unwrap(),
        (0.02, 2.0, Method::Auto, weak),
    );
    compare(
        "time-dependent, rattle",
        &driven,
        &sphere,
        &trapezoid(),
        (0.01, 2.0, Method::Auto, weak),
    );
}

#[test]
fn a_restored_constrained_run_ends_on_the_same_bits() {
    let (lag, sphere) = models::chain(3, 1, 1.0, 9.81, 1.0).unwrap();
    for element in [trapezoid(), Element::with_order(4).unwrap()] {
        let new = || {
            let grid = TimeGrid::uniform(0.0, 0.01, 3.0).unwrap();
            let opts = femvi::SolverOptions::default();
            Integrator::with_constraints(&lag, &element, grid, sphere_start(), opts, &sphere, Enforcement::Weak)
                .unwrap()
        };
        let mut whole = new();
        while whole.step().unwrap() {}
        let mut first = new();
        first.advance(137).unwrap();
        let saved = first.checkpoint("sphere");
        let mut resumed = new();
        resumed.restore(&saved, "sphere").unwrap();
        while resumed.step().unwrap() {}
        assert_eq!(bits(resumed.node().q), bits(whole.node().q));
        assert_eq!(bits(resumed.node().p), bits(whole.node().p));
        let (a, b) = (resumed.node_constraints().unwrap(), whole.node_constraints().unwrap());
        assert_eq!(a, b);
        // A plain run's checkpoint is another run's.
        let plain = Integrator::new(
            &lag,
            &element,
            TimeGrid::uniform(0.0, 0.01, 3.0).unwrap(),
            Start::Momentum {
                q: vec![0.6, 0.0, -0.8],
                p: vec![0.0; 3],
            },
            femvi::SolverOptions::default(),
        )
        .unwrap();
        assert!(resumed.restore(&plain.checkpoint("sphere"), "sphere").is_err());
    }
}

#[test]
fn a_start_off_the_manifold_is_refused_as_by_the_constrained_run() {
    let (lag, sphere) = models::chain(3, 1, 1.0, 9.81, 1.0).unwrap();
    let off = Start::Velocity {
        q: vec![0.7, 0.0, -0.8],
        v: vec![0.0; 3],
    };
    let grid = TimeGrid::uniform(0.0, 0.01, 1.0).unwrap();
    let opts = femvi::SolverOptions::default();
    let err = Integrator::with_constraints(&lag, &trapezoid(), grid, off.clone(), opts, &sphere, Enforcement::Weak)
        .err()
        .expect("refused");
    let reference = solve_constrained_with(
        &Problem::new(lag.clone(), off, 0.0, 1.0),
        &sphere,
        &trapezoid(),
        &SolveOptions::step(0.01),
        Enforcement::Weak,
    )
    .expect_err("refused");
    assert_eq!(err.to_string(), reference.to_string());
    assert!(err.to_string().contains("violates the constraints"));
}

/// `solve_constrained_observed`: the same nodes as `solve_constrained_with`, bit for bit, with
/// events, `saveat` and dense output on the constrained element polynomials. The crossings of
/// x = 0 are located to round-off in x, on the sphere to the method's error, and agree with a
/// run at a quarter of the step to its order (the difference shrinks like h⁴).
#[test]
fn events_saveat_and_dense_output_of_a_constrained_run() {
    use femvi::constraints::solve_constrained_observed;
    use femvi::solution::Event;
    let (lag, sphere) = models::chain(3, 1, 1.0, 9.81, 1.0).unwrap();
    let problem = Problem::new(lag.clone(), sphere_start(), 0.0, 4.0);
    let element = Element::with_order(4).unwrap();
    let run = |h: f64| {
        let options = SolveOptions {
            events: vec![Event::new("x = 0", |_t, q: &[f64], _v: &[f64]| q[0])],
            saveat: vec![0.5, 1.25, 3.0],
            dense: true,
            ..SolveOptions::step(h)
        };
        solve_constrained_observed(&problem, &sphere, &element, &options, Enforcement::Weak, &mut []).unwrap()
    };
    let (coarse, fine, finer) = (run(0.02), run(0.01), run(0.005));
    let plain = solve_constrained_with(
        &problem,
        &sphere,
        &element,
        &SolveOptions::step(0.02),
        Enforcement::Weak,
    )
    .unwrap();
    assert_eq!(bits(&coarse.q), bits(&plain.solution.q));
    assert_eq!(bits(&coarse.p), bits(&plain.solution.p));
    assert_eq!(bits(&coarse.energy), bits(&plain.solution.energy));
    assert!(coarse.events.len() >= 2, "{} events", coarse.events.len());
    for e in &coarse.events {
        let r = (e.q[0] * e.q[0] + e.q[1] * e.q[1] + e.q[2] * e.q[2]).sqrt();
        assert!(e.q[0].abs() < 1e-12 && (r - 1.0).abs() < 1e-5, "{e:?}");
    }
    let gap = |a: &femvi::Solution, b: &femvi::Solution| {
        assert_eq!(a.events.len(), b.events.len());
        a.events
            .iter()
            .zip(&b.events)
            .fold(0.0f64, |m, (x, y)| m.max((x.t - y.t).abs()))
    };
    let (g1, g2) = (gap(&coarse, &finer), gap(&fine, &finer));
    // Order 4: halving h divides the error by 16; allow 8 to 24 (the finest run is not exact).
    assert!(g1 / g2 > 8.0 && g1 / g2 < 24.0 && g1 < 1e-5, "{g1:e} {g2:e}");
    assert_eq!(coarse.saved.t, vec![0.5, 1.25, 3.0]);
    let dense = coarse.dense.as_ref().expect("dense output");
    for (i, &t) in coarse.saved.t.iter().enumerate() {
        let (mut q, mut v) = (vec![0.0; 3], vec![0.0; 3]);
        dense.state_at(t, &mut q, &mut v).unwrap();
        assert_eq!(bits(&q), bits(&coarse.saved.q[i * 3..(i + 1) * 3]));
        let r = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((r - 1.0).abs() < 1e-5, "|q({t})| = {r}");
    }
}
