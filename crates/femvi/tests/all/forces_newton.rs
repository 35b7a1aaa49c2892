//! The forced fixed-step Newton step (`femvi::forces::solve_forced`, full Newton) against the
//! conservative full Newton step (`Method::FullNewton`): with a zero force both solve the same equations in the same form (node row 0
//! as p_k + Δp − Σ_{j≥1} rows, issue 21), so the runs agree bit for bit (they did not while the
//! forced step solved p_k + row 0).

use femvi::forces::{solve_forced, LinearForce};
use femvi::{models, solve, Element, Method, Problem, SolveOptions, SolverOptions, Start};

#[test]
fn zero_force_is_the_conservative_newton_run_bit_for_bit() {
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.1, -0.1],
            p: vec![0.3, 0.2],
        },
        0.0,
        50.0,
    );
    for order in [2, 4, 6] {
        let el = Element::with_order(order).unwrap();
        let opts = SolveOptions {
            solver: SolverOptions {
                method: Method::FullNewton,
                ..SolverOptions::default()
            },
            ..SolveOptions::step(0.1)
        };
        let forced = solve_forced(&hh, &LinearForce::damping(2, 0.0), &el, &opts).unwrap();
        let plain = solve(&hh, &el, &opts).unwrap();
        let f = &forced.solution;
        assert!(f.error.is_none() && plain.error.is_none());
        assert_eq!(f.steps, plain.steps);
        assert!(bits(&f.q) == bits(&plain.q), "order {order}: q differs");
        assert!(bits(&f.p) == bits(&plain.p), "order {order}: p differs");
        assert!(forced.work.iter().all(|&w| w == 0.0));
    }
}
