//! Optimal control (issue 36): the double integrator against its closed form, minimum time
//! against T* = 2, and the solver's errors.

use crate::common::fitted_order;
use femvi::expr::ExprLagrangian;
use femvi::optimize::{optimize, ControlProblem, ExprControls, FinalTime, OptimizeOptions, Optimum};
use femvi::Element;

fn s(v: &[&str]) -> Vec<String> {
    v.iter().map(|x| x.to_string()).collect()
}

#[allow(clippy::too_many_arguments)]
fn double_integrator(
    elements: usize,
    order: usize,
    t1: FinalTime,
    bound: f64,
    running: &str,
    w: f64,
    q0: f64,
    q1: f64,
) -> Optimum {
    let lag = ExprLagrangian::new("0.5*x_dot^2", &s(&["x"]), &[]).unwrap();
    let ctl = ExprControls::new(&s(&["x"]), &s(&["u"]), &s(&["u"]), running, &[]).unwrap();
    let problem = ControlProblem {
        t0: 0.0,
        t1,
        q0: vec![q0],
        v0: vec![0.0],
        q1: vec![Some(q1)],
        v1: vec![Some(0.0)],
        elements,
        lower: vec![-bound],
        upper: vec![bound],
        q_lower: vec![],
        q_upper: vec![],
        time_weight: w,
    };
    let element = Element::with_order(order).unwrap();
    optimize(&lag, &ctl, &element, &problem, &OptimizeOptions::default()).unwrap()
}

/// J* of the cart-pole from CasADi 3.8.2 + IPOPT, Radau collocation refined to N = 1600
/// (benches/peers/casadi_cartpole.py; ±1e-10, three schemes agree): optimum A, one
/// back-swing to θ = −0.88, reached from the straight-line guess.
const CART_POLE_J: f64 = 225.55372407809;

fn cart_pole(elements: usize, order: usize) -> Optimum {
    cart_pole_with(elements, order, &OptimizeOptions::default())
}

fn cart_pole_with(elements: usize, order: usize, options: &OptimizeOptions) -> Optimum {
    let params = [
        ("mc".to_string(), 2.0),
        ("mp".to_string(), 0.5),
        ("l".to_string(), 0.5),
        ("g".to_string(), 9.81),
    ];
    let coords = s(&["x", "theta"]);
    let lag = ExprLagrangian::new(
        "0.5*(mc + mp)*x_dot^2 + mp*l*x_dot*theta_dot*cos(theta) + 0.5*mp*l^2*theta_dot^2 + mp*g*l*cos(theta)",
        &coords,
        &params,
    )
    .unwrap();
    let ctl = ExprControls::new(&coords, &s(&["u"]), &s(&["u", "0"]), "u^2", &params).unwrap();
    let problem = ControlProblem {
        t0: 0.0,
        t1: FinalTime::Fixed(2.0),
        q0: vec![0.0, 0.0],
        v0: vec![0.0, 0.0],
        q1: vec![Some(0.8), Some(std::f64::consts::PI)],
        v1: vec![Some(0.0), Some(0.0)],
        elements,
        lower: vec![-100.0],
        upper: vec![100.0],
        q_lower: vec![],
        q_upper: vec![],
        time_weight: 0.0,
    };
    let element = Element::with_order(order).unwrap();
    optimize(&lag, &ctl, &element, &problem, options).unwrap()
}

fn control_error(o: &Optimum) -> f64 {
    o.control_t
        .iter()
        .zip(&o.u)
        .map(|(t, u)| (u - (6.0 - 12.0 * t)).abs())
        .fold(0.0, f64::max)
}

/// The controls read off at the nodes against u(t) = 6 - 12t.
fn node_control_error(o: &Optimum) -> f64 {
    assert_eq!(o.u_nodes.len(), o.t.len());
    o.t.iter()
        .zip(&o.u_nodes)
        .map(|(t, u)| (u - (6.0 - 12.0 * t)).abs())
        .fold(0.0, f64::max)
}

/// The double integrator x'' = u, rest to rest over unit distance in unit time, minimising
/// the integral of u^2: u = 6 - 12t and J* = 12 in closed form. Degree 1 (midpoint) converges
/// at order 2; from degree 2 the discrete optimum is the exact one at the nodes and points
/// (the cubic path and linear control are reproduced), so only round-off remains.
#[test]
fn the_double_integrator_meets_its_closed_form() {
    let meshes = [10, 20, 40, 80];
    let runs: Vec<Optimum> = meshes
        .iter()
        .map(|&n| double_integrator(n, 2, FinalTime::Fixed(1.0), f64::INFINITY, "u^2", 0.0, 0.0, 1.0))
        .collect();
    assert!(runs.iter().all(|o| o.error.is_none() && o.violation < 1e-12));
    let cost: Vec<f64> = runs.iter().map(|o| o.objective - 12.0).collect();
    let control: Vec<f64> = runs.iter().map(control_error).collect();
    let nodal: Vec<f64> = runs.iter().map(node_control_error).collect();
    let (pc, pu) = (fitted_order(&meshes, &cost), fitted_order(&meshes, &control));
    let pn = fitted_order(&meshes, &nodal);
    assert!(
        (pc - 2.0).abs() < 0.05 && (pu - 2.0).abs() < 0.1 && (pn - 2.0).abs() < 0.1,
        "orders {pc:.3} {pu:.3} {pn:.3}: {cost:?} {control:?} {nodal:?}"
    );
    for order in [4, 6, 8] {
        for n in [5, 40] {
            let o = double_integrator(n, order, FinalTime::Fixed(1.0), f64::INFINITY, "u^2", 0.0, 0.0, 1.0);
            assert!(o.error.is_none());
            assert!(
                (o.objective - 12.0).abs() < 1e-10,
                "order {order} N {n}: J - 12 = {:.3e}",
                o.objective - 12.0
            );
            assert!(
                control_error(&o) < 1e-10 && node_control_error(&o) < 1e-10,
                "order {order} N {n}: control error {:.3e}, at the nodes {:.3e}",
                control_error(&o),
                node_control_error(&o)
            );
        }
    }
}

/// Minimum time with |u| <= 1 from (1, 0) to rest at 0: bang-bang, T* = 2.
#[test]
fn minimum_time_is_two() {
    for n in [100, 200, 400] {
        let o = double_integrator(
            n,
            2,
            FinalTime::Free {
                min: 0.5,
                max: 5.0,
                guess: 3.0,
            },
            1.0,
            "0",
            1.0,
            1.0,
            0.0,
        );
        assert!(o.error.is_none(), "{:?}", o.error);
        assert!((o.t1 - 2.0).abs() < 1e-8, "N {n}: T - 2 = {:.3e}", o.t1 - 2.0);
        assert!((o.objective - o.t1).abs() < 1e-15);
        // Bang-bang: the control is at a bound but near the switch.
        let near_bound = o.u.iter().filter(|u| (u.abs() - 1.0).abs() < 1e-6).count();
        assert!(near_bound + 4 >= o.u.len(), "{near_bound} of {} at a bound", o.u.len());
        // Read off at the nodes: within the bounds, +1 before the switch at t = 1 and -1 after
        // (the nodes next to it excepted).
        assert_eq!(o.u_nodes.len(), n + 1);
        assert!(o.u_nodes.iter().all(|u| u.abs() <= 1.0));
        let off =
            o.t.iter()
                .zip(&o.u_nodes)
                .filter(|(t, u)| (**u - if **t < 1.0 { -1.0 } else { 1.0 }).abs() > 1e-6);
        assert!(off.count() <= 4, "{:?}", o.u_nodes);
    }
}

/// The cart-pole swing-up against CasADi + IPOPT: degree s converges at order 2s in h, and
/// degree 3 at 200 elements is within 1e-10 of the reference.
#[test]
fn the_cart_pole_converges_to_the_collocation_reference_at_order_2s() {
    let meshes = [25, 50, 100];
    for (order, lo, hi) in [(2, 1.9, 2.1), (4, 3.7, 4.1), (6, 5.7, 6.8)] {
        let err: Vec<f64> = meshes
            .iter()
            .map(|&n| {
                let o = cart_pole(n, order);
                assert!(o.error.is_none(), "order {order} N {n}: {:?}", o.error);
                let theta_min = o.q.chunks(2).map(|r| r[1]).fold(f64::INFINITY, f64::min);
                assert!(
                    (theta_min + 0.88).abs() < 0.01,
                    "order {order} N {n}: another optimum, min theta {theta_min}"
                );
                o.objective / CART_POLE_J - 1.0
            })
            .collect();
        let p = fitted_order(&meshes, &err);
        assert!(p > lo && p < hi, "order {order}: fitted {p:.3} from {err:?}");
    }
    let o = cart_pole(200, 6);
    assert!(
        (o.objective / CART_POLE_J - 1.0).abs() < 1e-10,
        "{:.3e}",
        o.objective / CART_POLE_J - 1.0
    );
}

/// On finer meshes the iteration stops at the round-off floor of its residuals (the
/// optimality residual over h grows like 1/h there) only where the optimum is reached: the
/// midpoint rule's cost error keeps its order-2 ratio of 4 per halving up to 1000 elements,
/// which a stop short of the optimum would break (a normwise round-off test once stopped at
/// 10^4 elements 19x off the optimum's cost error; the componentwise test replaced it).
#[test]
fn fine_meshes_stop_at_the_optimum() {
    let err: Vec<f64> = [250, 500, 1000]
        .iter()
        .map(|&n| {
            let o = cart_pole(n, 2);
            assert!(o.error.is_none(), "N {n}: {:?}", o.error);
            o.objective / CART_POLE_J - 1.0
        })
        .collect();
    for w in err.windows(2) {
        assert!((w[0] / w[1] / 4.0 - 1.0).abs() < 0.01, "ratios of {err:?}");
    }
}

/// A run stopped by its iteration limit returns its best iterate with the error set.
#[test]
fn a_short_run_returns_its_best_iterate() {
    let options = OptimizeOptions {
        max_iterations: 3,
        ..OptimizeOptions::default()
    };
    let o = cart_pole_with(50, 4, &options);
    let e = o.error.expect("three iterations do not reach the optimum");
    assert!(e.to_string().contains("did not converge after 3 iterations"), "{e}");
    assert_eq!(o.iterations, 3);
    assert!(o.objective.is_finite() && o.q.len() == 51 * 2 && o.u.len() == 50 * 2);
}

/// Inconsistent data is a typed error before any work.
#[test]
fn bad_data_is_refused() {
    let lag = ExprLagrangian::new("0.5*x_dot^2", &s(&["x"]), &[]).unwrap();
    let ctl = ExprControls::new(&s(&["x"]), &s(&["u"]), &s(&["u"]), "u^2", &[]).unwrap();
    let good = ControlProblem {
        t0: 0.0,
        t1: FinalTime::Fixed(1.0),
        q0: vec![0.0],
        v0: vec![0.0],
        q1: vec![Some(1.0)],
        v1: vec![Some(0.0)],
        elements: 10,
        lower: vec![-1.0],
        upper: vec![1.0],
        q_lower: vec![],
        q_upper: vec![],
        time_weight: 0.0,
    };
    let element = Element::with_order(2).unwrap();
    let bad = [
        ControlProblem {
            lower: vec![1.0],
            ..good.clone()
        },
        ControlProblem {
            q1: vec![Some(1.0), Some(2.0)],
            ..good.clone()
        },
        ControlProblem {
            t1: FinalTime::Fixed(-1.0),
            ..good.clone()
        },
        ControlProblem {
            t1: FinalTime::Free {
                min: 2.0,
                max: 1.0,
                guess: 1.5,
            },
            ..good.clone()
        },
        ControlProblem {
            elements: 0,
            ..good.clone()
        },
        ControlProblem {
            v0: vec![f64::NAN],
            ..good.clone()
        },
        ControlProblem {
            v1: vec![Some(f64::INFINITY)],
            ..good.clone()
        },
        ControlProblem {
            q_lower: vec![0.5],
            q_upper: vec![2.0],
            ..good.clone()
        },
        ControlProblem {
            q_lower: vec![-1.0],
            q_upper: vec![0.5],
            ..good.clone()
        },
        ControlProblem {
            q_lower: vec![-1.0],
            q_upper: vec![-2.0],
            ..good.clone()
        },
        ControlProblem {
            q_lower: vec![-1.0, -1.0],
            q_upper: vec![2.0, 2.0],
            ..good.clone()
        },
    ];
    for p in bad {
        assert!(
            optimize(&lag, &ctl, &element, &p, &OptimizeOptions::default()).is_err(),
            "{p:?}"
        );
    }
    assert!(optimize(&lag, &ctl, &element, &good, &OptimizeOptions::default()).is_ok());
}
