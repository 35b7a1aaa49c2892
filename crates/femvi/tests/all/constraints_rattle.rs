//! Issue 33: constrained runs honour `SolverOptions::method`. Degree 1 with the trapezoid rule
//! on a mechanical Lagrangian without forces takes RATTLE steps solved on the multipliers
//! (`Method::Auto`, `Explicit`, `FixedPoint`); `Method::Newton` keeps the dense Newton step on
//! (Q¹, λ̂); Explicit where RATTLE does not fit is an input error (FixedPoint takes the
//! SHAKE-style steps of other elements, `constraints_shake.rs`).
//!
//! References: the dense Newton path on the same problem (node by node, one step at a time and
//! over 10⁴ steps), the hand-written RATTLE loop of `common::rattle`, and the bits the dense
//! path gave before this change (`golden/terms.txt`, "constrained: rattle", as of its commit
//! 2170412).

use crate::common::rattle::rattle;
use femvi::chaos::{constrained_indicators, ChaosOptions};
use femvi::constraints::{
    manifold_symplecticity, solve_constrained, solve_constrained_forced, solve_constrained_with, ConstrainedSolution,
    Enforcement, ExprConstraints,
};
use femvi::expr::ExprLagrangian;
use femvi::forces::LinearForce;
use femvi::{models, Element, Error, Method, NodeFamily, Problem, QuadratureKind, SolveOptions, Start};

const G: f64 = 9.81;

fn trapezoid() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap()
}

pub(crate) fn options(h: f64, method: Method) -> SolveOptions {
    let mut o = SolveOptions::step(h);
    o.solver.method = method;
    o
}

/// Largest difference of q, p, v and the node multipliers over all kept nodes.
pub(crate) fn max_difference(a: &ConstrainedSolution, b: &ConstrainedSolution) -> f64 {
    let (sa, sb) = (&a.solution, &b.solution);
    assert_eq!(sa.q.len(), sb.q.len());
    let diff = |x: &[f64], y: &[f64]| x.iter().zip(y).fold(0.0f64, |m, (u, w)| m.max((u - w).abs()));
    diff(&sa.q, &sb.q)
        .max(diff(&sa.p, &sb.p))
        .max(diff(&sa.v, &sb.v))
        .max(diff(&a.multipliers, &b.multipliers))
}

pub(crate) fn sphere_problem(
    t_end: f64,
) -> (
    Problem<impl femvi::Lagrangian + Clone>,
    impl femvi::constraints::Constraints,
) {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.3, 1.5, 0.225],
    };
    (Problem::new(lag, start, 0.0, t_end), sphere)
}

/// The planar double pendulum in Cartesian coordinates (n = 4, two rod constraints).
pub(crate) fn double_pendulum(
    t_end: f64,
) -> (
    Problem<impl femvi::Lagrangian + Clone>,
    impl femvi::constraints::Constraints,
) {
    let (lag, rods) = models::chain(2, 2, 1.0, G, 1.0).unwrap();
    let (a, c): (f64, f64) = (0.5, 1.2);
    let start = Start::Velocity {
        q: vec![a.sin(), -a.cos(), a.sin() + c.sin(), -a.cos() - c.cos()],
        v: vec![0.4, 0.3, -1.0, 0.2],
    };
    (Problem::new(lag, start, 0.0, t_end), rods)
}

/// One step from every 50th node of the dense Newton run, by both paths: the step maps agree
/// to round-off (a per-step comparison, free of the shear that amplifies differences along a
/// trajectory).
fn one_steps_agree<L: femvi::Lagrangian + Clone + Sync, C: femvi::constraints::Constraints + Sync>(
    problem: &Problem<L>,
    con: &C,
    newton: &ConstrainedSolution,
    h: f64,
) -> f64 {
    let (s, n) = (&newton.solution, newton.solution.n);
    let mut worst = 0.0f64;
    for k in (0..s.len() - 1).step_by(50) {
        let start = Start::Momentum {
            q: s.q[k * n..(k + 1) * n].to_vec(),
            p: s.p[k * n..(k + 1) * n].to_vec(),
        };
        let one = Problem::new(problem.lagrangian.clone(), start, s.t[k], s.t[k] + h);
        let fast = solve_constrained(&one, con, &trapezoid(), &options(h, Method::Explicit)).unwrap();
        let dense = solve_constrained(&one, con, &trapezoid(), &options(h, Method::Newton)).unwrap();
        assert_eq!((fast.solution.steps, dense.solution.steps), (1, 1));
        worst = worst.max(max_difference(&fast, &dense));
    }
    worst
}

#[test]
fn rattle_steps_agree_with_dense_newton_on_the_spherical_pendulum() {
    let h = 0.0078125;
    let steps = 10_000;
    let (problem, sphere) = sphere_problem(h * steps as f64);
    let newton = solve_constrained(&problem, &sphere, &trapezoid(), &options(h, Method::Newton)).unwrap();
    let per_step = one_steps_agree(&problem, &sphere, &newton, h);
    for method in [Method::Auto, Method::Explicit, Method::FixedPoint] {
        let fast = solve_constrained(&problem, &sphere, &trapezoid(), &options(h, method)).unwrap();
        assert!(fast.solution.error.is_none() && fast.solution.steps == steps);
        let dev = max_difference(&fast, &newton);
        println!(
            "{method:?}: max node difference to dense Newton over {steps} steps {dev:.2e} (one step {per_step:.2e}); \
             iterations per step {} against {}; max |g| {:.1e}",
            fast.solution.mean_iterations, newton.solution.mean_iterations, fast.max_residual
        );
        assert!(dev <= 1e-12, "{method:?}: {dev:e}");
        assert!(fast.max_residual <= 1e-15, "{:e}", fast.max_residual);
        assert!(fast.hidden_residual.iter().all(|&r| r <= 1e-13));
        // Different solvers: the iteration counts tell them apart.
        assert_ne!(fast.solution.mean_iterations, newton.solution.mean_iterations);
    }
    assert!(per_step <= 1e-14, "one step: {per_step:e}");
}

#[test]
fn rattle_steps_agree_with_dense_newton_on_the_double_pendulum() {
    let h = 0.005;
    let steps = 10_000;
    let (problem, rods) = double_pendulum(h * steps as f64);
    let newton = solve_constrained(&problem, &rods, &trapezoid(), &options(h, Method::Newton)).unwrap();
    let fast = solve_constrained(&problem, &rods, &trapezoid(), &options(h, Method::Auto)).unwrap();
    assert!(fast.solution.error.is_none() && fast.solution.steps == steps);
    assert_eq!(fast.m, 2);
    let per_step = one_steps_agree(&problem, &rods, &newton, h);
    // The double pendulum is chaotic from this start: differences of round-off grow along the
    // trajectory, so the whole run is compared over its first 2000 steps and step by step.
    let n = 4;
    let first = 2000;
    let diff = fast.solution.q[..first * n]
        .iter()
        .zip(&newton.solution.q[..first * n])
        .chain(fast.solution.p[..first * n].iter().zip(&newton.solution.p[..first * n]))
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    println!(
        "double pendulum: one step {per_step:.2e}, first {first} nodes {diff:.2e}, whole run {:.2e}; \
         iterations {} against {}",
        max_difference(&fast, &newton),
        fast.solution.mean_iterations,
        newton.solution.mean_iterations
    );
    assert!(per_step <= 1e-13, "{per_step:e}");
    assert!(diff <= 1e-12, "{diff:e}");
    assert!(fast.max_residual <= 1e-14, "{:e}", fast.max_residual);
    // The energy of RATTLE stays bounded (no drift) over the whole run.
    let e = &fast.solution.energy;
    let spread = e.iter().fold(0.0f64, |m, x| m.max((x - e[0]).abs()));
    assert!(spread < 1e-2 * e[0].abs().max(1.0), "{spread:e}");
}

type Node = ([f64; 3], [f64; 3]);

/// The RATTLE map of the spherical pendulum (unit sphere, L = ½|v|² − g z) in double-double
/// arithmetic (`twofloat`): the multiplier from the position constraint's quadratic (smaller
/// root, without cancellation), the projection a dot product; nodes rounded to f64 for the
/// comparison only.
fn rattle_double_double(q0: [f64; 3], p0: [f64; 3], h: f64, steps: usize) -> Vec<Node> {
    use twofloat::TwoFloat;
    let t = TwoFloat::from;
    let dot = |a: &[TwoFloat; 3], b: &[TwoFloat; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (mut q, mut p) = (q0.map(t), p0.map(t));
    let (h, half, grad_v) = (t(h), t(0.5), [t(0.0), t(0.0), t(G)]);
    let mut out = vec![(q0, p0)];
    for _ in 0..steps {
        let e: [TwoFloat; 3] = std::array::from_fn(|i| h * (p[i] - half * h * grad_v[i]));
        let (qq, qe, ee) = (dot(&q, &q), dot(&q, &e), dot(&e, &e));
        let (b, c0) = (qq + qe, (qq - t(1.0)) + t(2.0) * qe + ee);
        let c = c0 / (b + (b * b - qq * c0).sqrt());
        let d: [TwoFloat; 3] = std::array::from_fn(|i| e[i] - c * q[i]);
        let q1: [TwoFloat; 3] = std::array::from_fn(|i| q[i] + d[i]);
        let pt: [TwoFloat; 3] = std::array::from_fn(|i| d[i] / h - half * h * grad_v[i]);
        let mu = dot(&q1, &pt) / dot(&q1, &q1);
        p = std::array::from_fn(|i| pt[i] - mu * q1[i]);
        q = q1;
        out.push((q.map(f64::from), p.map(f64::from)));
    }
    out
}

fn node_difference(a: &[Node], b: &[Node]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x.0[c] - y.0[c]).abs().max((x.1[c] - y.1[c]).abs())))
        .fold(0.0, f64::max)
}

/// Against the hand-written RATTLE loop (`common::rattle`, double precision) and the RATTLE
/// map in double-double arithmetic: the RATTLE steps sum q and p with compensation, so they
/// follow the exact map to a few ulps over 10⁴ steps, where the double-precision loop (and the
/// dense path, ~7e-14 in `rattle_exact.rs`) drift by ~1e-13 (round-off of p turned into phase
/// by the shear); the loop and femvi differ by that loop's own drift.
#[test]
fn rattle_steps_follow_the_hand_written_rattle_loop() {
    let (h, steps) = (2f64.powi(-10), 10_000);
    for theta in [0.7f64, 1.0, 1.3] {
        let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
        let start = Start::Velocity {
            q: vec![theta.sin(), 0.0, -theta.cos()],
            v: vec![0.3 * theta.cos(), 2.0 * theta.sin(), 0.3 * theta.sin()],
        };
        let problem = Problem::new(lag, start, 0.0, h * steps as f64);
        let run = solve_constrained(&problem, &sphere, &trapezoid(), &options(h, Method::Explicit)).unwrap();
        let s = &run.solution;
        let femvi: Vec<Node> = (0..=steps)
            .map(|k| {
                (
                    std::array::from_fn(|c| s.q[3 * k + c]),
                    std::array::from_fn(|c| s.p[3 * k + c]),
                )
            })
            .collect();
        let (q0, p0) = femvi[0];
        let hand = rattle(q0, p0, h, G, steps);
        let exact = rattle_double_double(q0, p0, h, steps);
        let (to_hand, to_exact, hand_exact) = (
            node_difference(&femvi, &hand),
            node_difference(&femvi, &exact),
            node_difference(&hand, &exact),
        );
        // The first 100 steps, before round-off has grown: the same map.
        let early = node_difference(&femvi[..100], &hand[..100]);
        println!(
            "theta {theta}: femvi against the hand loop {to_hand:.2e} (first 100 steps {early:.2e}), \
             against double-double {to_exact:.2e}; hand loop against double-double {hand_exact:.2e}"
        );
        assert!(early <= 4e-15, "{early:e}");
        assert!(to_exact <= 1e-14, "{to_exact:e}");
        assert!(to_hand <= hand_exact + 1e-14, "{to_hand:e} against {hand_exact:e}");
    }
}

/// The dense Newton path is still taken under `Method::Newton`: the final node and the mean
/// iterations of the golden run "constrained: rattle (degree 1 trapezoid)" (tilted start,
/// h = 2⁻⁷, 512 steps, `Ends`) as the dense path gave them before RATTLE steps existed.
#[test]
fn method_newton_keeps_the_dense_newton_bits() {
    let (problem, sphere) = sphere_problem(4.0);
    let run = solve_constrained_with(
        &problem,
        &sphere,
        &trapezoid(),
        &options(0.0078125, Method::Newton),
        Enforcement::Ends,
    )
    .unwrap();
    let s = &run.solution;
    let i = s.len() - 1;
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(s.steps, 512);
    assert_eq!(
        bits(&s.q[3 * i..3 * i + 3]),
        [0x3fd152dc95d41258, 0x3fdcbab827a22d0c, 0xbfeb404f28f4a48b]
    );
    assert_eq!(
        bits(&s.p[3 * i..3 * i + 3]),
        [0xbff2c7628f680a40, 0x3ff60e66d0e1d4d0, 0x3fd6a135bd4c431a]
    );
    assert_eq!(s.mean_iterations.to_bits(), 0x4007f00000000000);
    assert_eq!(run.multipliers[i].to_bits(), 0x4017839c1a908632);
}

fn invalid_method(e: Error) -> String {
    match e {
        Error::Invalid { .. } => e.to_string(),
        other => panic!("expected an input error, got {other:?}"),
    }
}

#[test]
fn explicit_methods_where_rattle_does_not_fit_are_input_errors() {
    let (problem, sphere) = sphere_problem(0.1);
    // Degree 2: the RATTLE step does not fit Explicit; Auto and FixedPoint take the
    // SHAKE-style fixed point (`constraints_shake.rs`), Newton dense Newton.
    let degree2 = Element::with_order(4).unwrap();
    let e = solve_constrained(&problem, &sphere, &degree2, &options(0.01, Method::Explicit)).unwrap_err();
    let text = invalid_method(e);
    assert!(text.contains("degree 1 with the trapezoid rule"), "{text}");
    for method in [Method::Auto, Method::FixedPoint, Method::Newton] {
        let run = solve_constrained(&problem, &sphere, &degree2, &options(0.01, method)).unwrap();
        assert!(run.solution.error.is_none());
    }
    // Constraints enforced at the interior nodes: no fixed-point form.
    let degree3 = Element::with_order(6).unwrap();
    let e = solve_constrained_with(
        &problem,
        &sphere,
        &degree3,
        &options(0.01, Method::FixedPoint),
        Enforcement::Nodes,
    )
    .unwrap_err();
    assert!(invalid_method(e).contains("not at the nodes"));
    // Gauss quadrature at degree 1 (the midpoint rule): not RATTLE either.
    let midpoint = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Midpoint).unwrap();
    let e = solve_constrained(&problem, &sphere, &midpoint, &options(0.01, Method::Explicit)).unwrap_err();
    assert!(invalid_method(e).contains("trapezoid"));
    // A Lagrangian that is not mechanical (a magnetic term A·v).
    let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let magnetic = ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2 + z_dot^2) + 0.3*(x*y_dot - y*x_dot) - 9.81*z",
        &xyz,
        &[],
    )
    .unwrap();
    let unit = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[]).unwrap();
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.0, 1.0, 0.0],
    };
    let mag = Problem::new(magnetic, start, 0.0, 0.1);
    let e = solve_constrained(&mag, &unit, &trapezoid(), &options(0.01, Method::FixedPoint)).unwrap_err();
    assert!(invalid_method(e).contains("mechanical"));
    let run = solve_constrained(&mag, &unit, &trapezoid(), &options(0.01, Method::Auto)).unwrap();
    assert!(run.solution.error.is_none());
    // Forces: dense Newton under Auto, an input error under Explicit.
    let damping = LinearForce::damping(3, 0.4);
    let forced = |method| {
        solve_constrained_forced(
            &problem,
            &damping,
            &sphere,
            &trapezoid(),
            &options(0.01, method),
            Enforcement::Weak,
        )
    };
    let e = forced(Method::Explicit).unwrap_err();
    assert!(invalid_method(e).contains("forces"));
    let run = forced(Method::Auto).unwrap();
    assert!(run.constrained.solution.error.is_none());
}

/// The tangent map after a RATTLE step (the step system evaluated once at the solution): the
/// symplecticity defect on the manifold and the chaos indicators agree with the dense path's.
#[test]
fn tangent_maps_after_rattle_steps_match_dense_newton() {
    let (problem, sphere) = sphere_problem(2.0);
    let h = 0.01;
    let fast = manifold_symplecticity(
        &problem,
        &sphere,
        &trapezoid(),
        &options(h, Method::Auto),
        Enforcement::Weak,
    )
    .unwrap();
    let dense = manifold_symplecticity(
        &problem,
        &sphere,
        &trapezoid(),
        &options(h, Method::Newton),
        Enforcement::Weak,
    )
    .unwrap();
    println!(
        "symplecticity defect: RATTLE steps {:.2e}, dense Newton {:.2e}",
        fast.max_defect, dense.max_defect
    );
    assert_eq!(fast.steps, 200);
    assert!(fast.max_defect < 1e-12, "{:e}", fast.max_defect);
    assert_ne!(fast.run.solution.mean_iterations, dense.run.solution.mean_iterations);
    let chaos = |method| {
        constrained_indicators(
            &problem,
            &sphere,
            &trapezoid(),
            &options(h, method),
            Enforcement::Weak,
            &ChaosOptions::default(),
        )
        .unwrap()
    };
    let (a, b) = (chaos(Method::Auto), chaos(Method::Newton));
    assert!(a.error.is_none() && b.error.is_none());
    let (la, lb) = (&a.last, &b.last);
    println!(
        "MEGNO {} against {}, FLI {} against {}",
        la.megno, lb.megno, la.fli, lb.fli
    );
    assert!((la.megno - lb.megno).abs() <= 1e-9 * lb.megno.abs().max(1.0));
    assert!((la.fli - lb.fli).abs() <= 1e-9 * lb.fli.abs().max(1.0));
}
