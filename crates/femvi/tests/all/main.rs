//! femvi's integration tests as one test binary (one link instead of one per file; see
//! `cargo test -p femvi --test all -- --list`). Each file is a module: run one with
//! `cargo test -p femvi --test all -- golden::`. `tests/allocation.rs` stays a binary of its
//! own: its counting global allocator would otherwise serve every test here.
//!
//! A new test file goes in this directory with its `mod` line below; shared helpers are in
//! `common/` (`use crate::common::...`).

mod common;

mod adaptive;
mod adaptive_drift;
mod adaptive_events;
mod adaptive_fixed_point;
mod adaptive_kepler;
mod advance_observed;
mod auto_step;
mod bvp;
mod bvp_scale;
mod chaos;
mod chaos_forced_constrained;
mod chaos_forced_on_manifold;
mod conservation;
mod constrained_bvp;
mod constrained_term;
mod constraint_jacobian;
mod constraints;
mod constraints_forced;
mod constraints_rattle;
mod constraints_shake;
mod convergence;
mod energy;
mod explicit_blocked;
mod explicit_wide;
mod expr_compiled;
mod forces;
mod forces_energy;
mod forces_energy_observed;
mod forces_fixed_point;
mod forces_newton;
mod fuzz_expr;
mod general_newton;
mod golden;
mod golden_terms;
mod gyroscopic;
mod hostile;
mod legendre_regular;
mod model_params;
mod optimize;
mod optimize_constraints;
mod optimize_ends;
mod paper_formulas;
mod rattle_exact;
mod rotations;
mod rotations_chaos;
mod rotations_dense;
mod rotations_forced;
mod setup_scale;
mod solution;
mod solver;
mod streaming;
mod symplectic;
mod tangent_routes;
