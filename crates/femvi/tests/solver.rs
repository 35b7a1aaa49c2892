//! The step solvers never hang: a step too large to converge ends in a typed error (a stall
//! when the increments stop decreasing, or the iteration cap), with the step, time and
//! residual — where GNI_IRK2 loops forever on P3 at h = 1 (its residual stalls just above its
//! stopping threshold).

use femvi::{
    models, Element, Integrator, Method, NodeFamily, QuadratureKind, SolverOptions, Start, StepFailure, TimeGrid,
};

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
            let mut it = Integrator::new(
                &lag,
                &el,
                grid,
                Start::Momentum {
                    q: vec![0.0],
                    p: vec![1.5],
                },
                opts,
            )
            .unwrap();
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
    let mut it = Integrator::new(
        &lag,
        &el,
        grid,
        Start::Momentum {
            q: vec![0.0],
            p: vec![1.5],
        },
        SolverOptions::default(),
    )
    .unwrap();
    while it.step().unwrap() {}
    assert!(it.mean_iterations() < 20.0, "{}", it.mean_iterations());
}
