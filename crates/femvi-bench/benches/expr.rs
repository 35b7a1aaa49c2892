//! Expression Lagrangians against the built-in models they spell out (issue 15), same scheme,
//! same solver choice (`Method::Auto`): the README pendulum (degree 2, 3-point Gauss–Legendre,
//! h = 0.01, 2 000 steps) and Kepler (P1: q0 = (0.4, 0), p0 = (0, 2), h = 2π/1000, 2 000
//! steps) at degrees 2 and 4. Each group also runs the expression through automatic
//! differentiation only (`by_ad`, the path every expression took before the compiled tapes),
//! for the before/after ratio. Gyroscopic Lagrangians against the Kepler model's fixed-point
//! step of the same degree (issue 15's yardstick): the Arenstorf expression (rotating frame,
//! uniform h = T/10⁴ from the periodic orbit's start, 2 000 steps) and a charge in a uniform
//! magnetic field and a harmonic trap as a Rust Lagrangian with hand-coded gyroscopic parts
//! (b = 3, h = 0.002: 1/950 of the fast period), each also by Newton (`newton`, the path
//! they took before the gyroscopic fixed point). Report ratios of medians within one run;
//! the machine is shared. The general path (issue 15 item 2) and the adaptive Kepler are in
//! `benches/general.rs`.

use criterion::{criterion_group, criterion_main, Criterion};
use femvi::expr::ExprLagrangian;
use femvi::{
    models, Element, Integrator, Lagrangian, MassMatrix, Method, NodeFamily, QuadratureKind, Scalar, SolverOptions,
    Start, TimeGrid,
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

/// A charge in the plane with a uniform magnetic field b and a harmonic trap,
/// L = ½|v|² + ½b(x v_y − y v_x) − ½|q|², with its gyroscopic parts by hand.
struct TrappedCharge {
    b: f64,
    mass: MassMatrix,
}
impl Lagrangian for TrappedCharge {
    fn dim(&self) -> usize {
        2
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let kinetic = (v[0] * v[0] + v[1] * v[1]) * 0.5;
        let magnetic = (q[0] * v[1] - q[1] * v[0]) * (0.5 * self.b);
        kinetic + magnetic - (q[0] * q[0] + q[1] * q[1]) * 0.5
    }
    fn gyroscopic_mass(&self) -> Option<&MassMatrix> {
        Some(&self.mass)
    }
    fn gyroscopic_terms(&self, _t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        let hb = 0.5 * self.b;
        for ((q, v), o) in q.chunks_exact(2).zip(v.chunks_exact(2)).zip(out.chunks_exact_mut(4)) {
            o[0] = -hb * q[1];
            o[1] = hb * q[0];
            o[2] = hb * v[1] - q[0];
            o[3] = -hb * v[0] - q[1];
        }
    }
}

fn run<L: Lagrangian>(lag: &L, el: &Element, h: f64, q: &[f64], p: &[f64]) -> f64 {
    let start = Start::Momentum {
        q: q.to_vec(),
        p: p.to_vec(),
    };
    run_with(lag, el, h, start, Method::Auto)
}

fn run_with<L: Lagrangian>(lag: &L, el: &Element, h: f64, start: Start, method: Method) -> f64 {
    let grid = TimeGrid::uniform(0.0, h, h * STEPS as f64).unwrap();
    let opts = SolverOptions {
        method,
        ..Default::default()
    };
    let mut it = Integrator::new(lag, el, grid, start, opts).unwrap();
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

    let are_src = "0.5*(x_dot^2 + y_dot^2) + x*y_dot - y*x_dot + 0.5*(x^2 + y^2) \
        + (1 - mu)/sqrt((x + mu)^2 + y^2) + mu/sqrt((x - 1 + mu)^2 + y^2)";
    let are = ExprLagrangian::new(are_src, &xy, &[("mu".to_string(), 0.012277471)]).unwrap();
    assert!(are.gyroscopic_mass().is_some());
    let are_h = 17.065_216_560_157_96 / 1e4;
    let are_start = || Start::Velocity {
        q: vec![0.994, 0.0],
        v: vec![0.0, -2.001_585_106_379_082_5],
    };
    let charge = TrappedCharge {
        b: 3.0,
        mass: MassMatrix::identity(2),
    };
    let charge_start = || Start::Velocity {
        q: vec![1.0, 0.0],
        v: vec![0.0, 0.3],
    };
    for s in [2, 4] {
        let el = gauss(s, s);
        let mut g = c.benchmark_group(format!("gyroscopic_degree{s}_2k_steps"));
        g.sample_size(10);
        g.measurement_time(std::time::Duration::from_secs(2));
        g.bench_function("kepler_model", |b| b.iter(|| run(&kep, &el, h, &q, &p)));
        g.bench_function("arenstorf_expression", |b| {
            b.iter(|| run_with(&are, &el, are_h, are_start(), Method::Auto))
        });
        g.bench_function("arenstorf_expression_newton", |b| {
            b.iter(|| run_with(&are, &el, are_h, are_start(), Method::FullNewton))
        });
        g.bench_function("magnetic_rust", |b| {
            b.iter(|| run_with(&charge, &el, 0.002, charge_start(), Method::Auto))
        });
        g.bench_function("magnetic_rust_newton", |b| {
            b.iter(|| run_with(&charge, &el, 0.002, charge_start(), Method::FullNewton))
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
