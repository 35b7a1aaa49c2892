//! The `[solver]` table: how each step's equations are solved (method, tolerance, iteration
//! cap, polishing), checked and turned into the library's [`SolverOptions`].

use super::errors::{InputError, Source};
use femvi::{Method, SolverOptions};
use serde::Deserialize;

/// `[solver] method`.
#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum SolverMethod {
    /// The library chooses: explicit, fixed-point or Newton (the default).
    #[default]
    Auto,
    /// Newton's method with a line search.
    Newton,
    /// Fixed-point iteration on the forces (mechanical Lagrangians only).
    FixedPoint,
    /// Explicit stepping (degree 1, trapezoid rule, mechanical Lagrangians only).
    Explicit,
}

/// `[solver]` as written (absent: the library's defaults).
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SolverTable {
    /// Stopping tolerance of the iteration.
    pub tolerance: Option<f64>,
    /// Iteration cap per step.
    pub max_iterations: Option<usize>,
    /// Solution method.
    #[serde(default)]
    pub method: SolverMethod,
    /// Iterate on to round-off after reaching the tolerance.
    pub polish: Option<bool>,
}

impl SolverTable {
    /// The solver options, defaults filled in and validated.
    pub fn options(&self, src: &Source) -> Result<SolverOptions, InputError> {
        let method = match self.method {
            SolverMethod::Auto => Method::Auto,
            SolverMethod::Newton => Method::Newton,
            SolverMethod::FixedPoint => Method::FixedPoint,
            SolverMethod::Explicit => Method::Explicit,
        };
        let defaults = SolverOptions::default();
        let options = SolverOptions {
            tolerance: self.tolerance.unwrap_or(defaults.tolerance),
            max_iterations: self.max_iterations.unwrap_or(defaults.max_iterations),
            method,
            polish: self.polish.unwrap_or(defaults.polish),
        };
        options.validate().map_err(|e| src.error(format!("[solver]: {e}")))?;
        Ok(options)
    }
}
