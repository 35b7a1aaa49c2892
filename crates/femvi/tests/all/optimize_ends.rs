//! Optimal control with free end states, terminal costs and bounds on the coordinates
//! (issue 36, items 1 and 7), each against a closed form derived from Pontryagin's principle.

use crate::common::fitted_order;
use femvi::expr::ExprLagrangian;
use femvi::optimize::{optimize, ControlProblem, ExprControls, FinalTime, OptimizeOptions, Optimum};
use femvi::Element;

fn s(v: &[&str]) -> Vec<String> {
    v.iter().map(|x| x.to_string()).collect()
}

/// x'' = u on [0, 1] from x(0) = 0, v(0) = v0, minimising the integral of u^2 plus
/// `terminal`, with the given ends and coordinate bounds.
fn double_integrator(
    elements: usize,
    order: usize,
    terminal: &str,
    v0: f64,
    (q1, v1): (Option<f64>, Option<f64>),
    (q_lower, q_upper): (Vec<f64>, Vec<f64>),
) -> Optimum {
    let x = s(&["x"]);
    let lag = ExprLagrangian::new("0.5*x_dot^2", &x, &[]).unwrap();
    let ctl = ExprControls::new(&x, &s(&["u"]), &s(&["u"]), "u^2", &[])
        .unwrap()
        .with_terminal(&x, terminal, &[])
        .unwrap();
    let problem = ControlProblem {
        t0: 0.0,
        t1: FinalTime::Fixed(1.0),
        q0: vec![0.0],
        v0: vec![v0],
        q1: vec![q1],
        v1: vec![v1],
        elements,
        lower: vec![f64::NEG_INFINITY],
        upper: vec![f64::INFINITY],
        q_lower,
        q_upper,
        time_weight: 0.0,
    };
    let element = Element::with_order(order).unwrap();
    optimize(&lag, &ctl, &element, &problem, &OptimizeOptions::default()).unwrap()
}

/// Free end, terminal cost a(x(1) - 1)^2 + b v(1)^2 with a = 3, b = 1. Pontryagin: the
/// costates are λ1 = const = 2a(x1 - 1), λ2 = c - λ1 t with λ2(1) = 2b v1, u = -λ2/2; solving
/// the transversality conditions gives λ1 = -48/13, c = -36/13, so u = (18 - 24t)/13,
/// x(1) = 5/13, v(1) = 6/13 and J* = 24/13. With b = 0 (no cost on v(1)): u = 3(1 - t)/2,
/// x(1) = 1/2, v(1) = 3/4, J* = 3/2. The path is a cubic and u linear, which elements of
/// degree 2 and higher reproduce, so only round-off remains there; degree 1 converges at
/// order 2.
#[test]
fn a_terminal_cost_on_a_free_end_meets_its_closed_form() {
    for (terminal, j, x1, v1, u0, u1) in [
        (
            "3*(x - 1)^2 + x_dot^2",
            24.0 / 13.0,
            5.0 / 13.0,
            6.0 / 13.0,
            18.0 / 13.0,
            -6.0 / 13.0,
        ),
        ("3*(x - 1)^2", 1.5, 0.5, 0.75, 1.5, 0.0),
    ] {
        let u = |t: f64| u0 + (u1 - u0) * t;
        for order in [4, 6] {
            let o = double_integrator(10, order, terminal, 0.0, (None, None), (vec![], vec![]));
            assert!(o.error.is_none(), "{:?}", o.error);
            let q_end = o.q[o.q.len() - 1];
            let du = o
                .control_t
                .iter()
                .zip(&o.u)
                .map(|(t, v)| (v - u(*t)).abs())
                .fold(0.0, f64::max);
            assert!(
                (o.objective - j).abs() < 1e-11,
                "{terminal}, order {order}: J = {}",
                o.objective
            );
            assert!(
                (q_end - x1).abs() < 1e-11 && (o.v1[0] - v1).abs() < 1e-11,
                "{q_end} {:?}",
                o.v1
            );
            assert!(du < 1e-10, "{terminal}, order {order}: control error {du:.2e}");
        }
        let meshes = [10, 20, 40, 80];
        let errs: Vec<f64> = meshes
            .iter()
            .map(|&n| double_integrator(n, 2, terminal, 0.0, (None, None), (vec![], vec![])).objective - j)
            .collect();
        let p = fitted_order(&meshes, &errs);
        assert!(
            (p - 2.0).abs() < 0.1,
            "{terminal}, degree 1: order {p:.3} from {errs:?}"
        );
    }
}

/// A free end position with a given end velocity, and a free end velocity with a given end
/// position: with no terminal cost the transversality condition puts the free costate to
/// zero. x(1) free, v(1) = 0 from v(0) = 1: λ1 = 0, so u is constant, and v(1) = 1 + u = 0
/// gives u = -1, J* = 1, x(1) = 1/2. From rest with x(1) = 1, v(1) free: λ2(1) = 0 gives
/// u = 3(1 - t), J* = 3, v(1) = 3/2.
#[test]
fn free_components_obey_transversality() {
    let o = double_integrator(20, 4, "0", 1.0, (None, Some(0.0)), (vec![], vec![]));
    assert!(
        o.error.is_none() && (o.objective - 1.0).abs() < 1e-11,
        "{} {:?}",
        o.objective,
        o.error
    );
    assert!(
        (o.q[o.q.len() - 1] - 0.5).abs() < 1e-11,
        "x(1) = {}",
        o.q[o.q.len() - 1]
    );
    let o = double_integrator(20, 4, "0", 0.0, (Some(1.0), None), (vec![], vec![]));
    assert!(o.error.is_none(), "{:?}", o.error);
    assert!((o.objective - 3.0).abs() < 1e-11, "J = {}", o.objective);
    assert!((o.v1[0] - 1.5).abs() < 1e-11, "v(1) = {}", o.v1[0]);
}

/// Bryson and Ho's state-constrained double integrator (Applied Optimal Control, 1975,
/// section 3.11): x(0) = 0, v(0) = 1, x(1) = 0, v(1) = -1, x <= l. For l <= 1/6 the optimum
/// rides the bound on [3l, 1 - 3l], with x = l(1 - (1 - t/(3l))^3) before it, so
/// u = -(2/(3l))(1 - t/(3l)) there and the integral of u^2 is 8/(9l): J* = 8 at l = 1/9
/// (unconstrained, J = 4 with x reaching 1/4). The bound is held at the nodes; degree 1
/// converges at order 2.
#[test]
fn a_coordinate_bound_meets_bryson_and_ho() {
    let l = 1.0 / 9.0;
    let free = double_integrator(40, 2, "0", 1.0, (Some(0.0), Some(-1.0)), (vec![], vec![]));
    assert!(
        (free.objective - 4.0).abs() < 1e-10,
        "unconstrained J = {}",
        free.objective
    );
    let meshes = [25, 50, 100, 200];
    let mut errs = vec![];
    for &n in &meshes {
        let o = double_integrator(
            n,
            2,
            "0",
            1.0,
            (Some(0.0), Some(-1.0)),
            (vec![f64::NEG_INFINITY], vec![l]),
        );
        assert!(o.error.is_none(), "{n}: {:?}", o.error);
        let highest = o.q.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert!(highest <= l && highest > l - 1e-6, "{n}: max x = {highest}");
        errs.push(o.objective - 8.0);
    }
    let p = fitted_order(&meshes, &errs);
    assert!((p - 2.0).abs() < 0.1, "order {p:.3} from {errs:?}");
    assert!(errs[3].abs() < 1e-3, "{errs:?}");
}

/// Mesh refinement: a free end with a terminal cost from coarser solves gives the same
/// optimum as the direct solve (both meet the closed form J* = 24/13 to the discretisation
/// error of the fine mesh) and records its stages; coarse meshes that do not increase
/// below the problem's are refused.
#[test]
fn mesh_refinement_reaches_the_direct_optimum() {
    let x = s(&["x"]);
    let lag = ExprLagrangian::new("0.5*x_dot^2", &x, &[]).unwrap();
    let ctl = ExprControls::new(&x, &s(&["u"]), &s(&["u"]), "u^2", &[])
        .unwrap()
        .with_terminal(&x, "3*(x - 1)^2 + x_dot^2", &[])
        .unwrap();
    let problem = ControlProblem {
        t0: 0.0,
        t1: FinalTime::Fixed(1.0),
        q0: vec![0.0],
        v0: vec![0.0],
        q1: vec![None],
        v1: vec![None],
        elements: 80,
        lower: vec![-1.2],
        upper: vec![2.0],
        q_lower: vec![],
        q_upper: vec![],
        time_weight: 0.0,
    };
    let element = Element::with_order(2).unwrap();
    let direct = optimize(&lag, &ctl, &element, &problem, &OptimizeOptions::default()).unwrap();
    let options = OptimizeOptions {
        coarse: vec![5, 20],
        ..OptimizeOptions::default()
    };
    let refined = optimize(&lag, &ctl, &element, &problem, &options).unwrap();
    assert!(direct.error.is_none() && refined.error.is_none());
    assert!(
        (refined.objective - direct.objective).abs() < 1e-9,
        "{} {}",
        refined.objective,
        direct.objective
    );
    assert_eq!(
        refined.stages.iter().map(|s| s.elements).collect::<Vec<_>>(),
        vec![5, 20]
    );
    assert!(refined.stages.iter().all(|s| s.converged));
    assert!((direct.objective - 24.0 / 13.0).abs() < 1e-3);
    for coarse in [vec![80], vec![20, 10], vec![0, 20]] {
        let bad = OptimizeOptions {
            coarse,
            ..OptimizeOptions::default()
        };
        assert!(optimize(&lag, &ctl, &element, &problem, &bad).is_err());
    }
}
