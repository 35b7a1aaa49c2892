//! The `[initial]` table: the start of an initial value problem (its time, q, and one of v,
//! p or the second node q1), checked against the system's coordinates and turned into the
//! library's [`Start`].

use super::errors::{InputError, Source};
use femvi::Start;
use serde::Deserialize;

/// `[initial]` as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialTable {
    /// Start time (default 0).
    pub t: Option<f64>,
    /// Initial positions.
    pub q: Vec<f64>,
    /// Initial velocities.
    pub v: Option<Vec<f64>>,
    /// Initial momenta.
    pub p: Option<Vec<f64>>,
    /// Positions at the second node (the first step fixed by two positions).
    pub q1: Option<Vec<f64>>,
}

impl InitialTable {
    /// The start time.
    pub fn t0(&self) -> f64 {
        self.t.unwrap_or(0.0)
    }

    /// The start, each vector checked for its length and finiteness.
    pub fn start(&self, coordinates: &[String], src: &Source) -> Result<Start, InputError> {
        let check = |what: &str, v: &Vec<f64>| check_vector(what, v, coordinates, src);
        check("q", &self.q)?;
        let q = self.q.clone();
        match (&self.v, &self.p, &self.q1) {
            (Some(v), None, None) => {
                check("v", v)?;
                Ok(Start::Velocity { q, v: v.clone() })
            }
            (None, Some(p), None) => {
                check("p", p)?;
                Ok(Start::Momentum { q, p: p.clone() })
            }
            (None, None, Some(q1)) => {
                check("q1", q1)?;
                Ok(Start::Positions { q0: q, q1: q1.clone() })
            }
            _ => Err(src.error("[initial] needs exactly one of `v`, `p` or `q1`")),
        }
    }
}

/// One entry per coordinate, all finite.
fn check_vector(what: &str, v: &[f64], coordinates: &[String], src: &Source) -> Result<(), InputError> {
    let n = coordinates.len();
    if v.len() != n {
        return Err(src.error(format!(
            "[initial] {what} has {} entries, but the system has {n} coordinates ({})",
            v.len(),
            coordinates.join(", ")
        )));
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(src.error(format!("[initial] {what} has a non-finite entry")));
    }
    Ok(())
}
