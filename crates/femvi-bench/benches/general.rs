//! The general path (issue 15 item 2): a Lagrangian written only through `value`, every
//! derivative by automatic differentiation, solved by Newton, against the Kepler model's
//! fixed-point step of the same degree (issue 15's yardstick: ≤ 3×). Relativistic Kepler,
//! L = −c²√(1 − |v|²/c²) + 1/|q| (c = 10), from P1's start q0 = (0.4, 0), p0 = (0, 2),
//! h = 2π/1000, 2 000 steps, degree s with s Gauss–Legendre points, s = 2 and 4: as it runs
//! (`Method::Newton`, the simplified iteration), by full Newton (`full_newton`), and `before`
//! (full Newton with per-direction and per-pair AD passes, the path before issue 15). Then
//! the adaptive time-transformed Kepler (e = 0.9, one period, Δs = 0.05, order 8; its
//! Lagrangian has hand-coded derivatives and a position-dependent mass, so it takes the
//! Newton step): divide by the steps printed once for µs per step. Report ratios of medians
//! within one run: the machine is shared.

use criterion::{criterion_group, criterion_main, Criterion};
use femvi::adaptive::{solve_adaptive, AdaptiveOptions, KeplerMonitor};
use femvi::lagrangian::PointDerivatives;
use femvi::{
    models, Element, Integrator, Lagrangian, Method, NodeFamily, Problem, QuadratureKind, Scalar, SolverOptions, Start,
    TimeGrid,
};

const STEPS: usize = 2_000;

/// The per-direction and per-pair AD passes whatever n (the path before the one-pass vector
/// duals).
struct PerPair<L>(L);
impl<L: Lagrangian> Lagrangian for PerPair<L> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn is_autonomous(&self) -> bool {
        self.0.is_autonomous()
    }
    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.0.value(t, q, v)
    }
    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        out.first_by_directions(self, t, q, v, with_t);
    }
    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        out.second_by_pairs(self, t, q, v, with_t);
    }
}

/// Runs 2 000 steps of h from (q, p) = ((0.4, 0), (0, 2)); returns q_x at the end.
fn run<L: Lagrangian>(lag: &L, el: &Element, h: f64, method: Method) -> f64 {
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    let grid = TimeGrid::uniform(0.0, h, h * STEPS as f64).unwrap();
    let opts = SolverOptions {
        method,
        ..Default::default()
    };
    let mut it = Integrator::new(lag, el, grid, start, opts).unwrap();
    while it.advance(usize::MAX).unwrap() > 0 {}
    it.node().q[0]
}

fn bench(c: &mut Criterion) {
    let kep = models::kepler(1.0).unwrap();
    let rel = models::RelativisticKepler { c: 10.0 };
    let before = PerPair(models::RelativisticKepler { c: 10.0 });
    let h = 2.0 * std::f64::consts::PI / 1000.0;
    for s in [2, 4] {
        let el = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
        let mut g = c.benchmark_group(format!("general_path_degree{s}_2k_steps"));
        g.sample_size(10);
        g.measurement_time(std::time::Duration::from_secs(2));
        g.bench_function("kepler_model", |b| b.iter(|| run(&kep, &el, h, Method::Auto)));
        g.bench_function("relativistic", |b| b.iter(|| run(&rel, &el, h, Method::Newton)));
        g.bench_function("relativistic_full_newton", |b| {
            b.iter(|| run(&rel, &el, h, Method::FullNewton))
        });
        g.bench_function("relativistic_before", |b| {
            b.iter(|| run(&before, &el, h, Method::FullNewton))
        });
        g.finish();
    }

    let e = 0.9;
    let problem = Problem::new(
        models::kepler(1.0).unwrap(),
        Start::Momentum {
            q: vec![1.0 - e, 0.0],
            p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()],
        },
        0.0,
        2.0 * std::f64::consts::PI,
    );
    let el8 = Element::with_order(8).unwrap();
    let adaptive = |method: Method| {
        let options = AdaptiveOptions {
            every: 0,
            solver: SolverOptions {
                method,
                ..Default::default()
            },
            ..AdaptiveOptions::step(0.05)
        };
        solve_adaptive(&problem, KeplerMonitor, &el8, &options).unwrap()
    };
    let (fast, full) = (adaptive(Method::Newton), adaptive(Method::FullNewton));
    eprintln!(
        "adaptive kepler e = 0.9 order 8: {} steps (Newton: {:.2} iterations per step; full Newton: {} steps, {:.2})",
        fast.steps, fast.mean_iterations, full.steps, full.mean_iterations
    );
    let mut g = c.benchmark_group("general_path_adaptive_kepler_e0.9_order8_1_period");
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(2));
    g.bench_function("newton", |b| b.iter(|| adaptive(Method::Newton).steps));
    g.bench_function("full_newton", |b| b.iter(|| adaptive(Method::FullNewton).steps));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
