//! What a run with rotations reports of each rotation at a node, in the body frame
//! ([`crate::Integrator::node_rotations`]).

/// A rotation's state at a node, in the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyState {
    /// The body angular velocity w (Ṙ = R ŵ), from the inverse Legendre transform of the
    /// node's momentum (NaN where it does not converge).
    pub w: [f64; 3],
    /// The body angular momentum Π = 2 vee(RᵀP).
    pub pi: [f64; 3],
}
