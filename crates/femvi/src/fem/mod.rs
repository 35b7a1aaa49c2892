//! Finite element building blocks on the reference element τ ∈ [0, 1]: Lagrange bases
//! (the shape functions of the paper's (2.24)–(2.25) and (2.34)–(2.37), for any degree)
//! and quadrature rules that turn the element integral (2.27)/(2.39b) into a sum.

pub mod basis;
pub(crate) mod dd;
pub mod quadrature;

pub use basis::{LagrangeBasis, NodeFamily, MAX_DEGREE};
pub use quadrature::{QuadratureKind, QuadratureRule, MAX_POINTS};
