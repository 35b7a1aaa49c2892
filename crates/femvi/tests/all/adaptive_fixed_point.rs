//! Adaptive steps by the gyroscopic fixed point with the divisor g at the element's midpoint
//! (issue 39, item 4; `step/gyroscopic/divided.rs`): the step equations of full Newton,
//! solved to round-off without Hessians, so the two runs agree to the accumulated round-off
//! (`Method::FixedPoint`; `Method::Auto` keeps full Newton); non-unit masses and monitors by
//! automatic differentiation; the order against Kepler's closed form.

use crate::common::kepler_exact;
use femvi::adaptive::{
    solve_adaptive, AdaptiveOptions, AdaptiveSolution, ExprMonitor, KeplerMonitor, Monitor, NBodyMonitor,
};
use femvi::{models, Element, Lagrangian, Method, Problem, Start};
use std::f64::consts::PI;

fn kepler_start(e: f64) -> Start {
    Start::Momentum {
        q: vec![1.0 - e, 0.0],
        p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()],
    }
}

fn run<L: Lagrangian, G: Monitor>(
    problem: &Problem<L>,
    monitor: G,
    element: &Element,
    ds: f64,
    method: Method,
) -> AdaptiveSolution {
    let mut options = AdaptiveOptions {
        every: 0,
        saveat: vec![problem.t_end - 1e-9],
        ..AdaptiveOptions::step(ds)
    };
    options.solver.method = method;
    let sol = solve_adaptive(problem, monitor, element, &options).unwrap();
    assert!(sol.error.is_none(), "{:?}", sol.error);
    sol
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// The same run by the fixed point and by full Newton: the states at the end differ by the
/// round-off of the two solvers only (a fixed point stopped at a loose tolerance, or one
/// converging to another solution, would differ by the tolerance times the steps or more).
fn agree<L: Lagrangian, G: Monitor + Clone>(what: &str, problem: &Problem<L>, monitor: G, orders: &[usize], ds: f64) {
    for &order in orders {
        let element = Element::with_order(order).unwrap();
        let fp = run(problem, monitor.clone(), &element, ds, Method::FixedPoint);
        let auto = run(problem, monitor.clone(), &element, ds, Method::Auto);
        let newton = run(problem, monitor.clone(), &element, ds, Method::FullNewton);
        let dq = max_diff(&fp.saved.q, &newton.saved.q);
        let dp = max_diff(&fp.saved.p, &newton.saved.p);
        println!(
            "{what}, order {order}: {} steps, {:.2} sweeps per step (Newton {:.2} iterations), |dq| {dq:.1e}, |dp| {dp:.1e}",
            fp.steps, fp.mean_iterations, newton.mean_iterations
        );
        assert!(dq <= 1e-11 && dp <= 1e-10, "{what}, order {order}: {dq:e} {dp:e}");
        // Auto keeps full Newton (the fixed point is asked for: `adaptive/solve.rs`); the
        // fixed point is another solver (other bits).
        assert_eq!(auto.saved.q, newton.saved.q, "{what}, order {order}");
        assert_ne!(fp.saved.q, newton.saved.q, "{what}, order {order}");
    }
}

#[test]
fn the_fixed_point_agrees_with_full_newton_on_kepler() {
    let problem = Problem::new(models::kepler(1.0).unwrap(), kepler_start(0.9), 0.0, 3.0 * 2.0 * PI);
    agree("kepler e 0.9", &problem, KeplerMonitor, &[2, 4, 6, 8], 0.05);
}

#[test]
fn the_fixed_point_agrees_with_full_newton_with_masses_and_a_monitor_by_ad() {
    // Two bodies in the plane, masses 1 and 1e-3 (mass matrix diag(1, 1, 1e-3, 1e-3)): the
    // light body on an orbit of eccentricity 0.6 about the heavy one.
    let (m1, m2) = (1.0, 1e-3);
    let bodies = models::n_body(1.0, vec![m1, m2], 2).unwrap();
    assert!(!bodies.mass_matrix().unwrap().is_identity());
    let e: f64 = 0.6;
    let mu = m1 + m2;
    let vp = (mu * (1.0 + e) / (1.0 - e)).sqrt();
    // Centre-of-mass frame: positions and velocities split by the mass ratio.
    let (f1, f2) = (m2 / mu, m1 / mu);
    let q = vec![-f1 * (1.0 - e), 0.0, f2 * (1.0 - e), 0.0];
    let v = [0.0, -f1 * vp, 0.0, f2 * vp];
    let p = vec![m1 * v[0], m1 * v[1], m2 * v[2], m2 * v[3]];
    let period = 2.0 * PI / mu.sqrt();
    let problem = Problem::new(bodies, Start::Momentum { q, p }, 0.0, 2.0 * period);
    agree(
        "two bodies, masses 1 and 1e-3",
        &problem,
        NBodyMonitor::new(2, 2),
        &[4, 8],
        0.05,
    );
    // The Kepler monitor of the relative position written as an expression: g by dual
    // numbers (its derivatives by automatic differentiation, no hand-coded gradient).
    let names: Vec<String> = ["x1", "y1", "x2", "y2"].iter().map(|s| s.to_string()).collect();
    let monitor = ExprMonitor::new("((x2 - x1)^2 + (y2 - y1)^2)^0.75", &names, &[]).unwrap();
    agree("two bodies, expression monitor", &problem, monitor, &[6], 0.05);
}

#[test]
fn the_fixed_point_keeps_order_2s_against_the_closed_form() {
    // Kepler e = 0.5 over two periods: the last node (the first at or past t = 4π) against
    // the closed form at its physical time (nodes carry order 2s; the dense output between
    // them order s + 1).
    let e = 0.5;
    let problem = Problem::new(models::kepler(1.0).unwrap(), kepler_start(e), 0.0, 4.0 * PI);
    for (order, dss) in [(2, [0.2, 0.1, 0.05]), (4, [0.4, 0.2, 0.1]), (6, [0.8, 0.4, 0.2])] {
        let element = Element::with_order(order).unwrap();
        let errors: Vec<f64> = dss
            .iter()
            .map(|&ds| {
                let mut options = AdaptiveOptions {
                    every: 0,
                    ..AdaptiveOptions::step(ds)
                };
                options.solver.method = Method::FixedPoint;
                let sol = solve_adaptive(&problem, KeplerMonitor, &element, &options).unwrap();
                assert!(sol.error.is_none());
                let (t, k) = (sol.t[sol.t.len() - 1], sol.q.len() - 2);
                let (x, _) = kepler_exact(e, t);
                (sol.q[k] - x[0]).hypot(sol.q[k + 1] - x[1])
            })
            .collect();
        let fitted = (errors[0] / errors[2]).log2() / 2.0;
        let shown: Vec<String> = errors.iter().map(|x| format!("{x:.2e}")).collect();
        println!(
            "order {order}: node errors {}, fitted order {fitted:.2}",
            shown.join(", ")
        );
        assert!((fitted - order as f64).abs() < 0.3, "order {order}: {fitted}");
    }
}
