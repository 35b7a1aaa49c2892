//! Constrained initial value runs with non-conservative forces: the discrete
//! Lagrange–d'Alembert principle (Marsden–West 2001, §3.2) on the augmented action of
//! [`crate::constraints`] (§3.5). The virtual work of F over element k, by the element's own
//! quadrature and basis, adds the discrete forces
//!
//!   F_d^j = h Σ_i b_i F(t_k + c_i h, q_h(c_i), q̇_h(c_i)) ℓ_j(c_i)
//!
//! to node row j of the constrained step equations (`step.rs`; the same term as the forced and
//! the constrained forced boundary value problems, [`crate::forces`]), with its exact Jacobian
//! by dual numbers, so one step from (q_k, p_k) solves
//!
//!   p_k + ∂L_d/∂Q^0 + F_d^0 − G(q_k)ᵀλ̂_k − Σ_i a_i0 ω_i G(y_i)ᵀΛ(y_i) = 0,
//!   ∂L_d/∂Q^j + F_d^j − Σ_i a_ij ω_i G(y_i)ᵀΛ(y_i) = 0          (0 < j < s),
//!   g(Q^s) = 0,   Σ_i ω_i Ψ_ic g(y_i) = 0,
//!
//! and p_{k+1} = ∂L_d/∂Q^s + F_d^s − Σ_i a_is ω_i G(y_i)ᵀΛ(y_i) − G(q_{k+1})ᵀμ̂_k, μ̂_k fixed by
//! the hidden constraint as without forces (the momentum projected onto T*N). Summing the node
//! rows, p_{k+1} − p_k = h Σ_i b_i (∂L/∂q + F)(c_i) − constraint impulses.
//!
//! Energy balance: along the exact flow dH/dt = F·q̇ − ∂L/∂t (the constraint force does no
//! work, Gq̇ = 0). The run accumulates the discrete work of each element as in
//! [`crate::forces`], ΔW_k = h Σ_i b_i F(c_i)·q̇_h(c_i) − h Σ_i b_i ∂L/∂t(c_i), and reports
//! max_k |H_k − H_0 − W_k| over every node (H_k = H(q_k, p_k), as every run's energy). The
//! steps are those of the constraints' term of the one integrator with the force
//! ([`crate::Integrator::with_constraints_and_force`]). The multipliers reported per node are those of the exact forced flow at the
//! node state (`project.rs`, with F in the right-hand side).

use super::forcing::Forcing;
use super::layout::Enforcement;
use super::solve::{run_terms, ConstrainedSolution};
use super::Constraints;
use crate::discrete::Element;
use crate::error::{check_len, Result};
use crate::forces::{EnergyBalance, Force};
use crate::lagrangian::Lagrangian;
use crate::solution::{EnergyReport, Problem, SolveOptions};

/// A constrained run under non-conservative forces ([`solve_constrained_forced`]).
#[derive(Debug, Clone)]
pub struct ForcedConstrainedSolution {
    /// Nodes, momenta, energies, multipliers and constraint residuals as for
    /// [`super::solve_constrained_with`]; the multipliers are those of the forced flow, and
    /// `solution.energy_report` holds the largest relative change of H and, as
    /// `max_rel_balance`, the balance's relative error.
    pub constrained: ConstrainedSolution,
    /// W_k at the kept nodes: the discrete work of F along the element polynomials (and
    /// −∫∂L/∂t for a time-dependent L), by the element's quadrature, accumulated from t0.
    pub work: Vec<f64>,
    /// max |H_k − H_0 − W_k| over every node (absolute and relative to |H_0|).
    pub balance: EnergyBalance,
}

/// Integrates a constrained problem under the non-conservative force `force`: the
/// constrained step of [`super::solve_constrained_with`] with the discrete forces added to every
/// node row (module documentation), solved by dense Newton with the exact Jacobian. The
/// options, the checks of the start (on the manifold, its momentum projected onto T*N) and the
/// results are those of [`super::solve_constrained_with`], plus the discrete work and the energy
/// balance. A zero force gives the unforced run bit for bit (tested).
///
/// # Errors
/// As [`super::solve_constrained_with`]; also a force whose dimension is not the Lagrangian's.
///
/// # Example
///
/// A spherical pendulum with linear friction −c v, in Cartesian coordinates: the energy decays
/// by the work of the friction, the position stays on the sphere.
///
/// ```
/// use femvi::constraints::{solve_constrained_forced, Enforcement, ExprConstraints};
/// use femvi::expr::ExprLagrangian;
/// use femvi::forces::LinearForce;
/// use femvi::{Element, Problem, SolveOptions, Start};
///
/// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
/// let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z", &xyz, &[])?;
/// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[])?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 1.0, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 5.0);
/// let friction = LinearForce::damping(3, 0.5);
/// let run = solve_constrained_forced(&problem, &friction, &sphere, &Element::with_order(4)?, &SolveOptions::step(0.01), Enforcement::default())?;
/// let sol = &run.constrained.solution;
/// assert!(sol.error.is_none() && run.constrained.max_residual < 1e-13);
/// assert!(sol.energy.last().unwrap() < sol.energy.first().unwrap());
/// assert!(run.balance.max_abs < 1e-8);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn solve_constrained_forced<L: Lagrangian + Sync, F: Force + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    force: &F,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
) -> Result<ForcedConstrainedSolution> {
    let n = problem.lagrangian.dim();
    check_len("force", n, force.dim())?;
    let forcing = Box::new(Forcing::new(force, element, n));
    let mut run = run_terms(
        problem,
        constraints,
        element,
        options,
        (enforcement, false),
        Some(forcing),
    )?;
    run.constrained.solution.energy_report = Some(EnergyReport {
        max_rel_error: run.max_rel_change,
        max_rel_balance: Some(run.balance.max_rel),
        nodes: crate::solution::EnergyNodes::Every,
    });
    Ok(ForcedConstrainedSolution {
        constrained: run.constrained,
        work: run.work,
        balance: run.balance,
    })
}
