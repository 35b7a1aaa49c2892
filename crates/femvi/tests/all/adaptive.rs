//! The time-transformed Lagrangian (issue 21): hand-coded derivatives against automatic
//! differentiation, the momentum is the physical one, the step map is symplectic, output at
//! physical times against Kepler's closed form, and the refusals (typed errors, no hang).

use crate::common::{kepler_exact, Lcg};
use femvi::adaptive::{
    solve_adaptive, AdaptiveOptions, ExprMonitor, KeplerMonitor, Monitor, NBodyMonitor, TimeTransformed,
};
use femvi::diagnostics::symplecticity_defect;
use femvi::lagrangian::{hamiltonian, PointDerivatives};
use femvi::{models, Element, Error, Integrator, Lagrangian, Problem, SolverOptions, Start, TimeGrid};

fn kepler_start(e: f64) -> Start {
    Start::Momentum {
        q: vec![1.0 - e, 0.0],
        p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()],
    }
}

/// Largest difference of value, gradient and Hessian between two evaluations, relative to
/// the largest entry.
fn compare<L: Lagrangian, G: Monitor>(lg: &TimeTransformed<L, G>, q: &[f64], v: &[f64]) -> f64 {
    let n = q.len();
    let (mut hand, mut ad) = (PointDerivatives::new(n), PointDerivatives::new(n));
    lg.second_derivatives(0.0, q, v, false, &mut hand);
    ad.second_by_ad(lg, 0.0, q, v, false);
    let mut scale = hand.value.abs();
    let mut worst = (hand.value - ad.value).abs();
    for (a, b) in hand.grad.iter().zip(&ad.grad).chain(hand.hess.iter().zip(&ad.hess)) {
        scale = scale.max(b.abs());
        worst = worst.max((a - b).abs());
    }
    // The first derivatives by the same hand-coded path.
    let mut first = PointDerivatives::new(n);
    lg.first_derivatives(0.0, q, v, false, &mut first);
    for (a, b) in first.grad.iter().zip(&ad.grad) {
        worst = worst.max((a - b).abs());
    }
    worst / scale
}

#[test]
fn hand_coded_derivatives_match_automatic_differentiation() {
    let mut rng = Lcg(21);
    let kepler = TimeTransformed::new(models::kepler(1.0).unwrap(), KeplerMonitor, -0.5).unwrap();
    assert!(kepler.is_fast());
    let bodies = models::n_body(1.0, vec![1.0, 0.5, 2e-3], 3).unwrap();
    let nbody = TimeTransformed::new(bodies, NBodyMonitor::new(3, 3), -1.3).unwrap();
    let mut worst = 0.0f64;
    for _ in 0..20 {
        let mut r = |k: usize| (0..k).map(|_| 2.0 * rng.uniform() - 1.0).collect::<Vec<f64>>();
        let (q, v) = (r(2), r(2));
        worst = worst.max(compare(&kepler, &q, &v));
        let (q, v) = (r(9), r(9));
        worst = worst.max(compare(&nbody, &q, &v));
    }
    println!("hand-coded vs AD derivatives of L_g: largest relative difference {worst:.2e}");
    assert!(worst < 1e-13, "{worst:e}");
}

/// The n-body monitor with the trait's default derivatives (dual numbers over `value`).
struct NBodyByDuals(NBodyMonitor);

impl Monitor for NBodyByDuals {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn value<D: femvi::Scalar>(&self, q: &[D]) -> D {
        self.0.value(q)
    }
}

#[test]
fn nbody_monitor_derivatives_by_hand_match_dual_numbers() {
    let mut rng = Lcg(7);
    let mut worst = 0.0f64;
    for (bodies, space) in [(7, 2), (3, 3), (2, 1)] {
        let (hand, duals) = (
            NBodyMonitor::new(bodies, space),
            NBodyByDuals(NBodyMonitor::new(bodies, space)),
        );
        let n = bodies * space;
        for _ in 0..10 {
            let q: Vec<f64> = (0..n).map(|_| 4.0 * rng.uniform() - 2.0).collect();
            let (mut g1, mut g2, mut h1, mut h2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n * n], vec![0.0; n * n]);
            let v1 = hand.derivatives(&q, &mut g1, Some(&mut h1));
            let v2 = duals.derivatives(&q, &mut g2, Some(&mut h2));
            let scale = |x: &[f64]| x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            worst = worst.max((v1 - v2).abs() / v2.abs());
            let dg: Vec<f64> = g1.iter().zip(&g2).map(|(a, b)| a - b).collect();
            let dh: Vec<f64> = h1.iter().zip(&h2).map(|(a, b)| a - b).collect();
            worst = worst.max(scale(&dg) / scale(&g2)).max(scale(&dh) / scale(&h2));
            // The gradient alone agrees with the gradient of the full call.
            let mut g3 = vec![0.0; n];
            assert_eq!(hand.derivatives(&q, &mut g3, None), v1);
            assert_eq!(g3, g1);
        }
    }
    println!("n-body monitor, hand vs dual numbers: largest relative difference {worst:.2e}");
    assert!(worst < 1e-13, "{worst:e}");
}

#[test]
fn the_momentum_is_the_physical_momentum() {
    // ∂L_g/∂q' at q' = g v is ∂L/∂v at v (the pendulum: a non-quadratic potential).
    let pendulum = models::pendulum(1.3, 9.81, 0.7).unwrap();
    let g = ExprMonitor::new("1 + theta^2", &["theta".to_string()], &[]).unwrap();
    let lg = TimeTransformed::new(pendulum.clone(), &g, 2.0).unwrap();
    let (q, v) = ([0.4], [1.7]);
    let gq = 1.0 + 0.4 * 0.4;
    let (mut dl, mut dlg) = (PointDerivatives::new(1), PointDerivatives::new(1));
    pendulum.first_derivatives(0.0, &q, &v, false, &mut dl);
    lg.first_derivatives(0.0, &q, &[gq * v[0]], false, &mut dlg);
    assert!((dl.l_v()[0] - dlg.l_v()[0]).abs() < 1e-14);
    // And along a run: the nodes' p against the closed-form physical momentum at their t.
    let e = 0.9;
    let problem = Problem::new(
        models::kepler(1.0).unwrap(),
        kepler_start(e),
        0.0,
        4.0 * std::f64::consts::PI,
    );
    let sol = solve_adaptive(
        &problem,
        KeplerMonitor,
        &Element::with_order(6).unwrap(),
        &AdaptiveOptions::step(0.05),
    )
    .unwrap();
    let mut worst = 0.0f64;
    for (i, &t) in sol.t.iter().enumerate() {
        let (_, p) = kepler_exact(e, t);
        for c in 0..2 {
            worst = worst.max((sol.p[2 * i + c] - p[c]).abs() / (p[0].hypot(p[1])));
        }
    }
    println!("Kepler e = 0.9, 2 periods, order 6, ds = 0.05: max relative momentum error {worst:.2e}");
    assert!(worst < 1e-6, "{worst:e}");
}

#[test]
fn the_step_map_is_symplectic() {
    let e: f64 = 0.9;
    let kepler = models::kepler(1.0).unwrap();
    let (q0, p0) = (vec![1.0 - e, 0.0], vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()]);
    let e0 = hamiltonian(&kepler, 0.0, &q0, &p0, &mut [0.0; 2], &mut PointDerivatives::new(2)).unwrap();
    for (lg, order) in [
        (TimeTransformed::new(kepler.clone(), KeplerMonitor, e0).unwrap(), 4),
        (
            TimeTransformed::new(kepler.clone(), KeplerMonitor, e0).unwrap().by_ad(),
            8,
        ),
    ] {
        let element = Element::with_order(order).unwrap();
        let grid = TimeGrid::uniform(0.0, 0.1, 8.4).unwrap(); // about one period
        let start = Start::Momentum {
            q: q0.clone(),
            p: p0.clone(),
        };
        let mut it = Integrator::new(&lg, &element, grid, start, SolverOptions::default()).unwrap();
        let mut worst = 0.0f64;
        while it.step().unwrap() {
            worst = worst.max(symplecticity_defect(&it.tangent_map().unwrap(), 2));
        }
        println!("order {order}: max |MᵀJM − J| over one period of Kepler e = 0.9 = {worst:.2e}");
        assert!(worst <= 1e-12, "{worst:e}");
    }
}

#[test]
fn saveat_answers_physical_times_from_the_element() {
    let e = 0.9;
    let period = 2.0 * std::f64::consts::PI;
    let times: Vec<f64> = (0..=40).map(|i| period * i as f64 / 40.0).collect();
    let problem = Problem::new(models::kepler(1.0).unwrap(), kepler_start(e), 0.0, period);
    let element = Element::with_order(4).unwrap();
    let (mut errors_q, mut errors_p) = (vec![], vec![]);
    for ds in [0.05, 0.025] {
        let options = AdaptiveOptions {
            saveat: times.clone(),
            every: 0,
            ..AdaptiveOptions::step(ds)
        };
        let sol = solve_adaptive(&problem, KeplerMonitor, &element, &options).unwrap();
        assert_eq!(
            sol.saved.t, times,
            "every requested time is answered, exactly that time"
        );
        let (mut worst_q, mut worst_p) = (0.0f64, 0.0f64);
        for (i, &t) in times.iter().enumerate() {
            let (q, p) = kepler_exact(e, t);
            let dq = (sol.saved.q[2 * i] - q[0]).hypot(sol.saved.q[2 * i + 1] - q[1]);
            let dp = (sol.saved.p[2 * i] - p[0]).hypot(sol.saved.p[2 * i + 1] - p[1]) / p[0].hypot(p[1]);
            // v is p for unit mass.
            assert_eq!(sol.saved.v[2 * i], sol.saved.p[2 * i]);
            worst_q = worst_q.max(dq);
            worst_p = worst_p.max(dp);
        }
        errors_q.push(worst_q);
        errors_p.push(worst_p);
    }
    let (rq, rp) = (errors_q[0] / errors_q[1], errors_p[0] / errors_p[1]);
    println!(
        "saveat, Kepler e = 0.9, order 4, ds = 0.05 / 0.025: max |dq| {:.2e} / {:.2e} (ratio {rq:.1}), max relative |dp| {:.2e} / {:.2e} (ratio {rp:.1})",
        errors_q[0], errors_q[1], errors_p[0], errors_p[1]
    );
    // Between nodes the interpolant in s is of order s + 1 = 3 (ratio 8) and its derivative,
    // hence p, of order s = 2 (ratio 4), as the library's dense output.
    assert!(errors_q[1] < 1e-5 && rq > 6.0, "{errors_q:?}");
    assert!(errors_p[1] < 2e-4 && rp > 3.0, "{errors_p:?}");
}

#[test]
fn an_expression_monitor_gives_the_same_run_as_the_built_in_one() {
    let problem = Problem::new(models::kepler(1.0).unwrap(), kepler_start(0.7), 0.0, 10.0);
    let element = Element::with_order(4).unwrap();
    let options = AdaptiveOptions::step(0.05);
    let a = solve_adaptive(&problem, KeplerMonitor, &element, &options).unwrap();
    let g = ExprMonitor::new("(x^2 + y^2)^0.75", &["x".into(), "y".into()], &[]).unwrap();
    let b = solve_adaptive(&problem, g, &element, &options).unwrap();
    assert_eq!(a.t.len(), b.t.len());
    let worst = a.q.iter().zip(&b.q).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(worst < 1e-11, "{worst:e}");
}

#[test]
fn refusals_are_typed_errors_and_nothing_hangs() {
    let element = Element::with_order(2).unwrap();
    let options = AdaptiveOptions::step(0.1);
    let start = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    // A non-autonomous Lagrangian.
    let forced = Problem::new(
        models::forced_oscillator(1.0, 1.0, 0.5, 2.0).unwrap(),
        start.clone(),
        0.0,
        1.0,
    );
    let g = ExprMonitor::new("1", &["x".into()], &[]).unwrap();
    let err = solve_adaptive(&forced, &g, &element, &options).unwrap_err();
    assert!(
        matches!(err, Error::Invalid { .. }) && err.to_string().contains("autonomous"),
        "{err}"
    );
    // A start from (q0, q1), a bad ds, a monitor that is not positive at q0.
    let osc = models::harmonic(1.0, 1.0).unwrap();
    let positions = Problem::new(
        osc.clone(),
        Start::Positions {
            q0: vec![1.0],
            q1: vec![0.9],
        },
        0.0,
        1.0,
    );
    assert!(matches!(
        solve_adaptive(&positions, &g, &element, &options),
        Err(Error::Invalid { .. })
    ));
    let problem = Problem::new(osc, start, 0.0, 10.0);
    for ds in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let bad = AdaptiveOptions::step(ds);
        assert!(matches!(
            solve_adaptive(&problem, &g, &element, &bad),
            Err(Error::Invalid { .. })
        ));
    }
    let negative = ExprMonitor::new("x - 2", &["x".into()], &[]).unwrap();
    assert!(matches!(
        solve_adaptive(&problem, &negative, &element, &options),
        Err(Error::Invalid { .. })
    ));
    // g = x² vanishes where the oscillator crosses 0: physical time stalls there, and the
    // step limit ends the run (stopped) instead of a hang.
    let stall = ExprMonitor::new("x^2", &["x".into()], &[]).unwrap();
    let limited = AdaptiveOptions {
        max_steps: 2000,
        ..AdaptiveOptions::step(0.1)
    };
    let sol = solve_adaptive(&problem, &stall, &element, &limited).unwrap();
    assert!(
        sol.steps <= 2000 && (sol.stopped || sol.error.is_some()),
        "{} {:?}",
        sol.steps,
        sol.error
    );
    assert!(*sol.t.last().unwrap() < 10.0);
}

/// E₀ in double-double against exact arithmetic: the references were computed with Python's
/// `fractions.Fraction` (Kepler: H = p²/2 − 1/q of the rounded e = 0.99 pericentre state, a
/// rational number, correctly rounded) and 50-digit `decimal` (three bodies: square roots).
#[test]
fn accurate_energy_levels_match_exact_arithmetic() {
    let e = 0.99f64;
    let (q0, p0) = ([1.0 - e, 0.0], [0.0, ((1.0 + e) / (1.0 - e)).sqrt()]);
    let exact = -0.500000000000005;
    assert_eq!(femvi::adaptive::kepler_energy(1.0, &q0, &p0), exact);
    // H in f64 (p·v − L) is 2.3e-14 off: the error the accurate level removes.
    let kepler = models::kepler(1.0).unwrap();
    let mut v = vec![0.0; 2];
    let plain = hamiltonian(&kepler, 0.0, &q0, &p0, &mut v, &mut PointDerivatives::new(2)).unwrap();
    assert!((plain - exact).abs() > 1e-14, "{plain:e}");
    let (masses, q, p) = (
        [1.0, 0.5, 2e-3],
        [0.1, -0.7, 1.3, 0.25, -0.9, 0.6],
        [0.3, 0.2, -0.45, 0.11, 0.004, -0.003],
    );
    let h = femvi::adaptive::nbody_energy(1.3, &masses, 2, &q, &p);
    assert!((h - -0.14101030640934617f64).abs() <= f64::EPSILON * 0.15, "{h:e}");
    assert!(femvi::adaptive::nbody_energy(1.0, &masses, 2, &q[..4], &p).is_nan());
    // A level that is not H(q0, p0) up to rounding is refused.
    let problem = Problem::new(kepler, kepler_start(0.5), 0.0, 1.0);
    let options = AdaptiveOptions {
        energy_level: Some(-0.4),
        ..AdaptiveOptions::step(0.1)
    };
    let err = solve_adaptive(&problem, KeplerMonitor, &Element::with_order(4).unwrap(), &options).unwrap_err();
    assert!(matches!(err, Error::Invalid { .. }), "{err}");
}
