//! femvi-cli's integration tests as one test binary (one link instead of one per file): each
//! file is a module, e.g. `cargo test -p femvi-cli --test all -- resume::`. They run the
//! `femvi` binary (`assert_cmd`'s `cargo_bin`, `CARGO_BIN_EXE_femvi`) as child processes, so
//! the signals they send and the directories they use are the children's, not this process's.
//!
//! A new test file goes in this directory with its `mod` line below.

mod adaptive;
mod capabilities;
mod chaos;
mod chaos_forced_constrained;
mod chunked_runs;
mod cli;
mod constrained_bvp;
mod constraints;
mod constraints_forced;
mod defects;
mod diagnostics;
mod ensemble;
mod events_plots;
mod forced_commands;
mod forces;
mod fuzz_problems;
mod fuzz_terms;
mod optimize;
mod problem_input;
mod problem_reference;
mod resume;
mod rotations;
mod rotations_chain;
mod rotations_commands;
mod stopped_runs;
