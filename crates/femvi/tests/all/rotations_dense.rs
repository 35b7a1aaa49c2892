//! Dense output, `saveat` and events of runs with rotations (issue 37): between nodes each
//! rotation follows its element's path R_k exp(ζ̂(τ)) (`rotation/dense.rs`), so every sample is
//! a rotation to round-off (the polynomial through the nine entries is not: its defect is
//! O(h^{s+1})), and it converges to the independent reference (`rigid_reference.json`,
//! Euler's equations in 50 digits) at the interpolation order s + 1 or better at a time
//! midway between nodes.

use femvi::models::RigidBody;
use femvi::rotation::so3::orthogonality_defect;
use femvi::rotation::{embedded_velocity, Rotations};
use femvi::solution::{solve_on, Event};
use femvi::{Element, Integrator, Problem, SolveOptions, Start, TimeGrid};
use serde_json::Value;

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

/// The reference R at t = 2 of the free body (I = diag(1, 2, 3), w0 = (0.5, 1, 0.3), R0 = 1).
fn reference_at_2() -> [f64; 9] {
    let all: Value = serde_json::from_str(include_str!("rigid_reference.json")).unwrap();
    let state = all["free_body"]["states"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["t"].as_f64() == Some(2.0))
        .unwrap();
    let r = state["R"].as_array().unwrap();
    std::array::from_fn(|k| r[k].as_f64().unwrap())
}

fn solution(degree: usize, h: f64, options: SolveOptions) -> femvi::Solution {
    let body = RigidBody::free([1.0, 2.0, 3.0]).unwrap();
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: embedded_velocity(&IDENTITY, &[0.5, 1.0, 0.3]).to_vec(),
    };
    let problem = Problem::new(body, start, 0.0, 3.0);
    let element = Element::with_order(2 * degree).unwrap();
    let grid = TimeGrid::uniform(0.0, h, 3.0).unwrap();
    let layout = Rotations::new(9, &[0]).unwrap();
    let lag = &problem.lagrangian;
    let mut it =
        Integrator::with_rotations(lag, &element, grid, problem.start.clone(), Default::default(), layout).unwrap();
    solve_on(&mut it, &problem, &element, &options, &mut []).unwrap()
}

#[test]
fn dense_output_is_on_so3_and_converges_between_nodes() {
    let exact = reference_at_2();
    for degree in [1, 2, 3] {
        let mut errors = vec![];
        let mut steps = vec![];
        for m in [8.0, 16.0, 32.0] {
            // t = 2 midway between two nodes.
            let h = 2.0 / (m + 0.5);
            let options = SolveOptions {
                dense: true,
                saveat: (0..=60).map(|k| 0.05 * k as f64).collect(),
                ..SolveOptions::step(h)
            };
            let sol = solution(degree, h, options);
            let dense = sol.dense.as_ref().unwrap();
            let mut q = [0.0; 9];
            dense.q_at(2.0, &mut q).unwrap();
            assert!(
                orthogonality_defect(&q) < 1e-14,
                "degree {degree}, h = {h}: dense R off SO(3)"
            );
            for k in 0..sol.saved.t.len() {
                let r: [f64; 9] = sol.saved.q[9 * k..9 * k + 9].try_into().unwrap();
                assert!(orthogonality_defect(&r) < 1e-14, "saveat sample {k} off SO(3)");
            }
            errors.push(q.iter().zip(&exact).fold(0.0f64, |e, (a, b)| e.max((a - b).abs())));
            steps.push(h);
        }
        let order = (errors[0] / errors[2]).ln() / (steps[0] / steps[2]).ln();
        eprintln!("degree {degree}: dense errors at t = 2 {errors:?}, order {order:.2}");
        assert!(order > degree as f64 + 0.7, "degree {degree}: order {order}");
    }
}

#[test]
fn events_are_located_on_the_element_path() {
    // R33 = 0.9 (the body z axis tilted by acos 0.9 from space z): the event times of runs
    // with h = 0.1, 0.025, 0.00625 at degree 2 against a run with h = 0.00078125 converge at
    // the interpolation order s + 1 = 3 (whose constant depends on where in its element each
    // event falls, hence steps a factor 16 apart and a margin of 0.5), and the state at each
    // event is a rotation.
    let event = || vec![Event::new("tilt", |_t: f64, q: &[f64], _v: &[f64]| q[8] - 0.9)];
    let run = |h: f64| {
        let options = SolveOptions {
            events: event(),
            ..SolveOptions::step(h)
        };
        solution(2, h, options)
    };
    let fine = run(0.00078125);
    assert!(!fine.events.is_empty());
    let steps = [0.1, 0.025, 0.00625];
    let mut errors = vec![];
    for h in steps {
        let coarse = run(h);
        assert_eq!(coarse.events.len(), fine.events.len());
        let mut worst: f64 = 0.0;
        for (a, b) in coarse.events.iter().zip(&fine.events) {
            worst = worst.max((a.t - b.t).abs());
            let r: [f64; 9] = a.q.clone().try_into().unwrap();
            assert!(orthogonality_defect(&r) < 1e-14);
        }
        errors.push(worst);
    }
    let order = (errors[0] / errors[2]).ln() / (steps[0] / steps[2]).ln();
    eprintln!("event time errors {errors:?}, order {order:.2}");
    assert!(order > 2.5, "event times converge at order {order}");
}

#[test]
fn a_trajectory_with_rotations_is_the_dense_output_between_nodes() {
    use femvi::diagnostics::PiecewiseTrajectory;
    // The recorded elements of a run, its rotation on the element's path
    // (`PiecewiseTrajectory::with_rotations`, from the nodal values), against the same run's
    // dense output (from the left node and increments): the same path to round-off. Without
    // the rotation, the polynomial through the nine entries is off it by O(h³).
    let (degree, h) = (2, 0.2);
    let options = SolveOptions {
        dense: true,
        ..SolveOptions::step(h)
    };
    let sol = solution(degree, h, options);
    let dense = sol.dense.as_ref().unwrap();
    let body = RigidBody::free([1.0, 2.0, 3.0]).unwrap();
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: embedded_velocity(&IDENTITY, &[0.5, 1.0, 0.3]).to_vec(),
    };
    let element = Element::with_order(2 * degree).unwrap();
    let grid = TimeGrid::uniform(0.0, h, 3.0).unwrap();
    let layout = Rotations::new(9, &[0]).unwrap();
    let mut it = Integrator::with_rotations(&body, &element, grid, start, Default::default(), layout).unwrap();
    let plain = PiecewiseTrajectory::record(&mut it, &element.basis, 9).unwrap();
    let on_path = plain.clone().with_rotations(&[0]);
    let (mut worst_path, mut least_plain) = (0.0f64, f64::INFINITY);
    for k in 0..14 {
        let t = (k as f64 + 0.37) * h;
        let (mut want, mut a, mut b) = ([0.0; 9], [0.0; 9], [0.0; 9]);
        dense.q_at(t, &mut want).unwrap();
        on_path.eval(t, &mut a);
        plain.eval(t, &mut b);
        let diff = |x: &[f64; 9]| x.iter().zip(&want).fold(0.0f64, |m, (u, v)| m.max((u - v).abs()));
        worst_path = worst_path.max(diff(&a));
        least_plain = least_plain.min(diff(&b));
        assert!(orthogonality_defect(&a) < 1e-14, "t = {t}: off SO(3)");
    }
    assert!(worst_path < 1e-14, "path against dense output: {worst_path:e}");
    assert!(
        least_plain > 1e-7,
        "the entries' polynomial is that close: {least_plain:e}"
    );
}
