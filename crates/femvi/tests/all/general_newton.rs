//! The cheap general path (issue 15 item 2): derivatives in one pass of vector dual numbers
//! against the per-pair hyper-dual passes, and the simplified Newton iteration of the step
//! equations (`Method::SimplifiedNewton`) against full Newton (`Method::FullNewton`) on a velocity-dependent Lagrangian,
//! with its order, a variable grid, a strongly nonlinear case, checkpoints and hostile input.

use femvi::lagrangian::PointDerivatives;
use femvi::models::RelativisticKepler;
use femvi::solve::{simplified_newton, FrozenJacobian, Simplified};
use femvi::{
    Element, Error, Integrator, Lagrangian, Method, NodeFamily, QuadratureKind, Scalar, SolverOptions, Start, TimeGrid,
};

/// A non-autonomous L of any dimension that mixes q, v and t in every way (for the AD tests).
struct Mixed {
    n: usize,
}
impl Lagrangian for Mixed {
    fn dim(&self) -> usize {
        self.n
    }
    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        let mut sum = D::from(0.0);
        for i in 0..self.n {
            let j = (i + 1) % self.n;
            sum += (v[i] * v[i] * (q[j].cos() + 2.0)) * 0.5 + v[i] * q[j] * t.sin() - (q[i] * q[j] + 1.0).ln()
                + (v[j] * q[i]).exp() * 0.1;
        }
        sum * (t * 0.3).cos()
    }
}

/// A deterministic stream of numbers in (−1, 1) (splitmix64).
struct Stream(u64);
impl Stream {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Every entry of `a` within `rel` of `b`'s largest entry (relative to the array's size: an
/// entry that cancels to near zero cannot be asked for more).
fn close(a: &[f64], b: &[f64], rel: f64) -> bool {
    let s = max_abs(b).max(f64::MIN_POSITIVE);
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= rel * s)
}

#[test]
fn one_pass_derivatives_match_the_per_pair_passes_on_random_points() {
    let mut rng = Stream(7);
    for n in 1..=5 {
        let lag = Mixed { n };
        for _ in 0..50 {
            let t = rng.next();
            let q: Vec<f64> = (0..n).map(|_| 0.5 + 0.4 * rng.next()).collect();
            let v: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            for with_t in [false, true] {
                let (mut one, mut pairs) = (PointDerivatives::new(n), PointDerivatives::new(n));
                one.second_by_ad(&lag, t, &q, &v, with_t);
                pairs.second_by_pairs(&lag, t, &q, &v, with_t);
                assert!((one.value - pairs.value).abs() <= 1e-14 * pairs.value.abs(), "n = {n}");
                assert!(
                    close(&one.grad, &pairs.grad, 1e-14),
                    "n = {n}: {:?} {:?}",
                    one.grad,
                    pairs.grad
                );
                assert!(
                    close(&one.hess, &pairs.hess, 1e-14),
                    "n = {n}: {:?} {:?}",
                    one.hess,
                    pairs.hess
                );
                let (mut one, mut dirs) = (PointDerivatives::new(n), PointDerivatives::new(n));
                one.first_by_ad(&lag, t, &q, &v, with_t);
                dirs.first_by_directions(&lag, t, &q, &v, with_t);
                assert!((one.value - dirs.value).abs() <= 1e-14 * dirs.value.abs());
                assert!(
                    close(&one.grad, &dirs.grad, 1e-14),
                    "n = {n}: {:?} {:?}",
                    one.grad,
                    dirs.grad
                );
                // The t entries are there exactly when asked for.
                assert_eq!(one.grad[0] == 0.0, !with_t);
            }
        }
    }
}

fn options(method: Method) -> SolverOptions {
    SolverOptions {
        method,
        ..Default::default()
    }
}

/// Every node (t, q, p) of a run.
fn nodes<L: Lagrangian>(
    lag: &L,
    el: &Element,
    grid: TimeGrid,
    start: Start,
    method: Method,
) -> femvi::Result<Vec<Vec<f64>>> {
    let mut it = Integrator::new(lag, el, grid, start, options(method))?;
    let mut out = Vec::new();
    loop {
        let nd = it.node();
        out.push([nd.t].iter().chain(nd.q).chain(nd.p).copied().collect());
        if !it.step()? {
            return Ok(out);
        }
    }
}

fn p1() -> Start {
    Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    }
}

/// The largest difference between two runs over all nodes, relative to max(1, |entry|).
fn largest_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(x, y)| (x - y).abs() / y.abs().max(1.0)))
        .fold(0.0, f64::max)
}

#[test]
fn simplified_newton_agrees_with_full_newton_at_every_node() {
    let lag = RelativisticKepler { c: 10.0 };
    let h = 2.0 * std::f64::consts::PI / 1000.0;
    for order in [2, 4, 6, 8] {
        let el = Element::with_order(order).unwrap();
        let grid = || TimeGrid::uniform(0.0, h, 1000.0 * h).unwrap();
        let a = nodes(&lag, &el, grid(), p1(), Method::SimplifiedNewton).unwrap();
        let b = nodes(&lag, &el, grid(), p1(), Method::FullNewton).unwrap();
        let d = largest_difference(&a, &b);
        assert!(d <= 1e-13, "order {order}: {d:e}");
    }
}

#[test]
fn simplified_newton_follows_a_variable_grid() {
    // h changes at every step (a cycle of three): the kept Jacobian is refreshed each time.
    let lag = RelativisticKepler { c: 10.0 };
    let el = Element::with_order(4).unwrap();
    let grid = || TimeGrid::steps(0.0, vec![0.004, 0.007, 0.0055], 5.0).unwrap();
    let a = nodes(&lag, &el, grid(), p1(), Method::SimplifiedNewton).unwrap();
    let b = nodes(&lag, &el, grid(), p1(), Method::FullNewton).unwrap();
    assert!(a.len() > 900);
    let d = largest_difference(&a, &b);
    assert!(d <= 1e-13, "{d:e}");
}

#[test]
fn strongly_nonlinear_steps_refresh_and_still_agree() {
    // c = 2.2 with speeds up to 2: γ reaches ~2.4 near pericentre, and a large step (h = T/150)
    // makes the Jacobian of one step a poor one for the next.
    let lag = RelativisticKepler { c: 2.2 };
    let el = Element::with_order(6).unwrap();
    let grid = || TimeGrid::uniform(0.0, 0.04, 12.0).unwrap();
    let a = nodes(&lag, &el, grid(), p1(), Method::SimplifiedNewton).unwrap();
    let b = nodes(&lag, &el, grid(), p1(), Method::FullNewton).unwrap();
    let d = largest_difference(&a, &b);
    // A regression bound, not a derived one: 1e-13 when the simplified iteration landed; with
    // the issue-21 form of R_0 (p_k + Δp − Σ_{j≥1} rows) the two solvers end 1.1e-13 apart
    // here. The simplified iteration's iterates carried a small bias then; since it
    // iterates to round-off (issue 15, now the default `Method::Newton`) the bound is kept.
    assert!(d <= 2e-13, "{d:e}");
}

/// The predictor's error correction (`NewtonStep::correct`): a regression bound, not a derived
/// one. The mean corrections per step of `examples/general_profile`'s run were 4.37 / 4.02 /
/// 3.45 at degrees 1 / 2 / 3 with the linear extrapolation of the errors, and 3.93 / 3.59 /
/// 2.91 once the quadratic one is taken where it predicted better; the bounds sit between.
#[test]
fn the_corrected_guess_saves_iterations() {
    let lag = RelativisticKepler { c: 10.0 };
    let h = 2.0 * std::f64::consts::PI / 1000.0;
    for (s, bound) in [(1, 4.2), (2, 3.8), (3, 3.2)] {
        let el = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
        let grid = TimeGrid::uniform(0.0, h, 2000.0 * h).unwrap();
        let mut it = Integrator::new(&lag, &el, grid, p1(), options(Method::Newton)).unwrap();
        while it.advance(usize::MAX).unwrap() > 0 {}
        let mean = it.mean_iterations();
        assert!(mean <= bound, "degree {s}: {mean} corrections per step");
    }
}

#[test]
fn a_stale_jacobian_is_given_up_for_a_fresh_one() {
    // x³ = 8 from x = 1.9 with the Jacobian of x = 0.6 frozen (a ninth of the true slope
    // near the root): the iteration overshoots and diverges, θ > 1.
    let mut frozen = FrozenJacobian::new(1);
    frozen.jac[0] = 3.0 * 0.6 * 0.6;
    assert!(frozen.factor());
    let mut x = [1.9];
    let out = simplified_newton(
        &mut x,
        1e-14,
        50,
        |_| 2.0,
        &mut frozen,
        |x, r| r[0] = x[0].powi(3) - 8.0,
    );
    assert!(matches!(out, Simplified::Slow { .. }), "{out:?}");
    // With a Jacobian near the root (x = 2.1: θ ≈ 1 − 12/13.2 < 0.1) it converges to round-off.
    let mut x = [2.1];
    frozen.jac[0] = 3.0 * x[0] * x[0];
    assert!(frozen.factor());
    let out = simplified_newton(
        &mut x,
        1e-14,
        50,
        |_| 2.0,
        &mut frozen,
        |x, r| r[0] = x[0].powi(3) - 8.0,
    );
    assert!(matches!(out, Simplified::Converged { .. }), "{out:?}");
    assert!((x[0] - 2.0).abs() <= 4e-16, "{}", x[0]);
}

/// Fitted slope of log(error) against log(h).
fn slope(hs: &[f64], errs: &[f64]) -> f64 {
    let (x, y): (Vec<f64>, Vec<f64>) = hs.iter().zip(errs).map(|(h, e)| (h.ln(), e.ln())).unzip();
    let m = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / m, y.iter().sum::<f64>() / m);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

#[test]
fn order_is_2s_for_a_velocity_dependent_lagrangian() {
    let lag = RelativisticKepler { c: 3.0 };
    let end = 1.0;
    let final_q = |order: usize, steps: usize| {
        let el = Element::with_order(order).unwrap();
        let h = end / steps as f64;
        let run = nodes(
            &lag,
            &el,
            TimeGrid::uniform(0.0, h, end).unwrap(),
            p1(),
            Method::SimplifiedNewton,
        )
        .unwrap();
        run.last().unwrap()[1..3].to_vec()
    };
    // Reference: the order-16 element with 400 steps (its error is far below the fits').
    let reference = final_q(16, 400);
    for s in 1..=4usize {
        let counts: &[usize] = match s {
            1 => &[100, 200, 400, 800],
            2 => &[50, 100, 200, 400],
            3 => &[10, 14, 20, 28],
            _ => &[5, 7, 10, 14],
        };
        let hs: Vec<f64> = counts.iter().map(|&k| end / k as f64).collect();
        let errs: Vec<f64> = counts
            .iter()
            .map(|&k| {
                let q = final_q(2 * s, k);
                (q[0] - reference[0]).hypot(q[1] - reference[1])
            })
            .collect();
        assert!(
            errs.iter().all(|&e| e > 1e-12),
            "s = {s}: {errs:?} too close to round-off"
        );
        let p = slope(&hs, &errs);
        eprintln!("s = {s}: order {p:.3} ({errs:?})");
        assert!((p - 2.0 * s as f64).abs() < 0.3, "s = {s}: order {p:.2} ({errs:?})");
    }
}

#[test]
fn a_resumed_newton_run_equals_the_uninterrupted_one_bit_for_bit() {
    let lag = RelativisticKepler { c: 10.0 };
    let el = Element::with_order(4).unwrap();
    let h = 2.0 * std::f64::consts::PI / 1000.0;
    let new = || {
        Integrator::new(
            &lag,
            &el,
            TimeGrid::uniform(0.0, h, 300.0 * h).unwrap(),
            p1(),
            options(Method::SimplifiedNewton),
        )
    };
    let mut whole = new().unwrap();
    while whole.step().unwrap() {}
    for at in [1, 37, 150] {
        let mut first = new().unwrap();
        first.advance(at).unwrap();
        let saved = first.checkpoint("relativistic");
        let mut resumed = new().unwrap();
        resumed.restore(&saved, "relativistic").unwrap();
        while resumed.step().unwrap() {}
        let (a, b) = (resumed.node(), whole.node());
        for (x, y) in a.q.iter().chain(a.p).zip(b.q.iter().chain(b.p)) {
            assert_eq!(x.to_bits(), y.to_bits(), "restored at step {at}");
        }
    }
}

#[test]
fn a_lagrangian_that_turns_nan_is_a_typed_step_error() {
    // L = ½v² − ln x: the particle falls into x = 0, where L stops being defined.
    struct Log;
    impl Lagrangian for Log {
        fn dim(&self) -> usize {
            1
        }
        fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
            v[0] * v[0] * (v[0] * v[0] * 1e-3 + 0.5) - q[0].ln()
        }
    }
    let el = Element::with_order(4).unwrap();
    for method in [Method::SimplifiedNewton, Method::FullNewton] {
        let start = Start::Velocity {
            q: vec![1.0],
            v: vec![-1.0],
        };
        let got = nodes(&Log, &el, TimeGrid::uniform(0.0, 0.05, 10.0).unwrap(), start, method);
        assert!(matches!(got, Err(Error::Step(_))), "{method:?}: {got:?}");
    }
}
