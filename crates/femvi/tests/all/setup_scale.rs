//! Set-up at scale (issue 15, "O(n) set-up"): starting a run of a mechanical Lagrangian
//! evaluates neither the force nor the potential (for n bodies each costs O(N²), a whole step),
//! and the models' size limits are typed errors. Times are measured by
//! `examples/setup_scale.rs`, not here.

use femvi::lagrangian::MassMatrix;
use femvi::{models, Element, Integrator, Mechanical, Potential, Scalar, SolverOptions, Start, TimeGrid};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A harmonic chain potential V = Σ q_i²/2 that counts its evaluations.
struct Counted {
    n: usize,
    values: AtomicUsize,
    forces: AtomicUsize,
}

impl Potential for Counted {
    fn dim(&self) -> usize {
        self.n
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        self.values.fetch_add(1, Ordering::Relaxed);
        q.iter().fold(D::from(0.0), |s, &x| s + x * x * 0.5)
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        self.forces.fetch_add(1, Ordering::Relaxed);
        out.iter_mut().zip(q).for_each(|(o, x)| *o = -x);
    }
}

/// Integrator::new from (q0, v0) with a constant mass matrix takes p0 = M v0 (exactly, as the
/// mass matrix applies it) and evaluates nothing else; the first step then needs the force.
#[test]
fn starting_a_mechanical_run_evaluates_no_force_and_no_potential() {
    let n = 1000;
    let masses: Vec<f64> = (0..n).map(|i| 1.0 + (i % 7) as f64 * 0.25).collect();
    let lag = Mechanical::new(
        Counted {
            n,
            values: AtomicUsize::new(0),
            forces: AtomicUsize::new(0),
        },
        MassMatrix::diagonal(masses.clone()).unwrap(),
    )
    .unwrap();
    let q: Vec<f64> = (0..n).map(|i| (i as f64 * 0.01).sin()).collect();
    let v: Vec<f64> = (0..n).map(|i| (i as f64 * 0.02).cos()).collect();
    let el = Element::with_order(2).unwrap();
    let grid = TimeGrid::uniform(0.0, 0.1, 1.0).unwrap();
    let start = Start::Velocity { q, v: v.clone() };
    let mut it = Integrator::new(&lag, &el, grid, start, SolverOptions::default()).unwrap();
    let pot = &lag.potential;
    assert_eq!(pot.forces.load(Ordering::Relaxed), 0, "force evaluated at set-up");
    assert_eq!(pot.values.load(Ordering::Relaxed), 0, "potential evaluated at set-up");
    for (i, p) in it.node().p.iter().enumerate() {
        assert_eq!(*p, masses[i] * v[i], "p0[{i}]");
    }
    it.step().unwrap();
    assert!(pot.forces.load(Ordering::Relaxed) > 0);
}

/// The FPUT chain beyond [`models::MAX_FPU_MASSES`] (10⁸ masses, usize::MAX) is refused by the
/// library and by the problem-file parameters with a typed error, before any allocation.
#[test]
fn fpu_beyond_the_limit_is_a_typed_error() {
    for n in [models::MAX_FPU_MASSES + 1, 100_000_000, usize::MAX] {
        let err = models::fpu(n, 0.25, 0.0).unwrap_err();
        assert!(matches!(err, femvi::Error::Invalid { .. }), "{err:?}");
    }
    let given = [("n".to_string(), 1e8)];
    let err = models::parameters("fpu", &given).unwrap_err();
    assert!(matches!(err, femvi::Error::Invalid { .. }), "{err:?}");
    // The limit itself is accepted.
    assert!(models::fpu(models::MAX_FPU_MASSES, 0.25, 0.0).is_ok());
    let given = [("n".to_string(), models::MAX_FPU_MASSES as f64)];
    assert!(models::parameters("fpu", &given).is_ok());
}
