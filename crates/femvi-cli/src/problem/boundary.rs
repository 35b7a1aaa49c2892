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
    /// End time, or "free" (an optimal control problem's unknown, with t1_min and t1_max).
    pub t1: EndTime,
    /// Smallest free end time (`femvi optimize`).
    pub t1_min: Option<f64>,
    /// Largest free end time (`femvi optimize`).
    pub t1_max: Option<f64>,
    /// Velocities at `t0` (`femvi optimize`).
    pub v0: Option<Vec<f64>>,
    /// Velocities at `t1` (`femvi optimize`): numbers, each or all "free".
    pub v1: Option<EndState>,
    /// Momenta at `t0` instead of `v0` (`femvi optimize`).
    pub p0: Option<Vec<f64>>,
    /// Momenta at `t1` instead of `v1` (`femvi optimize`).
    pub p1: Option<Vec<f64>>,
    /// Positions at `t1`; for `femvi optimize` each or all may be "free".
    pub q1: EndState,
    /// Number of elements between `t0` and `t1`.
    pub elements: usize,
    /// A trajectory.csv to interpolate as the initial guess (default: the straight line).
    pub guess: Option<String>,
    /// Coarser meshes solved first (`femvi optimize`: mesh refinement).
    pub coarse: Option<Vec<usize>>,
    /// "fixed" (a uniform mesh) or "energy" (the interior element end times are unknowns).
    #[serde(default)]
    pub time_mode: Mode,
}

/// `t1`: a time or the word "free".
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum EndTime {
    /// A given end time.
    Time(f64),
    /// A word; only "free" is accepted.
    Word(String),
}

/// `q1` or `v1`: numbers, some of them "free", or "free" for all.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum EndState {
    /// One entry per coordinate.
    Each(Vec<EndTime>),
    /// A word for all; only "free" is accepted.
    All(String),
}

impl EndState {
    /// Per coordinate: the given value or `None` for "free" (n entries for "free" alone).
    fn resolve(&self, what: &str, n: usize, src: &Source) -> Result<Vec<Option<f64>>, InputError> {
        let word = |w: &str| {
            if w == "free" {
                Ok(None)
            } else {
                Err(src.error(format!("[boundary] {what}: \"{w}\" is neither a number nor \"free\"")))
            }
        };
        match self {
            EndState::All(w) => word(w).map(|_| vec![None; n]),
            EndState::Each(v) => v
                .iter()
                .map(|x| match x {
                    EndTime::Time(t) => Ok(Some(*t)),
                    EndTime::Word(w) => word(w),
                })
                .collect(),
        }
    }

    /// All numbers (`femvi bvp`).
    fn numbers(&self, src: &Source) -> Result<Vec<f64>, InputError> {
        let free = || src.error("[boundary] q1: a free end is for `femvi optimize`; `femvi bvp` needs positions");
        match self {
            EndState::All(_) => Err(free()),
            EndState::Each(v) => v
                .iter()
                .map(|x| match x {
                    EndTime::Time(t) => Ok(*t),
                    EndTime::Word(_) => Err(free()),
                })
                .collect(),
        }
    }
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
        let t1 = match &self.t1 {
            EndTime::Time(t) => *t,
            EndTime::Word(_) => {
                return Err(src.error("[boundary] t1 = \"free\" is for `femvi optimize`; `femvi bvp` needs a time"))
            }
        };
        if self.v0.is_some()
            || self.v1.is_some()
            || self.p0.is_some()
            || self.p1.is_some()
            || self.t1_min.is_some()
            || self.t1_max.is_some()
            || self.coarse.is_some()
        {
            return Err(src.error(
                "[boundary] v0, v1, p0, p1, t1_min, t1_max and coarse are for `femvi optimize` (with [controls]); `femvi bvp` takes positions only",
            ));
        }
        let values = BoundaryValues {
            t0: self.t0,
            q0: self.q0.clone(),
            t1,
            q1: self.q1.numbers(src)?,
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

impl BoundaryTable {
    /// The boundary data of an optimal control problem (`femvi optimize`): positions and
    /// velocities at both ends, t1 given or free within [t1_min, t1_max].
    pub fn resolve_control(&self, n: usize, src: &Source) -> Result<ControlBoundary, InputError> {
        if self.elements > 50_000_000 {
            return Err(src.error(format!(
                "[boundary] elements = {} is too many (at most 5e7)",
                self.elements
            )));
        }
        if self.time_mode != Mode::Fixed {
            return Err(src.error("[boundary] time_mode: `femvi optimize` takes a uniform mesh (a free t1 scales it)"));
        }
        let need = |end: &str| {
            src.error(format!(
                "[boundary] `femvi optimize` needs the velocities v{end} or the momenta p{end} at each end (v1 may be \"free\")"
            ))
        };
        let both = |end: &str| src.error(format!("[boundary] give v{end} or p{end}, not both"));
        let (v0, p0) = match (&self.v0, &self.p0) {
            (Some(v), None) => (v.clone(), None),
            (None, Some(p)) => (vec![], Some(p.clone())),
            (Some(_), Some(_)) => return Err(both("0")),
            (None, None) => return Err(need("0")),
        };
        let (v1, p1) = match (&self.v1, &self.p1) {
            (Some(v), None) => (v.resolve("v1", n, src)?, None),
            (None, Some(p)) => (vec![], Some(p.clone())),
            (Some(_), Some(_)) => return Err(both("1")),
            (None, None) => return Err(need("1")),
        };
        let t1 = match (&self.t1, self.t1_min, self.t1_max) {
            (EndTime::Time(t), None, None) => femvi::optimize::FinalTime::Fixed(*t),
            (EndTime::Time(_), ..) => return Err(src.error("[boundary] t1_min and t1_max go with t1 = \"free\"")),
            (EndTime::Word(w), Some(min), Some(max)) if w == "free" => femvi::optimize::FinalTime::Free {
                min,
                max,
                guess: 0.5 * (min + max),
            },
            (EndTime::Word(w), ..) if w == "free" => {
                return Err(src.error("[boundary] t1 = \"free\" needs t1_min and t1_max"))
            }
            (EndTime::Word(w), ..) => {
                return Err(src.error(format!("[boundary] t1 = \"{w}\": give a time or \"free\"")))
            }
        };
        let guess = self
            .guess
            .as_ref()
            .map(|g| src.path.parent().unwrap_or(Path::new(".")).join(g));
        Ok(ControlBoundary {
            t0: self.t0,
            t1,
            q0: self.q0.clone(),
            v0,
            q1: self.q1.resolve("q1", n, src)?,
            v1,
            p0,
            p1,
            elements: self.elements,
            guess,
            coarse: self.coarse.clone().unwrap_or_default(),
        })
    }
}

/// The checked boundary data of `femvi optimize`.
#[derive(Debug, Clone)]
pub struct ControlBoundary {
    /// Start time.
    pub t0: f64,
    /// End time, given or free.
    pub t1: femvi::optimize::FinalTime,
    /// Positions at t0.
    pub q0: Vec<f64>,
    /// Velocities at t0; empty when `p0` is given.
    pub v0: Vec<f64>,
    /// Positions at t1 (`None`: free).
    pub q1: Vec<Option<f64>>,
    /// Velocities at t1 (`None`: free); empty when `p1` is given.
    pub v1: Vec<Option<f64>>,
    /// Momenta at t0, given instead of `v0` (which is then empty).
    pub p0: Option<Vec<f64>>,
    /// Momenta at t1, given instead of `v1`.
    pub p1: Option<Vec<f64>>,
    /// Number of elements.
    pub elements: usize,
    /// A guess file (columns t and the coordinates, optionally the controls).
    pub guess: Option<PathBuf>,
    /// Coarser meshes solved first (mesh refinement).
    pub coarse: Vec<usize>,
}
