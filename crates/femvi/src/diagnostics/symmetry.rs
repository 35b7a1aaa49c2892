//! Continuous symmetries of a Lagrangian (translations, rotations) and their Noether
//! momenta, which the discrete flow of a symmetric discrete Lagrangian conserves exactly
//! (discrete Noether theorem); `femvi check` reports their drift.

use crate::error::{check_len, invalid, Result};

/// A continuous symmetry of a Lagrangian, whose Noether momentum the discrete flow of a
/// symmetric discrete Lagrangian conserves.
#[derive(Debug, Clone, PartialEq)]
pub enum Symmetry {
    /// Invariance under translations along d: momentum p·d.
    Translation(Vec<f64>),
    /// Invariance under rotations in the plane of coordinates (i, j): q_i p_j − q_j p_i.
    Rotation(usize, usize),
    /// Invariance under simultaneous rotations of several planes (e.g. the same plane of every
    /// body): Σ (q_i p_j − q_j p_i), with a label.
    Rotations(Vec<(usize, usize)>, String),
}

impl Symmetry {
    /// Checks the symmetry against a system of dimension n: a translation needs n finite
    /// weights, not all zero, and a rotation two different coordinates below n.
    ///
    /// # Errors
    /// [`crate::Error::Dimension`] or [`crate::Error::Invalid`] saying what does not fit.
    pub fn validate(&self, n: usize) -> Result<()> {
        let plane = |&(i, j): &(usize, usize)| {
            if i >= n || j >= n || i == j {
                Err(invalid(
                    "symmetry",
                    format!("rotation plane ({i}, {j}) needs two different coordinates below {n}"),
                ))
            } else {
                Ok(())
            }
        };
        match self {
            Symmetry::Translation(d) => {
                check_len("translation direction", n, d.len())?;
                if d.iter().any(|w| !w.is_finite()) || d.iter().all(|w| *w == 0.0) {
                    return Err(invalid("symmetry", "a translation needs finite weights, not all zero"));
                }
                Ok(())
            }
            Symmetry::Rotation(i, j) => plane(&(*i, *j)),
            Symmetry::Rotations(planes, _) => planes.iter().try_for_each(plane),
        }
    }

    /// The Noether momentum at (q, p); NaN if the symmetry does not fit them
    /// ([`Symmetry::validate`] with their length).
    pub fn momentum(&self, q: &[f64], p: &[f64]) -> f64 {
        let n = q.len();
        if p.len() != n || self.validate(n).is_err() {
            return f64::NAN;
        }
        let angular = |&(i, j): &(usize, usize)| q[i] * p[j] - q[j] * p[i];
        match self {
            Symmetry::Translation(d) => d.iter().zip(p).map(|(a, b)| a * b).sum(),
            Symmetry::Rotation(i, j) => angular(&(*i, *j)),
            Symmetry::Rotations(planes, _) => planes.iter().map(angular).sum(),
        }
    }

    /// A label such as "rotation(x,y)" or "translation(x0,x1)" from coordinate names.
    pub fn label(&self, names: &[String]) -> String {
        match self {
            Symmetry::Translation(d) => {
                // The coordinates it moves, with their weights where these are not 1.
                let parts: Vec<String> = d
                    .iter()
                    .zip(names)
                    .filter(|(w, _)| **w != 0.0)
                    .map(|(w, n)| if *w == 1.0 { n.clone() } else { format!("{w}*{n}") })
                    .collect();
                format!("translation({})", parts.join(","))
            }
            Symmetry::Rotation(i, j) => {
                let name = |k: usize| names.get(k).cloned().unwrap_or_else(|| format!("#{k}"));
                format!("rotation({},{})", name(*i), name(*j))
            }
            Symmetry::Rotations(_, label) => label.clone(),
        }
    }
}
