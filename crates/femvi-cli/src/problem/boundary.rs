//! The `[boundary]` table: a two-point boundary value problem for `femvi bvp` (end times and
//! positions, the number of elements, an optional guess file, fixed or moving mesh), checked
//! and turned into the library's [`BoundaryValues`].

use super::errors::{InputError, Source};
use super::time::Mode;
use femvi::bvp::BoundaryValues;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The two-point boundary value problem of `femvi bvp`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryTable {
    /// Start time.
    pub t0: f64,
    /// Positions at `t0`.
    pub q0: Vec<f64>,
    /// End time.
    pub t1: f64,
    /// Positions at `t1`.
    pub q1: Vec<f64>,
    /// Number of elements between `t0` and `t1`.
    pub elements: usize,
    /// A trajectory.csv to interpolate as the initial guess (default: the straight line).
    pub guess: Option<String>,
    /// "fixed" (a uniform mesh) or "energy" (the interior element end times are unknowns).
    #[serde(default)]
    pub time_mode: Mode,
}

/// A checked `[boundary]` table.
pub struct Boundary {
    /// The boundary values and mesh size.
    pub values: BoundaryValues,
    /// The guess file, relative to the problem file's directory.
    pub guess: Option<PathBuf>,
    /// `time_mode = "energy"`.
    pub moving_mesh: bool,
}

impl BoundaryTable {
    /// The boundary values for a system with `n` coordinates, checked.
    pub fn resolve(&self, n: usize, src: &Source) -> Result<Boundary, InputError> {
        if self.elements > 50_000_000 {
            return Err(src.error(format!(
                "[boundary] elements = {} is too many (at most 5e7)",
                self.elements
            )));
        }
        let values = BoundaryValues {
            t0: self.t0,
            q0: self.q0.clone(),
            t1: self.t1,
            q1: self.q1.clone(),
            elements: self.elements,
        };
        values.validate(n).map_err(|e| src.error(format!("[boundary]: {e}")))?;
        let guess = self
            .guess
            .as_ref()
            .map(|g| src.path.parent().unwrap_or(Path::new(".")).join(g));
        Ok(Boundary {
            values,
            guess,
            moving_mesh: self.time_mode == Mode::Energy,
        })
    }
}
