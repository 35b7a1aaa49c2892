//! Nonlinear solvers shared by every problem femvi solves: a dense Newton iteration with a
//! backtracking line search (general Lagrangians), a simplified Newton iteration with a kept
//! factorisation (the fast path of general Lagrangians), and a banded LU for boundary value
//! problems.

pub mod banded;
mod frozen;
pub mod newton;
pub mod simplified;

pub use banded::BandMatrix;
pub use newton::{newton_dense, DenseNewtonWork, NewtonFailure, NewtonReport};
pub use simplified::{simplified_newton, FrozenJacobian, Simplified};
