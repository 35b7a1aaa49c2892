//! Compiled expressions (issue 15): the symbolic derivative tapes of `ExprLagrangian` against
//! automatic differentiation of the same expression on random points, for every function and
//! operator the parser knows; structure detection (mass matrix and force against AD, and the
//! expressions that must stay general); and whole runs of mechanical expressions against the
//! built-in models they spell out.

use femvi::expr::ExprLagrangian;
use femvi::lagrangian::{check_regular, PointDerivatives};
use femvi::{models, Element, Error, Integrator, Lagrangian, Method, SolverOptions, Start, TimeGrid};

/// A small deterministic generator (xorshift), uniform in [lo, hi).
struct Rng(u64);
impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// |a − b| ≤ 1e-14 |b| + floor, where the floor scales with the size of the terms that may
/// cancel (`scale`, the largest magnitude among the compared entries) so that entries that are
/// zero up to rounding compare sensibly.
fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-14 * b.abs() + 1e-15 * scale || (a.is_nan() && b.is_nan())
}

/// Compares tapes and AD at `points` random points in [lo, hi); returns the worst relative
/// difference seen (for the message).
fn compare(src: &str, coords: &[&str], lo: f64, hi: f64, seed: u64) -> f64 {
    let c = names(coords);
    let n = c.len();
    let lag = ExprLagrangian::new(src, &c, &[("k".into(), 1.7)]).unwrap();
    assert_eq!(lag.has_compiled_derivatives(), (true, true), "{src}");
    let mut rng = Rng(seed);
    let mut worst = 0.0f64;
    for _ in 0..50 {
        let t = rng.uniform(lo, hi);
        let q: Vec<f64> = (0..n).map(|_| rng.uniform(lo, hi)).collect();
        let v: Vec<f64> = (0..n).map(|_| rng.uniform(lo, hi)).collect();
        for with_t in [false, true] {
            let (mut tape, mut ad) = (PointDerivatives::new(n), PointDerivatives::new(n));
            lag.first_derivatives(t, &q, &v, with_t, &mut tape);
            ad.first_by_ad(&lag, t, &q, &v, with_t);
            let scale = ad.grad.iter().fold(ad.value.abs(), |m, g| m.max(g.abs()));
            assert!(
                close(tape.value, ad.value, scale),
                "{src}: value {} vs {}",
                tape.value,
                ad.value
            );
            for (a, b) in tape.grad.iter().zip(&ad.grad) {
                assert!(
                    close(*a, *b, scale),
                    "{src} at {q:?} {v:?}: grad {:?} vs {:?}",
                    tape.grad,
                    ad.grad
                );
                worst = worst.max((a - b).abs() / scale.max(1e-300));
            }
            lag.second_derivatives(t, &q, &v, with_t, &mut tape);
            ad.second_by_ad(&lag, t, &q, &v, with_t);
            let scale = ad.hess.iter().fold(scale, |m, g| m.max(g.abs()));
            for (a, b) in tape.grad.iter().zip(&ad.grad) {
                assert!(
                    close(*a, *b, scale),
                    "{src}: second-pass grad {:?} vs {:?}",
                    tape.grad,
                    ad.grad
                );
            }
            for (a, b) in tape.hess.iter().zip(&ad.hess) {
                assert!(
                    close(*a, *b, scale),
                    "{src} at {q:?} {v:?}: hess {:?} vs {:?}",
                    tape.hess,
                    ad.hess
                );
                worst = worst.max((a - b).abs() / scale.max(1e-300));
            }
        }
    }
    worst
}

#[test]
fn tapes_agree_with_automatic_differentiation_for_every_function() {
    // Each function applied to an argument mixing t, both coordinates and both velocities,
    // inside the domain of the function on [0.1, 0.6).
    let u = "(0.3*x + 0.2*y_dot + 0.1*t*x_dot - 0.05*y)";
    let cases = [
        format!("sin({u})*x_dot^2 + y"),
        format!("cos({u})*y_dot + x*x_dot"),
        format!("tan({u}) + k*x_dot^2"),
        format!("exp({u})*x_dot"),
        format!("ln({u} + 1) + log(x)*y_dot^3"),
        format!("sqrt({u} + 1)*x_dot^2"),
        format!("abs({u} - 0.05)*x_dot + abs(-x)*y_dot"),
        format!("sinh({u})*x_dot + cosh({u})*y_dot"),
        format!("tanh({u})*x_dot^2"),
        format!("asin({u}) + acos({u})*x_dot"),
        format!("atan({u})*y_dot^2"),
        format!("atan2({u}, x + y_dot)"),
        format!("pow(x, y_dot) + x^y + {u}^1.5 + y^-2.5 + x_dot^-3"),
        format!("min({u}, x_dot*y) + max(x*y_dot, {u})"),
        format!("-{u}/(x_dot + y) - x/y*t + (x - y_dot)/2"),
        "0.5*(x_dot^2 + y_dot^2) + 0.5*k*(x*y_dot - y*x_dot) + 1/sqrt(x^2 + y^2)".to_string(),
        "sqrt(1 - x_dot^2 - y_dot^2) + t*x*y".to_string(),
        "x^0 + x^1 + 2^x + t^2*x_dot".to_string(),
    ];
    for (i, src) in cases.iter().enumerate() {
        let worst = compare(src, &["x", "y"], 0.1, 0.6, 0x9E37_79B9_7F4A_7C15 + i as u64);
        eprintln!("{src}: worst difference {worst:.1e} of the largest entry");
    }
}

#[test]
fn the_pendulum_expression_is_mechanical_with_the_force_of_the_model() {
    let lag = ExprLagrangian::new(
        "0.5*m*l^2*theta_dot^2 + m*g*l*cos(theta)",
        &names(&["theta"]),
        &[("g".into(), 9.81), ("l".into(), 1.3), ("m".into(), 2.0)],
    )
    .unwrap();
    assert!(lag.is_mechanical());
    let model = models::pendulum(2.0, 9.81, 1.3).unwrap();
    let m = lag.mass_matrix().unwrap();
    assert!((m.get(0, 0).unwrap() - 2.0 * 1.3 * 1.3).abs() < 1e-15);
    let mut rng = Rng(7);
    for _ in 0..100 {
        let q = [rng.uniform(-4.0, 4.0)];
        let (mut f, mut g) = ([0.0], [0.0]);
        lag.force(0.0, &q, &mut f);
        model.force(0.0, &q, &mut g);
        // Closed form: −m g l sin θ.
        let want = -2.0 * 9.81 * 1.3 * q[0].sin();
        assert!((f[0] - want).abs() <= 1e-14 * 25.5, "{} vs {want}", f[0]);
        assert!((f[0] - g[0]).abs() <= 1e-14 * 25.5);
    }
}

/// The mass matrix and the force of `lag` against AD: M = ∂²L/∂v², force = ∂L/∂q at v = 0.
fn check_against_ad(lag: &ExprLagrangian, n: usize, seed: u64) {
    let m = lag.mass_matrix().expect("mechanical");
    let mut rng = Rng(seed);
    for _ in 0..20 {
        let q: Vec<f64> = (0..n).map(|_| rng.uniform(0.5, 2.0)).collect();
        let v: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let mut ad = PointDerivatives::new(n);
        ad.second_by_ad(lag, 0.3, &q, &v, false);
        for i in 0..n {
            for j in 0..n {
                let h = ad.h(1 + n + i, 1 + n + j);
                assert!(
                    (m.get(i, j).unwrap() - h).abs() <= 1e-14 * h.abs().max(1.0),
                    "M[{i}][{j}]"
                );
                // No q·v terms.
                assert!(ad.h(1 + i, 1 + n + j).abs() <= 1e-14, "q v coupling");
            }
        }
        let mut f = vec![0.0; n];
        lag.force(0.3, &q, &mut f);
        ad.first_by_ad(lag, 0.3, &q, &vec![0.0; n], false);
        let scale = ad.l_q().iter().fold(1.0f64, |m, x| m.max(x.abs()));
        for (a, b) in f.iter().zip(ad.l_q()) {
            assert!((a - b).abs() <= 1e-14 * scale, "force {f:?} vs {:?}", ad.l_q());
        }
    }
}

#[test]
fn mechanical_structure_is_detected_with_dense_and_diagonal_masses() {
    let xy = names(&["x", "y"]);
    let p = [("a".to_string(), 3.0), ("b".to_string(), 0.5)];
    let diagonal = [
        "0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)",
        "x_dot^2/2 + a*y_dot*y_dot - (x^2*y - y^3/3) - t*x",
        "-(-(x_dot^2)) + (y_dot*2)*y_dot/a - exp(-x*y)",
    ];
    for (i, src) in diagonal.iter().enumerate() {
        let lag = ExprLagrangian::new(src, &xy, &p).unwrap();
        assert!(lag.is_mechanical(), "{src}");
        assert!(lag.mass_matrix().unwrap().diagonal_entries().is_some(), "{src}");
        check_against_ad(&lag, 2, 11 + i as u64);
    }
    let dense = [
        "0.5*(a*x_dot^2 + 2*b*x_dot*y_dot + y_dot^2) - cos(x) - cos(y)",
        "0.5*(x_dot + y_dot)^2 + 0.5*(x_dot - b*y_dot)^2 - x^2*y^2",
        "(x_dot*(a*x_dot + y_dot) + y_dot*y_dot)/2 + sin(x + t)",
    ];
    for (i, src) in dense.iter().enumerate() {
        let lag = ExprLagrangian::new(src, &xy, &p).unwrap();
        assert!(lag.is_mechanical(), "{src}");
        assert!(lag.mass_matrix().unwrap().diagonal_entries().is_none(), "{src}");
        check_against_ad(&lag, 2, 21 + i as u64);
    }
}

#[test]
fn general_lagrangians_stay_general() {
    let xy = names(&["x", "y"]);
    for src in [
        // A term linear in v (magnetic field).
        "0.5*(x_dot^2 + y_dot^2) + 0.5*(x*y_dot - y*x_dot)",
        // A mass matrix that depends on q (double-pendulum-like).
        "0.5*(x_dot^2 + (1 + x^2)*y_dot^2) - y",
        // Not polynomial in v (relativistic).
        "-sqrt(1 - x_dot^2 - y_dot^2) - 1/x",
        // Degree 4 in v.
        "0.5*(x_dot^2 + y_dot^2) + 0.1*x_dot^4",
        // A time-dependent mass.
        "0.5*exp(t)*(x_dot^2 + y_dot^2) - x",
        // Not positive definite.
        "0.5*(x_dot^2 - y_dot^2) - x*y",
        "-0.5*(x_dot^2 + y_dot^2)",
        // Singular.
        "0.5*x_dot^2 + y*y_dot - x",
        "0.5*(x_dot + y_dot)^2 - x - y",
    ] {
        let lag = ExprLagrangian::new(src, &xy, &[]).unwrap();
        assert!(!lag.is_mechanical(), "{src}");
        assert!(lag.mass_matrix().is_none(), "{src}");
    }
}

#[test]
fn singular_kinetic_terms_are_still_rejected_with_the_same_error() {
    let el = Element::with_order(4).unwrap();
    let grid = TimeGrid::uniform(0.0, 0.1, 1.0).unwrap();
    let xy = names(&["x", "y"]);
    for src in [
        "0.5*(x_dot + y_dot)^2 - x - y",
        "0.5*x_dot^2 + y*y_dot - x",
        "0*x_dot^2 + 0*y_dot^2 - x",
    ] {
        let lag = ExprLagrangian::new(src, &xy, &[]).unwrap();
        let e = check_regular(&lag, 0.0, &[1.0, 1.0], &[0.1, 0.2]).unwrap_err();
        assert!(matches!(e, Error::DegenerateLagrangian { .. }), "{src}: {e:?}");
        let start = Start::Velocity {
            q: vec![1.0, 1.0],
            v: vec![0.1, 0.2],
        };
        let e = Integrator::new(&lag, &el, grid.clone(), start, SolverOptions::default()).err();
        assert!(matches!(e, Some(Error::DegenerateLagrangian { .. })), "{src}: {e:?}");
    }
}

/// Final (q, p) of `lag` from (q0, p0) with `method`.
fn final_state<L: Lagrangian>(lag: &L, el: &Element, h: f64, end: f64, q: Vec<f64>, p: Vec<f64>) -> Vec<f64> {
    let grid = TimeGrid::uniform(0.0, h, end).unwrap();
    let opts = SolverOptions {
        method: Method::Auto,
        ..Default::default()
    };
    let mut it = Integrator::new(lag, el, grid, Start::Momentum { q, p }, opts).unwrap();
    while it.advance(usize::MAX).unwrap() > 0 {}
    let node = it.node();
    node.q.iter().chain(node.p.iter()).copied().collect()
}

#[test]
fn mechanical_expressions_run_like_the_models_they_spell_out() {
    // Kepler (P1 of the paper's examples) for 20 time units at degrees 1, 2 and 4: the
    // expression takes the model's solver (explicit or fixed point), and the two final states
    // differ by rounding only (the force formulas associate differently).
    let xy = names(&["x", "y"]);
    let kepler_expr = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &xy, &[]).unwrap();
    let kepler = models::kepler(1.0).unwrap();
    for degree in [1, 2, 4] {
        let el = Element::with_order(2 * degree).unwrap();
        let a = final_state(&kepler_expr, &el, 0.01, 20.0, vec![0.4, 0.0], vec![0.0, 2.0]);
        let b = final_state(&kepler, &el, 0.01, 20.0, vec![0.4, 0.0], vec![0.0, 2.0]);
        let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        eprintln!("kepler degree {degree}: expression vs model {diff:.1e}");
        assert!(diff <= 1e-9, "degree {degree}: {a:?} vs {b:?}");
    }
    let pend_expr = ExprLagrangian::new(
        "0.5*l^2*theta_dot^2 + g*l*cos(theta)",
        &names(&["theta"]),
        &[("g".into(), 9.81), ("l".into(), 1.0)],
    )
    .unwrap();
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    let el = Element::with_order(4).unwrap();
    let a = final_state(&pend_expr, &el, 0.01, 100.0, vec![1.0], vec![0.0]);
    let b = final_state(&pend, &el, 0.01, 100.0, vec![1.0], vec![0.0]);
    let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    eprintln!("pendulum: expression vs model {diff:.1e}");
    assert!(diff <= 1e-9, "{a:?} vs {b:?}");
}

/// An expression Lagrangian seen through its value only, so that every derivative comes from
/// the trait's automatic differentiation (the path all expressions took before the tapes).
struct ByAd(ExprLagrangian);
impl Lagrangian for ByAd {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn value<D: femvi::Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.0.value(t, q, v)
    }
    fn is_autonomous(&self) -> bool {
        self.0.is_autonomous()
    }
}

#[test]
fn a_gyroscopic_newton_run_with_tapes_agrees_with_the_run_by_automatic_differentiation() {
    // The golden test's "magnetic expression newton degree 3 cyclic" run: its stored bits
    // changed when the tapes replaced AD; this is the check that the new result is right.
    let magnetic = ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) + 1/sqrt(x^2 + y^2)",
        &names(&["x", "y"]),
        &[("b".into(), 0.7)],
    )
    .unwrap();
    assert!(!magnetic.is_mechanical());
    let el = Element::galerkin(
        3,
        femvi::NodeFamily::Equispaced,
        femvi::QuadratureKind::GaussLegendre(3),
    )
    .unwrap();
    let go = |lag: &dyn Fn(TimeGrid, Start) -> Vec<f64>| {
        let grid = TimeGrid::steps(0.0, vec![0.05, 0.04], 8.0).unwrap();
        let start = Start::Velocity {
            q: vec![0.4, 0.0],
            v: vec![0.0, 2.0],
        };
        lag(grid, start)
    };
    fn state<L: Lagrangian>(lag: &L, el: &Element, grid: TimeGrid, start: Start) -> Vec<f64> {
        // Newton, as the golden run (Auto would take the gyroscopic fixed point).
        let opts = SolverOptions {
            method: Method::Newton,
            ..Default::default()
        };
        let mut it = Integrator::new(lag, el, grid, start, opts).unwrap();
        while it.step().unwrap() {}
        let node = it.node();
        node.q.iter().chain(node.p.iter()).copied().collect()
    }
    let a = go(&|g, s| state(&magnetic, &el, g, s));
    let ad = ByAd(magnetic.clone());
    let b = go(&|g, s| state(&ad, &el, g, s));
    let diff = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    eprintln!("magnetic, tapes vs AD after 180 steps: {diff:.1e}");
    assert!(diff <= 1e-11, "{a:?} vs {b:?}");
}

#[test]
fn forces_at_many_points_are_the_forces_at_each() {
    // `forces` evaluates points four at a time; every count of points, including partial
    // groups, must give each point's `force` bit for bit.
    let xyz = names(&["x", "y", "z"]);
    let lag = ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2 + z_dot^2) + 1/sqrt(x^2 + y^2 + z^2) - t*x*y + min(x, z)^3 - abs(y)*exp(-z^2)",
        &xyz,
        &[],
    )
    .unwrap();
    assert!(lag.is_mechanical());
    let mut rng = Rng(99);
    for points in 0..11 {
        let t: Vec<f64> = (0..points).map(|_| rng.uniform(0.0, 1.0)).collect();
        let q: Vec<f64> = (0..3 * points).map(|_| rng.uniform(-2.0, 2.0)).collect();
        let mut all = vec![f64::NAN; 3 * points];
        lag.forces(&t, &q, &mut all);
        for j in 0..points {
            let mut one = [0.0; 3];
            lag.force(t[j], &q[3 * j..3 * j + 3], &mut one);
            let got: Vec<u64> = all[3 * j..3 * j + 3].iter().map(|x| x.to_bits()).collect();
            assert_eq!(got, one.map(f64::to_bits), "{points} points, point {j}");
        }
    }
}
