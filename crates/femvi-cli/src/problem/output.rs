//! The `[output]` table: where a run writes, how often it writes a row, and whether it draws
//! plots.

use super::errors::{InputError, Source};
use serde::Deserialize;
use std::path::PathBuf;

/// `[output]` as written (absent: every node into out/NAME, no plots).
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct OutputTable {
    /// Output directory (default out/NAME).
    pub directory: Option<String>,
    /// Write every n-th node (the first and the last always).
    pub every: Option<usize>,
    /// Draw plots (SVG) next to the trajectory.
    pub plots: Option<bool>,
    /// The nodes whose energy summary.json's largest error covers: "auto" (default), "every"
    /// or "kept" ([`femvi::solution::EnergyNodes`]).
    pub energy_nodes: Option<String>,
}

impl OutputTable {
    /// `every`, at least 1 (default 1).
    pub fn every(&self, src: &Source) -> Result<usize, InputError> {
        let every = self.every.unwrap_or(1);
        if every == 0 {
            return Err(src.error("[output] every must be at least 1"));
        }
        Ok(every)
    }

    /// `energy_nodes` (default "auto").
    pub fn energy_nodes(&self, src: &Source) -> Result<femvi::solution::EnergyNodes, InputError> {
        match &self.energy_nodes {
            None => Ok(femvi::solution::EnergyNodes::Auto),
            Some(s) => s.parse().map_err(|e: String| src.error(format!("[output] {e}"))),
        }
    }

    /// The output directory of a problem called `name`.
    pub fn directory(&self, name: &str) -> PathBuf {
        PathBuf::from(self.directory.clone().unwrap_or_else(|| format!("out/{name}")))
    }

    /// Whether plots are asked for.
    pub fn plots(&self) -> bool {
        self.plots.unwrap_or(false)
    }
}
