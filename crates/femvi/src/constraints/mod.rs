//! Holonomic constraints g(q) = 0 (m of them) for Lagrangians on Rⁿ: the constrained discrete
//! Euler–Lagrange equations with Lagrange multipliers (Marsden–West 2001, §3.5;
//! Leyendecker–Marsden–Ortiz 2008) for Galerkin elements of any degree, in position–momentum
//! form, with the momenta on the cotangent space of the constraint manifold N = {g = 0}.
//!
//! # Derivation
//!
//! The continuous equations come from the action ∫ L − λ·g dt: d/dt ∂L/∂v = ∂L/∂q − G(q)ᵀλ,
//! g(q) = 0, with G = ∂g/∂q. Discretise the constraint term of element k by the end nodes and
//! by evaluation points y_i = Σ_j a_ij Q^j inside the element ([`Enforcement`]): the augmented
//! discrete Lagrangian is
//!
//!   L_d^aug = L_d(Q^0 … Q^s) − λ̂_k·g(Q^0) − Σ_i ω_i Λ(y_i)·g(y_i) − μ̂_k·g(Q^s),
//!
//! with Λ(y_i) = Σ_c Ψ_ic Λ̂_c (the multiplier unknowns are impulses: they absorb h and the
//! quadrature weights). Varying the augmented discrete action Σ_k L_d^aug over paths with
//! nodes on N, and defining the momenta by the discrete Legendre transforms of L_d^aug
//! (p_k = −∂L_d^aug/∂Q^0, p_{k+1} = ∂L_d^aug/∂Q^s), one step maps (q_k, p_k) to
//! (q_{k+1}, p_{k+1}) by solving
//!
//!   p_k + ∂L_d/∂Q^0 − G(q_k)ᵀλ̂_k − Σ_i a_i0 ω_i G(y_i)ᵀΛ(y_i) = 0,
//!   ∂L_d/∂Q^j − Σ_i a_ij ω_i G(y_i)ᵀΛ(y_i) = 0                (0 < j < s),
//!   g(Q^s) = 0,   Σ_i ω_i Ψ_ic g(y_i) = 0                        (every interior site c)
//!
//! for Q^1 … Q^s, λ̂_k, Λ̂ (s n + m + I m unknowns and equations; the sign of the multiplier
//! terms is that of −λ·g in the action, so λ̂ ≈ h·λ/2 for degree 1), and then
//!
//!   p_{k+1} = ∂L_d/∂Q^s − Σ_i a_is ω_i G(y_i)ᵀΛ(y_i) − G(q_{k+1})ᵀμ̂_k,
//!
//! with μ̂_k fixed by the hidden constraint G(q_{k+1}) ∂H/∂p(q_{k+1}, p_{k+1}) = 0 (for
//! L = ½vᵀMv − V: G M⁻¹ p = 0): the momentum is projected onto T*N (module `project`).
//! The node-k multipliers λ̂_k and μ̂_{k−1} are the two halves of the constrained DEL equation
//! at node k, D_s L_d(w_{k−1}) + D_0 L_d(w_k) = G(q_k)ᵀ(λ̂_k + μ̂_{k−1}) + interior terms: the
//! split is fixed by the hidden constraint, which the variational principle leaves free.
//!
//! Degree 1 with the trapezoid rule, L = ½vᵀMv − V: L_d = h(½ΔqᵀMΔq/h² − ½V(q_k) − ½V(q_{k+1})),
//! so the equations read p_{k+1/2} := M(q_{k+1} − q_k)/h = p_k − (h/2)∇V(q_k) − G(q_k)ᵀλ̂_k,
//! g(q_{k+1}) = 0, p_{k+1} = p_{k+1/2} − (h/2)∇V(q_{k+1}) − G(q_{k+1})ᵀμ̂_k, G M⁻¹ p_{k+1} = 0:
//! exactly RATTLE (Andersen 1983; Hairer–Lubich–Wanner VII.1.4) with λ̂ = hλ/2 (tested
//! against a hand-written RATTLE loop).
//!
//! The step map is the discrete Hamiltonian map of L_d restricted to N × N (the interior
//! constraints only restrict the interior unknowns over which L_d is made stationary), so it
//! is symplectic on T*N ([`manifold_symplecticity`] measures it). Each step is solved by dense
//! Newton on (Q^1 … Q^s, λ̂, Λ̂) with exact Jacobians (the element's Hessian, and the constraint
//! derivatives by hyper-dual numbers, `jet.rs`), [`crate::solve::newton_dense`], under the
//! Newton methods and wherever the faster solvers do not fit. For a mechanical Lagrangian
//! without forces, under `Method::Auto` and `Method::FixedPoint`: in the RATTLE case above
//! (also under `Method::Explicit`) by Newton on the m multipliers λ̂ alone and a linear
//! projection (`rattle.rs`); on other elements whose constraints are enforced weakly, at the
//! quadrature points or at the ends, by a fixed-point iteration on the forces with the
//! multipliers from a linearised m(1 + I) system in each sweep (`shake/`, derived there),
//! which under `Method::Auto` hands a step it cannot converge to dense Newton. Explicit and
//! FixedPoint are input errors where their steps do not fit (`rattle::choose` names why).
//!
//! Which interior enforcement keeps the nodal order 2s was measured on the spherical pendulum
//! (README, "Holonomic constraints"): [`Enforcement::Weak`] is the default.
//!
//! Files: `limits.rs` (the start tolerance, the size limit, the rank tolerance), `expr.rs`
//! (constraints from expressions), `jet.rs` (g, G, ∇²g by AD), `layout.rs`
//! (where the constraints are enforced), `step.rs` (the step equations), `project.rs` (the
//! projection onto T*N and the multiplier at a node), `start.rs` (the checked start of a run),
//! `solve.rs` (the run), `stepper.rs` (one step), `rattle.rs` (the RATTLE step on the
//! multipliers, with `small.rs`), `shake/` (the fixed-point step of any degree),
//! `forced.rs` (runs under non-conservative forces, [`solve_constrained_forced`]: the discrete Lagrange–d'Alembert principle on the
//! augmented action, with the energy balance),
//! `forcing.rs` (a force as the constrained step takes it), `tangent.rs` (the step's tangent
//! map and its defect on the manifold), `symplecticity.rs` ([`manifold_symplecticity`]), `chart.rs`
//! (symplectic coordinates on the tangent space of T*N), `chaos_run.rs` (a run carrying
//! tangent vectors, for [`crate::chaos::constrained_indicators`]); `bvp.rs` (constrained
//! two-point boundary value problems, [`solve_constrained_bvp`], with `bvp_assembly.rs`,
//! `bvp_newton.rs` and `bvp_finish.rs`; with forces `bvp_forced.rs`); `term.rs` (the
//! constraints as a term of the one integrator, [`crate::Integrator::with_constraints`], which
//! every constrained run drives) and `observed.rs` (constrained runs with `saveat`, dense
//! output, events and observers, [`solve_constrained_observed`]).

mod bvp;
mod bvp_assembly;
mod bvp_finish;
mod bvp_forced;
mod bvp_newton;
mod chaos_run;
mod chart;
mod expr;
mod forced;
mod forcing;
pub(crate) mod jet;
mod layout;
pub(crate) mod limits;
mod observed;
pub(crate) mod project;
mod rattle;
mod shake;
mod small;
mod solve;
mod start;
mod step;
mod stepper;
mod symplecticity;
mod tangent;
mod term;

pub use bvp::{solve_constrained_bvp, solve_constrained_bvp_with, ConstrainedBvpSolution};
pub use bvp_forced::solve_constrained_forced_bvp;
pub(crate) use chaos_run::ManifoldRun;
pub use expr::ExprConstraints;
pub use forced::{solve_constrained_forced, ForcedConstrainedSolution};
pub use layout::Enforcement;
pub use limits::{MAX_COORDINATES, START_TOLERANCE};
pub use observed::{solve_constrained_forced_observed, solve_constrained_observed};
pub use solve::{solve_constrained, solve_constrained_with, ConstrainedSolution};
pub use symplecticity::{manifold_symplecticity, ManifoldSymplecticity};
pub use term::NodeConstraints;

use crate::lagrangian::Scalar;

/// Holonomic constraints g(q) = 0: m functions of the n coordinates, generic over the scalar
/// type so that the Jacobian G(q) = ∂g/∂q and the second derivatives come by automatic
/// differentiation.
///
/// # Example
///
/// ```
/// use femvi::constraints::Constraints;
/// use femvi::Scalar;
///
/// /// A particle on the sphere |q| = l.
/// struct Sphere { l: f64 }
/// impl Constraints for Sphere {
///     fn dim(&self) -> usize { 3 }
///     fn count(&self) -> usize { 1 }
///     fn value<D: Scalar>(&self, q: &[D], out: &mut [D]) {
///         out[0] = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - self.l * self.l;
///     }
/// }
/// let mut g = [0.0f64];
/// Sphere { l: 1.0 }.value(&[0.6, 0.0, -0.8], &mut g);
/// assert!(g[0].abs() < 1e-15);
/// ```
pub trait Constraints {
    /// Dimension n of the configuration space.
    fn dim(&self) -> usize;

    /// Number of constraints m.
    fn count(&self) -> usize;

    /// g(q) into `out` (m entries), for any scalar type. The library calls it with slices of
    /// lengths [`Constraints::dim`] and [`Constraints::count`] only.
    fn value<D: Scalar>(&self, q: &[D], out: &mut [D]);

    /// g(q) into `g` (m entries) and the Jacobian G(q) = ∂g/∂q row by row into `jac` (m n
    /// entries) in f64, for constraints that have a faster way than automatic
    /// differentiation of [`Constraints::value`] (expression constraints compile it); false,
    /// with nothing written, lets the library differentiate `value`. Default: false.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::constraints::{Constraints, ExprConstraints};
    /// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    /// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[])?;
    /// let (mut g, mut jac) = ([0.0], [0.0; 3]);
    /// assert!(sphere.value_and_jacobian(&[0.6, 0.0, -0.8], &mut g, &mut jac));
    /// assert!(g[0].abs() < 1e-15 && jac == [1.2, 0.0, -1.6]);
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    fn value_and_jacobian(&self, q: &[f64], g: &mut [f64], jac: &mut [f64]) -> bool {
        let _ = (q, g, jac);
        false
    }

    /// How errors name constraint `l` (0-based). Default: "constraint {l + 1}".
    fn name(&self, l: usize) -> String {
        format!("constraint {}", l + 1)
    }
}
