//! Expression Lagrangians against the built-in models they spell out (issue 15), same scheme,
//! same solver choice (`Method::Auto`): the README pendulum (degree 2, 3-point Gauss–Legendre,
//! h = 0.01, 2 000 steps) and Kepler (P1: q0 = (0.4, 0), p0 = (0, 2), h = 2π/1000, 2 000
//! steps) at degrees 2 and 4. Each group also runs the expression through automatic
//! differentiation only (`by_ad`, the path every expression took before the compiled tapes),
//! for the before/after ratio. Report ratios of medians within one run; the machine is shared.

use criterion::{criterion_group, criterion_main, Criterion};
use femvi::expr::ExprLagrangian;
use femvi::{
    models, Element, Integrator, Lagrangian, NodeFamily, QuadratureKind, Scalar, SolverOptions, Start, TimeGrid,
};

const STEPS: usize = 2_000;

/// An expression seen through its value only: every derivative by automatic differentiation.
struct ByAd(ExprLagrangian);
impl Lagrangian for ByAd {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.0.value(t, q, v)
    }
    fn is_autonomous(&self) -> bool {
        self.0.is_autonomous()
    }
}

fn run<L: Lagrangian>(lag: &L, el: &Element, h: f64, q: &[f64], p: &[f64]) -> f64 {
    let grid = TimeGrid::uniform(0.0, h, h * STEPS as f64).unwrap();
    let start = Start::Momentum {
        q: q.to_vec(),
        p: p.to_vec(),
    };
    let mut it = Integrator::new(lag, el, grid, start, SolverOptions::default()).unwrap();
    while it.advance(usize::MAX).unwrap() > 0 {}
    it.node().q[0]
}

fn gauss(degree: usize, points: usize) -> Element {
    Element::galerkin(degree, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(points)).unwrap()
}

fn bench(c: &mut Criterion) {
    let theta = ["theta".to_string()];
    let pend_params = [("g".to_string(), 9.81), ("l".to_string(), 1.0)];
    let pend_src = "0.5*l^2*theta_dot^2 + g*l*cos(theta)";
    let pend_expr = ExprLagrangian::new(pend_src, &theta, &pend_params).unwrap();
    let pend_ad = ByAd(pend_expr.clone());
    let pend = models::pendulum(1.0, 9.81, 1.0).unwrap();
    let el = gauss(2, 3);
    let mut g = c.benchmark_group("pendulum_readme_2k_steps");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(2));
    let (q, p) = ([1.0], [0.0]);
    g.bench_function("model", |b| b.iter(|| run(&pend, &el, 0.01, &q, &p)));
    g.bench_function("expression", |b| b.iter(|| run(&pend_expr, &el, 0.01, &q, &p)));
    g.bench_function("expression_by_ad", |b| b.iter(|| run(&pend_ad, &el, 0.01, &q, &p)));
    g.finish();

    let xy = ["x".to_string(), "y".to_string()];
    let kep_expr = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &xy, &[]).unwrap();
    let kep_ad = ByAd(kep_expr.clone());
    let kep = models::kepler(1.0).unwrap();
    let h = 2.0 * std::f64::consts::PI / 1000.0;
    let (q, p) = ([0.4, 0.0], [0.0, 2.0]);
    for s in [2, 4] {
        let el = gauss(s, s);
        let mut g = c.benchmark_group(format!("kepler_degree{s}_2k_steps"));
        g.sample_size(10);
        g.measurement_time(std::time::Duration::from_secs(2));
        g.bench_function("model", |b| b.iter(|| run(&kep, &el, h, &q, &p)));
        g.bench_function("expression", |b| b.iter(|| run(&kep_expr, &el, h, &q, &p)));
        g.bench_function("expression_by_ad", |b| b.iter(|| run(&kep_ad, &el, h, &q, &p)));
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
