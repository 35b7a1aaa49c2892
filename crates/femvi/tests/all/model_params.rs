//! Every built-in model constructor rejects parameters that are not finite (NaN, ±∞), and
//! finite ones whose products overflow, with a typed error; Newton's dense matrices are
//! refused, before they are allocated, past `femvi::step::MAX_DENSE_NEWTON`.

use femvi::step::MAX_DENSE_NEWTON;
use femvi::{models, Element, Error, Integrator, Method, SolverOptions, Start, TimeGrid};

const BAD: [f64; 3] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];

fn invalid<T>(r: femvi::Result<T>, what: &str) {
    match r {
        Err(Error::Invalid { .. }) | Err(Error::MassNotPositiveDefinite) => {}
        Err(e) => panic!("{what}: unexpected error {e}"),
        Ok(_) => panic!("{what}: accepted"),
    }
}

#[test]
fn every_model_constructor_rejects_non_finite_parameters() {
    for x in BAD {
        invalid(models::harmonic(x, 1.0), "harmonic m");
        invalid(models::harmonic(1.0, x), "harmonic k");
        invalid(models::pendulum(x, 1.0, 1.0), "pendulum m");
        invalid(models::pendulum(1.0, x, 1.0), "pendulum g");
        invalid(models::pendulum(1.0, 1.0, x), "pendulum l");
        invalid(models::kepler(x), "kepler mu");
        invalid(models::KeplerPotential::new(x), "kepler potential mu");
        for i in 0..4 {
            let mut p = [1.0, 1.0, 0.5, 1.3];
            p[i] = x;
            invalid(models::forced_oscillator(p[0], p[1], p[2], p[3]), "forced oscillator");
        }
        invalid(models::fpu(8, x, 0.0), "fpu alpha");
        invalid(models::fpu(8, 0.25, x), "fpu beta");
        invalid(models::FpuPotential::new(8, x, 0.0), "fpu potential");
        invalid(models::n_body(x, vec![1.0, 1.0], 2), "n-body G");
        invalid(models::n_body(1.0, vec![1.0, x], 2), "n-body mass");
        for i in 0..5 {
            let mut p = [1.0; 5];
            p[i] = x;
            invalid(
                models::DoublePendulum::new(p[0], p[1], p[2], p[3], p[4]),
                "double pendulum",
            );
        }
    }
    invalid(models::fpu(0, 0.25, 0.0), "fpu n = 0");
    // Good parameters are accepted.
    assert!(models::kepler(1.0).is_ok() && models::fpu(8, 0.25, 0.1).is_ok());
    assert!(models::DoublePendulum::new(1.0, 2.0, 0.5, 1.5, 9.81).is_ok());
}

#[test]
fn finite_parameters_whose_products_overflow_are_rejected() {
    let huge = 1e200;
    invalid(models::pendulum(huge, huge, 1.0), "pendulum m g l");
    invalid(models::pendulum(1.0, 1.0, huge), "pendulum m l^2");
    invalid(models::n_body(huge, vec![huge, 1.0], 3), "n-body G m m");
    invalid(
        models::DoublePendulum::new(huge, 1.0, huge, 1.0, 1.0),
        "double pendulum (m1 + m2) l1^2",
    );
    invalid(
        models::DoublePendulum::new(1.0, 1.0, 1.0, huge, huge),
        "double pendulum m2 g l2",
    );
    // Large but representable products are fine.
    assert!(models::pendulum(1e100, 1e100, 1e50).is_ok());
}

/// A chain whose Newton matrices would take ((s+1) n)² = 10⁸ entries (800 MB) is refused at
/// set-up with the limit in the message, at once; one just under the limit is set up.
#[test]
fn newton_refuses_dense_matrices_past_the_limit() {
    let el = Element::with_order(2).unwrap(); // degree 1: two nodes per element
    let opts = SolverOptions {
        method: Method::Newton,
        ..SolverOptions::default()
    };
    let setup = |n: usize| {
        let lag = models::fpu(n, 0.25, 0.0).unwrap();
        let start = Start::Velocity {
            q: vec![0.0; n],
            v: vec![0.0; n],
        };
        Integrator::new(&lag, &el, TimeGrid::uniform(0.0, 0.1, 1.0).unwrap(), start, opts).map(|_| ())
    };
    match setup(5000) {
        Err(Error::Invalid { .. }) => {}
        other => panic!("not refused: {other:?}"),
    }
    let message = setup(5000).unwrap_err().to_string();
    assert!(message.contains(&MAX_DENSE_NEWTON.to_string()), "{message}");
    assert!(setup(MAX_DENSE_NEWTON / 2).is_ok());
    assert!(setup(MAX_DENSE_NEWTON / 2 + 1).is_err());
}

/// The other users of the dense element Hessian refuse past the same limit: a start from
/// (q0, q1) and the tangent map of an explicit run (which itself needs no Hessian).
#[test]
fn the_start_from_two_positions_and_the_tangent_map_refuse_past_the_limit() {
    let el = Element::with_order(2).unwrap();
    let n = MAX_DENSE_NEWTON / 2 + 1;
    let lag = models::fpu(n, 0.25, 0.0).unwrap();
    let grid = || TimeGrid::uniform(0.0, 0.1, 1.0).unwrap();
    let two = Start::Positions {
        q0: vec![0.0; n],
        q1: vec![0.0; n],
    };
    match Integrator::new(&lag, &el, grid(), two, SolverOptions::default()) {
        Err(Error::Invalid { what, .. }) => assert!(what.contains("Newton"), "{what}"),
        other => panic!("not refused: {:?}", other.map(|_| ())),
    }
    let start = Start::Velocity {
        q: vec![0.0; n],
        v: vec![0.0; n],
    };
    let mut it = Integrator::new(&lag, &el, grid(), start, SolverOptions::default()).unwrap();
    it.step().unwrap();
    assert!(matches!(it.tangent_map(), Err(Error::Invalid { .. })));
}
