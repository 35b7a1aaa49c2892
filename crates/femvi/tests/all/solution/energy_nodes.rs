//! `SolveOptions::energy_nodes` (issue 15, item 4): for a Lagrangian without a constant mass
//! matrix the energy report covers, by default, the kept nodes only; each kept energy is the
//! inverse Legendre transform's at that node, the report is their largest relative error and
//! says which nodes it is over.

use femvi::expr::ExprLagrangian;
use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::models::RelativisticKepler;
use femvi::solution::EnergyNodes;
use femvi::{solve, Element, Error, Lagrangian, NodeFamily, Problem, QuadratureKind, SolveOptions, Start};

fn problem() -> Problem<RelativisticKepler> {
    let start = Start::Velocity {
        q: vec![0.4, 0.0],
        v: vec![0.0, 1.9],
    };
    Problem::new(RelativisticKepler { c: 10.0 }, start, 0.0, 20.0)
}

fn element() -> Element {
    Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2)).unwrap()
}

/// The largest |H − H0| / |H0| over an energy column (the tracker's largest deviation over
/// |H0|: division rounds monotonically, so the same number).
fn max_rel(energy: &[f64]) -> f64 {
    let e0 = energy[0];
    energy.iter().fold(0.0f64, |m, e| m.max((e - e0).abs())) / e0.abs()
}

#[test]
fn a_general_lagrangian_is_checked_at_the_kept_nodes_by_default() {
    let (p, e) = (problem(), element());
    let options = SolveOptions {
        every: 10,
        ..SolveOptions::step(0.01)
    };
    let kept = solve(&p, &e, &options).unwrap();
    let report = kept.energy_report.unwrap();
    assert_eq!(report.nodes, EnergyNodes::Kept);
    // Nodes 0, 10, 20, … and the last.
    assert!(kept.len() > 100 && kept.step[..kept.len() - 1].iter().all(|k| k % 10 == 0));
    assert_eq!(report.max_rel_error, max_rel(&kept.energy));
    // Each kept energy and velocity is the inverse transform's at that node, from a cold start.
    let (mut v, mut work) = (vec![0.0; 2], PointDerivatives::new(2));
    for i in 0..kept.len() {
        let (q, pm) = (&kept.q[2 * i..2 * i + 2], &kept.p[2 * i..2 * i + 2]);
        v.fill(0.0);
        let h = hamiltonian(&p.lagrangian, kept.t[i], q, pm, &mut v, &mut work).unwrap();
        assert!((kept.energy[i] - h).abs() <= 1e-13 * h.abs(), "node {i}");
        for c in 0..2 {
            assert!((kept.v[2 * i + c] - v[c]).abs() <= 1e-14 * v[c].abs().max(1.0));
        }
    }
    // Every node: the same kept states, and a largest error over more nodes.
    let every = solve(
        &p,
        &e,
        &SolveOptions {
            energy_nodes: EnergyNodes::Every,
            ..options.clone()
        },
    )
    .unwrap();
    let all = every.energy_report.unwrap();
    assert_eq!(all.nodes, EnergyNodes::Every);
    assert_eq!(every.q, kept.q);
    assert_eq!(every.p, kept.p);
    assert!(all.max_rel_error >= report.max_rel_error * (1.0 - 1e-6));
    // Every node kept: both modes see the same nodes, with the same start for each inversion
    // but the first; the reports agree to round-off.
    let one = SolveOptions::step(0.01);
    let a = solve(&p, &e, &one).unwrap().energy_report.unwrap();
    let b = solve(
        &p,
        &e,
        &SolveOptions {
            energy_nodes: EnergyNodes::Every,
            ..one
        },
    )
    .unwrap()
    .energy_report
    .unwrap();
    assert!((a.max_rel_error - b.max_rel_error).abs() <= 1e-3 * b.max_rel_error);
}

#[test]
fn a_run_stopped_between_kept_nodes_is_checked_at_its_last_node() {
    let (p, e) = (problem(), element());
    let options = SolveOptions {
        every: 10,
        max_steps: Some(1234),
        ..SolveOptions::step(0.01)
    };
    let sol = solve(&p, &e, &options).unwrap();
    assert_eq!(*sol.step.last().unwrap(), 1234);
    let report = sol.energy_report.unwrap();
    assert_eq!(report.max_rel_error, max_rel(&sol.energy));
    let n = sol.len() - 1;
    let (mut v, mut work) = (vec![0.0; 2], PointDerivatives::new(2));
    let h = hamiltonian(
        &p.lagrangian,
        sol.t[n],
        &sol.q[2 * n..],
        &sol.p[2 * n..],
        &mut v,
        &mut work,
    )
    .unwrap();
    assert!((sol.energy[n] - h).abs() <= 1e-13 * h.abs());
}

#[test]
fn mechanical_and_time_dependent_lagrangians_are_checked_at_every_node() {
    let kepler = femvi::models::kepler(1.0).unwrap();
    assert_eq!(EnergyNodes::Auto.resolve(&kepler), EnergyNodes::Every);
    assert_eq!(EnergyNodes::Kept.resolve(&kepler), EnergyNodes::Kept);
    // L = ½|v|² − V(t, q) through an expression: time-dependent, so every node.
    let forced =
        femvi::expr::ExprLagrangian::new("0.5*x_dot^2 - 0.5*x^2*(1 + 0.1*cos(t))", &["x".to_string()], &[]).unwrap();
    assert!(!forced.is_autonomous());
    assert_eq!(EnergyNodes::Kept.resolve(&forced), EnergyNodes::Every);
    assert_eq!("every".parse::<EnergyNodes>(), Ok(EnergyNodes::Every));
    assert!("all".parse::<EnergyNodes>().is_err());
}

/// A free particle (x = t, the other terms below 1e-299) from x = 0 to t = 2 that reaches
/// x = 1 at node 4 of h = 0.25. 1e-300·sqrt((x − 1)² − 0.025²) is NaN within 0.025 of x = 1,
/// where no Gauss point falls (they sit 0.053 or more from the nodes): the steps are finite,
/// H at node 4 is not. (As an expression: its derivatives in v are exactly those of the other
/// terms; by dual numbers the NaN would reach ∂²L/∂v² and the error would be a degenerate
/// Legendre transform instead.)
fn near_one() -> Problem<ExprLagrangian> {
    let coords = vec!["x".to_string()];
    let lag = ExprLagrangian::new(
        "0.5*x_dot^2 + 1e-300*x_dot^4 + 1e-300*sqrt((x - 1)^2 - 0.025^2)",
        &coords,
        &[],
    )
    .unwrap();
    let start = Start::Velocity {
        q: vec![0.0],
        v: vec![1.0],
    };
    Problem::new(lag, start, 0.0, 2.0)
}

#[test]
fn a_later_kept_node_whose_energy_is_not_finite_ends_the_run_on_the_node_before() {
    // Node 4 (x = 1) is kept (every = 2).
    let problem = near_one();
    for nodes in [EnergyNodes::Kept, EnergyNodes::Every] {
        let options = SolveOptions {
            every: 2,
            energy_nodes: nodes,
            ..SolveOptions::step(0.25)
        };
        let sol = solve(&problem, &element(), &options).unwrap();
        let error = sol.error.as_ref().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            error.starts_with("non-finite energy at step 4, t = 1"),
            "{nodes:?}: {error}"
        );
        assert!(
            matches!(sol.error, Some(Error::NonFiniteEnergy { step: 4, .. })),
            "{nodes:?}"
        );
        // The step to node 4 was taken; the nodes kept are 0 and 2, and node 3, the last the
        // run reached with a finite energy (as a run that ends on a failed step keeps the node
        // it ended on), all at x = t with H = ½ (up to the 1e-300 terms, below round-off).
        assert_eq!(sol.steps, 4, "{nodes:?}");
        assert_eq!(sol.step, [0, 2, 3], "{nodes:?}");
        assert_eq!(sol.q, sol.t, "{nodes:?}");
        assert!(
            sol.energy.iter().all(|e| (e - 0.5).abs() <= 1e-15),
            "{nodes:?}: {:?}",
            sol.energy
        );
        assert_eq!(sol.energy_report.unwrap().max_rel_error, 0.0, "{nodes:?}");
    }
}

#[test]
fn a_run_that_ends_without_an_error_on_a_node_whose_energy_is_not_finite_fails_there() {
    // The step limit stops the run at node 4 (x = 1, H NaN), a node that is not kept (every =
    // 3) and, without energy tracking, whose energy no one computed on the way: the run
    // fails there rather than leave its last node out.
    let problem = near_one();
    let options = SolveOptions {
        every: 3,
        max_steps: Some(4),
        track_energy: false,
        ..SolveOptions::step(0.25)
    };
    let sol = solve(&problem, &element(), &options).unwrap();
    assert!(
        matches!(sol.error, Some(Error::NonFiniteEnergy { step: 4, .. })),
        "{:?}",
        sol.error
    );
    assert_eq!(sol.step, [0, 3]);
    assert!(sol.energy.iter().all(|e| e.is_finite()));
}
