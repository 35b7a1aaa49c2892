//! Ensemble throughput on one core (issue 39 item 2), in member-steps per second (criterion's
//! element throughput; ns per member-step is its inverse): Kepler and Hénon–Heiles at degree 1
//! (Störmer–Verlet) and at degree 2 (2-point Gauss–Legendre, the fixed-point step), 4096
//! members × 1000 steps, each member's energy checked at every node as
//! `femvi ensemble` does. Members in SIMD lanes (`femvi::ensemble`, each compiled width)
//! against the same members one at a time (`Integrator::step` with an `EnergyTracker`, the
//! path of other schemes) and against a hand-written Verlet loop of one trajectory with the
//! energy at every node, in the same run; and Kepler written as an expression (degree 1), in
//! lanes against one at a time.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use femvi::ensemble::{EnsembleLanes, Width};
use femvi::solution::EnergyTracker;
use femvi::{models, Element, Integrator, Lagrangian, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
use std::hint::black_box;

const MEMBERS: usize = 4096;
const STEPS: usize = 1000;
const H: f64 = 0.01;

fn starts(kepler: bool) -> Vec<Start> {
    femvi_bench::ensemble_starts(kepler, MEMBERS)
}

/// Members one at a time, each with its energy at every node.
fn one_by_one<L: Lagrangian>(lag: &L, el: &Element, grid: &TimeGrid, starts: &[Start]) -> f64 {
    let mut sum = 0.0;
    for s in starts {
        let mut it = Integrator::new(lag, el, grid.clone(), s.clone(), SolverOptions::default()).unwrap();
        let mut tracker = EnergyTracker::new(lag.dim(), s, true);
        let node = it.node();
        tracker.node(lag, node.t, node.q, node.p).unwrap();
        while it.step().unwrap() {
            let node = it.node();
            tracker.node(lag, node.t, node.q, node.p).unwrap();
        }
        sum += it.node().q[0] + tracker.report().max_rel_error;
    }
    sum
}

/// One Kepler trajectory by hand (Störmer–Verlet, the energy at every node), `MEMBERS` times.
fn hand_loop(starts: &[Start]) -> f64 {
    let mut sum = 0.0;
    for s in starts {
        let Start::Momentum { q, p } = s else { continue };
        let (mut x, mut y, mut px, mut py) = (q[0], q[1], p[0], p[1]);
        let mut k = -1.0 / ((x * x + y * y) * (x * x + y * y).sqrt());
        let (mut fx, mut fy) = (k * x, k * y);
        let e0 = 0.5 * (px * px + py * py) - 1.0 / (x * x + y * y).sqrt();
        let mut dev = 0.0f64;
        for _ in 0..STEPS {
            px += 0.5 * H * fx;
            py += 0.5 * H * fy;
            x += H * px;
            y += H * py;
            let r2 = x * x + y * y;
            k = -1.0 / (r2 * r2.sqrt());
            fx = k * x;
            fy = k * y;
            px += 0.5 * H * fx;
            py += 0.5 * H * fy;
            let e = 0.5 * (px * px + py * py) - 1.0 / r2.sqrt();
            dev = dev.max((e - e0).abs());
        }
        sum += x + dev;
    }
    sum
}

fn bench(c: &mut Criterion) {
    let verlet = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let grid = TimeGrid::uniform(0.0, H, H * STEPS as f64).unwrap();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let kepler = models::kepler(1.0).unwrap();
    let hh = models::henon_heiles();
    let degree2 = Element::with_order(4).unwrap();
    for (name, is_kepler, element) in [
        ("kepler", true, &verlet),
        ("henon_heiles", false, &verlet),
        ("kepler_degree2", true, &degree2),
        ("henon_heiles_degree2", false, &degree2),
    ] {
        let mut g = c.benchmark_group(format!("ensemble_{name}_4096x1000"));
        g.sample_size(10);
        g.throughput(Throughput::Elements((MEMBERS * STEPS) as u64));
        let s = starts(is_kepler);
        macro_rules! lanes {
            ($lag:expr) => {{
                let template = Integrator::new(
                    $lag,
                    element,
                    grid.clone(),
                    s[0].clone(),
                    SolverOptions::default(),
                )
                .unwrap();
                let lanes = EnsembleLanes::of(&template).unwrap();
                for (label, width) in [
                    ("lanes_avx512", Width::Avx512),
                    ("lanes_avx2", Width::Avx2),
                    ("lanes_portable", Width::Portable),
                ] {
                    let l = lanes.width(width);
                    g.bench_function(label, |b| {
                        b.iter(|| one.install(|| l.run(black_box(&s), &|_| {})).len())
                    });
                }
                g.bench_function("lanes_two_threads", |b| {
                    b.iter(|| two.install(|| lanes.run(black_box(&s), &|_| {})).len())
                });
                g.bench_function("one_by_one", |b| {
                    b.iter(|| one_by_one($lag, element, &grid, black_box(&s)))
                });
            }};
        }
        if is_kepler {
            lanes!(&kepler);
            if element.degree() == 1 {
                g.bench_function("hand_loop_one_by_one", |b| b.iter(|| hand_loop(black_box(&s))));
            }
        } else {
            lanes!(&hh);
        }
        g.finish();
    }
    // Kepler written as an expression (the force and L as code across lanes,
    // `expr/native/lanes.rs`) against the same members one at a time.
    let xy = ["x".to_string(), "y".to_string()];
    let expr = femvi::expr::ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &xy, &[]).unwrap();
    let mut g = c.benchmark_group("ensemble_kepler_expression_4096x1000");
    g.sample_size(10);
    g.throughput(Throughput::Elements((MEMBERS * STEPS) as u64));
    let s = starts(true);
    let template = Integrator::new(&expr, &verlet, grid.clone(), s[0].clone(), SolverOptions::default()).unwrap();
    let lanes = EnsembleLanes::of(&template).unwrap();
    g.bench_function("lanes_best", |b| {
        b.iter(|| one.install(|| lanes.run(black_box(&s), &|_| {})).len())
    });
    g.bench_function("one_by_one", |b| {
        b.iter(|| one_by_one(&expr, &verlet, &grid, black_box(&s)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
