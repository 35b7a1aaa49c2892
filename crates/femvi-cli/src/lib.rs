//! The `femvi` command's machinery as a library, so that other front ends (the Python
//! package) load problem files and run them exactly as the command does: [`problem`]
//! (problem files, table by table, into library types), [`run`] (a run with its outputs as
//! observers, [`record`]; stopped runs and resume: [`signals`], [`resume`], [`summary`],
//! [`estimate`]), [`check`] (one `femvi check` for every kind of problem), [`convergence`], [`bvp`], [`models`] (the model
//! catalogue's text), [`plot`]. `main.rs` is only the argument parsing and exit codes.

pub mod adaptive;
pub mod bounded;
pub mod bvp;
pub mod bvp_constrained;
pub mod bvp_output;
pub mod chaos;
pub mod chaos_command;
pub mod chaos_forced;
pub mod chaos_plot;
pub mod check;
pub mod constrained;
pub mod convergence;
pub mod ensemble;
pub mod estimate;
pub mod events;
pub mod models;
pub mod models_forced;
pub mod optimize;
pub mod outcome;
pub mod plot;
pub mod problem;
pub mod record;
pub mod reference;
pub mod resume;
pub mod run;
pub mod run_output;
pub mod signals;
pub mod summary;

/// Exit code of a numerical failure.
pub const NUMERICAL: u8 = 1;
/// Exit code of bad input.
pub const BAD_INPUT: u8 = 2;
