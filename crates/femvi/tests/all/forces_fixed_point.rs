//! Forced runs by fixed-point iteration (issue 19, item 1, `forces/fixed_point.rs`): for a
//! constant mass matrix and a force F(t, q) independent of v, `solve_forced` takes the
//! mechanical fixed-point solver with the force −∇V + F. The second method is the forced
//! Newton step (`Method::Newton`), which solves the same equations: the two agree to
//! round-off at every node, in q, p and the discrete work. The driven harmonic oscillator is
//! also checked against its closed form (nodal order 2s).

use femvi::expr::ExprLagrangian;
use femvi::forces::{solve_forced, ExprForces, Force, ForcedSolution, LinearForce};
use femvi::{models, Element, Error, Lagrangian, Method, Problem, Scalar, SolveOptions, Start};

const F0: f64 = 0.5;
const W: f64 = 1.7;

/// x(t), x'(t) of x'' + x = F0 cos(W t) from x(0) = 1, x'(0) = 0 (W ≠ 1).
fn driven(t: f64) -> (f64, f64) {
    let a = F0 / (1.0 - W * W);
    let x = (1.0 - a) * t.cos() + a * (W * t).cos();
    let v = -(1.0 - a) * t.sin() - a * W * (W * t).sin();
    (x, v)
}

fn options(h: f64, method: Method) -> SolveOptions {
    let mut o = SolveOptions::step(h);
    o.solver.method = method;
    o
}

fn start() -> Start {
    Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    }
}

/// The least-squares slope of log(err) against log(h).
fn slope(h: &[f64], err: &[f64]) -> f64 {
    let xs: Vec<f64> = h.iter().map(|x| x.ln()).collect();
    let ys: Vec<f64> = err.iter().map(|x| x.ln()).collect();
    let m = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / m, ys.iter().sum::<f64>() / m);
    let num: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let den: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    num / den
}

/// Largest difference between two runs over every kept node: q, p, H and W (and the same
/// nodes and times).
fn max_difference(a: &ForcedSolution, b: &ForcedSolution) -> f64 {
    let (ra, rb) = (&a.solution, &b.solution);
    assert!(
        ra.error.is_none() && rb.error.is_none(),
        "{:?} {:?}",
        ra.error,
        rb.error
    );
    assert_eq!(ra.step, rb.step);
    assert_eq!(ra.t, rb.t);
    let pairs = [
        (&ra.q, &rb.q),
        (&ra.p, &rb.p),
        (&ra.energy, &rb.energy),
        (&a.work, &b.work),
    ];
    pairs
        .iter()
        .flat_map(|(x, y)| x.iter().zip(y.iter()).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max)
}

/// Whether two runs agree bit for bit in q and p.
fn identical(a: &ForcedSolution, b: &ForcedSolution) -> bool {
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    bits(&a.solution.q) == bits(&b.solution.q) && bits(&a.solution.p) == bits(&b.solution.p)
}

/// Auto (the fixed point here), an explicit `Method::FixedPoint` and Newton on one problem:
/// Auto is the fixed point bit for bit, not Newton, and Newton agrees to `tol`.
fn compare<L: Lagrangian + Sync, F: Force + Sync>(
    problem: &Problem<L>,
    force: &F,
    element: &Element,
    h: f64,
    tol: f64,
) -> f64 {
    let auto = solve_forced(problem, force, element, &options(h, Method::Auto)).unwrap();
    let fixed = solve_forced(problem, force, element, &options(h, Method::FixedPoint)).unwrap();
    let newton = solve_forced(problem, force, element, &options(h, Method::Newton)).unwrap();
    assert!(identical(&auto, &fixed), "Auto takes the fixed point");
    assert!(!identical(&auto, &newton), "Auto does not take Newton");
    let d = max_difference(&fixed, &newton);
    assert!(d <= tol, "fixed point against Newton: {d:e}");
    assert!(
        (fixed.balance.max_abs - newton.balance.max_abs).abs() <= tol,
        "balance {} against {}",
        fixed.balance.max_abs,
        newton.balance.max_abs
    );
    d
}

/// The driven oscillator x'' + x = F0 cos(W t), degrees 1–4: fixed point equals Newton.
#[test]
fn driven_oscillator_fixed_point_equals_newton() {
    let problem = Problem::new(models::harmonic(1.0, 1.0).unwrap(), start(), 0.0, 20.0);
    let force = LinearForce::drive(vec![F0], W);
    assert!(!force.depends_on_velocity());
    for s in 1..=4 {
        let element = Element::with_order(2 * s).unwrap();
        let d = compare(&problem, &force, &element, 0.1, 1e-13);
        println!("driven oscillator s = {s}: max |fixed point - Newton| = {d:.2e}");
    }
}

/// The forced Duffing oscillator x'' + αx + βx³ = γ cos(ωt) + εx² (force F(t, q) from
/// expressions, a mechanical `ExprLagrangian`), degrees 1–4: fixed point equals Newton.
#[test]
fn forced_duffing_fixed_point_equals_newton() {
    let coords = ["x".to_string()];
    let params: Vec<(String, f64)> = [("a", -1.0), ("b", 1.0), ("g", 0.3), ("w", 1.2), ("e", 0.1)]
        .iter()
        .map(|(k, v)| (k.to_string(), *v))
        .collect();
    let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*a*x^2 - 0.25*b*x^4", &coords, &params).unwrap();
    assert!(lag.mass_matrix().is_some());
    let force = ExprForces::new(&["g*cos(w*t) + e*x^2"], &coords, &params).unwrap();
    assert!(!force.depends_on_velocity());
    let problem = Problem::new(lag, start(), 0.0, 20.0);
    for s in 1..=4 {
        let element = Element::with_order(2 * s).unwrap();
        let d = compare(&problem, &force, &element, 0.05, 1e-13);
        println!("forced Duffing s = {s}: max |fixed point - Newton| = {d:.2e}");
    }
}

/// A time-dependent L (the drive as a potential −F0 x cos(W t)) with a force F(t, q): the work
/// W_k then holds −h Σ b_i ∂L/∂t, evaluated by the fixed-point run as by Newton's.
#[test]
fn time_dependent_lagrangian_work_equals_newton() {
    let coords = ["x".to_string()];
    let params = [("f".to_string(), F0), ("w".to_string(), W)];
    let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*x^2 + f*x*cos(w*t)", &coords, &params).unwrap();
    assert!(lag.mass_matrix().is_some() && !lag.is_autonomous());
    let force = ExprForces::new(&["-0.2*x^3"], &coords, &params).unwrap();
    let problem = Problem::new(lag, start(), 0.0, 10.0);
    for s in 1..=4 {
        let element = Element::with_order(2 * s).unwrap();
        let fixed = solve_forced(&problem, &force, &element, &options(0.1, Method::Auto)).unwrap();
        let newton = solve_forced(&problem, &force, &element, &options(0.1, Method::Newton)).unwrap();
        assert!(fixed.work.iter().any(|w| w.abs() > 0.1), "the work is not trivial");
        assert!(max_difference(&fixed, &newton) <= 1e-13);
        let (a, b) = (fixed.balance.max_abs, newton.balance.max_abs);
        assert!((a - b).abs() <= 1e-13, "s = {s}: balance {a} against {b}");
    }
}

/// The fixed-point forced run against the closed form of the driven oscillator: nodal order
/// 2s for s = 1…4 in q and p, and the energy balance as small as Newton's.
#[test]
fn driven_oscillator_fixed_point_order_2s() {
    let t_end = 10.0;
    let (x_ref, v_ref) = driven(t_end);
    let problem = Problem::new(models::harmonic(1.0, 1.0).unwrap(), start(), 0.0, t_end);
    let force = LinearForce::drive(vec![F0], W);
    for s in 1..=4 {
        let element = Element::with_order(2 * s).unwrap();
        let hs: Vec<f64> = match s {
            1 => vec![0.1, 0.05, 0.025, 0.0125],
            2 => vec![0.4, 0.2, 0.1, 0.05],
            3 => vec![0.5, 0.25, 0.2, 0.125],
            _ => vec![0.625, 0.5, 0.4, 0.3125],
        };
        let (mut eq, mut ep) = (vec![], vec![]);
        for &h in &hs {
            let sol = solve_forced(&problem, &force, &element, &options(h, Method::Auto)).unwrap();
            let r = &sol.solution;
            assert!(r.error.is_none(), "{:?}", r.error);
            assert_eq!(*r.t.last().unwrap(), t_end);
            eq.push((r.q.last().unwrap() - x_ref).abs());
            ep.push((r.p.last().unwrap() - v_ref).abs());
        }
        let (oq, op) = (slope(&hs, &eq), slope(&hs, &ep));
        println!("s = {s}: h {hs:?} |q error| {eq:?} order {oq:.2}, |p error| {ep:?} order {op:.2}");
        let want = 2.0 * s as f64;
        assert!((oq - want).abs() < 0.3, "s = {s}: q order {oq}");
        assert!((op - want).abs() < 0.3, "s = {s}: p order {op}");
    }
}

/// `every` and `max_steps` with the fixed point: the same kept nodes and stop as Newton's.
#[test]
fn every_and_max_steps_as_newton() {
    let problem = Problem::new(models::harmonic(1.0, 1.0).unwrap(), start(), 0.0, 20.0);
    let force = LinearForce::drive(vec![F0], W);
    let element = Element::with_order(4).unwrap();
    let run = |method| {
        let mut o = options(0.1, method);
        o.every = 10;
        o.max_steps = Some(37);
        solve_forced(&problem, &force, &element, &o).unwrap()
    };
    let (fixed, newton) = (run(Method::Auto), run(Method::Newton));
    assert!(fixed.solution.stopped && newton.solution.stopped);
    assert_eq!(fixed.solution.step, [0, 10, 20, 30, 37]);
    assert!(max_difference(&fixed, &newton) <= 1e-13);
}

/// A velocity-dependent force or a Lagrangian without a mass matrix keeps Newton under Auto
/// (bit for bit) and is an input error under `Method::FixedPoint`.
#[test]
fn fixed_point_only_where_it_fits() {
    let problem = Problem::new(models::harmonic(1.0, 1.0).unwrap(), start(), 0.0, 2.0);
    let element = Element::with_order(4).unwrap();
    let damped = LinearForce::damping(1, 0.3);
    let auto = solve_forced(&problem, &damped, &element, &options(0.1, Method::Auto)).unwrap();
    let newton = solve_forced(&problem, &damped, &element, &options(0.1, Method::Newton)).unwrap();
    assert!(identical(&auto, &newton));
    let err = solve_forced(&problem, &damped, &element, &options(0.1, Method::FixedPoint)).unwrap_err();
    assert!(matches!(err, Error::Invalid { .. }), "{err}");
    assert!(err.to_string().contains("independent of the velocities"), "{err}");

    /// L = ½v² + v⁴/12 − ½x²: regular, but no constant mass matrix.
    struct Quartic;
    impl Lagrangian for Quartic {
        fn dim(&self) -> usize {
            1
        }
        fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
            v[0] * v[0] * 0.5 + v[0].powi(4) / 12.0 - q[0] * q[0] * 0.5
        }
    }
    let quartic = Problem::new(Quartic, start(), 0.0, 2.0);
    let drive = LinearForce::drive(vec![F0], W);
    let auto = solve_forced(&quartic, &drive, &element, &options(0.1, Method::Auto)).unwrap();
    let newton = solve_forced(&quartic, &drive, &element, &options(0.1, Method::Newton)).unwrap();
    assert!(identical(&auto, &newton));
    assert!(solve_forced(&quartic, &drive, &element, &options(0.1, Method::FixedPoint)).is_err());
}

/// A step the fixed point cannot solve (a stiff spring, h far beyond its contraction) ends
/// the run at the last good node with the step's error, as a failed Newton step does.
#[test]
fn failed_fixed_point_step_is_reported() {
    let problem = Problem::new(models::harmonic(1.0, 1e6).unwrap(), start(), 0.0, 10.0);
    let force = LinearForce::drive(vec![F0], W);
    let sol = solve_forced(
        &problem,
        &force,
        &Element::with_order(4).unwrap(),
        &options(1.0, Method::Auto),
    )
    .unwrap();
    let r = &sol.solution;
    assert!(
        matches!(r.error, Some(Error::Step(ref e)) if e.step == 0),
        "{:?}",
        r.error
    );
    assert_eq!(r.step, [0]);
    assert_eq!(sol.work, [0.0]);
}

/// Degree 1 with the trapezoid rule (Störmer–Verlet without forces): `Method::Explicit` takes
/// the fixed point too (there is no explicit forced step), equal to Newton.
#[test]
fn trapezoid_explicit_request_takes_the_fixed_point() {
    use femvi::{NodeFamily, QuadratureKind};
    let problem = Problem::new(models::harmonic(1.0, 1.0).unwrap(), start(), 0.0, 20.0);
    let force = LinearForce::drive(vec![F0], W);
    let element = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    compare(&problem, &force, &element, 0.05, 1e-13);
    let explicit = solve_forced(&problem, &force, &element, &options(0.05, Method::Explicit)).unwrap();
    let fixed = solve_forced(&problem, &force, &element, &options(0.05, Method::FixedPoint)).unwrap();
    assert!(identical(&explicit, &fixed));
}
