//! The `[forces]` table: non-conservative forces (issue 19), as one expression per coordinate
//! (`generalized = ["-c*x_dot + f0*cos(w*t)", ...]`) and/or a Rayleigh dissipation function
//! (`dissipation = "0.5*c*x_dot^2"`, F = −∂R/∂v), in t, the coordinates, their `_dot`
//! velocities and the `[system]` parameters. Compiled once when the problem is loaded (errors
//! point into the file) into [`super::Terms::force`], which the commands that run it use
//! (`femvi run`, `check`, `bvp`, `chaos`, `ensemble`).

use super::errors::{bad, InputError, Source};
use femvi::expr::ExprError;
use femvi::forces::{ExprForces, Force, Rayleigh, Sum};
use femvi::Scalar;
use serde::Deserialize;

/// `[forces]` as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForcesTable {
    /// One force expression per coordinate, in their order.
    pub generalized: Option<Vec<toml::Spanned<String>>>,
    /// A Rayleigh dissipation function R(t, q, q_dot); the force is −∂R/∂q_dot.
    pub dissipation: Option<toml::Spanned<String>>,
    /// Torques on rotations, in their body frames: `{ R = ["τ1", "τ2", "τ3"] }`
    /// (`problem/torques.rs`).
    pub torques: Option<super::torques::TorqueTable>,
}

/// The force a problem file describes.
#[derive(Debug, Clone)]
pub enum ProblemForce {
    /// `generalized` only.
    Generalized(ExprForces),
    /// `dissipation` only.
    Dissipation(Rayleigh),
    /// Both, added.
    Both(Sum<ExprForces, Rayleigh>),
}

impl Force for ProblemForce {
    fn dim(&self) -> usize {
        match self {
            ProblemForce::Generalized(f) => f.dim(),
            ProblemForce::Dissipation(f) => f.dim(),
            ProblemForce::Both(f) => f.dim(),
        }
    }
    fn force<D: Scalar>(&self, t: D, q: &[D], v: &[D], out: &mut [D]) {
        match self {
            ProblemForce::Generalized(f) => f.force(t, q, v, out),
            ProblemForce::Dissipation(f) => f.force(t, q, v, out),
            ProblemForce::Both(f) => f.force(t, q, v, out),
        }
    }
    fn depends_on_velocity(&self) -> bool {
        match self {
            ProblemForce::Generalized(f) => f.depends_on_velocity(),
            ProblemForce::Dissipation(f) => f.depends_on_velocity(),
            ProblemForce::Both(f) => f.depends_on_velocity(),
        }
    }
}

impl ForcesTable {
    /// Checks the table and compiles its force for the coordinates and parameters.
    ///
    /// # Errors
    /// An empty table, a count of `generalized` expressions other than the number of
    /// coordinates, or an error in an expression (pointing into the file).
    pub fn resolve(
        &self,
        (coordinates, rotations): (&[String], &[String]),
        params: &[(String, f64)],
        src: &Source,
    ) -> Result<ProblemForce, InputError> {
        if !rotations.is_empty() {
            return self.resolve_with_rotations((coordinates, rotations), params, src);
        }
        if self.torques.is_some() {
            return Err(src.error("[forces] torques act on rotations: the system has none ([system] rotations)"));
        }
        let generalized = match &self.generalized {
            Some(list) => {
                if list.len() != coordinates.len() {
                    return Err(src.error(format!(
                        "[forces] generalized has {} expressions for {} coordinates [{}]: give one per coordinate, in their order",
                        list.len(),
                        coordinates.len(),
                        coordinates.join(", ")
                    )));
                }
                let sources: Vec<&str> = list.iter().map(|s| s.get_ref().as_str()).collect();
                // Compile one by one first, so that an error points at its own string.
                for (i, s) in list.iter().enumerate() {
                    let mut one = vec!["0"; coordinates.len()];
                    one[i] = s.get_ref();
                    ExprForces::new(&one, coordinates, params).map_err(|e| located(src, s, &e))?;
                }
                Some(ExprForces::new(&sources, coordinates, params).map_err(|e| src.error(e.render()))?)
            }
            None => None,
        };
        let dissipation = match &self.dissipation {
            Some(r) => Some(Rayleigh::new(r.get_ref(), coordinates, params).map_err(|e| located(src, r, &e))?),
            None => None,
        };
        combine(generalized, dissipation, src)
    }

    /// [`ForcesTable::resolve`] for a system with rotations: the expressions written out in
    /// the rotations' entries, the torques added to `generalized`.
    fn resolve_with_rotations(
        &self,
        (coordinates, rotations): (&[String], &[String]),
        params: &[(String, f64)],
        src: &Source,
    ) -> Result<ProblemForce, InputError> {
        let given = self.generalized.is_some() || self.torques.is_some();
        let generalized = if given {
            let list = super::torques::generalized(
                self.generalized.as_deref(),
                self.torques.as_ref(),
                (coordinates, rotations),
                src,
            )?;
            let refs: Vec<&str> = list.iter().map(String::as_str).collect();
            let compiled = ExprForces::new(&refs, coordinates, params);
            Some(compiled.map_err(|e| src.error(format!("in [forces]: {}", e.message)))?)
        } else {
            None
        };
        let dissipation = match &self.dissipation {
            Some(r) => {
                let text = super::rotations::substitute(r.get_ref(), rotations);
                let compiled = Rayleigh::new(&text, coordinates, params);
                Some(compiled.map_err(|e| src.error(format!("in [forces] dissipation: {}", e.message)))?)
            }
            None => None,
        };
        combine(generalized, dissipation, src)
    }
}

/// The force of `generalized` and `dissipation`, added if both.
fn combine(
    generalized: Option<ExprForces>,
    dissipation: Option<Rayleigh>,
    src: &Source,
) -> Result<ProblemForce, InputError> {
    match (generalized, dissipation) {
        (Some(g), Some(d)) => Ok(ProblemForce::Both(Sum(g, d))),
        (Some(g), None) => Ok(ProblemForce::Generalized(g)),
        (None, Some(d)) => Ok(ProblemForce::Dissipation(d)),
        (None, None) => Err(src.error(
            "[forces] needs `generalized` (one expression per coordinate), `dissipation` (a Rayleigh function) or `torques` (on rotations)",
        )),
    }
}

/// An expression error at its position in the file (when the string has no escapes).
fn located(src: &Source, expr: &toml::Spanned<String>, e: &ExprError) -> InputError {
    let span = expr.span();
    let raw = src.text.get(span.clone()).unwrap_or("");
    let inner = raw.get(1..raw.len().saturating_sub(1)).unwrap_or("");
    if inner == expr.get_ref() && !raw.starts_with("\"\"\"") && !raw.starts_with("'''") {
        bad(src.excerpt(span.start + 1 + e.offset, &format!("in [forces]: {}", e.message)))
    } else {
        src.error(format!("in [forces]: {}", e.render()))
    }
}
