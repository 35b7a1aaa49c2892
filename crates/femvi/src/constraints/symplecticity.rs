//! [`manifold_symplecticity`]: a constrained run that measures the symplecticity defect of every
//! step's tangent map on the tangent space of T*N (the tangent map and the defect are
//! `tangent.rs`'s; the run is the one integrator with the constraints' term, `term.rs`).

use super::layout::Enforcement;
use super::solve::{run_constrained, ConstrainedSolution};
use super::Constraints;
use crate::discrete::Element;
use crate::error::Result;
use crate::lagrangian::Lagrangian;
use crate::solution::{Problem, SolveOptions};

/// The symplecticity defect of a constrained run on its manifold.
#[derive(Debug, Clone)]
pub struct ManifoldSymplecticity {
    /// max over the steps of max |(ΦB)ᵀJ(ΦB) − BᵀJB| (B orthonormal, so BᵀJB is O(1)).
    pub max_defect: f64,
    /// Steps checked.
    pub steps: usize,
    /// The run itself.
    pub run: ConstrainedSolution,
}

/// Runs the constrained problem and measures the symplecticity defect of every step's tangent
/// map on the tangent space of T*N (module doc).
///
/// # Errors
/// As [`super::solve_constrained_with`].
///
/// # Example
///
/// ```
/// use femvi::constraints::{manifold_symplecticity, Enforcement, ExprConstraints};
/// use femvi::expr::ExprLagrangian;
/// use femvi::{Element, Problem, SolveOptions, Start};
///
/// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
/// let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - z", &xyz, &[])?;
/// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[])?;
/// let start = Start::Velocity { q: vec![0.6, 0.0, -0.8], v: vec![0.0, 1.0, 0.0] };
/// let problem = Problem::new(lag, start, 0.0, 0.5);
/// let check = manifold_symplecticity(&problem, &sphere, &Element::with_order(4)?, &SolveOptions::step(0.05), Enforcement::Weak)?;
/// assert!(check.max_defect < 1e-12 && check.steps == 10);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn manifold_symplecticity<L: Lagrangian + Sync, C: Constraints + Sync>(
    problem: &Problem<L>,
    constraints: &C,
    element: &Element,
    options: &SolveOptions,
    enforcement: Enforcement,
) -> Result<ManifoldSymplecticity> {
    let (run, defect) = run_constrained(problem, constraints, element, options, enforcement, true)?;
    let steps = run.solution.steps;
    Ok(ManifoldSymplecticity {
        max_defect: defect.unwrap_or(f64::NAN),
        steps,
        run,
    })
}
