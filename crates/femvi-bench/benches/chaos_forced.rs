//! Cost of the forced tangent map: a forced run ([`femvi::forces::solve_forced`]) against
//! the same run carrying k = 1 tangent vector (MEGNO, FLI, λ_max: `forced_indicators`
//! without the spectrum) and k = 1 + 2n (with the spectrum), on a damped, driven Duffing
//! oscillator (n = 1) and a damped FPU chain (n = 8), 1000 steps per iteration, degree 2.
//! Report ratios of medians against the plain forced run (the machine is shared and noisy).

use criterion::{criterion_group, criterion_main, Criterion};
use femvi::chaos::{forced_indicators, ChaosOptions};
use femvi::expr::ExprLagrangian;
use femvi::forces::{solve_forced, ExprForces, Force, LinearForce};
use femvi::{models, Element, Lagrangian, Problem, SolveOptions, Start};
use std::hint::black_box;

fn group<L: Lagrangian + Sync, F: Force + Sync>(c: &mut Criterion, name: &str, problem: &Problem<L>, force: &F) {
    let (el, options) = (
        Element::with_order(4).unwrap(),
        SolveOptions {
            every: 0,
            ..SolveOptions::step(0.02)
        },
    );
    let mut g = c.benchmark_group(name);
    g.sample_size(10);
    g.measurement_time(std::time::Duration::from_secs(3));
    g.bench_function("forced_run", |b| {
        b.iter(|| black_box(solve_forced(problem, force, &el, &options).unwrap().solution.steps))
    });
    for (label, spectrum) in [("tangent_k1", false), ("tangent_k1_plus_2n", true)] {
        let chaos = ChaosOptions {
            spectrum,
            ..ChaosOptions::default()
        };
        g.bench_function(label, |b| {
            b.iter(|| black_box(forced_indicators(problem, force, &el, &options, &chaos).unwrap().steps))
        });
    }
    g.finish();
}

fn bench(c: &mut Criterion) {
    let x = vec!["x".to_string()];
    let params = [("d", 0.15), ("g", 0.3), ("w", 1.2)].map(|(k, v)| (k.to_string(), v));
    let lag = ExprLagrangian::new("0.5*x_dot^2 + 0.5*x^2 - 0.25*x^4", &x, &params).unwrap();
    let force = ExprForces::new(&["-d*x_dot + g*cos(w*t)"], &x, &params).unwrap();
    let start = Start::Momentum {
        q: vec![1.2],
        p: vec![0.1],
    };
    group(c, "duffing_n1_1000_steps", &Problem::new(lag, start, 0.0, 20.0), &force);
    let n = 8;
    let start = Start::Momentum {
        q: (0..n).map(|i| 0.1 * (i as f64 + 1.0).sin()).collect(),
        p: vec![0.0; n],
    };
    let fpu = Problem::new(models::fpu(n, 0.25, 0.0).unwrap(), start, 0.0, 20.0);
    group(c, "damped_fpu_n8_1000_steps", &fpu, &LinearForce::damping(n, 0.05));
}

criterion_group!(benches, bench);
criterion_main!(benches);
