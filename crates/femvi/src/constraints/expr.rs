//! Holonomic constraints from math expressions, for problem files: one expression g_l(q) per
//! constraint in the coordinates and parameters (the syntax of [`crate::expr`]; no `t` and no
//! velocities: the constraints are holonomic and scleronomic), compiled once and evaluated
//! over any scalar type, so the Jacobian G(q) comes by automatic differentiation; g and G in
//! f64 also come from one compiled tape of the symbolic gradients (`expr/jacobian.rs`), which
//! the RATTLE step and the other first-order jets take.

use super::Constraints;
use crate::expr::{ExprError, JacobianTape, Program};
use crate::lagrangian::Scalar;

/// Constraints g(q) = 0 given by expressions.
#[derive(Debug, Clone)]
pub struct ExprConstraints {
    n: usize,
    programs: Vec<Program>,
    sources: Vec<String>,
    /// g and G compiled (None beyond the expression graph's budget).
    jacobian: Option<JacobianTape>,
}

impl ExprConstraints {
    /// Compiles `sources` (one expression per constraint) in the coordinates and parameters.
    ///
    /// # Errors
    /// [`ExprError`] for a syntax error or an unknown symbol (including `t` and `_dot`
    /// velocities, which holonomic constraints do not have).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::constraints::{Constraints, ExprConstraints};
    /// let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    /// let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - l^2".to_string()], &xyz, &[("l".into(), 2.0)])?;
    /// let mut g = [0.0];
    /// sphere.value(&[0.0, 0.0, 2.0], &mut g);
    /// assert_eq!((sphere.count(), g[0]), (1, 0.0));
    /// assert!(ExprConstraints::new(&["x_dot".to_string()], &xyz, &[]).is_err());
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn new(sources: &[String], coordinates: &[String], parameters: &[(String, f64)]) -> Result<Self, ExprError> {
        let programs = sources
            .iter()
            .map(|s| Program::compile(s, coordinates, parameters))
            .collect::<Result<Vec<_>, _>>()?;
        let n = coordinates.len();
        Ok(Self {
            n,
            jacobian: JacobianTape::new(&programs, n),
            programs,
            sources: sources.to_vec(),
        })
    }

    /// The expressions as given.
    pub fn sources(&self) -> &[String] {
        &self.sources
    }
}

impl Constraints for ExprConstraints {
    fn dim(&self) -> usize {
        self.n
    }

    fn count(&self) -> usize {
        self.programs.len()
    }

    fn value<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        for (o, p) in out.iter_mut().zip(&self.programs) {
            *o = p.eval(|i| q.get(i).copied().unwrap_or(D::from(f64::NAN)));
        }
    }

    fn value_and_jacobian(&self, q: &[f64], g: &mut [f64], jac: &mut [f64]) -> bool {
        self.jacobian.as_ref().is_some_and(|t| t.eval(q, g, jac))
    }

    fn name(&self, l: usize) -> String {
        match self.sources.get(l) {
            Some(src) => format!("constraint {} ('{src}')", l + 1),
            None => format!("constraint {}", l + 1),
        }
    }
}
