//! The step solvers never hang: a step too large to converge ends in a typed error (a stall
//! when the increments stop decreasing, or the iteration cap), with the step, time and
//! residual — where GNI_IRK2 loops forever on P3 at h = 1 (its residual stalls just above its
//! stopping threshold).

use femvi::{
    models, Element, Integrator, Lagrangian, Method, NodeFamily, QuadratureKind, SolverOptions, Start, StepFailure,
    TimeGrid,
};

/// An integrator from P3's initial data (q0 = 0, p0 = 1.5).
fn from_p3_start<'a, L: Lagrangian>(
    lag: &'a L,
    el: &'a Element,
    grid: TimeGrid,
    opts: SolverOptions,
) -> Integrator<'a, L> {
    let start = Start::Momentum {
        q: vec![0.0],
        p: vec![1.5],
    };
    Integrator::new(lag, el, grid, start, opts).unwrap()
}

#[test]
fn a_step_too_large_to_converge_is_a_typed_error_not_a_hang() {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    for (s, method) in [(6, Method::FixedPoint), (3, Method::Newton)] {
        let el = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
        for h in [4.0, 8.0] {
            let grid = TimeGrid::uniform(0.0, h, 1e5).unwrap();
            let opts = SolverOptions {
                method,
                max_iterations: 50,
                ..Default::default()
            };
            let mut it = from_p3_start(&lag, &el, grid, opts);
            let started = std::time::Instant::now();
            let err = loop {
                match it.step() {
                    Ok(true) => continue,
                    Ok(false) => panic!("{method:?} h={h}: expected a failure"),
                    Err(e) => break e,
                }
            };
            let femvi::Error::Step(e) = err else { panic!("{err}") };
            eprintln!("{method:?} s={s} h={h}: {e} (after {:?})", started.elapsed());
            assert!(matches!(
                e.failure,
                StepFailure::Stalled | StepFailure::NotConverged | StepFailure::NonFinite
            ));
            assert!(e.iterations <= 50);
            assert!(e.t >= 0.0);
        }
    }
    // P3 itself at h = 1 (where GNI_IRK2 hangs) converges here.
    let el = Element::galerkin(6, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(6)).unwrap();
    let grid = TimeGrid::uniform(0.0, 1.0, 1000.0).unwrap();
    let mut it = from_p3_start(&lag, &el, grid, SolverOptions::default());
    while it.step().unwrap() {}
    assert!(it.mean_iterations() < 20.0, "{}", it.mean_iterations());
}

/// The fixed-point solver (whose starting stage values come from the last step's forces
/// extrapolated in time, and whose inner loop is specialised for n ≤ 3) reaches the same
/// discrete trajectory as Newton's method on the full step equations: for rules with and
/// without end points, unit and non-unit masses, n = 1, 2, 3 and 6, uniform steps and steps
/// varying by factors up to 2 (and once by 3, where the start falls back to the element
/// polynomial).
#[test]
fn fixed_point_agrees_with_newton_on_every_rule_and_grid() {
    fn compare<L: femvi::Lagrangian>(name: &str, lag: &L, q0: Vec<f64>, p0: Vec<f64>) {
        let rules = [
            (1, NodeFamily::Equispaced, QuadratureKind::Trapezoid),
            (1, NodeFamily::Equispaced, QuadratureKind::Midpoint),
            (2, NodeFamily::Equispaced, QuadratureKind::Simpson),
            (3, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(4)),
            (4, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(4)),
            (9, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(9)),
        ];
        // Uniform; ratios up to 2; one jump by 3.
        let grids = [
            TimeGrid::uniform(0.0, 0.05, 3.0).unwrap(),
            TimeGrid::steps(0.0, (0..60).map(|k| [0.03, 0.06, 0.045, 0.05][k % 4]).collect(), 3.0).unwrap(),
            TimeGrid::steps(0.0, (0..60).map(|k| if k == 20 { 0.15 } else { 0.05 }).collect(), 3.0).unwrap(),
        ];
        for (s, family, rule) in rules {
            let el = Element::galerkin(s, family, rule).unwrap();
            for (g, grid) in grids.iter().enumerate() {
                let run = |method| {
                    let opts = SolverOptions {
                        method,
                        ..Default::default()
                    };
                    let start = Start::Momentum {
                        q: q0.clone(),
                        p: p0.clone(),
                    };
                    let mut it = Integrator::new(lag, &el, grid.clone(), start, opts).unwrap();
                    let mut path = vec![];
                    while it.step().unwrap() {
                        path.extend_from_slice(it.node().q);
                        path.extend_from_slice(it.node().p);
                    }
                    (path, it.mean_iterations())
                };
                let (fp, iters) = run(Method::FixedPoint);
                let (nw, _) = run(Method::Newton);
                assert_eq!(fp.len(), nw.len());
                let worst = fp.iter().zip(&nw).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                assert!(
                    worst < 1e-12,
                    "{name} degree {s} {rule:?} grid {g}: fixed point vs Newton {worst:e} ({iters:.1} iterations/step)"
                );
            }
        }
    }
    compare(
        "pendulum (n = 1, mass 2)",
        &models::pendulum(2.0, 1.0, 1.0).unwrap(),
        vec![0.3],
        vec![1.0],
    );
    compare(
        "Kepler (n = 2)",
        &models::kepler(1.0).unwrap(),
        vec![0.4, 0.0],
        vec![0.0, 2.0],
    );
    compare(
        "two bodies in space (n = 6, masses 1 and 0.5)",
        &models::n_body(1.0, vec![1.0, 0.5], 3).unwrap(),
        vec![0.0, 0.0, 0.0, 1.0, 0.1, 0.0],
        vec![0.0, -0.3, 0.0, 0.0, 0.3, 0.05],
    );
    compare(
        "FPU chain (n = 3)",
        &models::fpu(3, 0.25, 0.0).unwrap(),
        vec![0.1, -0.2, 0.3],
        vec![0.0, 0.5, 0.0],
    );
}

/// `polish = false` stops the fixed-point iteration at the tolerance: fewer sweeps, and the
/// truncation it leaves (one-signed, ≲ h·|∂f/∂q|·tolerance·max|q| per step, here |∂f/∂q| ≤ 1
/// and max|q| < 2) adds at most N·h·tolerance·2 to the energy error of the polished run.
#[test]
fn without_polish_the_iteration_stops_at_the_tolerance() {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let el = Element::galerkin(6, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(6)).unwrap();
    let (h, steps) = (1.25, 4000usize);
    let tolerance = 1e-10;
    let run = |polish: bool| {
        let grid = TimeGrid::uniform(0.0, h, h * steps as f64).unwrap();
        let opts = SolverOptions {
            tolerance,
            polish,
            ..Default::default()
        };
        let mut it = from_p3_start(&lag, &el, grid, opts);
        let e0 = 0.5 * 1.5f64 * 1.5 - 1.0;
        let mut worst = 0.0f64;
        while it.step().unwrap() {
            let n = it.node();
            worst = worst.max((0.5 * n.p[0] * n.p[0] - n.q[0].cos() - e0).abs());
        }
        (it.mean_iterations(), worst)
    };
    let (sweeps_polished, err_polished) = run(true);
    let (sweeps, err) = run(false);
    assert!(
        sweeps < sweeps_polished - 1.0,
        "{sweeps:.2} sweeps per step without the polish, {sweeps_polished:.2} with"
    );
    let bound = steps as f64 * h * tolerance * 2.0;
    assert!(
        err <= err_polished + bound,
        "energy error {err:e} without the polish, {err_polished:e} with (bound {bound:e})"
    );
    eprintln!("sweeps {sweeps:.2} vs {sweeps_polished:.2}; energy error {err:e} vs {err_polished:e}");
}
