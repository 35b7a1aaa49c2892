//! Boundary value problems at scale: the convergence test does not depend on the number of
//! elements (the scaled residual of `bvp/newton.rs`), a solve at 10⁵ elements agrees with the
//! initial value integrator started from its momentum. (Sizes beyond memory are typed errors:
//! `hostile.rs`.)

use femvi::bvp::{line_guess, solve, BoundaryValues, BvpOptions};
use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};

fn gauss(s: usize) -> Element {
    Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
}

/// The pendulum from θ = 0.1 back to 0.1 over [0, 5] on 10⁵ elements of degree 2, with a
/// tolerance of 10⁻¹⁵ that the Newton corrections do not reach at this size (their round-off
/// noise is about 10⁻¹³ of |Q|: the rule on corrections alone stalls, measured): the scaled
/// residual stops the iteration at round-off, reported with the unscaled residual, which grows
/// like N and is much larger. The solution is the discrete trajectory: the initial value
/// integrator with the same element and step from (q0, p0) reproduces the nodal values at
/// every element end, up to the round-off of 10⁵ steps and of p0.
#[test]
fn bvp_at_1e5_elements_stops_at_round_off_and_matches_the_ivp() {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let el = gauss(2);
    let big_n = 100_000;
    let bv = BoundaryValues {
        t0: 0.0,
        q0: vec![0.1],
        t1: 5.0,
        q1: vec![0.1],
        elements: big_n,
    };
    let opts = BvpOptions {
        tolerance: 1e-15,
        ..Default::default()
    };
    let sol = solve(&lag, &el, &bv, &line_guess(&bv, &el), opts).unwrap();
    eprintln!(
        "10^5 elements: residual {:.2e}, scaled {:.2e}, {} iterations",
        sol.residual_norm, sol.scaled_residual, sol.newton_iterations
    );
    assert!(
        sol.scaled_residual <= 1e-15,
        "scaled residual {:e}",
        sol.scaled_residual
    );
    // ‖J‖∞·max|Q| ≈ (16/3)/h · 0.1 ≈ 1e4 here: the unscaled residual is reported as it is.
    assert!(sol.residual_norm > 1e3 * sol.scaled_residual);
    assert!(sol.newton_iterations <= 8, "{} iterations", sol.newton_iterations);

    let grid = TimeGrid::uniform(0.0, bv.step(), 5.0).unwrap();
    let ivp_opts = SolverOptions {
        tolerance: 1e-15,
        ..Default::default()
    };
    let start = Start::Momentum {
        q: bv.q0.clone(),
        p: sol.p[..1].to_vec(),
    };
    let mut it = Integrator::new(&lag, &el, grid, start, ivp_opts).unwrap();
    let mut gap = 0.0f64;
    let mut k = 0;
    while it.step().unwrap() {
        k += 1;
        gap = gap.max((it.node().q[0] - sol.q[k]).abs());
    }
    assert_eq!(k, big_n);
    // Round-off: p0 carries the residual's error over the element, δp ≈ ε·|Q|/h ≈ 1e-12,
    // which moves q by about δp·T ≈ 5e-12; 10⁵ steps add at most N·ε·|q| ≈ 2e-12 more.
    eprintln!("IVP from the BVP's p0: max |q_ivp − q_bvp| over the element ends {gap:.2e}");
    assert!(gap < 2e-11, "{gap:e}");
}
