//! Forces together with holonomic constraints in initial value runs
//! (`femvi::constraints::solve_constrained_forced`): the spherical pendulum in Cartesian
//! coordinates with friction and a drive. Constraint residual at every node, gravity as a force
//! against gravity in the Lagrangian, a zero force against the unforced run (bits), the forced
//! constrained boundary value solver fed the ends of a run, the nodal order 2s against a much
//! finer degree-4 run, the vertical angular momentum against its closed-form decay, the energy
//! balance with damping, and the typed errors.

use femvi::bvp::{line_guess, BoundaryValues, BvpOptions};
use femvi::constraints::{
    solve_constrained, solve_constrained_forced, solve_constrained_forced_bvp, Enforcement, ForcedConstrainedSolution,
};
use femvi::forces::{ExprForces, Force, LinearForce};
use femvi::{models, Element, Error, Problem, Scalar, SolveOptions, Start};

const G: f64 = 9.81;

fn sphere_start(theta: f64, phidot: f64) -> Start {
    Start::Velocity {
        q: vec![theta.sin(), 0.0, -theta.cos()],
        v: vec![0.0, theta.sin() * phidot, 0.0],
    }
}

fn xyz() -> Vec<String> {
    ["x", "y", "z"].iter().map(|s| s.to_string()).collect()
}

/// Friction −c v and a horizontal drive f0 cos(w t) along x: velocity- and time-dependent.
fn damped_driven() -> ExprForces {
    let params = [("c".to_string(), 0.4), ("f0".to_string(), 1.5), ("w".to_string(), 2.3)];
    ExprForces::new(&["-c*x_dot + f0*cos(w*t)", "-c*y_dot", "-c*z_dot"], &xyz(), &params).unwrap()
}

fn run<F: Force + Sync>(force: &F, order: usize, h: f64, t_end: f64, every: usize) -> ForcedConstrainedSolution {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let options = SolveOptions {
        every,
        ..SolveOptions::step(h)
    };
    let problem = Problem::new(lag, sphere_start(1.0, 2.0), 0.0, t_end);
    let out = solve_constrained_forced(
        &problem,
        force,
        &sphere,
        &Element::with_order(order).unwrap(),
        &options,
        Enforcement::default(),
    )
    .unwrap();
    assert!(
        out.constrained.solution.error.is_none(),
        "{:?}",
        out.constrained.solution.error
    );
    out
}

#[test]
fn constraint_holds_at_every_node_under_forces() {
    for order in [2, 4, 6, 8] {
        let out = run(&damped_driven(), order, 0.01, 10.0, 1);
        let c = &out.constrained;
        println!(
            "order {order}: max |g| {:.2e}, max |G v| at kept nodes {:.2e}",
            c.max_residual,
            c.hidden_residual.iter().fold(0.0f64, |a, &b| a.max(b))
        );
        assert!(c.max_residual <= 1e-13, "order {order}: {}", c.max_residual);
        assert!(c.residual.iter().all(|&r| r <= 1e-13));
        assert!(c.hidden_residual.iter().all(|&r| r <= 1e-12));
    }
}

/// L = ½|v|² (no potential) with gravity (0, 0, −g) as a force.
#[derive(Clone, Copy)]
struct Weight;
impl Force for Weight {
    fn dim(&self) -> usize {
        3
    }
    fn force<D: Scalar>(&self, _t: D, _q: &[D], _v: &[D], out: &mut [D]) {
        out[0] = D::from(0.0);
        out[1] = D::from(0.0);
        out[2] = D::from(-G);
    }
    fn depends_on_velocity(&self) -> bool {
        false
    }
}

#[test]
fn gravity_as_a_force_equals_gravity_in_the_lagrangian() {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let free = models::chain(3, 1, 1.0, 0.0, 1.0).unwrap().0;
    let start = sphere_start(1.0, 2.0);
    for order in [2, 4, 6, 8] {
        let element = Element::with_order(order).unwrap();
        let options = SolveOptions::step(0.01);
        let problem = Problem::new(lag.clone(), start.clone(), 0.0, 5.0);
        let potential = solve_constrained(&problem, &sphere, &element, &options).unwrap();
        let problem = Problem::new(free.clone(), start.clone(), 0.0, 5.0);
        let forced =
            solve_constrained_forced(&problem, &Weight, &sphere, &element, &options, Enforcement::default()).unwrap();
        let (a, b) = (&potential.solution, &forced.constrained.solution);
        assert_eq!(a.len(), b.len());
        let dq = a.q.iter().zip(&b.q).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        let dp = a.p.iter().zip(&b.p).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        let dl = potential
            .multipliers
            .iter()
            .zip(&forced.constrained.multipliers)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        // H with the potential is H without it plus g z, and the discrete work of a constant
        // force is exact, W_k = −g (z_k − z_0): the balance error of the forced run is the
        // energy error of the run with the potential.
        let dbal = (0..a.len())
            .map(|i| (a.energy[i] - a.energy[0] - (b.energy[i] - b.energy[0] - forced.work[i])).abs())
            .fold(0.0, f64::max);
        // The same equations evaluated in another order: round-off, relative to the largest
        // |q| (the rod, 1) and |p|.
        let pmax = a.p.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        println!(
            "order {order}: max |dq| {dq:.1e}, |dp| {dp:.1e} (max |p| {pmax:.2}), |dλ| {dl:.1e}, energy vs work {dbal:.1e}"
        );
        assert!(dq <= 1e-14 && dp <= 1e-14 * pmax, "order {order}: {dq} {dp}");
        assert!(dl <= 1e-12, "order {order}: multipliers {dl}");
        assert!(dbal <= 1e-12, "order {order}: energy against work {dbal}");
    }
}

#[test]
fn zero_force_is_the_unforced_run_bit_for_bit() {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let zero = LinearForce::drive(vec![0.0; 3], 0.0);
    for (order, enforcement) in [
        (2, Enforcement::Weak),
        (4, Enforcement::Weak),
        (6, Enforcement::Nodes),
        (8, Enforcement::Weak),
        (6, Enforcement::Ends),
    ] {
        let element = Element::with_order(order).unwrap();
        // Forces take dense Newton; so does the plain run under `Method::Newton` (under
        // `Method::Auto` it takes the fixed point of `constraints/shake/mod.rs`).
        let mut options = SolveOptions::step(0.02);
        options.solver.method = femvi::Method::Newton;
        let problem = Problem::new(lag.clone(), sphere_start(1.0, 2.0), 0.0, 4.0);
        let plain =
            femvi::constraints::solve_constrained_with(&problem, &sphere, &element, &options, enforcement).unwrap();
        let forced = solve_constrained_forced(&problem, &zero, &sphere, &element, &options, enforcement).unwrap();
        let (a, b) = (&plain.solution, &forced.constrained.solution);
        let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(a.steps, b.steps);
        assert_eq!(bits(&a.t), bits(&b.t));
        assert_eq!(bits(&a.q), bits(&b.q), "order {order} {enforcement:?}");
        assert_eq!(bits(&a.p), bits(&b.p), "order {order} {enforcement:?}");
        assert_eq!(bits(&a.v), bits(&b.v));
        assert_eq!(bits(&a.energy), bits(&b.energy));
        assert_eq!(bits(&plain.multipliers), bits(&forced.constrained.multipliers));
        assert_eq!(bits(&plain.residual), bits(&forced.constrained.residual));
        assert!(forced.work.iter().all(|&w| w == 0.0));
    }
}

#[test]
fn constrained_forced_bvp_recovers_the_run() {
    let force = damped_driven();
    for order in [2, 4, 6, 8] {
        let (h, steps) = (0.01, 60);
        let out = run(&force, order, h, h * steps as f64, 1);
        let sol = &out.constrained.solution;
        let n = 3;
        let last = sol.len() - 1;
        let bv = BoundaryValues {
            t0: 0.0,
            q0: sol.q_row(0).unwrap().to_vec(),
            t1: sol.t[last],
            q1: sol.q_row(last).unwrap().to_vec(),
            elements: steps,
        };
        let element = Element::with_order(order).unwrap();
        let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
        let bvp = solve_constrained_forced_bvp(
            &lag,
            &force,
            &sphere,
            &element,
            &bv,
            &line_guess(&bv, &element),
            BvpOptions::default(),
            Enforcement::default(),
        )
        .unwrap();
        let b = &bvp.solution;
        assert!(b.residual_norm <= 1e-12, "order {order}: residual {}", b.residual_norm);
        assert_eq!(b.q.len(), sol.q.len());
        let dq = b.q.iter().zip(&sol.q).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        let dp = b.p.iter().zip(&sol.p).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        // The multipliers of the forced flow at the element ends (F in their equation).
        let dl = bvp
            .multipliers
            .iter()
            .zip(&out.constrained.multipliers)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        let lmax = out.constrained.multipliers.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        println!(
            "order {order}: BVP against the run: max |dq| {dq:.1e}, |dp| {dp:.1e}, |dλ| {dl:.1e} (max |λ| {lmax:.1}, {n} coordinates)"
        );
        assert!(dq <= 1e-12, "order {order}: {dq}");
        assert!(dp <= 1e-12, "order {order}: {dp}");
        assert!(dl <= 1e-12 * lmax, "order {order}: {dl}");
    }
}

/// Least-squares slope of log(error) against log(h).
fn fitted_order(hs: &[f64], errors: &[f64]) -> f64 {
    let (x, y): (Vec<f64>, Vec<f64>) = hs.iter().zip(errors).map(|(h, e)| (h.ln(), e.ln())).unzip();
    let k = x.len() as f64;
    let (xm, ym) = (x.iter().sum::<f64>() / k, y.iter().sum::<f64>() / k);
    x.iter().zip(&y).map(|(a, b)| (a - xm) * (b - ym)).sum::<f64>() / x.iter().map(|a| (a - xm) * (a - xm)).sum::<f64>()
}

#[test]
fn damped_spherical_pendulum_converges_with_order_2s() {
    let t_end = 2.0;
    let force = damped_driven();
    let reference = run(&force, 8, 0.0025, t_end, 0);
    let rs = &reference.constrained.solution;
    let exact = rs.q_row(rs.len() - 1).unwrap().to_vec();
    for s in 1..=4usize {
        let h0 = [0.02, 0.08, 0.2, 0.4][s - 1];
        let hs: Vec<f64> = (1..4).map(|i| h0 / f64::from(1 << i)).collect();
        let errors: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let out = run(&force, 2 * s, h, t_end, 0);
                let sol = &out.constrained.solution;
                let q = sol.q_row(sol.len() - 1).unwrap();
                q.iter().zip(&exact).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
            })
            .collect();
        let order = fitted_order(&hs, &errors);
        println!("degree {s}: h {hs:?}, errors {errors:?}, fitted order {order:.2}");
        assert!((order - 2.0 * s as f64).abs() < 0.25, "degree {s}: order {order}");
    }
}

#[test]
fn vertical_angular_momentum_decays_as_the_closed_form() {
    // Friction −c v (m = 1): gravity and the rod force have no vertical torque, so
    // L_z = x p_y − y p_x obeys dL_z/dt = −c L_z, L_z(t) = L_z(0) e^{−ct}.
    let c = 0.4;
    let friction = LinearForce::damping(3, c);
    let t_end = 4.0;
    for s in 1..=4usize {
        let h0 = [0.02, 0.08, 0.2, 0.4][s - 1];
        let hs: Vec<f64> = (1..4).map(|i| h0 / f64::from(1 << i)).collect();
        let errors: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let out = run(&friction, 2 * s, h, t_end, 0);
                let sol = &out.constrained.solution;
                let lz = |i: usize| {
                    let (q, p) = (sol.q_row(i).unwrap(), sol.p_row(i).unwrap());
                    q[0] * p[1] - q[1] * p[0]
                };
                let exact = lz(0) * (-c * t_end).exp();
                ((lz(sol.len() - 1) - exact) / exact).abs()
            })
            .collect();
        let order = fitted_order(&hs, &errors);
        println!("degree {s}: L_z relative errors {errors:?}, fitted order {order:.2}");
        assert!((order - 2.0 * s as f64).abs() < 0.3, "degree {s}: order {order}");
    }
}

#[test]
fn energy_decays_by_the_discrete_work() {
    // Friction only: H must decrease at every node and H_k − H_0 = W_k up to the method's
    // error, which falls with order 2s.
    let friction = LinearForce::damping(3, 0.4);
    for s in 1..=4usize {
        let h0 = [0.02, 0.08, 0.2, 0.4][s - 1];
        let mut gaps = vec![];
        let mut hs = vec![];
        for i in 1..4 {
            let h = h0 / f64::from(1 << i);
            let out = run(&friction, 2 * s, h, 10.0, 1);
            let sol = &out.constrained.solution;
            assert!(
                sol.energy.windows(2).all(|w| w[1] < w[0]),
                "degree {s}: H not decreasing"
            );
            assert!(
                out.work.windows(2).all(|w| w[1] < w[0]),
                "degree {s}: work not decreasing"
            );
            let h_end = sol.energy[sol.len() - 1] - sol.energy[0];
            println!(
                "degree {s}, h {h}: H_end − H_0 = {h_end:.6}, W_end = {:.6}, max |H − H0 − W| = {:.2e} ({:.2e} relative)",
                out.work[out.work.len() - 1],
                out.balance.max_abs,
                out.balance.max_rel
            );
            assert!(h_end < -1.0, "the friction takes most of the energy");
            gaps.push(out.balance.max_abs);
            hs.push(h);
        }
        let order = fitted_order(&hs, &gaps);
        println!("degree {s}: balance error order {order:.2}");
        assert!(order > 2.0 * s as f64 - 0.3, "degree {s}: balance order {order}");
        assert!(gaps[2] < 1e-4, "degree {s}: balance {}", gaps[2]);
    }
}

#[test]
fn hostile_inputs_are_typed_errors() {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let element = Element::with_order(4).unwrap();
    let options = SolveOptions::step(0.01);
    let problem = Problem::new(lag.clone(), sphere_start(1.0, 2.0), 0.0, 1.0);
    // A force of the wrong dimension.
    let wrong = LinearForce::damping(2, 0.1);
    let err =
        solve_constrained_forced(&problem, &wrong, &sphere, &element, &options, Enforcement::default()).unwrap_err();
    assert!(matches!(err, Error::Dimension { .. }), "{err}");
    // A start off the sphere names the residual.
    let off = Problem::new(
        lag.clone(),
        Start::Velocity {
            q: vec![0.0, 0.0, -1.1],
            v: vec![0.0; 3],
        },
        0.0,
        1.0,
    );
    let friction = LinearForce::damping(3, 0.1);
    let err =
        solve_constrained_forced(&off, &friction, &sphere, &element, &options, Enforcement::default()).unwrap_err();
    assert!(
        matches!(err, Error::Invalid { .. }) && err.to_string().contains("2.100e-1"),
        "{err}"
    );
    // A force that turns NaN ends the run with a step error, nodes before it kept.
    let params = [("c".to_string(), 1.0)];
    let nan = ExprForces::new(&["0", "0", "sqrt(0.5 - t)"], &xyz(), &params).unwrap();
    let out = solve_constrained_forced(&problem, &nan, &sphere, &element, &options, Enforcement::default()).unwrap();
    let sol = &out.constrained.solution;
    assert!(matches!(sol.error, Some(Error::Step(_))), "{:?}", sol.error);
    assert!(sol.t.last().is_some_and(|&t| t > 0.4 && t <= 0.5), "{:?}", sol.t.last());
    assert_eq!(out.work.len(), sol.len());
    // An explosive force: the step fails with an error rather than a panic or a hang.
    let huge = ExprForces::new(&["1e300*x_dot^3", "0", "0"], &xyz(), &[]).unwrap();
    let out = solve_constrained_forced(&problem, &huge, &sphere, &element, &options, Enforcement::default()).unwrap();
    assert!(out.constrained.solution.error.is_some());
    // Options the constrained run refuses are refused with forces too.
    let saveat = SolveOptions {
        saveat: vec![0.5],
        ..options.clone()
    };
    let err =
        solve_constrained_forced(&problem, &friction, &sphere, &element, &saveat, Enforcement::default()).unwrap_err();
    assert!(matches!(err, Error::Invalid { .. }), "{err}");
}
