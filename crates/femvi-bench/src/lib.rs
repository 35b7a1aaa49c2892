//! The criterion benchmarks of femvi (`benches/`): time per step against a hand-written
//! Störmer–Verlet loop, boundary value problems, compiled expressions, the forced tangent map,
//! general Lagrangians and blocked chains. Run with `cargo bench -p femvi-bench --bench step`
//! (or `bvp`, `expr`, `chaos_forced`, `general`, `chain`); the figures and their baselines are
//! in the repository's `benches/README.md`. The crate has no code of its own: it exists so that
//! criterion is built only for the benchmarks, not for the test suite.
