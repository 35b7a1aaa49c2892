//! Time per step on Kepler (P1: q0 = (0.4, 0), p0 = (0, 2), h = 2π/1000), 10 000 steps per
//! iteration. The baseline is a hand-written Störmer–Verlet loop in the same run; report
//! ratios against it (machines are shared and noisy).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use femvi::expr::ExprLagrangian;
use femvi::{
    models, Element, Integrator, Lagrangian, Method, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid,
};
use std::hint::black_box;

const STEPS: usize = 10_000;
const H: f64 = 2.0 * std::f64::consts::PI / 1000.0;

fn verlet(steps: usize) -> [f64; 4] {
    let (mut x, mut y, mut px, mut py) = (0.4f64, 0.0f64, 0.0f64, 2.0f64);
    let r3 = (x * x + y * y).powf(1.5);
    let (mut fx, mut fy) = (-x / r3, -y / r3);
    for _ in 0..steps {
        px += 0.5 * H * fx;
        py += 0.5 * H * fy;
        x += H * px;
        y += H * py;
        let r2 = x * x + y * y;
        let k = -1.0 / (r2 * r2.sqrt());
        fx = k * x;
        fy = k * y;
        px += 0.5 * H * fx;
        py += 0.5 * H * fy;
    }
    [x, y, px, py]
}

fn run<L: Lagrangian>(lag: &L, el: &Element, method: Method) -> f64 {
    let grid = TimeGrid::uniform(0.0, H, H * STEPS as f64).unwrap();
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    let opts = SolverOptions {
        method,
        ..Default::default()
    };
    let mut it = Integrator::new(lag, el, grid, start, opts).unwrap();
    while it.advance(usize::MAX).unwrap() > 0 {}
    it.node().q[0]
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("kepler_10k_steps");
    g.sample_size(20);
    g.measurement_time(std::time::Duration::from_secs(3));
    g.bench_function("verlet_hand_loop", |b| b.iter(|| verlet(black_box(STEPS))));
    let kepler = models::kepler(1.0).unwrap();
    let trap = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    g.bench_function("femvi_degree1_trapezoid", |b| {
        b.iter(|| run(&kepler, &trap, Method::Auto))
    });
    for s in 2..=4 {
        let el = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
        g.bench_with_input(BenchmarkId::new("gauss_fixed_point", s), &el, |b, el| {
            b.iter(|| run(&kepler, el, Method::FixedPoint))
        });
        g.bench_with_input(BenchmarkId::new("gauss_newton", s), &el, |b, el| {
            b.iter(|| run(&kepler, el, Method::Newton))
        });
    }
    let expr = ExprLagrangian::new(
        "0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)",
        &["x".to_string(), "y".to_string()],
        &[],
    )
    .unwrap();
    let el2 = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2)).unwrap();
    g.bench_function("expression_newton_degree2", |b| {
        b.iter(|| run(&expr, &el2, Method::Newton))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
