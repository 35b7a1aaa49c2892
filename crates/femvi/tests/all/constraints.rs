//! Holonomic constraints (`femvi::constraints`): RATTLE against a hand-written loop, the
//! spherical pendulum in Cartesian coordinates (constraint residual, vertical angular
//! momentum, energy, order against the pendulum in spherical angles), symplecticity on the
//! manifold, the double pendulum, and the typed errors.

use femvi::constraints::{manifold_symplecticity, solve_constrained, solve_constrained_with, Constraints, Enforcement};
use femvi::{models, Element, Error, Lagrangian, NodeFamily, Problem, QuadratureKind, Scalar, SolveOptions, Start};

const G: f64 = 9.81;

use crate::common::rattle::rattle;

fn sphere_start(theta: f64, phidot: f64) -> Start {
    Start::Velocity {
        q: vec![theta.sin(), 0.0, -theta.cos()],
        v: vec![0.0, theta.sin() * phidot, 0.0],
    }
}

fn trapezoid() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap()
}

#[test]
fn degree_one_trapezoid_is_rattle() {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let theta: f64 = 1.0;
    let (q0, v0) = (
        [theta.sin(), 0.0, -theta.cos()],
        [0.3 * theta.cos(), 2.0 * theta.sin(), 0.3 * theta.sin()],
    );
    let start = Start::Velocity {
        q: q0.to_vec(),
        v: v0.to_vec(),
    };
    // h = 2⁻⁷: every node time k·h and the end time are exact, so the grid's last step is h
    // too (with h = 0.01 it is 100 − t_9999, off by an ulp of 100).
    let (h, steps) = (0.0078125, 10_000);
    let run = solve_constrained(
        &Problem::new(lag, start, 0.0, h * steps as f64),
        &sphere,
        &trapezoid(),
        &SolveOptions::step(h),
    )
    .unwrap();
    assert!(run.solution.error.is_none());
    assert!(
        run.start_projection < 1e-15,
        "tangent start changed by {:e}",
        run.start_projection
    );
    // The same map: one hand-written RATTLE step from each femvi node gives the next node.
    let sol = &run.solution;
    let mut local: f64 = 0.0;
    for k in 0..steps {
        let q: [f64; 3] = std::array::from_fn(|c| sol.q[3 * k + c]);
        let p: [f64; 3] = std::array::from_fn(|c| sol.p[3 * k + c]);
        let (q1, p1) = rattle(q, p, h, G, 1)[1];
        for c in 0..3 {
            local = local
                .max((sol.q[3 * (k + 1) + c] - q1[c]).abs())
                .max((sol.p[3 * (k + 1) + c] - p1[c]).abs());
        }
    }
    // The whole trajectories: round-off differences of 1e-16 per step in p, a random walk in
    // the energy, amplified by the shear of the flow (an energy error becomes a phase error
    // growing with t): ~1e-16·k^{3/2}·h. Measured 3.4e-13 at k = 10⁴ (8.4e-13 while node row 0
    // was p_k + row 0, a bias; 1.7e-11 against the loop without increments and compensated
    // summation). `tests/all/rattle_exact.rs` measures both against the map in double-double.
    // From femvi's node 0: the start's projection onto the hidden constraint may move p by an
    // ulp (asserted above), and a start an ulp off in energy drifts in phase linearly in t.
    let hand = rattle(
        std::array::from_fn(|c| sol.q[c]),
        std::array::from_fn(|c| sol.p[c]),
        h,
        G,
        steps,
    );
    assert_eq!(sol.len(), hand.len());
    let mut global: f64 = 0.0;
    for (k, (q, p)) in hand.iter().enumerate() {
        for c in 0..3 {
            global = global
                .max((sol.q[3 * k + c] - q[c]).abs())
                .max((sol.p[3 * k + c] - p[c]).abs());
        }
    }
    println!("RATTLE over {steps} steps: max one-step difference {local:.2e}, trajectories {global:.2e}");
    assert!(local <= 1e-14, "{local:e}");
    assert!(global <= 1e-12, "{global:e}");
}

fn vertical_momentum_drift(order: usize, steps: usize) -> (femvi::constraints::ConstrainedSolution, f64) {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let h = 0.02;
    let problem = Problem::new(lag, sphere_start(1.0, 2.0), 0.0, h * steps as f64);
    let run = solve_constrained(
        &problem,
        &sphere,
        &Element::with_order(order).unwrap(),
        &SolveOptions::step(h),
    )
    .unwrap();
    let sol = &run.solution;
    assert!(sol.error.is_none() && sol.steps == steps);
    let lz = |k: usize| sol.q[3 * k] * sol.p[3 * k + 1] - sol.q[3 * k + 1] * sol.p[3 * k];
    let lz0 = lz(0);
    let drift = (0..sol.len()).map(|k| ((lz(k) - lz0) / lz0).abs()).fold(0.0, f64::max);
    (run, drift)
}

#[test]
fn spherical_pendulum_keeps_constraint_and_vertical_momentum() {
    let steps = 100_000;
    // Degree 1 (RATTLE).
    let (run, drift) = vertical_momentum_drift(2, steps);
    println!(
        "degree 1: max |g(q)| {:.2e}, max relative change of L_z {drift:.2e}",
        run.max_residual
    );
    assert!(run.max_residual <= 1e-13 && drift <= 1e-13);
    // Degree 2: the same. (It drifted linearly by 3e-17 per step, 2.9e-12 here, while the step
    // took p̃ from node row s of the element; it now adds the rows' sum to p_k, as the
    // unconstrained Newton step does: `StepSystem::momentum_by_sums`.)
    let (run, drift) = vertical_momentum_drift(4, steps);
    println!(
        "degree 2: max |g(q)| {:.2e}, max relative change of L_z {drift:.2e}",
        run.max_residual
    );
    assert!(run.max_residual <= 1e-13 && drift <= 1e-13);
    // Energy: bounded, no drift. Fit a line through H(t); the change it predicts over the
    // run must be far below the oscillation of H (which is O(h⁴)).
    let sol = &run.solution;
    let n = sol.len() as f64;
    let (tm, em) = (sol.t.iter().sum::<f64>() / n, sol.energy.iter().sum::<f64>() / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (t, e) in sol.t.iter().zip(&sol.energy) {
        sxy += (t - tm) * (e - em);
        sxx += (t - tm) * (t - tm);
    }
    let slope = sxy / sxx;
    let e0 = sol.energy[0];
    let spread = sol.energy.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max);
    let t_end = sol.t[sol.len() - 1];
    println!(
        "energy: max |H - H0| = {spread:.2e}, fitted slope {slope:.2e} (change over the run {:.2e})",
        slope * t_end
    );
    assert!(spread < 1e-5 && (slope * t_end).abs() < 0.05 * spread);
}

/// L = ½(θ̇² + sin²θ φ̇²) + g cos θ: the same pendulum in spherical angles, unconstrained.
struct Angles;

impl Lagrangian for Angles {
    fn dim(&self) -> usize {
        2
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let st = q[0].sin();
        (v[0] * v[0] + st * st * v[1] * v[1]) * 0.5 + q[0].cos() * G
    }
}

#[test]
fn spherical_pendulum_converges_with_order_2s() {
    let t_end = 2.0;
    let reference = femvi::solve(
        &Problem::new(
            Angles,
            Start::Velocity {
                q: vec![1.0, 0.0],
                v: vec![0.0, 2.0],
            },
            0.0,
            t_end,
        ),
        &Element::with_order(8).unwrap(),
        &SolveOptions::step(0.002),
    )
    .unwrap();
    let a = reference.q_row(reference.len() - 1).unwrap();
    let exact = [a[0].sin() * a[1].cos(), a[0].sin() * a[1].sin(), -a[0].cos()];
    for s in 1..=4usize {
        let h0 = [0.02, 0.08, 0.2, 0.4][s - 1];
        let element = Element::with_order(2 * s).unwrap();
        let mut errors = vec![];
        let mut hs = vec![];
        for i in 1..4 {
            let h = h0 / f64::from(1 << i);
            let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
            let options = SolveOptions {
                every: 0,
                ..SolveOptions::step(h)
            };
            let run = solve_constrained(
                &Problem::new(lag, sphere_start(1.0, 2.0), 0.0, t_end),
                &sphere,
                &element,
                &options,
            )
            .unwrap();
            let q = run.solution.q_row(run.solution.len() - 1).unwrap();
            errors.push(
                q.iter()
                    .zip(&exact)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max)
                    .ln(),
            );
            hs.push(h.ln());
        }
        let (hm, em) = (hs.iter().sum::<f64>() / 3.0, errors.iter().sum::<f64>() / 3.0);
        let order = hs.iter().zip(&errors).map(|(h, e)| (h - hm) * (e - em)).sum::<f64>()
            / hs.iter().map(|h| (h - hm) * (h - hm)).sum::<f64>();
        println!(
            "degree {s}: errors {:?}, fitted order {order:.2}",
            errors.iter().map(|e| e.exp()).collect::<Vec<_>>()
        );
        assert!((order - 2.0 * s as f64).abs() < 0.25, "degree {s}: order {order}");
    }
}

#[test]
fn constrained_flow_is_symplectic_on_the_manifold() {
    for (order, enforcement) in [
        (2, Enforcement::Weak),
        (4, Enforcement::Weak),
        (6, Enforcement::Weak),
        (6, Enforcement::Nodes),
        (4, Enforcement::Ends),
    ] {
        let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
        let start = Start::Velocity {
            q: vec![0.6, 0.0, -0.8],
            v: vec![0.2, 1.5, 0.15],
        };
        let check = manifold_symplecticity(
            &Problem::new(lag, start, 0.0, 2.0),
            &sphere,
            &Element::with_order(order).unwrap(),
            &SolveOptions::step(0.05),
            enforcement,
        )
        .unwrap();
        println!(
            "sphere, order {order}, {enforcement:?}: defect {:.2e}",
            check.max_defect
        );
        assert!(check.steps == 40 && check.max_defect <= 1e-12, "{}", check.max_defect);
    }
    // The planar double pendulum in Cartesian coordinates (two constraints).
    let (lag, rods) = models::chain(2, 2, 1.0, G, 1.0).unwrap();
    let (a, b): (f64, f64) = (0.5, 1.2);
    let start = Start::Velocity {
        q: vec![a.sin(), -a.cos(), a.sin() + b.sin(), -a.cos() - b.cos()],
        v: vec![0.0; 4],
    };
    let check = manifold_symplecticity(
        &Problem::new(lag, start, 0.0, 2.0),
        &rods,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.02),
        Enforcement::Weak,
    )
    .unwrap();
    println!(
        "double pendulum: defect {:.2e}, residual {:.2e}",
        check.max_defect, check.run.max_residual
    );
    assert!(check.max_defect <= 1e-12 && check.run.max_residual <= 1e-13);
}

#[test]
fn multipliers_are_the_rod_tension() {
    // At rest hanging down, the tension balances gravity: λ = g/(2l) for g = |q|² − l²
    // (force −Gᵀλ = −2qλ = (0, 0, g)).
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 2.0).unwrap();
    let start = Start::Velocity {
        q: vec![0.0, 0.0, -2.0],
        v: vec![0.0; 3],
    };
    let run = solve_constrained(
        &Problem::new(lag, start, 0.0, 1.0),
        &sphere,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap();
    for lam in &run.multipliers {
        assert!((lam - G / 4.0).abs() < 1e-12, "{lam}");
    }
}

#[test]
fn start_off_the_manifold_is_refused_with_its_residual() {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.81],
        v: vec![0.0; 3],
    };
    let err = solve_constrained(
        &Problem::new(lag, start, 0.0, 1.0),
        &sphere,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(err, Error::Invalid { .. }) && msg.contains("1.610e-2"),
        "{msg}"
    );
}

#[test]
fn normal_start_velocity_is_projected() {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    // v has a radial part 0.5 q: projected away (M = I, so p0 = v0 − 0.5 q0).
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.3, 1.0, -0.4],
    };
    let run = solve_constrained(
        &Problem::new(lag, start, 0.0, 0.1),
        &sphere,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap();
    let p0 = run.solution.p_row(0).unwrap();
    assert!((run.start_projection - 0.4).abs() < 1e-15, "{}", run.start_projection);
    assert!(
        (p0[0] - 0.0).abs() < 1e-15 && (p0[1] - 1.0).abs() < 1e-15 && p0[2].abs() < 1e-15,
        "{p0:?}"
    );
    assert!(run.hidden_residual.iter().all(|r| *r < 1e-14));
}

/// The same sphere twice: G has rank 1, not 2.
struct Twice;

impl Constraints for Twice {
    fn dim(&self) -> usize {
        3
    }
    fn count(&self) -> usize {
        2
    }
    fn value<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        let r = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - 1.0;
        out[0] = r;
        out[1] = r * 2.0;
    }
}

#[test]
fn dependent_constraints_are_a_typed_error() {
    let (lag, _) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let problem = Problem::new(lag, sphere_start(1.0, 2.0), 0.5, 1.0);
    let err = solve_constrained(
        &problem,
        &Twice,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap_err();
    assert!(
        matches!(err, Error::SingularConstraints { step: 0, t, .. } if t == 0.5),
        "{err}"
    );
    assert!(err.to_string().contains("node 0 (t = 0.5)"));
}

#[test]
fn unsupported_options_are_refused() {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let problem = Problem::new(lag, sphere_start(1.0, 2.0), 0.0, 1.0);
    let element = Element::with_order(4).unwrap();
    let dense = SolveOptions {
        dense: true,
        ..SolveOptions::step(0.1)
    };
    assert!(matches!(
        solve_constrained(&problem, &sphere, &element, &dense),
        Err(Error::Invalid { .. })
    ));
    let one = Element::with_order(2).unwrap();
    let points = solve_constrained_with(&problem, &sphere, &one, &SolveOptions::step(0.1), Enforcement::Points);
    assert!(matches!(points, Err(Error::Invalid { .. })));
}
