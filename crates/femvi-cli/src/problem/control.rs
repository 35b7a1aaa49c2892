//! The `[controls]` and `[objective]` tables of an optimal control problem (`femvi optimize`):
//! control names, the generalised force through which they act, their bounds, and the
//! running and terminal costs and the weight of the final time, and the `[coordinate_bounds]`
//! table. Checked and compiled into the library's [`ExprControls`].

use super::errors::{InputError, Source};
use femvi::optimize::ExprControls;
use serde::Deserialize;

/// `[controls]` as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControlsTable {
    /// Control names (usable in the force and cost expressions).
    pub names: Vec<String>,
    /// The generalised force, one expression per coordinate in t, q, v and the controls.
    pub force: Vec<String>,
    /// Lower bounds, one per control (default: none).
    pub lower: Option<Vec<f64>>,
    /// Upper bounds, one per control (default: none).
    pub upper: Option<Vec<f64>>,
}

/// `[objective]` as written.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectiveTable {
    /// The running cost C(t, q, v, u) (default 0).
    pub running: Option<String>,
    /// The weight w of w·t1 (default 0; with a free t1 and no running cost, minimum time).
    pub time: Option<f64>,
    /// The terminal cost Φ(t, q, v) in the end state (default none).
    pub terminal: Option<String>,
}

/// `[coordinate_bounds]` as written: bounds held by the coordinates at every node.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoordinateBoundsTable {
    /// Lower bounds, one per coordinate (`-inf` for none; default: none).
    pub lower: Option<Vec<f64>>,
    /// Upper bounds, one per coordinate (`inf` for none; default: none).
    pub upper: Option<Vec<f64>>,
}

impl CoordinateBoundsTable {
    /// The bounds for `coordinates`, checked (n entries each, lower below upper).
    pub fn resolve(&self, coordinates: &[String], src: &Source) -> Result<(Vec<f64>, Vec<f64>), InputError> {
        let n = coordinates.len();
        let side = |b: &Option<Vec<f64>>, what: &str, default: f64| -> Result<Vec<f64>, InputError> {
            match b {
                None => Ok(vec![default; n]),
                Some(v) if v.len() == n => Ok(v.clone()),
                Some(v) => Err(src.error(format!(
                    "[coordinate_bounds] {what} has {} entries for {n} coordinates",
                    v.len()
                ))),
            }
        };
        let lower = side(&self.lower, "lower", f64::NEG_INFINITY)?;
        let upper = side(&self.upper, "upper", f64::INFINITY)?;
        if let Some(c) = (0..n).find(|&c| lower[c].is_nan() || upper[c].is_nan() || lower[c] >= upper[c]) {
            return Err(src.error(format!(
                "[coordinate_bounds] bounds of '{}': lower {} is not below upper {}",
                coordinates[c], lower[c], upper[c]
            )));
        }
        Ok((lower, upper))
    }
}

/// The checked controls and objective.
#[derive(Debug, Clone)]
pub struct ControlSpec {
    /// Control names.
    pub names: Vec<String>,
    /// The compiled force and running cost.
    pub controls: ExprControls,
    /// Lower bounds (−∞ for none).
    pub lower: Vec<f64>,
    /// Upper bounds (+∞ for none).
    pub upper: Vec<f64>,
    /// The weight of t1.
    pub time_weight: f64,
}

impl ControlsTable {
    /// Compiles the controls with the objective for the given coordinates and parameters.
    pub fn resolve(
        &self,
        objective: Option<&ObjectiveTable>,
        coordinates: &[String],
        parameters: &[(String, f64)],
        src: &Source,
    ) -> Result<ControlSpec, InputError> {
        let m = self.names.len();
        if m == 0 {
            return Err(src.error("[controls] names is empty: name at least one control"));
        }
        // The controls are columns of trajectory.csv beside step, t, the coordinates and p_<q>.
        let taken = |name: &str| {
            name == "step"
                || coordinates
                    .iter()
                    .any(|c| name == c.as_str() || name == format!("p_{c}"))
        };
        if let Some(name) = self.names.iter().find(|n| taken(n)) {
            return Err(src.error(format!(
                "[controls] a control is named '{name}', the name of a column of trajectory.csv (step, t, a coordinate or p_<coordinate>): rename it"
            )));
        }
        let bounds = |b: &Option<Vec<f64>>, what: &str, default: f64| -> Result<Vec<f64>, InputError> {
            match b {
                None => Ok(vec![default; m]),
                Some(v) if v.len() == m => Ok(v.clone()),
                Some(v) => Err(src.error(format!("[controls] {what} has {} entries for {m} controls", v.len()))),
            }
        };
        let lower = bounds(&self.lower, "lower", f64::NEG_INFINITY)?;
        let upper = bounds(&self.upper, "upper", f64::INFINITY)?;
        if let Some(c) = (0..m).find(|&c| lower[c].is_nan() || upper[c].is_nan() || lower[c] >= upper[c]) {
            return Err(src.error(format!(
                "[controls] bounds of '{}': lower {} is not below upper {}",
                self.names[c], lower[c], upper[c]
            )));
        }
        let empty = ObjectiveTable::default();
        let objective = objective.unwrap_or(&empty);
        let running = objective.running.clone().unwrap_or_else(|| "0".to_string());
        let time_weight = objective.time.unwrap_or(0.0);
        if !time_weight.is_finite() {
            return Err(src.error("[objective] time must be a finite number"));
        }
        let mut controls = ExprControls::new(coordinates, &self.names, &self.force, &running, parameters)
            .map_err(|e| src.error(format!("[controls]/[objective]: {e}")))?;
        if let Some(terminal) = &objective.terminal {
            controls = controls
                .with_terminal(coordinates, terminal, parameters)
                .map_err(|e| src.error(format!("[objective] terminal: {e}")))?;
        }
        Ok(ControlSpec {
            names: self.names.clone(),
            controls,
            lower,
            upper,
            time_weight,
        })
    }
}
