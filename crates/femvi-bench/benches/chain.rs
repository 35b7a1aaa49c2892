//! The explicit step of a long FPUT chain (α = 0.25, lowest mode, h = 0.1, degree 1 with the
//! trapezoid rule, M = I) at n = 2¹⁷ and 10⁶, 128 steps per iteration (the set-up outside the timing): `Integrator::advance`,
//! which takes them in blocks of space and time (`step/explicit_blocked.rs`), against
//! `advance_observed` with a callback that looks at nothing, which keeps the whole-step loop
//! (`step/explicit_wide.rs`). Both give the same bits (checked before timing); report the
//! ratio of the two in the same run. `benches/peers/lib_scale.py` has the per-dof table
//! against the C loop.

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion};
use femvi::models::FpuPotential;
use femvi::{models, Element, Integrator, Mechanical, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
use std::hint::black_box;

const STEPS: usize = 128;
const H: f64 = 0.1;

/// A run of the chain of n masses from its lowest mode, ready to step.
fn integrator(n: usize) -> Integrator<'static, Mechanical<FpuPotential>> {
    let lag = models::fpu(n, 0.25, 0.0).unwrap();
    let el = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let v = (1..=n)
        .map(|i| (std::f64::consts::PI * i as f64 / (n + 1) as f64).sin())
        .collect();
    let start = Start::Velocity { q: vec![0.0; n], v };
    let grid = TimeGrid::uniform(0.0, H, H * STEPS as f64).unwrap();
    Integrator::owned(lag, el, grid, start, SolverOptions::default()).unwrap()
}

/// The 128 steps, blocked or not; the final q.
fn steps(it: &mut Integrator<'static, Mechanical<FpuPotential>>, blocked: bool) -> Vec<f64> {
    let done = if blocked {
        it.advance(STEPS).unwrap()
    } else {
        it.advance_observed(STEPS, |_| true).unwrap()
    };
    assert_eq!(done, STEPS);
    it.node().q.to_vec()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("fpu_chain_128_steps");
    g.sample_size(10);
    for n in [1 << 17, 1_000_000] {
        let bits = |q: Vec<f64>| q.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let (mut a, mut b) = (integrator(n), integrator(n));
        assert_eq!(bits(steps(&mut a, true)), bits(steps(&mut b, false)), "n = {n}");
        for (name, blocked) in [("whole_steps", false), ("blocked", true)] {
            g.bench_with_input(BenchmarkId::new(name, n), &n, |b, &n| {
                b.iter_batched(
                    || integrator(n),
                    |mut it| black_box(steps(&mut it, blocked)),
                    BatchSize::LargeInput,
                )
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
