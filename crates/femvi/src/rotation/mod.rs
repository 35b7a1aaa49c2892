//! Rotations as configuration variables (issue 37): rigid bodies whose configuration holds
//! R ∈ SO(3) (body to space; Ṙ = R ŵ with w the body angular velocity, DESIGN.md), stepped by
//! Lie-group Galerkin elements of any degree (Hall and Leok, *Lie group spectral variational
//! integrators*, FoCM 17 (2017); Bou-Rabee and Marsden, FoCM 9 (2009)).
//!
//! # The element
//!
//! A rotation is stored as nine coordinates (the entries of R, row-major), so that a run
//! with rotations is an ordinary run of the Lagrangian on the embedding, L̃(R, Ṙ) =
//! L(R, w(R, Ṙ)), with every output, event and checkpoint of one. On the element
//! [t_k, t_k + h] the path is R(τ) = R_k exp(ξ̂(τ)), ξ(τ) = Σ_j ξ^j ℓ_j(τ) a polynomial of
//! degree s in the algebra with ξ^0 = 0 (the paper's Lagrange basis and quadrature, as for
//! coordinates), w(τ) = (1/h) dexp_{−ξ(τ)} ξ′(τ), and
//!
//!   L_d(R_k, R_{k+1}) = ext over ξ^1 … ξ^{s−1} of h Σ_i b_i L(t_k + c_i h, R(c_i), w(c_i)),
//!   R_{k+1} = R_k exp(ξ̂^s).
//!
//! The discrete Legendre transforms, left-trivialised, give the body angular momenta
//! μ_k = −T*L_{R_k} D₁L_d and μ_{k+1} = T*L_{R_{k+1}} D₂L_d. Moving R_k moves the chart's
//! centre: with R_k → R_k exp(εη̂) and R_{k+1} fixed, ξ^s changes by −ε dexp_{ξ^s}⁻¹ η, so
//! D₁L_d is the derivative of the quadrature along the path R_k exp(η̂) exp(ζ̂(τ)) with
//! ζ^s = ξ^s − dexp_{ξ^s}⁻¹ η (`action.rs`); the internal nodes are stationary, so any
//! variation of them gives the same derivative. The step solves
//!
//!   μ_k + ∂S/∂η = 0,   ∂S/∂ξ^j = 0 (0 < j < s)
//!
//! for ξ^1 … ξ^s (`step.rs`), then μ_{k+1} = dexp_{ξ^s}⁻¹ ∂S/∂ξ^s. Ordinary coordinates in
//! the same configuration take the paper's element beside them. On the embedding the node's
//! momentum is P = ∂L̃/∂Ṙ = ½ R μ̂ (since ∂w/∂Ṙ · δṘ = vee(skew(RᵀδṘ)) and
//! Π·vee(A) = ½ tr(Π̂ᵀA)), the projected momentum of the nine coordinates under RᵀR = 1.
//!
//! Being a variational integrator on the group, the map is symplectic on T*SO(3), keeps
//! R_k on SO(3) by construction (to the round-off of the products R_k exp(ξ̂)), and conserves
//! the momentum maps of the Lagrangian's symmetries: for a free body, the spatial angular
//! momentum R Π, hence |Π|, to the solver's tolerance.
//!
//! # The Lagrangian on the embedding
//!
//! Only the values of L̃ on T SO(3) matter to the element. For the Legendre transform of the
//! run's start and energy, L̃ should be regular on all of R⁹; [`crate::models::RigidBody`]
//! adds ½ c |sym(RᵀṘ)|², which vanishes with its first derivatives on T SO(3), so that the
//! nine-by-nine Hessian in Ṙ is regular without changing the motion.

mod action;
mod body;
mod body_state;
pub(crate) mod dense;
mod layout;
mod run;
pub mod so3;
mod step;
mod tangent;
mod term;

pub use body_state::{body_states, BodyState};
pub use layout::Rotations;
pub use run::{body_state, embedded_velocity, ORTHOGONALITY_TOLERANCE};
