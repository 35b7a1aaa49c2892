//! Generalised forces from math expressions, one per coordinate, in t, the coordinates and
//! their `_dot` velocities and named parameters (the syntax of [`crate::expr`]), compiled to
//! [`Program`]s and evaluated over any scalar, so that the step's Jacobian is exact.

use super::Force;
use crate::expr::{ExprError, Program};
use crate::lagrangian::Scalar;

/// The names of the variables of a force or dissipation expression, in the order
/// [`Program::eval`] numbers them: t, the coordinates, their velocities. Errors if two agree.
pub(super) fn variables(source: &str, coordinates: &[String]) -> Result<Vec<String>, ExprError> {
    let mut vars = vec!["t".to_string()];
    vars.extend(coordinates.iter().cloned());
    vars.extend(coordinates.iter().map(|c| format!("{c}_dot")));
    let mut seen = std::collections::HashSet::with_capacity(vars.len());
    if let Some(twice) = vars.iter().find(|v| !seen.insert(v.as_str())) {
        return Err(ExprError::at(
            source,
            0,
            format!("the name '{twice}' is given twice (t, the coordinates and their _dot velocities must all differ)"),
        ));
    }
    Ok(vars)
}

/// Evaluates `program` at (t, q, v) numbered as [`variables`] (NaN for a short slice).
pub(super) fn eval<D: Scalar>(program: &Program, t: D, q: &[D], v: &[D]) -> D {
    let n = q.len();
    let nan = D::from(f64::NAN);
    program.eval(|i| {
        if i == 0 {
            t
        } else if i <= n {
            q.get(i - 1).copied().unwrap_or(nan)
        } else {
            v.get(i - 1 - n).copied().unwrap_or(nan)
        }
    })
}

/// Forces F_c(t, q, v) given by one expression per coordinate.
#[derive(Debug, Clone)]
pub struct ExprForces {
    programs: Vec<Program>,
    velocity: bool,
}

impl ExprForces {
    /// Compiles one expression per coordinate.
    ///
    /// # Errors
    /// [`ExprError`]: a count of expressions other than the number of coordinates, or an
    /// error in an expression (its message names the coordinate).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::forces::{ExprForces, Force};
    ///
    /// let x = ["x".to_string()];
    /// let f = ExprForces::new(&["-c*x_dot + f0*cos(w*t)"], &x, &[("c".into(), 0.1), ("f0".into(), 2.0), ("w".into(), 0.0)])?;
    /// let mut out = [0.0f64];
    /// f.force(0.0f64, &[0.0], &[1.0], &mut out);
    /// assert!((out[0] - 1.9).abs() < 1e-15);
    /// assert!(ExprForces::new(&["x", "x"], &x, &[]).is_err()); // two forces, one coordinate
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    pub fn new<S: AsRef<str>>(
        sources: &[S],
        coordinates: &[String],
        parameters: &[(String, f64)],
    ) -> Result<Self, ExprError> {
        if sources.len() != coordinates.len() {
            return Err(ExprError::at(
                "",
                0,
                format!(
                    "{} force expressions for {} coordinates (one per coordinate, in their order)",
                    sources.len(),
                    coordinates.len()
                ),
            ));
        }
        let mut programs = Vec::with_capacity(sources.len());
        for (src, name) in sources.iter().zip(coordinates) {
            let src = src.as_ref();
            let vars = variables(src, coordinates)?;
            let program = Program::compile(src, &vars, parameters).map_err(|mut e| {
                e.message = format!("force on {name}: {}", e.message);
                e
            })?;
            programs.push(program);
        }
        let n = coordinates.len();
        let velocity = programs.iter().any(|p| (1 + n..1 + 2 * n).any(|i| p.uses_variable(i)));
        Ok(Self { programs, velocity })
    }
}

impl Force for ExprForces {
    fn dim(&self) -> usize {
        self.programs.len()
    }

    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], out: &mut [D]) {
        for (o, p) in out.iter_mut().zip(&self.programs) {
            *o = eval(p, t, q, v);
        }
    }

    fn depends_on_velocity(&self) -> bool {
        self.velocity
    }
}
