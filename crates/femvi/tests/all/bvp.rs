//! Two-point boundary value problems by the discrete variational principle: order 2s against
//! the closed form of the harmonic oscillator, consistency with the initial value integrator,
//! two pendulum solutions from two guesses, a problem with no solution, and the moving mesh
//! (discrete energy conserved, action stationary in the times, folding reported).

use crate::common::{fit_order, Errs};
use femvi::bvp::{line_guess, node_times, solve, BoundaryValues, BvpOptions};
use femvi::{
    models, Element, Integrator, Mechanical, NodeFamily, Potential, QuadratureKind, Scalar, SolverOptions, Start,
    StepFailure, TimeGrid,
};

fn gauss(s: usize) -> Element {
    Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
}

#[test]
fn harmonic_oscillator_nodal_order_2s() {
    // x'' = −x, x(0) = 1, x(1.5) = 0.3 (1.5 < π: no conjugate point). x = cos t + B sin t.
    let lag = models::harmonic(1.0, 1.0).unwrap();
    let (t1, x1) = (1.5f64, 0.3f64);
    let b = (x1 - t1.cos()) / t1.sin();
    for (s, counts) in [(1usize, [10, 20, 40, 80]), (2, [4, 8, 16, 32]), (3, [2, 4, 8, 16])] {
        let el = gauss(s);
        let (mut hs, mut errs) = (vec![], vec![]);
        for n in counts {
            let bv = BoundaryValues {
                t0: 0.0,
                q0: vec![1.0],
                t1,
                q1: vec![x1],
                elements: n,
            };
            let sol = solve(&lag, &el, &bv, &line_guess(&bv, &el), BvpOptions::default()).unwrap();
            assert!(sol.residual_norm <= 1e-12, "{}", sol.residual_norm);
            let err = sol
                .times
                .iter()
                .zip(&sol.q)
                .map(|(t, q)| (q - (t.cos() + b * t.sin())).abs())
                .fold(0.0, f64::max);
            hs.push(bv.step());
            errs.push(err);
        }
        let order = fit_order(&hs, &errs);
        eprintln!("bvp s={s}: errors {} order {order:.3}", Errs(&errs));
        assert!((order - 2.0 * s as f64).abs() < 0.3, "s={s}: order {order}");
    }
}

#[test]
fn boundary_solution_reproduced_by_the_initial_value_integrator() {
    let lag = models::kepler(1.0).unwrap();
    for s in [1usize, 2, 3] {
        let el = gauss(s);
        let bv = BoundaryValues {
            t0: 0.0,
            q0: vec![1.0, 0.0],
            t1: 2.0,
            q1: vec![-0.2, 0.9],
            elements: 40,
        };
        let sol = solve(&lag, &el, &bv, &line_guess(&bv, &el), BvpOptions::default()).unwrap();
        let p0 = sol.p[..2].to_vec();
        let grid = TimeGrid::uniform(0.0, bv.step(), 2.0).unwrap();
        let opts = SolverOptions {
            tolerance: 1e-15,
            ..Default::default()
        };
        let mut it = Integrator::new(
            &lag,
            &el,
            grid,
            Start::Momentum {
                q: bv.q0.clone(),
                p: p0,
            },
            opts,
        )
        .unwrap();
        while it.step().unwrap() {}
        let dq = it
            .node()
            .q
            .iter()
            .zip(&bv.q1)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let dp = it
            .node()
            .p
            .iter()
            .zip(&sol.p[80..])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "s={s}: IVP from the BVP's p0 misses q1 by {dq:.2e} (p by {dp:.2e}), {} Newton iterations",
            sol.newton_iterations
        );
        assert!(dq < 1e-11 && dp < 1e-10, "s={s}: {dq:e} {dp:e}");
    }
}

#[test]
fn pendulum_has_two_solutions_from_two_guesses() {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let el = gauss(2);
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![0.1],
        t1: 5.0,
        q1: vec![0.1],
        elements: 100,
    };
    let straight = solve(&lag, &el, &bv, &line_guess(&bv, &el), BvpOptions::default()).unwrap();
    let swing: Vec<f64> = node_times(&bv, &el)
        .iter()
        .map(|t| 0.1 + 2.5 * (std::f64::consts::PI * t / 5.0).sin())
        .collect();
    let big = solve(&lag, &el, &bv, &swing, BvpOptions::default()).unwrap();
    eprintln!(
        "pendulum: action {:.12} (residual {:.1e}, {} iterations) and {:.12} (residual {:.1e}, {} iterations)",
        straight.action,
        straight.residual_norm,
        straight.newton_iterations,
        big.action,
        big.residual_norm,
        big.newton_iterations
    );
    assert!(straight.residual_norm <= 1e-12 && big.residual_norm <= 1e-12);
    let gap = straight
        .q
        .iter()
        .zip(&big.q)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(gap > 1.0, "two distinct solutions: max difference {gap}");
    assert!((straight.action - big.action).abs() > 1e-3);
}

/// The Bratu problem q'' = −λ e^q: L = ½v² − λ e^q has no solution with q(0) = q(1) = 0 for
/// λ > 3.51.
struct Bratu(f64);
impl Potential for Bratu {
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0].exp() * self.0
    }
}

#[test]
fn no_solution_gives_the_typed_error() {
    let el = gauss(2);
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![0.0],
        t1: 1.0,
        q1: vec![0.0],
        elements: 50,
    };
    // Below the fold it solves (a check that the problem is set up right).
    let ok = solve(
        &Mechanical::unit_mass(Bratu(2.0)),
        &el,
        &bv,
        &line_guess(&bv, &el),
        BvpOptions::default(),
    )
    .unwrap();
    assert!(ok.residual_norm < 1e-12);
    let err = solve(
        &Mechanical::unit_mass(Bratu(5.0)),
        &el,
        &bv,
        &line_guess(&bv, &el),
        BvpOptions::default(),
    )
    .unwrap_err();
    let femvi::Error::Step(e) = err else { panic!("{err}") };
    eprintln!("Bratu λ = 5: {e}");
    assert!(matches!(
        e.failure,
        StepFailure::Stalled | StepFailure::NotConverged | StepFailure::NonFinite | StepFailure::Singular
    ));
    assert!(e.residual > 0.0);
    // Bad data is rejected.
    let bad = BoundaryValues {
        elements: 0,
        ..bv.clone()
    };
    assert!(solve(
        &Mechanical::unit_mass(Bratu(2.0)),
        &el,
        &bad,
        &[0.0],
        BvpOptions::default()
    )
    .is_err());
}

/// The discrete action of a solved mesh with the node times `times` and all nodal values
/// `nodes`, recomputed element by element through the public element API; with `energies`,
/// also each element's discrete energies (E⁻, E⁺).
fn action_and_energies<L: femvi::Lagrangian>(
    lag: &L,
    el: &Element,
    times: &[f64],
    nodes: &[f64],
) -> (f64, Vec<(f64, f64)>) {
    let s = el.degree();
    let mut work = femvi::ElementWork::new(el, 1);
    let mut grad = vec![0.0; s + 1];
    let (mut action, mut energies) = (0.0, vec![]);
    for k in 0..times.len() - 1 {
        let base = [nodes[k * s]];
        let incr: Vec<f64> = (0..=s).map(|j| nodes[k * s + j] - base[0]).collect();
        let h = times[k + 1] - times[k];
        action += el.gradient_in_place(lag, times[k], h, &base, &incr, true, &mut work, &mut grad);
        energies.push(el.energies(h, &work));
    }
    (action, energies)
}

/// T. D. Lee's discrete mechanics: with the interior element end times unknown, the solution
/// conserves the discrete energy from element to element (E⁺ of element k − 1 equals E⁻ of
/// element k, recomputed here from the public element API), the mesh really moves, and the
/// action is stationary with respect to each time, which it is not on the uniform mesh.
#[test]
fn moving_mesh_conserves_the_discrete_energy_where_the_action_is_stationary_in_time() {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![1.0],
        t1: 3.0,
        q1: vec![-0.5],
        elements: 20,
    };
    for el in [
        Element::midpoint(),
        Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap(),
    ] {
        let guess = line_guess(&bv, &el);
        let fixed = solve(&lag, &el, &bv, &guess, BvpOptions::default()).unwrap();
        let opts = BvpOptions {
            moving_mesh: true,
            ..Default::default()
        };
        let moving = solve(&lag, &el, &bv, &guess, opts).unwrap();
        assert!(moving.residual_norm <= 1e-12, "residual {:e}", moving.residual_norm);
        let t = &moving.times;
        assert_eq!((t[0], t[20]), (0.0, 3.0));
        assert!(t.windows(2).all(|w| w[1] > w[0]), "times must increase: {t:?}");
        let spread = t.windows(2).map(|w| (w[1] - w[0] - 0.15).abs()).fold(0.0, f64::max);
        assert!(spread > 1e-3, "the mesh did not move: {spread:e}");
        let (action, energies) = action_and_energies(&lag, &el, t, &moving.nodes);
        assert!((action - moving.action).abs() < 1e-12 * action.abs().max(1.0));
        let jump = energies.windows(2).map(|w| (w[0].1 - w[1].0).abs()).fold(0.0, f64::max);
        assert!(jump < 1e-12, "discrete energy jumps by {jump:e} at a node");
        // ∂S/∂t_k by central differences (nodal values held): zero on the moving mesh, not on
        // the uniform one.
        let slope = |times: &[f64], nodes: &[f64], k: usize| {
            let d = 1e-5;
            let (mut up, mut down) = (times.to_vec(), times.to_vec());
            up[k] += d;
            down[k] -= d;
            (action_and_energies(&lag, &el, &up, nodes).0 - action_and_energies(&lag, &el, &down, nodes).0) / (2.0 * d)
        };
        let on_moving = (1..20).map(|k| slope(t, &moving.nodes, k).abs()).fold(0.0, f64::max);
        let on_fixed = (1..20)
            .map(|k| slope(&fixed.times, &fixed.nodes, k).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "degree 1, {kind:?}: moving mesh, steps {:.4}..{:.4}, action {:.12} (uniform {:.12}), max dS/dt_k {on_moving:.1e} (uniform {on_fixed:.1e})",
            t.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min),
            t.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max),
            moving.action,
            fixed.action,
            kind = el.rule.kind
        );
        assert!(on_moving < 1e-8 && on_fixed > 5e-5, "{on_moving:e} vs {on_fixed:e}");
    }
}

/// A moving mesh that would fold (a pendulum asked to climb to q = 3 over a long time with
/// three elements) ends in the typed error, naming the element.
#[test]
fn a_folding_mesh_is_a_typed_error() {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let el = Element::midpoint();
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![1.0],
        t1: 10.0,
        q1: vec![3.0],
        elements: 3,
    };
    let opts = BvpOptions {
        moving_mesh: true,
        ..Default::default()
    };
    let err = solve(&lag, &el, &bv, &line_guess(&bv, &el), opts).unwrap_err();
    let femvi::Error::Step(e) = err else { panic!("{err}") };
    assert_eq!(e.failure, StepFailure::MeshFolded, "{e}");
    assert!(e.step < 3);
    // The same problem on the fixed mesh solves.
    assert!(solve(&lag, &el, &bv, &line_guess(&bv, &el), BvpOptions::default()).is_ok());
}
