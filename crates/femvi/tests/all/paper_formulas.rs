//! The paper's discrete Euler–Lagrange equations reproduced by the general element, with
//! unequal steps, for L = ½q̇² − V(q) with V(q) = q⁴/4 + q²/2 (so the element integrals of the
//! exact-integral cases have closed forms): (2.20), (2.30), corrected (2.48)–(2.50), and
//! Störmer–Verlet for degree 1 with the trapezoid rule.

use crate::common::Lcg;
use femvi::{
    Element, Integrator, Mechanical, NodeFamily, Potential, QuadratureKind, Scalar, SolverOptions, Start, TimeGrid,
};

struct Quartic;
impl Potential for Quartic {
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0].powi(4) * 0.25 + q[0] * q[0] * 0.5
    }
}
fn dv(q: f64) -> f64 {
    q * q * q + q
}

fn random_steps(n: usize, h: f64) -> Vec<f64> {
    let mut r = Lcg(7);
    (0..n).map(|_| h * (0.5 + r.uniform())).collect()
}

/// Nodes q_k and, for degree 2, the mid nodes q_{k+1/2}, of a run from (q0, q1).
fn run(el: &Element, steps: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let lag = Mechanical::unit_mass(Quartic);
    let end: f64 = steps.iter().sum();
    let grid = TimeGrid::steps(0.0, steps.to_vec(), end).unwrap();
    let start = Start::Positions {
        q0: vec![0.8],
        q1: vec![0.8 + 0.3 * steps[0]],
    };
    let opts = SolverOptions {
        tolerance: 1e-15,
        ..Default::default()
    };
    let mut it = Integrator::new(&lag, el, grid, start, opts).unwrap();
    let (mut q, mut mid) = (vec![it.node().q[0]], vec![]);
    while it.step().unwrap() {
        q.push(it.node().q[0]);
        let e = it.last_element().unwrap();
        if el.degree() == 2 {
            mid.push(e.base[0] + e.incr[1]);
        }
    }
    (q, mid)
}

#[test]
fn midpoint_lagrangian_is_2_19_and_gives_2_20_with_unequal_steps() {
    // L_d of the element equals h × (2.19).
    let lag = Mechanical::unit_mass(Quartic);
    let el = Element::midpoint();
    let mut work = femvi::ElementWork::new(&el, 1);
    let (q0, q1, h) = (0.3, 0.55, 0.17);
    let mut g = vec![0.0; 2];
    let ld = el.gradient_in_place(&lag, 0.0, h, &[q0], &[0.0, q1 - q0], false, &mut work, &mut g);
    let v = |q: f64| q.powi(4) / 4.0 + q * q / 2.0;
    let paper = h * (0.5 * ((q1 - q0) / h).powi(2) - v((q0 + q1) / 2.0));
    assert!((ld - paper).abs() < 1e-15, "{ld} vs {paper}");

    let steps = random_steps(40, 0.1);
    let (q, _) = run(&el, &steps);
    let mut worst = 0.0f64;
    for k in 1..q.len() - 1 {
        let (hm, hk) = (steps[k - 1], steps[k]);
        let (bar_m, bar_k) = ((q[k - 1] + q[k]) / 2.0, (q[k] + q[k + 1]) / 2.0);
        let r = (q[k + 1] - q[k]) / hk - (q[k] - q[k - 1]) / hm + (dv(bar_k) * hk + dv(bar_m) * hm) / 2.0;
        worst = worst.max(r.abs());
    }
    assert!(worst < 1e-13, "(2.20) residual {worst:e}");
}

#[test]
fn linear_element_with_exact_integral_gives_2_30() {
    // F(a, b) = ∫₀¹ V((1−s)a + sb) ds = (a⁴+a³b+a²b²+ab³+b⁴)/20 + (a²+ab+b²)/6.
    let d1f =
        |a: f64, b: f64| (4.0 * a.powi(3) + 3.0 * a * a * b + 2.0 * a * b * b + b.powi(3)) / 20.0 + (2.0 * a + b) / 6.0;
    let d2f = |a: f64, b: f64| d1f(b, a);
    let el = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(3)).unwrap();
    let steps = random_steps(40, 0.1);
    let (q, _) = run(&el, &steps);
    let mut worst = 0.0f64;
    for k in 1..q.len() - 1 {
        let (hm, hk) = (steps[k - 1], steps[k]);
        let r = (q[k + 1] - q[k]) / hk - (q[k] - q[k - 1]) / hm + d1f(q[k], q[k + 1]) * hk + d2f(q[k - 1], q[k]) * hm;
        worst = worst.max(r.abs());
    }
    assert!(worst < 1e-13, "(2.30) residual {worst:e}");
}

#[test]
fn quadratic_element_gives_corrected_2_48_to_2_50() {
    // ∂G/∂(q_k, q_m, q_{k+1}) = ∫₀¹ V'(q_h(τ)) f(τ) dτ, integrated exactly (degree 8 in τ) by
    // a 6-point Gauss rule computed here from its closed form nodes' recurrence-free values.
    let gl = femvi::fem::QuadratureRule::new(QuadratureKind::GaussLegendre(6)).unwrap();
    let shapes = |t: f64| [(2.0 * t - 1.0) * (t - 1.0), 4.0 * t * (1.0 - t), t * (2.0 * t - 1.0)];
    let dg = |a: f64, m: f64, b: f64| {
        let mut d = [0.0; 3];
        for (c, w) in gl.nodes.iter().zip(&gl.weights) {
            let f = shapes(*c);
            let qh = a * f[0] + m * f[1] + b * f[2];
            for j in 0..3 {
                d[j] += w * dv(qh) * f[j];
            }
        }
        d
    };
    let el = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(5)).unwrap();
    let steps = random_steps(30, 0.1);
    let (q, mid) = run(&el, &steps);
    let (mut w48, mut w49) = (0.0f64, 0.0f64);
    for k in 1..q.len() - 1 {
        let (hm, hk) = (steps[k - 1], steps[k]);
        let (a1, a2, a3) = (1.0 / (3.0 * hm), 7.0 / 3.0 * (1.0 / hm + 1.0 / hk), 1.0 / (3.0 * hk));
        let (a4, a5) = (-8.0 / (3.0 * hm), -8.0 / (3.0 * hk));
        let d1 = dg(q[k], mid[k], q[k + 1])[0];
        let d2 = dg(q[k - 1], mid[k - 1], q[k])[2];
        let r = a1 * q[k - 1] + a2 * q[k] + a3 * q[k + 1] + a4 * mid[k - 1] + a5 * mid[k] - d1 * hk - d2 * hm;
        w48 = w48.max(r.abs());
        // (2.49): −8/(3h²)(q_k + q_{k+1} − 2q_m) − ∂G/∂q_m = 0.
        let r = -8.0 / (3.0 * hk * hk) * (q[k] + q[k + 1] - 2.0 * mid[k]) - dg(q[k], mid[k], q[k + 1])[1];
        w49 = w49.max(r.abs() * hk);
    }
    assert!(w48 < 1e-12, "(2.48) residual {w48:e}");
    assert!(w49 < 1e-12, "(2.49) residual {w49:e}");
    // The misprinted (2.48) (a4 in place of a5) does not hold with unequal steps.
    let k = 5;
    let (hm, hk) = (steps[k - 1], steps[k]);
    let a4 = -8.0 / (3.0 * hm);
    let d1 = dg(q[k], mid[k], q[k + 1])[0];
    let d2 = dg(q[k - 1], mid[k - 1], q[k])[2];
    let misprint = q[k - 1] / (3.0 * hm)
        + 7.0 / 3.0 * (1.0 / hm + 1.0 / hk) * q[k]
        + q[k + 1] / (3.0 * hk)
        + a4 * mid[k - 1]
        + a4 * mid[k]
        - d1 * hk
        - d2 * hm;
    assert!(misprint.abs() > 1e-3, "the misprint should not hold: {misprint:e}");
}

#[test]
fn linear_element_with_trapezoid_rule_is_stormer_verlet() {
    let lag = femvi::models::kepler(1.0).unwrap();
    let el = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let h = 0.01;
    let n = 2000;
    let grid = TimeGrid::uniform(0.0, h, n as f64 * h).unwrap();
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    for method in [
        femvi::Method::Explicit,
        femvi::Method::FixedPoint,
        femvi::Method::Newton,
    ] {
        let opts = SolverOptions {
            method,
            ..Default::default()
        };
        let mut it = Integrator::new(&lag, &el, grid.clone(), start.clone(), opts).unwrap();
        // Hand-written velocity Verlet.
        let (mut q, mut p) = ([0.4f64, 0.0], [0.0f64, 2.0]);
        let f = |q: [f64; 2]| {
            let r3 = (q[0] * q[0] + q[1] * q[1]).powf(1.5);
            [-q[0] / r3, -q[1] / r3]
        };
        let mut worst = 0.0f64;
        for _ in 0..n {
            let f0 = f(q);
            let ph = [p[0] + 0.5 * h * f0[0], p[1] + 0.5 * h * f0[1]];
            q = [q[0] + h * ph[0], q[1] + h * ph[1]];
            let f1 = f(q);
            p = [ph[0] + 0.5 * h * f1[0], ph[1] + 0.5 * h * f1[1]];
            assert!(it.step().unwrap());
            let node = it.node();
            for c in 0..2 {
                worst = worst.max((node.q[c] - q[c]).abs()).max((node.p[c] - p[c]).abs());
            }
        }
        assert!(worst < 1e-11, "{method:?}: deviation from Verlet {worst:e}");
    }
}

#[test]
fn advance_is_bit_identical_to_step() {
    // The fixed-size fast path of explicit stepping against the general step, on Kepler
    // (n = 2), Hénon–Heiles with a non-unit diagonal mass (n = 2) and a 5-D chain (generic n).
    let trap = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let grid = TimeGrid::uniform(0.0, 0.01, 7.005).unwrap();
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    let lag = femvi::models::kepler(1.0).unwrap();
    let hh = Mechanical::new(
        femvi::models::HenonHeilesPotential,
        femvi::MassMatrix::diagonal(vec![2.0, 0.5]).unwrap(),
    )
    .unwrap();
    fn compare<L: femvi::Lagrangian>(lag: &L, el: &Element, grid: &TimeGrid, start: &Start) {
        let mut a = Integrator::new(lag, el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
        let mut b = Integrator::new(lag, el, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
        while a.step().unwrap() {}
        let mut total = 0;
        loop {
            let d = b.advance(97).unwrap();
            if d == 0 {
                break;
            }
            total += d;
        }
        assert_eq!(total, grid.count());
        assert_eq!(a.node().k, b.node().k);
        assert_eq!(a.node().t, b.node().t);
        assert_eq!(a.node().q, b.node().q);
        assert_eq!(a.node().p, b.node().p);
        let (ea, eb) = (a.last_element().unwrap(), b.last_element().unwrap());
        assert_eq!((ea.t, ea.h, ea.base, ea.incr), (eb.t, eb.h, eb.base, eb.incr));
    }
    compare(&lag, &trap, &grid, &start);
    compare(
        &hh,
        &trap,
        &grid,
        &Start::Momentum {
            q: vec![0.1, -0.1],
            p: vec![0.3, 0.2],
        },
    );
    struct Chain;
    impl Potential for Chain {
        fn dim(&self) -> usize {
            5
        }
        fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
            (1..5)
                .map(|i| (q[i] - q[i - 1]).powi(4) * 0.25)
                .fold(q[0] * q[0], |a, b| a + b)
        }
    }
    let chain = Mechanical::unit_mass(Chain);
    compare(
        &chain,
        &trap,
        &grid,
        &Start::Velocity {
            q: vec![0.1, 0.0, -0.1, 0.2, 0.0],
            v: vec![0.0; 5],
        },
    );
}

/// A force that turns infinite (past q = 1) stops explicit stepping with the typed
/// non-finite error at the last good node, the same node by `step` and by the fast `advance`
/// path, which also agree with a hand-written Verlet loop run to the first non-finite value.
#[test]
fn explicit_steps_stop_at_the_last_finite_node() {
    use femvi::{Error, StepFailure};
    struct Wall;
    impl Potential for Wall {
        fn dim(&self) -> usize {
            1
        }
        fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
            -q[0]
        }
        fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
            out[0] = if q[0] > 1.0 { f64::INFINITY } else { 1.0 };
        }
    }
    let lag = Mechanical::unit_mass(Wall);
    let trap = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let h = 0.01;
    let grid = TimeGrid::uniform(0.0, h, 10.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.0],
        p: vec![0.0],
    };
    // Hand-written: from rest under a unit force, q_k ≈ (kh)²/2 until it passes 1.
    let (mut q, mut p, mut good) = (0.0f64, 0.0f64, 0usize);
    loop {
        let qn = q + h * p + 0.5 * h * h;
        let f1 = if qn > 1.0 { f64::INFINITY } else { 1.0 };
        let pn = p + 0.5 * h * (1.0 + f1);
        if !pn.is_finite() {
            break;
        }
        (q, p, good) = (qn, pn, good + 1);
    }
    let mut a = Integrator::new(&lag, &trap, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
    let ea = loop {
        match a.step() {
            Ok(true) => {}
            Ok(false) => panic!("step: the wall was not met"),
            Err(e) => break e,
        }
    };
    let mut b = Integrator::new(&lag, &trap, grid, start, SolverOptions::default()).unwrap();
    let eb = loop {
        match b.advance(usize::MAX) {
            Ok(0) => panic!("advance: the wall was not met"),
            Ok(_) => {}
            Err(e) => break e,
        }
    };
    for (it, e) in [(&a, ea), (&b, eb)] {
        let Error::Step(e) = e else { panic!("{e}") };
        assert_eq!(e.failure, StepFailure::NonFinite);
        assert_eq!(it.node().k, good);
        assert!((it.node().q[0] - q).abs() < 1e-12 && (it.node().p[0] - p).abs() < 1e-12);
    }
    assert_eq!((a.node().q, a.node().p), (b.node().q, b.node().p));
}

/// The explicit fast path on a variable grid (steps 0.01, 0.017, 0.006 in turn, so that the
/// drift's coefficients ½h_k h_{k−1} and ½h_k(h_{k−1} + h_k) differ every step) against a
/// hand-written variable-step velocity Verlet with M⁻¹ and against Newton's method on the
/// element equations, with unit and non-unit diagonal masses.
#[test]
fn explicit_steps_on_a_variable_grid_are_verlet() {
    let trap = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let grid = TimeGrid::steps(0.0, vec![0.01, 0.017, 0.006], 30.0).unwrap();
    let hh = Mechanical::new(
        femvi::models::HenonHeilesPotential,
        femvi::MassMatrix::diagonal(vec![2.0, 0.5]).unwrap(),
    )
    .unwrap();
    fn check<L: femvi::Lagrangian>(
        lag: &L,
        minv: [f64; 2],
        trap: &Element,
        grid: &TimeGrid,
        q0: [f64; 2],
        p0: [f64; 2],
    ) {
        let start = Start::Momentum {
            q: q0.to_vec(),
            p: p0.to_vec(),
        };
        let newton = SolverOptions {
            method: femvi::Method::Newton,
            ..Default::default()
        };
        let mut fast = Integrator::new(lag, trap, grid.clone(), start.clone(), SolverOptions::default()).unwrap();
        let mut slow = Integrator::new(lag, trap, grid.clone(), start, newton).unwrap();
        let f = |q: [f64; 2]| {
            let mut out = [0.0; 2];
            lag.force(0.0, &q, &mut out);
            out
        };
        let (mut q, mut p, mut k) = (q0, p0, 0usize);
        let (mut worst_hand, mut worst_newton) = (0.0f64, 0.0f64);
        while let Some((h, _)) = grid.next(k, fast.node().t) {
            let f0 = f(q);
            let qn = [
                q[0] + h * minv[0] * p[0] + 0.5 * h * h * minv[0] * f0[0],
                q[1] + h * minv[1] * p[1] + 0.5 * h * h * minv[1] * f0[1],
            ];
            let f1 = f(qn);
            p = [p[0] + 0.5 * h * (f0[0] + f1[0]), p[1] + 0.5 * h * (f0[1] + f1[1])];
            q = qn;
            assert!(fast.step().unwrap() && slow.step().unwrap());
            k += 1;
            let (a, b) = (fast.node(), slow.node());
            for c in 0..2 {
                worst_hand = worst_hand.max((a.q[c] - q[c]).abs()).max((a.p[c] - p[c]).abs());
                worst_newton = worst_newton.max((a.q[c] - b.q[c]).abs()).max((a.p[c] - b.p[c]).abs());
            }
        }
        assert!(k > 2000);
        assert!(worst_hand < 1e-11, "against the hand-written loop: {worst_hand:e}");
        assert!(worst_newton < 1e-11, "against Newton: {worst_newton:e}");
    }
    check(
        &femvi::models::kepler(1.0).unwrap(),
        [1.0, 1.0],
        &trap,
        &grid,
        [0.4, 0.0],
        [0.0, 2.0],
    );
    check(&hh, [0.5, 2.0], &trap, &grid, [0.1, -0.1], [0.3, 0.2]);
}
