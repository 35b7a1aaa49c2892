//! The step (and degree) femvi chooses for a requested accuracy (femvi::step::auto), checked
//! against closed-form solutions: the chosen run meets the accuracy without overshooting it
//! by more than two orders of magnitude.

use femvi::diagnostics::exact;
use femvi::step::auto::{choose_step, degree_for_accuracy, nominal_order, MIN_ACCURACY};
use femvi::{
    models, Element, Error, Integrator, Lagrangian, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid,
};

fn gauss(s: usize) -> Element {
    Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
}

/// The final position of a run with uniform steps h.
fn run<L: Lagrangian>(lag: &L, el: &Element, start: &Start, h: f64, end: f64) -> Vec<f64> {
    let grid = TimeGrid::uniform(0.0, h, end).unwrap();
    let mut it = Integrator::new(lag, el, grid, start.clone(), SolverOptions::default()).unwrap();
    while it.advance(usize::MAX).unwrap() > 0 {}
    it.node().q.to_vec()
}

#[test]
fn harmonic_oscillator_meets_the_requested_accuracy() {
    // x'' = −x, x(0) = 1, v(0) = 0: x(t) = cos t; max |x| = 1, so the error is relative.
    let lag = models::harmonic(1.0, 1.0).unwrap();
    let start = Start::Momentum {
        q: vec![1.0],
        p: vec![0.0],
    };
    let end = 1000.0;
    for accuracy in [1e-4, 1e-6, 1e-8, 1e-10] {
        let el = gauss(degree_for_accuracy(accuracy));
        let c = choose_step(&lag, &el, &start, 0.0, end, accuracy, SolverOptions::default()).unwrap();
        let q = run(&lag, &el, &start, c.step, end);
        let error = (q[0] - end.cos()).abs();
        assert!(
            error <= accuracy && error >= accuracy / 100.0,
            "accuracy {accuracy:e}: error {error:e}, step {}, estimate {:e}",
            c.step,
            c.estimated_error
        );
        assert!(c.estimated_error <= accuracy);
    }
}

#[test]
fn kepler_meets_the_requested_accuracy() {
    // P1's orbit (e = 0.6) over 10 periods against Kepler's equation; the first trial step
    // (the span / 200) is too large for the pericentre and fails, so the search also goes
    // through the solver's typed failures.
    let lag = models::kepler(1.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    let end = 2.0 * std::f64::consts::PI * 10.0;
    let (qe, _) = exact::kepler(1.0, 0.0, [0.4, 0.0], [0.0, 2.0], end).unwrap();
    for accuracy in [1e-6, 1e-10] {
        let el = gauss(degree_for_accuracy(accuracy));
        let c = choose_step(&lag, &el, &start, 0.0, end, accuracy, SolverOptions::default()).unwrap();
        let q = run(&lag, &el, &start, c.step, end);
        // Relative to the largest coordinate on the orbit (the apocentre, 1.6).
        let error = (q[0] - qe[0]).abs().max((q[1] - qe[1]).abs()) / 1.6;
        assert!(
            error <= accuracy && error >= accuracy / 100.0,
            "accuracy {accuracy:e}: error {error:e}, step {}",
            c.step
        );
    }
}

#[test]
fn a_short_run_at_round_off_takes_a_few_large_steps() {
    // Over one time unit degree 8 is at round-off with any step up to the span / 8: the
    // search stops growing the step there instead of chasing an error it cannot measure.
    let lag = models::harmonic(1.0, 1.0).unwrap();
    let start = Start::Momentum {
        q: vec![1.0],
        p: vec![0.0],
    };
    let el = gauss(8);
    let c = choose_step(&lag, &el, &start, 0.0, 1.0, 1e-9, SolverOptions::default()).unwrap();
    assert!(c.step <= 1.0 / 8.0 + 1e-15, "{c:?}");
    let q = run(&lag, &el, &start, c.step, 1.0);
    assert!((q[0] - 1f64.cos()).abs() <= 1e-9);
}

#[test]
fn requests_that_cannot_be_met_are_typed_errors() {
    let lag = models::harmonic(1.0, 1.0).unwrap();
    let start = Start::Momentum {
        q: vec![1.0],
        p: vec![0.0],
    };
    let el = gauss(4);
    let opts = SolverOptions::default();
    for accuracy in [MIN_ACCURACY / 10.0, 0.5, -1e-6, f64::NAN] {
        let e = choose_step(&lag, &el, &start, 0.0, 10.0, accuracy, opts).unwrap_err();
        assert!(matches!(e, Error::Invalid { .. }), "{accuracy}: {e}");
    }
    // A start from (q0, q1) fixes the first step.
    let q1 = Start::Positions {
        q0: vec![1.0],
        q1: vec![0.99],
    };
    let e = choose_step(&lag, &el, &q1, 0.0, 10.0, 1e-6, opts).unwrap_err();
    assert!(e.to_string().contains("fixes the first step"), "{e}");
    let e = choose_step(&lag, &el, &start, 1.0, 1.0, 1e-6, opts).unwrap_err();
    assert!(matches!(e, Error::Invalid { .. }), "{e}");
}

#[test]
fn degree_and_nominal_order() {
    // Finer accuracy never picks a lower degree.
    let accs = [1e-2, 1e-4, 1e-5, 1e-6, 1e-8, 1e-9, 1e-12];
    let degrees: Vec<usize> = accs.iter().map(|&a| degree_for_accuracy(a)).collect();
    assert!(degrees.windows(2).all(|w| w[0] <= w[1]), "{degrees:?}");
    assert_eq!(nominal_order(&Element::midpoint()), 2);
    assert_eq!(nominal_order(&gauss(5)), 10);
    let el = |s, q| Element::galerkin(s, NodeFamily::Equispaced, q).unwrap();
    assert_eq!(nominal_order(&el(1, QuadratureKind::Trapezoid)), 2);
    assert_eq!(nominal_order(&el(2, QuadratureKind::Simpson)), 4);
    assert_eq!(nominal_order(&el(3, QuadratureKind::GaussLobatto(4))), 6);
    // Under-integrated: the rule's order, not 2s.
    assert_eq!(nominal_order(&el(3, QuadratureKind::GaussLegendre(2))), 4);
}
