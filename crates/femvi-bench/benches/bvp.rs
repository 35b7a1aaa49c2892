//! Time per Newton iteration of a boundary value problem against the number of elements N
//! (pendulum, degree 2 with Gauss 2): one iteration = assembling the banded Hessian of the
//! action and factorising it, plus one residual evaluation for the line search. Linear in N
//! is the claim; the figures go to benches/README.md as time per element.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use femvi::bvp::{line_guess, solve, BoundaryValues, BvpOptions};
use femvi::{models, Element, NodeFamily, QuadratureKind};

fn bench(c: &mut Criterion) {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let el = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2)).unwrap();
    let mut g = c.benchmark_group("bvp_one_newton_iteration");
    g.sample_size(10);
    for n in [1_000usize, 10_000, 100_000, 1_000_000] {
        let bv = BoundaryValues {
            t0: 0.0,
            q0: vec![0.1],
            t1: 5.0,
            q1: vec![0.2],
            elements: n,
        };
        let guess = line_guess(&bv, &el);
        // The iteration cap stops after one Newton correction (reported as not converged).
        let opts = BvpOptions {
            tolerance: 1e-14,
            max_iterations: 1,
            ..Default::default()
        };
        g.bench_with_input(BenchmarkId::from_parameter(n), &guess, |b, guess| {
            b.iter(|| {
                solve(&lag, &el, &bv, guess, opts)
                    .map(|s| s.newton_iterations)
                    .unwrap_or(1)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
