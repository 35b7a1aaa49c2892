//! Cost of a tangent step against a plain step (issue 39, item 1): a plain run
//! ([`femvi::solve`], no rows kept) against the same run carrying one tangent vector (MEGNO,
//! FLI and λ_max: [`femvi::chaos::indicators`]) and 1 + 2n vectors (with the Lyapunov
//! spectrum, re-orthonormalised every 10 steps), 1000 steps each, on Kepler's problem,
//! Hénon–Heiles, a star with two planets in three dimensions (n = 9) and the FPU chain with
//! n = 64, at degree 1 (trapezoid: Störmer–Verlet) and degree 2 (2-point Gauss–Legendre).
//! Report ratios of the medians against the plain run of the same group.

use criterion::{criterion_group, criterion_main, Criterion};
use femvi::chaos::{indicators, ChaosOptions};
use femvi::{Element, Lagrangian, NodeFamily, Problem, QuadratureKind, SolveOptions};
use std::hint::black_box;

fn group<L: Lagrangian>(c: &mut Criterion, name: &str, problem: &Problem<L>, h: f64) {
    for (degree, element) in [
        (
            1,
            Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap(),
        ),
        (2, Element::with_order(4).unwrap()),
    ] {
        let options = SolveOptions {
            every: 0,
            ..SolveOptions::step(h)
        };
        let mut g = c.benchmark_group(format!("{name}_degree{degree}_1000_steps"));
        g.sample_size(10);
        g.measurement_time(std::time::Duration::from_secs(2));
        g.bench_function("plain", |b| {
            b.iter(|| black_box(femvi::solve(problem, &element, &options).unwrap().steps))
        });
        for (label, spectrum) in [("tangent_1", false), ("tangent_1_plus_2n", true)] {
            let chaos = ChaosOptions {
                spectrum,
                renormalize_every: 10,
                ..ChaosOptions::default()
            };
            g.bench_function(label, |b| {
                b.iter(|| black_box(indicators(problem, &element, &options, &chaos).unwrap().steps))
            });
        }
        g.finish();
    }
}

fn bench(c: &mut Criterion) {
    let (kepler, h) = femvi_bench::tangent_kepler();
    group(c, "kepler", &kepler, h);
    let (hh, h) = femvi_bench::tangent_henon_heiles();
    group(c, "henon_heiles", &hh, h);
    let (planets, h) = femvi_bench::tangent_planets();
    group(c, "star_two_planets", &planets, h);
    let (fpu, h) = femvi_bench::tangent_fpu();
    group(c, "fpu64", &fpu, h);
}

criterion_group!(benches, bench);
criterion_main!(benches);
