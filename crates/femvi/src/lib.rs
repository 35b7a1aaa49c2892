//! femvi: discrete mechanics from finite elements (Chen, Guo, Wu, "Discrete Mechanics Based
//! on Finite Element Methods"). Variational integrators whose discrete Lagrangian comes from
//! interpolating the path with piecewise polynomials of any degree and integrating the
//! Lagrangian with a quadrature rule.
//!
//! Start with [`solution`]: [`solve()`] runs a [`Problem`] to a [`Solution`] (the README has
//! a quick start). The modules read like a table of contents: [`lagrangian`] (continuous systems),
//! [`bvp`] (two-point boundary value problems by the discrete variational principle),
//! [`constraints`] (holonomic constraints with multipliers; RATTLE at degree 1),
//! [`fem`] (bases, quadrature), [`forces`] (non-conservative forces, discrete
//! Lagrange–d'Alembert), [`discrete`] (the element: L_d, its derivatives, discrete
//! Legendre transforms and energies), [`mod@solve`] (nonlinear solvers), [`step`] (the discrete
//! flow with time steps as parameters and as variables, checkpoints, the run driver), [`diagnostics`] (symplecticity,
//! orders), [`expr`] (Lagrangians from math expressions) and
//! [`models`] (built-in systems).
#![deny(missing_docs)]

pub mod adaptive;
pub mod bvp;
pub mod chaos;
pub mod constraints;
pub mod diagnostics;
pub mod discrete;
pub mod ensemble;
pub mod error;
pub mod expr;
pub mod fem;
pub mod forces;
pub mod lagrangian;
pub mod models;
pub mod optimize;
pub mod rotation;
mod slices;
pub mod solution;
pub mod solve;
pub mod step;
#[cfg(test)]
mod testing;

pub use adaptive::{solve_adaptive, AdaptiveOptions, AdaptiveSolution};
pub use discrete::{Element, ElementWork};
pub use error::{Error, Result, StepError, StepFailure};
pub use fem::{NodeFamily, QuadratureKind};
pub use lagrangian::{Lagrangian, Lanes, MassMatrix, Mechanical, Potential, Scalar, LANES};
pub use solution::{solve, Problem, Solution, SolveOptions, Steps};
pub use step::{Degenerate, EnergyOptions, EnergyStats, Integrator, Method, SolverOptions, Start, TimeGrid};

/// The README's Rust blocks, compiled and run as doc-tests.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
