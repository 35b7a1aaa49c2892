//! The criterion benchmarks of femvi (`benches/`): time per step against a hand-written
//! Störmer–Verlet loop, boundary value problems, compiled expressions, the forced tangent map,
//! general Lagrangians and blocked chains. Run with `cargo bench -p femvi-bench --bench step`
//! (or `bvp`, `expr`, `chaos_forced`, `general`, `chain`); the figures and their baselines are
//! in the repository's `benches/README.md`. The crate exists so that criterion is built only
//! for the benchmarks, not for the test suite; its only code is the members the ensemble
//! benchmark and the `lanes` timing binary share.

use femvi::Start;

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
