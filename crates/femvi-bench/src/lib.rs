//! The criterion benchmarks of femvi (`benches/`): time per step against a hand-written
//! Störmer–Verlet loop, boundary value problems, compiled expressions, the forced tangent map,
//! general Lagrangians and blocked chains. Run with `cargo bench -p femvi-bench --bench step`
//! (or `bvp`, `expr`, `chaos_forced`, `general`, `chain`); the figures and their baselines are
//! in the repository's `benches/README.md`. The crate exists so that criterion is built only
//! for the benchmarks, not for the test suite; its only code is what the benchmarks and the
//! timing binaries share: the ensemble members (`ensemble` and `lanes`) and the tangent
//! benchmark's systems (`tangent` and `tangent_ratios`).

use femvi::models::{FpuPotential, GravityPotential, HenonHeilesPotential, KeplerPotential};
use femvi::{models, Mechanical, Problem, Start};

/// Kepler's problem at e = 0.5 (perihelion start, μ = 1), 10 time units, and its step 0.01.
pub fn tangent_kepler() -> (Problem<Mechanical<KeplerPotential>>, f64) {
    let start = Start::Momentum {
        q: vec![0.5, 0.0],
        p: vec![0.0, 3f64.sqrt()],
    };
    (
        Problem::new(models::kepler(1.0).expect("μ = 1"), start, 0.0, 10.0),
        0.01,
    )
}

/// Hénon–Heiles at E = 1/6 from (0, −0.1), p_y = 0 (chaotic), 100 time units, step 0.1.
pub fn tangent_henon_heiles() -> (Problem<Mechanical<HenonHeilesPotential>>, f64) {
    let y0: f64 = -0.1;
    let v = 0.5 * y0 * y0 - y0.powi(3) / 3.0;
    let start = Start::Momentum {
        q: vec![0.0, y0],
        p: vec![(2.0 * (1.0 / 6.0 - v)).sqrt(), 0.0],
    };
    (Problem::new(models::henon_heiles(), start, 0.0, 100.0), 0.1)
}

/// A star with two planets (masses 1, 1e-3, 3e-4; a = 1 and 1.6, circular) in 3-D (n = 9),
/// 1000 steps of P1/200.
pub fn tangent_planets() -> (Problem<Mechanical<GravityPotential>>, f64) {
    let masses = [1.0, 1e-3, 3e-4];
    let (a1, a2) = (1.0f64, 1.6f64);
    let (v1, v2) = (1.0 / a1.sqrt(), 1.0 / a2.sqrt());
    let q = vec![0.0, 0.0, 0.0, a1, 0.0, 0.0, 0.0, a2, 0.01];
    let vel = [0.0, 0.0, 0.0, 0.0, v1, 0.0, -v2, 0.0, 0.0];
    let p = (0..9).map(|i| masses[i / 3] * vel[i]).collect();
    let h = 2.0 * std::f64::consts::PI / 200.0;
    let bodies = models::n_body(1.0, masses.to_vec(), 3).expect("positive masses");
    (Problem::new(bodies, Start::Momentum { q, p }, 0.0, 1000.0 * h), h)
}

/// The FPU chain with n = 64, α = 0.25, from q_i = 0.1 sin(i + 1) at rest, 50 time units,
/// step 0.05.
pub fn tangent_fpu() -> (Problem<Mechanical<FpuPotential>>, f64) {
    let n = 64;
    let start = Start::Momentum {
        q: (0..n).map(|i| 0.1 * (i as f64 + 1.0).sin()).collect(),
        p: vec![0.0; n],
    };
    (
        Problem::new(models::fpu(n, 0.25, 0.0).expect("n = 64"), start, 0.0, 50.0),
        0.05,
    )
}

/// `members` starts for the ensemble benchmarks: Kepler orbits from x = 0.5 … 1.5 with 0.8 …
/// 1.2 times the circular speed, or Hénon–Heiles from (0, 0.1) with p_x = 0.1 … 0.5.
pub fn ensemble_starts(kepler: bool, members: usize) -> Vec<Start> {
    (0..members)
        .map(|i| {
            let a = i as f64 / members as f64;
            if kepler {
                let x = 0.5 + a;
                Start::Momentum {
                    q: vec![x, 0.0],
                    p: vec![0.0, (1.0 / x).sqrt() * (0.8 + 0.4 * a)],
                }
            } else {
                Start::Momentum {
                    q: vec![0.0, 0.1],
                    p: vec![0.1 + 0.4 * a, 0.0],
                }
            }
        })
        .collect()
}
