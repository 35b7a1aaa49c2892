//! Cost of a tangent step against a plain step (issue 39, item 1): a plain run
//! ([`femvi::solve`], no rows kept) against the same run carrying one tangent vector (MEGNO,
//! FLI and λ_max: [`femvi::chaos::indicators`]) and 1 + 2n vectors (with the Lyapunov
//! spectrum, re-orthonormalised every 10 steps), 1000 steps each, on Kepler's problem,
//! Hénon–Heiles, a star with two planets in three dimensions (n = 9) and the FPU chain with
//! n = 64, at degree 1 (trapezoid: Störmer–Verlet) and degree 2 (2-point Gauss–Legendre).
//! Report ratios of the medians against the plain run of the same group.

use criterion::{criterion_group, criterion_main, Criterion};
use femvi::chaos::{indicators, ChaosOptions};
use femvi::{models, Element, Lagrangian, NodeFamily, Problem, QuadratureKind, SolveOptions, Start};
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
    // Kepler, e = 0.5 (perihelion start, μ = 1).
    let kepler = Problem::new(
        models::kepler(1.0).unwrap(),
        Start::Momentum {
            q: vec![0.5, 0.0],
            p: vec![0.0, 3f64.sqrt()],
        },
        0.0,
        10.0,
    );
    group(c, "kepler", &kepler, 0.01);
    // Hénon–Heiles at E = 1/6 from (0, −0.1), p_y = 0 (chaotic).
    let y0: f64 = -0.1;
    let v = 0.5 * y0 * y0 - y0.powi(3) / 3.0;
    let hh = Problem::new(
        models::henon_heiles(),
        Start::Momentum {
            q: vec![0.0, y0],
            p: vec![(2.0 * (1.0 / 6.0 - v)).sqrt(), 0.0],
        },
        0.0,
        100.0,
    );
    group(c, "henon_heiles", &hh, 0.1);
    // Star + two planets (masses 1, 1e-3, 3e-4; a = 1 and 1.6, circular), 3-D, h = P1/200.
    let masses = [1.0, 1e-3, 3e-4];
    let (a1, a2) = (1.0f64, 1.6f64);
    let (v1, v2) = (1.0 / a1.sqrt(), 1.0 / a2.sqrt());
    let q = vec![0.0, 0.0, 0.0, a1, 0.0, 0.0, 0.0, a2, 0.01];
    let vel = [0.0, 0.0, 0.0, 0.0, v1, 0.0, -v2, 0.0, 0.0];
    let p = (0..9).map(|i| masses[i / 3] * vel[i]).collect();
    let h = 2.0 * std::f64::consts::PI / 200.0;
    let planets = Problem::new(
        models::n_body(1.0, masses.to_vec(), 3).unwrap(),
        Start::Momentum { q, p },
        0.0,
        1000.0 * h,
    );
    group(c, "star_two_planets", &planets, h);
    // FPU, n = 64, α = 0.25.
    let n = 64;
    let fpu = Problem::new(
        models::fpu(n, 0.25, 0.0).unwrap(),
        Start::Momentum {
            q: (0..n).map(|i| 0.1 * (i as f64 + 1.0).sin()).collect(),
            p: vec![0.0; n],
        },
        0.0,
        50.0,
    );
    group(c, "fpu64", &fpu, 0.05);
}

criterion_group!(benches, bench);
criterion_main!(benches);
