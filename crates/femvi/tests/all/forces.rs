//! Non-conservative forces (issue 19, item 1): the damped harmonic oscillator against its
//! closed form (nodal order 2s for s = 1…4, the discrete energy against the continuous one,
//! the energy balance H − H0 − W), the forced Duffing oscillator against a fine classical
//! Runge–Kutta reference (a second method), and every error path of `femvi::forces`.

use femvi::expr::ExprLagrangian;
use femvi::forces::{solve_forced, ExprForces, Force, LinearForce, Rayleigh, Sum};
use femvi::{models, Element, Error, Problem, Scalar, SolveOptions, Start, Steps};

const OMEGA0: f64 = 1.0;
const C: f64 = 0.3;

/// x(t), x'(t) of x'' + c x' + ω0² x = 0 from x(0) = 1, x'(0) = 0 (underdamped).
fn damped(t: f64) -> (f64, f64) {
    let g = C / 2.0;
    let wd = (OMEGA0 * OMEGA0 - g * g).sqrt();
    let (a, b) = (1.0, g / wd);
    let e = (-g * t).exp();
    let (c, s) = ((wd * t).cos(), (wd * t).sin());
    let x = e * (a * c + b * s);
    let v = e * (-g * (a * c + b * s) + (-a * wd * s + b * wd * c));
    (x, v)
}

/// Numbers as `[1.234e-5, …]`.
fn e3(x: &[f64]) -> String {
    let items: Vec<String> = x.iter().map(|v| format!("{v:.3e}")).collect();
    format!("[{}]", items.join(", "))
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

fn damped_problem(t_end: f64) -> Problem<femvi::Mechanical<models::HarmonicPotential>> {
    let lag = models::harmonic(1.0, OMEGA0 * OMEGA0).unwrap();
    Problem::new(
        lag,
        Start::Velocity {
            q: vec![1.0],
            v: vec![0.0],
        },
        0.0,
        t_end,
    )
}

/// Steps per degree whose errors lie well above round-off and in the asymptotic range.
fn steps_for(s: usize) -> Vec<f64> {
    match s {
        1 => vec![0.1, 0.05, 0.025, 0.0125],
        2 => vec![0.4, 0.2, 0.1, 0.05],
        3 => vec![0.8, 0.4, 0.2, 0.1],
        _ => vec![1.25, 1.0, 0.625, 0.5],
    }
}

/// Nodal order 2s in q and p (= x') at t = 10, and the energy balance to round-off.
#[test]
fn damped_oscillator_nodal_order_2s() {
    let t_end = 10.0;
    let (x_ref, v_ref) = damped(t_end);
    for s in 1..=4 {
        let element = Element::with_order(2 * s).unwrap();
        let hs = steps_for(s);
        let (mut eq, mut ep, mut eb) = (vec![], vec![], vec![]);
        for &h in &hs {
            let sol = solve_forced(
                &damped_problem(t_end),
                &LinearForce::damping(1, C),
                &element,
                &SolveOptions::step(h),
            )
            .unwrap();
            let r = &sol.solution;
            assert!(r.error.is_none(), "{:?}", r.error);
            assert_eq!(*r.t.last().unwrap(), t_end);
            eq.push((r.q.last().unwrap() - x_ref).abs());
            ep.push((r.p.last().unwrap() - v_ref).abs());
            eb.push(sol.balance.max_abs);
        }
        let (oq, op, ob) = (slope(&hs, &eq), slope(&hs, &ep), slope(&hs, &eb));
        println!(
            "s = {s}: h {hs:?}\n  |q error| {} order {oq:.2}\n  |p error| {} order {op:.2}\n  balance {} order {ob:.2}",
            e3(&eq),
            e3(&ep),
            e3(&eb)
        );
        let want = 2.0 * s as f64;
        assert!((oq - want).abs() < 0.3, "s = {s}: q order {oq}");
        assert!((op - want).abs() < 0.3, "s = {s}: p order {op}");
        // H is quadratic and F linear: Gauss elements keep the balance H_k − H_0 = W_k exactly
        // (the quadratic-invariant property of Gauss methods applied to d/dt H = F·v), so only
        // round-off remains; its order is measured on the Duffing oscillator below.
        assert!(eb.iter().all(|&b| b < 1e-13), "s = {s}: balance {eb:?}");
    }
}

/// The discrete energy H_k follows the continuous E(t) = ½x'² + ½ω0²x² (which decays by a
/// factor e^{-c t} on average): |H_k − E(t_k)| at every node shrinks with order 2s, and is
/// far below the decay itself.
#[test]
fn damped_oscillator_energy_decay() {
    let t_end = 20.0;
    for s in [1, 2] {
        let element = Element::with_order(2 * s).unwrap();
        let hs = [0.1, 0.05];
        let (mut errs, mut balances) = (vec![], vec![]);
        for h in hs {
            let sol = solve_forced(
                &damped_problem(t_end),
                &LinearForce::damping(1, C),
                &element,
                &SolveOptions::step(h),
            )
            .unwrap();
            let r = &sol.solution;
            let mut worst = 0.0f64;
            for (i, &t) in r.t.iter().enumerate() {
                let (x, v) = damped(t);
                let e = 0.5 * v * v + 0.5 * OMEGA0 * OMEGA0 * x * x;
                worst = worst.max((r.energy[i] - e).abs());
            }
            let (e0, e1) = (r.energy[0], *r.energy.last().unwrap());
            assert!(e1 < 0.01 * e0, "the energy decays: {e0} -> {e1}");
            // W is the work of the friction: negative. H − H0 − W vanishes up to round-off:
            // the element is Gauss collocation, along whose polynomial dE/dt = F·q̇ has degree
            // 2s − 1 for a quadratic energy and a linear force, which the s-point Gauss rule
            // of the discrete work integrates exactly.
            let w = *sol.work.last().unwrap();
            assert!(w < 0.0, "friction does negative work: {w}");
            errs.push(worst);
            balances.push(sol.balance.max_abs);
        }
        let order = (errs[0] / errs[1]).log2();
        println!(
            "s = {s}: max |H_k - E(t_k)| {}, order {order:.2}; max |H_k - H_0 - W_k| {}",
            e3(&errs),
            e3(&balances)
        );
        assert!((order - 2.0 * s as f64).abs() < 0.3, "s = {s}: order {order}");
        assert!(balances.iter().all(|&b| b <= 1e-14), "s = {s}: balance {balances:?}");
    }
}

/// The forced Duffing oscillator x'' + δx' + αx + βx³ = γ cos ωt (as L = ½v² − ½αx² − ¼βx⁴ with
/// a force from expressions) against classical Runge–Kutta with a step 10⁴ times smaller;
/// the energy balance max |H_k − H_0 − W_k| with the same order.
#[test]
fn forced_duffing_order_2s_against_runge_kutta() {
    let (delta, alpha, beta, gamma, omega) = (0.2, -1.0, 1.0, 0.3, 1.2);
    let t_end = 5.0;
    // Reference: RK4 with h = 1e-4 (error ~ h⁴ ≈ 1e-16 per unit time).
    let rhs = |t: f64, x: f64, v: f64| (v, -delta * v - alpha * x - beta * x * x * x + gamma * (omega * t).cos());
    let (mut x, mut v, mut t) = (1.0f64, 0.0f64, 0.0f64);
    let n = 50_000;
    let hr = t_end / n as f64;
    for _ in 0..n {
        let k1 = rhs(t, x, v);
        let k2 = rhs(t + hr / 2.0, x + hr / 2.0 * k1.0, v + hr / 2.0 * k1.1);
        let k3 = rhs(t + hr / 2.0, x + hr / 2.0 * k2.0, v + hr / 2.0 * k2.1);
        let k4 = rhs(t + hr, x + hr * k3.0, v + hr * k3.1);
        x += hr / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        v += hr / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        t += hr;
    }
    let coords = ["x".to_string()];
    let params: Vec<(String, f64)> = [("a", alpha), ("b", beta), ("d", delta), ("g", gamma), ("w", omega)]
        .iter()
        .map(|(k, v)| (k.to_string(), *v))
        .collect();
    let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*a*x^2 - 0.25*b*x^4", &coords, &params).unwrap();
    let force = ExprForces::new(&["-d*x_dot + g*cos(w*t)"], &coords, &params).unwrap();
    let problem = Problem::new(
        lag,
        Start::Velocity {
            q: vec![1.0],
            v: vec![0.0],
        },
        0.0,
        t_end,
    );
    for s in 1..=4 {
        let element = Element::with_order(2 * s).unwrap();
        let hs: Vec<f64> = match s {
            1 => vec![0.05, 0.025, 0.0125],
            2 => vec![0.2, 0.1, 0.05],
            3 => vec![0.5, 0.25, 0.125],
            _ => vec![0.5, 0.4, 0.3125, 0.25],
        };
        let (mut err, mut bal) = (vec![], vec![]);
        for &h in &hs {
            let sol = solve_forced(&problem, &force, &element, &SolveOptions::step(h)).unwrap();
            let r = &sol.solution;
            assert!(r.error.is_none(), "{:?}", r.error);
            err.push((r.q.last().unwrap() - x).abs().max((r.p.last().unwrap() - v).abs()));
            bal.push(sol.balance.max_abs);
        }
        let order = slope(&hs, &err);
        let border = slope(&hs, &bal);
        println!(
            "Duffing s = {s}: h {hs:?} errors {} order {order:.2}; balance {} order {border:.2}",
            e3(&err),
            e3(&bal)
        );
        assert!(border > 2.0 * s as f64 - 0.35, "s = {s}: balance order {border}");
        assert!(
            err.iter().all(|e| *e > 1e-12),
            "errors must stay above the reference's: {err:?}"
        );
        assert!((order - 2.0 * s as f64).abs() < 0.35, "s = {s}: order {order}");
    }
}

/// A Rayleigh function ½c v² gives the same run as the force −c v, and a sum of forces adds.
#[test]
fn rayleigh_and_sum_agree_with_the_linear_force() {
    let coords = ["x".to_string()];
    let r = Rayleigh::new("0.5*c*x_dot^2", &coords, &[("c".into(), C)]).unwrap();
    let e = Element::with_order(4).unwrap();
    let opts = SolveOptions::step(0.1);
    let a = solve_forced(&damped_problem(5.0), &r, &e, &opts).unwrap();
    let b = solve_forced(&damped_problem(5.0), &LinearForce::damping(1, C), &e, &opts).unwrap();
    for (x, y) in a.solution.q.iter().zip(&b.solution.q) {
        assert!((x - y).abs() < 1e-13, "{x} vs {y}");
    }
    let half = Sum(LinearForce::damping(1, C / 2.0), LinearForce::damping(1, C / 2.0));
    let c = solve_forced(&damped_problem(5.0), &half, &e, &opts).unwrap();
    for (x, y) in c.solution.q.iter().zip(&b.solution.q) {
        assert!((x - y).abs() < 1e-13, "{x} vs {y}");
    }
    assert!(!LinearForce::drive(vec![1.0], 1.0).depends_on_velocity() && r.depends_on_velocity());
}

/// A force that is not finite at the start: the run ends with a typed step error at step 0.
struct Bad;
impl Force for Bad {
    fn dim(&self) -> usize {
        1
    }
    fn force<D: Scalar>(&self, _t: D, q: &[D], _v: &[D], out: &mut [D]) {
        out[0] = (q[0] - 10.0).sqrt();
    }
}

#[test]
fn error_paths() {
    let coords = ["x".to_string()];
    // Bad expression, with its position.
    let e = ExprForces::new(&["-c*x_dot +"], &coords, &[("c".into(), 1.0)]).unwrap_err();
    assert!(e.message.contains("force on x"), "{}", e.message);
    let e = ExprForces::new(&["-k*y_dot"], &coords, &[]).unwrap_err();
    assert!(e.message.contains("unknown symbol"), "{}", e.message);
    assert!(Rayleigh::new("0.5*x_dot^", &coords, &[]).is_err());
    // Wrong count of forces.
    let e = ExprForces::new(&["x", "x_dot"], &coords, &[]).unwrap_err();
    assert!(
        e.message.contains("2 force expressions for 1 coordinates"),
        "{}",
        e.message
    );
    // A force of the wrong dimension.
    let e = solve_forced(
        &damped_problem(1.0),
        &LinearForce::damping(2, 0.1),
        &Element::with_order(2).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap_err();
    assert!(matches!(e, Error::Dimension { .. }), "{e}");
    // Newton failure: a NaN force, reported at step 0 and t = 0 with the run kept up to there.
    let sol = solve_forced(
        &damped_problem(1.0),
        &Bad,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap();
    match &sol.solution.error {
        Some(Error::Step(s)) => assert_eq!((s.step, s.t, s.failure), (0, 0.0, femvi::StepFailure::NonFinite)),
        other => panic!("expected a step error, got {other:?}"),
    }
    assert_eq!(sol.solution.t, [0.0]);
    // Newton failure by the iteration cap: a stiff force and one iteration.
    let mut opts = SolveOptions::step(0.5);
    opts.solver.max_iterations = 1;
    let coords2 = coords.clone();
    let cubic = ExprForces::new(&["-50*x_dot^3"], &coords2, &[]).unwrap();
    let sol = solve_forced(&damped_problem(5.0), &cubic, &Element::with_order(4).unwrap(), &opts).unwrap();
    assert!(
        matches!(sol.solution.error, Some(Error::Step(_))),
        "{:?}",
        sol.solution.error
    );
    // Energy mode is supported (tests/all/forces_energy.rs); a (q0, q1) start is a typed "not
    // supported" error.
    let energy = SolveOptions {
        steps: Steps::Energy {
            step: 0.1,
            options: femvi::EnergyOptions::from_step(0.1),
        },
        ..SolveOptions::step(0.1)
    };
    let e = solve_forced(
        &damped_problem(1.0),
        &LinearForce::damping(1, 0.1),
        &Element::with_order(2).unwrap(),
        &energy,
    )
    .unwrap();
    assert!(e.solution.error.is_none() && e.solution.energy_stats.is_some());
    let mut p = damped_problem(1.0);
    p.start = Start::Positions {
        q0: vec![1.0],
        q1: vec![1.0],
    };
    let e = solve_forced(
        &p,
        &LinearForce::damping(1, 0.1),
        &Element::with_order(2).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap_err();
    assert!(e.to_string().contains("not supported"), "{e}");
}

/// The damped oscillator as a boundary value problem, x(0) = 1 and x(T) from the closed form:
/// residual ≤ 1e-12, nodal order 2s (max over the element ends) for s = 1…4, and the forced
/// Legendre transform p_0 against x'(0) = 0.
#[test]
fn damped_oscillator_bvp_order_2s() {
    use femvi::bvp::{line_guess, BoundaryValues, BvpOptions};
    use femvi::forces::solve_forced_bvp;
    let t_end = 4.0;
    let lag = models::harmonic(1.0, OMEGA0 * OMEGA0).unwrap();
    for s in 1..=4 {
        let element = Element::with_order(2 * s).unwrap();
        let counts: Vec<usize> = match s {
            1 => vec![40, 80, 160],
            2 => vec![10, 20, 40],
            3 => vec![5, 10, 20],
            _ => vec![4, 6, 8],
        };
        let (mut hs, mut err) = (vec![], vec![]);
        for &elements in &counts {
            let bv = BoundaryValues {
                t0: 0.0,
                q0: vec![1.0],
                t1: t_end,
                q1: vec![damped(t_end).0],
                elements,
            };
            let sol = solve_forced_bvp(
                &lag,
                &LinearForce::damping(1, C),
                &element,
                &bv,
                &line_guess(&bv, &element),
                BvpOptions::default(),
            )
            .unwrap();
            assert!(sol.residual_norm <= 1e-12, "s = {s}: residual {}", sol.residual_norm);
            let mut worst = sol.p[0].abs();
            for (k, t) in sol.times.iter().enumerate() {
                worst = worst
                    .max((sol.q[k] - damped(*t).0).abs())
                    .max((sol.p[k] - damped(*t).1).abs());
            }
            hs.push(t_end / elements as f64);
            err.push(worst);
        }
        let order = slope(&hs, &err);
        println!("BVP s = {s}: h {hs:?} errors {} order {order:.2}", e3(&err));
        assert!((order - 2.0 * s as f64).abs() < 0.35, "s = {s}: order {order}");
    }
    // A moving mesh is refused.
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![1.0],
        t1: 1.0,
        q1: vec![0.0],
        elements: 4,
    };
    let e = Element::with_order(2).unwrap();
    let opts = BvpOptions {
        moving_mesh: true,
        ..BvpOptions::default()
    };
    assert!(solve_forced_bvp(&lag, &LinearForce::damping(1, C), &e, &bv, &line_guess(&bv, &e), opts).is_err());
}

/// The Jacobian of the discrete forces (dual numbers) is the derivative of the discrete forces
/// by central differences, for a nonlinear force of t, q and v on a degree-3 element in 2-d.
#[test]
fn discrete_force_jacobian_is_the_derivative() {
    use femvi::forces::{element_forces, element_forces_jacobian};
    let coords = ["x".to_string(), "y".to_string()];
    let f = ExprForces::new(&["-x_dot*y^2 + sin(t*x)", "-0.5*y_dot^3 + x*x_dot"], &coords, &[]).unwrap();
    let element = Element::with_order(6).unwrap();
    let (t0, h, base) = (0.3, 0.2, [0.7, -0.4]);
    let incr: Vec<f64> = (0..8)
        .map(|i| if i < 2 { 0.0 } else { 0.05 * (i as f64).sin() })
        .collect();
    let w = incr.len();
    let (mut fd, mut jac) = (vec![0.0; w], vec![0.0; w * w]);
    element_forces_jacobian(&element, &f, t0, h, &base, &incr, &mut fd, &mut jac);
    let d = 1e-6;
    for b in 0..w {
        let (mut xp, mut xm) = (incr.clone(), incr.clone());
        xp[b] += d;
        xm[b] -= d;
        let (mut fp, mut fm) = (vec![0.0; w], vec![0.0; w]);
        element_forces(&element, &f, t0, h, &base, &xp, &mut fp);
        element_forces(&element, &f, t0, h, &base, &xm, &mut fm);
        for a in 0..w {
            let fdq = (fp[a] - fm[a]) / (2.0 * d);
            assert!(
                (fdq - jac[a * w + b]).abs() < 1e-7 * (1.0 + fdq.abs()),
                "J[{a}][{b}] = {} vs {fdq}",
                jac[a * w + b]
            );
        }
    }
}
