//! `[constraints]`: holonomic constraints g(q) = 0, one expression per constraint in the
//! coordinates and the system's parameters (`holonomic = ["x^2 + y^2 + z^2 - l^2"]`), and
//! where the elements enforce them inside (`enforcement = "weak"` (default), "nodes", "ends"
//! or "points"; [`femvi::constraints::Enforcement`]).

use super::errors::{InputError, Source};
use femvi::constraints::{Enforcement, ExprConstraints};
use serde::Deserialize;

/// `[constraints]` as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintsTable {
    /// One expression g_l(q) per constraint.
    pub holonomic: Vec<String>,
    /// "weak", "nodes", "ends" or "points".
    pub enforcement: Option<String>,
}

impl ConstraintsTable {
    /// The compiled constraints and the enforcement.
    ///
    /// # Errors
    /// No constraints, as many constraints as coordinates or more, an expression that does not
    /// compile (with its position), or an unknown enforcement.
    pub fn resolve(
        &self,
        coordinates: &[String],
        parameters: &[(String, f64)],
        src: &Source,
    ) -> Result<(ExprConstraints, Enforcement), InputError> {
        if self.holonomic.is_empty() || self.holonomic.len() >= coordinates.len() {
            return Err(src.error(format!(
                "[constraints] holonomic needs from 1 to {} expressions (fewer than the coordinates), got {}",
                coordinates.len().saturating_sub(1),
                self.holonomic.len()
            )));
        }
        let constraints = ExprConstraints::new(&self.holonomic, coordinates, parameters)
            .map_err(|e| src.error(format!("[constraints] holonomic: {}", e.render())))?;
        let enforcement = match self.enforcement.as_deref() {
            None | Some("weak") => Enforcement::Weak,
            Some("nodes") => Enforcement::Nodes,
            Some("ends") => Enforcement::Ends,
            Some("points") => Enforcement::Points,
            Some(other) => {
                return Err(src.error(format!(
                    "[constraints] enforcement = \"{other}\": expected \"weak\", \"nodes\", \"ends\" or \"points\""
                )))
            }
        };
        Ok((constraints, enforcement))
    }
}
