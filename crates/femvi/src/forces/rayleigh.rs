//! A Rayleigh dissipation function R(t, q, v) given by an expression, with the force
//! F = −∂R/∂v (e.g. R = ½ c v², F = −c v). The derivative is taken by a dual number over
//! whatever scalar the force is evaluated with (nested duals for the step's Jacobian).

use super::expr::{eval, variables};
use super::Force;
use crate::expr::{ExprError, Program};
use crate::lagrangian::Scalar;
use num_dual::Dual;

/// The force −∂R/∂v of a Rayleigh dissipation function.
#[derive(Debug, Clone)]
pub struct Rayleigh {
    program: Program,
    n: usize,
}

impl Rayleigh {
    /// Compiles R from `source` with the coordinate names and parameters.
    ///
    /// # Errors
    /// [`ExprError`] as for [`crate::expr::ExprLagrangian::new`].
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::forces::{Force, Rayleigh};
    ///
    /// let r = Rayleigh::new("0.5*c*x_dot^2", &["x".to_string()], &[("c".into(), 0.3)])?;
    /// let mut f = [0.0f64];
    /// r.force(0.0f64, &[1.0], &[2.0], &mut f);
    /// assert!((f[0] + 0.6).abs() < 1e-15);
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn new(source: &str, coordinates: &[String], parameters: &[(String, f64)]) -> Result<Self, ExprError> {
        let vars = variables(source, coordinates)?;
        let program = Program::compile(source, &vars, parameters).map_err(|mut e| {
            e.message = format!("dissipation: {}", e.message);
            e
        })?;
        Ok(Self {
            program,
            n: coordinates.len(),
        })
    }
}

impl Force for Rayleigh {
    fn dim(&self) -> usize {
        self.n
    }

    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], out: &mut [D]) {
        let td = Dual::from_re(t);
        let qd: Vec<Dual<D>> = q.iter().map(|&x| Dual::from_re(x)).collect();
        let mut vd: Vec<Dual<D>> = v.iter().map(|&x| Dual::from_re(x)).collect();
        for (c, o) in out.iter_mut().enumerate().take(vd.len()) {
            vd[c].eps = D::from(1.0);
            *o = -eval(&self.program, td, &qd, &vd).eps;
            vd[c].eps = D::from(0.0);
        }
    }
}
