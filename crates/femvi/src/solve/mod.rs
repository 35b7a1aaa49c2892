//! Nonlinear solvers shared by every problem femvi solves: a dense Newton iteration with a
//! backtracking line search (general Lagrangians), and the convergence rules they share.

pub mod newton;

pub use newton::{newton_dense, DenseNewtonWork, NewtonFailure, NewtonReport};
