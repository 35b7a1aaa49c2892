//! Constrained boundary value problems (`femvi::constraints::solve_constrained_bvp`):
//! geodesics on the unit sphere against the great circle (closed form), the spherical
//! pendulum against the initial value run of the same element and against a converged
//! reference, and the typed errors on hostile input.

use femvi::bvp::{line_guess, BoundaryValues, BvpOptions};
use femvi::constraints::{
    solve_constrained, solve_constrained_bvp, solve_constrained_forced_bvp, ConstrainedBvpSolution, Constraints,
    Enforcement,
};
use femvi::diagnostics::fit_order;
use femvi::forces::LinearForce;
use femvi::{models, Element, Error, NodeFamily, Problem, QuadratureKind, Scalar, SolveOptions, Start, StepFailure};

const G: f64 = 9.81;

fn unit(v: [f64; 3]) -> [f64; 3] {
    let r = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    v.map(|x| x / r)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn bvp(q0: &[f64], q1: &[f64], t1: f64, elements: usize) -> BoundaryValues {
    BoundaryValues {
        t0: 0.0,
        q0: q0.to_vec(),
        t1,
        q1: q1.to_vec(),
        elements,
    }
}

/// Solves on the unit sphere (free particle if `g` = 0, else the spherical pendulum) from the
/// straight line.
fn on_sphere(g: f64, el: &Element, bv: &BoundaryValues) -> femvi::Result<ConstrainedBvpSolution> {
    let (lag, sphere) = models::chain(3, 1, 1.0, g, 1.0)?;
    solve_constrained_bvp(&lag, &sphere, el, bv, &line_guess(bv, el), BvpOptions::default())
}

/// Geodesics: q(t) = cos(ωt) a + sin(ωt) b, the great circle through q0 = a and q1 at uniform
/// speed ω = angle / T, and p = q̇. By the symmetries of the sphere (the reflection in the
/// circle's plane, and the reversal of time composed with the reflection swapping the ends)
/// the discrete nodes lie exactly on the circle at uniform angles; what converges is the
/// speed, so the nodal momenta are measured against ω(−sin(ωt) a + cos(ωt) b).
#[test]
fn geodesic_on_the_sphere_is_the_great_circle_with_momenta_of_order_2s() {
    let a = unit([1.0, 0.2, -0.3]);
    let q1 = unit([-0.2, 0.9, 0.4]);
    let c = dot(&a, &q1);
    let b = unit(std::array::from_fn(|i| q1[i] - c * a[i]));
    let t1 = 2.0;
    let w = c.acos() / t1;
    let meshes: [&[usize]; 4] = [&[8, 16, 32, 64], &[4, 8, 16, 32], &[2, 3, 4, 6, 8], &[2, 3, 4, 6]];
    for s in 1..=4 {
        let el = Element::with_order(2 * s).unwrap();
        let (mut hs, mut errs) = (vec![], vec![]);
        for &elements in meshes[s - 1] {
            let bv = bvp(&a, &q1, t1, elements);
            let sol = on_sphere(0.0, &el, &bv).unwrap();
            assert!(sol.solution.residual_norm <= 1e-12, "{}", sol.solution.residual_norm);
            assert!(sol.residual.iter().all(|r| *r <= 1e-13), "{:?}", sol.residual);
            assert!(sol.hidden_residual.iter().all(|r| *r <= 1e-13));
            let (mut qerr, mut perr) = (0.0f64, 0.0f64);
            for (k, t) in sol.solution.times.iter().enumerate() {
                let (sn, cs) = (w * t).sin_cos();
                let q: Vec<f64> = (0..3).map(|i| cs * a[i] + sn * b[i]).collect();
                let p: Vec<f64> = (0..3).map(|i| w * (-sn * a[i] + cs * b[i])).collect();
                qerr = qerr.max(max_diff(&sol.solution.q[3 * k..3 * k + 3], &q));
                perr = perr.max(max_diff(&sol.solution.p[3 * k..3 * k + 3], &p));
            }
            assert!(
                qerr <= 1e-14,
                "degree {s}, {elements} elements: nodes off the circle by {qerr:e}"
            );
            hs.push(t1 / elements as f64);
            errs.push(perr);
        }
        let order = fit_order(&hs, &errs);
        println!("geodesic, degree {s}: momentum errors {errs:?}, fitted order {order:.2}");
        assert!((order - 2.0 * s as f64).abs() < 0.3, "degree {s}: order {order}");
    }
}

/// The pendulum start used below: θ = 1 from the downward vertical, swinging sideways.
fn pendulum_start() -> Start {
    let th: f64 = 1.0;
    Start::Velocity {
        q: vec![th.sin(), 0.0, -th.cos()],
        v: vec![0.5 * th.cos(), 1.5, 0.5 * th.sin()],
    }
}

/// The boundary value solution from the ends of an initial value run is that run: same
/// interior nodes, same start momentum (same element, same enforcement), with degree 1 and
/// the trapezoid rule (RATTLE) too.
#[test]
fn spherical_pendulum_bvp_reproduces_the_initial_value_run() {
    let trapezoid = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let elements = [
        trapezoid,
        Element::with_order(2).unwrap(),
        Element::with_order(4).unwrap(),
        Element::with_order(6).unwrap(),
        Element::with_order(8).unwrap(),
        Element::galerkin(3, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(4)).unwrap(),
    ];
    let (steps, h) = (40, 0.025);
    for el in &elements {
        let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
        let problem = Problem::new(lag, pendulum_start(), 0.0, h * steps as f64);
        let ivp = solve_constrained(&problem, &sphere, el, &SolveOptions::step(h)).unwrap();
        let iq = &ivp.solution.q;
        assert_eq!(ivp.solution.steps, steps);
        let bv = bvp(&iq[..3], &iq[3 * steps..], h * steps as f64, steps);
        let sol = on_sphere(G, el, &bv).unwrap();
        let nodes = max_diff(&sol.solution.q, iq);
        let p0 = max_diff(&sol.solution.p[..3], &ivp.solution.p[..3]);
        let p = max_diff(&sol.solution.p, &ivp.solution.p);
        let lam = max_diff(&sol.multipliers, &ivp.multipliers);
        println!(
            "degree {}: nodes {nodes:.1e}, p0 {p0:.1e}, all p {p:.1e}, multipliers {lam:.1e}, residual {:.1e} (scaled {:.1e}), {} iterations",
            el.degree(),
            sol.solution.residual_norm,
            sol.solution.scaled_residual,
            sol.solution.newton_iterations
        );
        assert!(nodes <= 1e-10 && p0 <= 1e-10 && p <= 1e-10 && lam <= 1e-8);
        assert!(sol.solution.residual_norm <= 1e-12 && sol.max_residual <= 1e-13);
        // ‖r‖∞ / (‖J‖∞·max|x|): round-off level.
        assert!(
            sol.solution.scaled_residual <= 1e-15,
            "{}",
            sol.solution.scaled_residual
        );
        // Degree 1 has no interior multipliers: the node impulses ν_k ≈ h λ_k (to O(h)).
        if el.degree() > 1 {
            continue;
        }
        for (k, nu) in sol.impulses.iter().enumerate() {
            let lam = sol.multipliers[k + 1];
            assert!(
                (nu / h - lam).abs() <= 0.1 * lam.abs(),
                "node {}: {nu} vs h·{lam}",
                k + 1
            );
        }
    }
}

/// Nodal order 2s of the spherical pendulum BVP against a converged reference: a run of
/// degree 4 with a small step (a second method: the initial value problem) gives the end
/// point and the nodes.
#[test]
fn spherical_pendulum_bvp_converges_with_order_2s() {
    let (t1, fine) = (1.0, 480);
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let problem = Problem::new(lag, pendulum_start(), 0.0, t1);
    let reference = solve_constrained(
        &problem,
        &sphere,
        &Element::with_order(8).unwrap(),
        &SolveOptions::step(t1 / fine as f64),
    )
    .unwrap();
    let rq = &reference.solution.q;
    assert_eq!(reference.solution.steps, fine);
    let meshes: [&[usize]; 4] = [
        &[16, 32, 48, 80],
        &[6, 8, 12, 16],
        &[8, 10, 12, 16, 20],
        &[6, 8, 10, 12, 16],
    ];
    for s in 1..=4 {
        let el = Element::with_order(2 * s).unwrap();
        let (mut hs, mut errs) = (vec![], vec![]);
        for &elements in meshes[s - 1] {
            let bv = bvp(&rq[..3], &rq[3 * fine..], t1, elements);
            let sol = on_sphere(G, &el, &bv).unwrap();
            assert!(sol.solution.residual_norm <= 1e-12 && sol.max_residual <= 1e-13);
            let every = fine / elements;
            let err = (0..=elements)
                .map(|k| max_diff(&sol.solution.q[3 * k..3 * k + 3], &rq[3 * k * every..3 * k * every + 3]))
                .fold(0.0, f64::max);
            hs.push(t1 / elements as f64);
            errs.push(err);
        }
        let order = fit_order(&hs, &errs);
        println!("pendulum, degree {s}: nodal errors {errs:?}, fitted order {order:.2}");
        assert!((order - 2.0 * s as f64).abs() < 0.3, "degree {s}: order {order}");
    }
}

/// No constraints: the unconstrained boundary value solver's solution (a second, independent
/// assembly), also with a single element (degree 1: nothing to solve).
struct Free;

impl Constraints for Free {
    fn dim(&self) -> usize {
        3
    }
    fn count(&self) -> usize {
        0
    }
    fn value<D: Scalar>(&self, _q: &[D], _out: &mut [D]) {}
}

#[test]
fn without_constraints_it_is_the_unconstrained_solution() {
    let (lag, _) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    for (order, elements) in [(2, 1), (4, 1), (2, 10), (6, 10)] {
        let el = Element::with_order(order).unwrap();
        let bv = bvp(&[0.6, 0.0, -0.8], &[0.0, 0.8, -0.6], 1.0, elements);
        let guess = line_guess(&bv, &el);
        let plain = femvi::bvp::solve(&lag, &el, &bv, &guess, BvpOptions::default()).unwrap();
        let sol = solve_constrained_bvp(&lag, &Free, &el, &bv, &guess, BvpOptions::default()).unwrap();
        let (nodes, p) = (
            max_diff(&sol.solution.nodes, &plain.nodes),
            max_diff(&sol.solution.p, &plain.p),
        );
        assert!(
            nodes <= 1e-14 && p <= 1e-13,
            "order {order}, {elements} elements: {nodes:e}, {p:e}"
        );
        assert!((sol.solution.action - plain.action).abs() <= 1e-14 * plain.action.abs());
        assert!(sol.multipliers.is_empty() && sol.impulses.is_empty());
    }
    // The initial value run without constraints too (it panicked in the multipliers).
    let problem = Problem::new(lag, pendulum_start(), 0.0, 0.5);
    let run = solve_constrained(
        &problem,
        &Free,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.1),
    )
    .unwrap();
    assert!(run.solution.error.is_none() && run.multipliers.is_empty());
}

/// With forces: gravity as a force on the free particle is gravity in the Lagrangian (the
/// discrete force of a potential's gradient is the gradient of its discrete potential term),
/// and damping forward in time is anti-damping backward (the elements are symmetric, so the
/// discrete equations map onto each other under t → T − t).
#[test]
fn forced_constrained_bvp_meets_two_identities() {
    let (free, sphere) = models::chain(3, 1, 1.0, 0.0, 1.0).unwrap();
    let (a, b) = ([0.6, 0.0, -0.8], [0.0, 0.6, -0.8]);
    let opts = BvpOptions::default();
    for order in [2, 4, 6] {
        let el = Element::with_order(order).unwrap();
        let bv = bvp(&a, &b, 0.7, 12);
        let guess = line_guess(&bv, &el);
        let pendulum = on_sphere(G, &el, &bv).unwrap();
        let gravity = LinearForce::drive(vec![0.0, 0.0, -G], 0.0);
        let weak = Enforcement::Weak;
        let forced = solve_constrained_forced_bvp(&free, &gravity, &sphere, &el, &bv, &guess, opts, weak).unwrap();
        let (dq, dp) = (
            max_diff(&forced.solution.nodes, &pendulum.solution.nodes),
            max_diff(&forced.solution.p, &pendulum.solution.p),
        );
        assert!(dq <= 1e-13 && dp <= 1e-12, "order {order}: {dq:e} {dp:e}");
        let (lag, _) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
        let damped = LinearForce::damping(3, 0.4);
        let anti = LinearForce::damping(3, -0.4);
        let fwd = solve_constrained_forced_bvp(&lag, &damped, &sphere, &el, &bv, &guess, opts, weak).unwrap();
        let back_bv = bvp(&b, &a, 0.7, 12);
        let back = solve_constrained_forced_bvp(
            &lag,
            &anti,
            &sphere,
            &el,
            &back_bv,
            &line_guess(&back_bv, &el),
            opts,
            weak,
        )
        .unwrap();
        for sol in [&fwd, &back] {
            assert!(sol.solution.residual_norm <= 1e-12 && sol.max_residual <= 1e-13);
        }
        let reversed: Vec<f64> = back.solution.q.chunks_exact(3).rev().flatten().copied().collect();
        let moved = max_diff(&fwd.solution.q, &pendulum.solution.q);
        let dr = max_diff(&fwd.solution.q, &reversed);
        println!(
            "order {order}: gravity as a force {dq:.1e}, reversal {dr:.1e}, damping moved the nodes by {moved:.1e}"
        );
        assert!(dr <= 1e-13 && moved > 1e-3, "order {order}: {dr:e}, {moved:e}");
        // p at t_0 forward is −p at T backward.
        let p_end = &back.solution.p[back.solution.p.len() - 3..];
        assert!(max_diff(&fwd.solution.p[..3], &p_end.iter().map(|x| -x).collect::<Vec<_>>()) <= 1e-12);
    }
}

/// Constraints for the hostile cases: `Count(k)` repeats the sphere k times; `Squared` is
/// (|q|² − 1)², whose Jacobian vanishes on the sphere; `Root` is the sphere plus 0·√x, NaN for
/// x < 0.
enum Odd {
    Count(usize),
    Squared,
    Root,
}

impl Constraints for Odd {
    fn dim(&self) -> usize {
        3
    }
    fn count(&self) -> usize {
        match self {
            Odd::Count(k) => *k,
            Odd::Squared | Odd::Root => 1,
        }
    }
    fn value<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        let r = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - 1.0;
        match self {
            Odd::Count(_) => out.iter_mut().for_each(|o| *o = r),
            Odd::Squared => out[0] = r * r,
            Odd::Root => out[0] = r + q[0].sqrt() * 0.0,
        }
    }
}

#[test]
fn hostile_input_gives_typed_errors() {
    let el = Element::with_order(4).unwrap();
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0).unwrap();
    let (a, b) = ([0.6, 0.0, -0.8], [0.0, 0.6, -0.8]);
    let opts = BvpOptions::default();
    let solve = |con: &dyn Fn(&BoundaryValues, &[f64]) -> femvi::Result<ConstrainedBvpSolution>,
                 bv: &BoundaryValues| { con(bv, &line_guess(bv, &el)) };
    let sph = |bv: &BoundaryValues, guess: &[f64]| solve_constrained_bvp(&lag, &sphere, &el, bv, guess, opts);
    // Ends off the manifold: the residual is named.
    let err = solve(&sph, &bvp(&[0.6, 0.0, -0.81], &b, 1.0, 4)).unwrap_err();
    assert!(
        matches!(err, Error::Invalid { .. }) && err.to_string().contains("1.610e-2"),
        "{err}"
    );
    let err = solve(&sph, &bvp(&a, &[0.0, 0.0, 0.0], 1.0, 4)).unwrap_err();
    assert!(
        err.to_string().contains("boundary q1") && err.to_string().contains("1.000e0"),
        "{err}"
    );
    // NaN in the ends, in the guess; wrong lengths.
    assert!(matches!(
        solve(&sph, &bvp(&[f64::NAN, 0.0, -0.8], &b, 1.0, 4)),
        Err(Error::Invalid { .. })
    ));
    let bv = bvp(&a, &b, 1.0, 4);
    let mut guess = line_guess(&bv, &el);
    guess[5] = f64::NAN;
    assert!(matches!(sph(&bv, &guess), Err(Error::Invalid { .. })));
    assert!(matches!(sph(&bv, &guess[1..]), Err(Error::Dimension { .. })));
    assert!(matches!(
        solve(&sph, &bvp(&a, &b[..2], 1.0, 4)),
        Err(Error::Dimension { .. })
    ));
    // m ≥ n, and a dimension that disagrees.
    for k in [3, 4] {
        let r = solve_constrained_bvp(&lag, &Odd::Count(k), &el, &bv, &line_guess(&bv, &el), opts);
        assert!(matches!(r, Err(Error::Invalid { .. })), "{r:?}");
    }
    let (lag2, _) = models::chain(2, 1, 1.0, G, 1.0).unwrap();
    let r = solve_constrained_bvp(
        &lag2,
        &sphere,
        &el,
        &bvp(&[1.0, 0.0], &[0.0, -1.0], 1.0, 4),
        &[0.0; 18],
        opts,
    );
    assert!(matches!(r, Err(Error::Dimension { .. })), "{r:?}");
    // Dependent constraints (G of rank 1 for 2 rows), and G = 0 on the manifold: singular at
    // the start node.
    for con in [Odd::Count(2), Odd::Squared] {
        let r = solve_constrained_bvp(&lag, &con, &el, &bv, &line_guess(&bv, &el), opts);
        assert!(matches!(r, Err(Error::SingularConstraints { step: 0, .. })), "{r:?}");
    }
    // Antipodal ends from the straight line: its middle node is the origin, where G = 0.
    let r = solve(&sph, &bvp(&a, &[-0.6, 0.0, 0.8], 1.0, 4));
    assert!(matches!(r, Err(Error::SingularConstraints { step: 2, .. })), "{r:?}");
    // Constraints that are NaN at the guess's interior nodes.
    let right = bvp(&a, &[0.48, 0.6, -0.64], 1.0, 4);
    let mut guess = line_guess(&right, &el);
    let last = guess.len() - 3;
    guess[3..last].chunks_exact_mut(3).for_each(|q| q[0] = -0.6);
    let r = solve_constrained_bvp(&lag, &Odd::Root, &el, &right, &guess, opts);
    assert!(
        matches!(&r, Err(Error::Step(e)) if e.failure == StepFailure::NonFinite),
        "{r:?}"
    );
    // The iteration cap; a moving mesh; far too many elements (refused before allocating).
    let capped = BvpOptions {
        max_iterations: 1,
        ..opts
    };
    let r = solve_constrained_bvp(&lag, &sphere, &el, &bv, &line_guess(&bv, &el), capped);
    assert!(
        matches!(&r, Err(Error::Step(e)) if e.failure == StepFailure::NotConverged && e.residual > 0.0),
        "{r:?}"
    );
    let moving = BvpOptions {
        moving_mesh: true,
        ..opts
    };
    let r = solve_constrained_bvp(&lag, &sphere, &el, &bv, &line_guess(&bv, &el), moving);
    assert!(matches!(r, Err(Error::Invalid { .. })), "{r:?}");
    for elements in [usize::MAX / 2, 1 << 26] {
        let r = solve_constrained_bvp(&lag, &sphere, &el, &bvp(&a, &b, 1.0, elements), &[], opts);
        assert!(matches!(r, Err(Error::Invalid { .. })), "{r:?}");
    }
}
