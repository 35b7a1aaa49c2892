//! The `[symmetries]` table: the continuous symmetries whose Noether momenta `femvi check`
//! follows, declared in the file or, without the table, those of the built-in model.

use super::errors::{InputError, Source};
pub use femvi::diagnostics::Symmetry;
use serde::Deserialize;

/// Continuous symmetries whose Noether momenta `femvi check` follows.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SymmetriesTable {
    /// Directions d of translation invariance: momentum p·d.
    #[serde(default)]
    pub translations: Vec<Vec<f64>>,
    /// Planes (i, j) of rotation invariance: momentum q_i p_j − q_j p_i.
    #[serde(default)]
    pub rotations: Vec<[usize; 2]>,
}

impl SymmetriesTable {
    /// The declared symmetries of a system with `n` coordinates, checked.
    pub fn symmetries(&self, n: usize, src: &Source) -> Result<Vec<Symmetry>, InputError> {
        let mut out = Vec::new();
        for d in &self.translations {
            if d.len() != n || d.iter().any(|x| !x.is_finite()) || d.iter().all(|x| *x == 0.0) {
                return Err(src.error(format!(
                    "[symmetries] translation {d:?} must be a non-zero vector of {n} finite numbers"
                )));
            }
            out.push(Symmetry::Translation(d.clone()));
        }
        for [i, j] in &self.rotations {
            if *i >= n || *j >= n || i == j {
                return Err(src.error(format!(
                    "[symmetries] rotation [{i}, {j}] must name two different coordinate indices below {n}"
                )));
            }
            out.push(Symmetry::Rotation(*i, *j));
        }
        Ok(out)
    }
}

/// The symmetries of a problem: the table's if there is one, else the built-in model's (none
/// for an expression).
pub fn resolve(
    table: Option<&SymmetriesTable>,
    n: usize,
    model: Option<&(String, Vec<f64>)>,
    src: &Source,
) -> Result<Vec<Symmetry>, InputError> {
    match (table, model) {
        (Some(table), _) => table.symmetries(n, src),
        (None, Some((m, p))) => Ok(model_symmetries(m, p)),
        (None, None) => Ok(vec![]),
    }
}

/// The symmetries a built-in model declares, with its resolved parameters.
pub fn model_symmetries(model: &str, p: &[f64]) -> Vec<Symmetry> {
    match model {
        "kepler" => vec![Symmetry::Rotation(0, 1)],
        "n-body" => nbody_symmetries(p[0] as usize, p[1] as usize),
        "outer-solar-system" => nbody_symmetries(6, 3),
        _ => vec![],
    }
}

/// Total momentum along each axis and total angular momentum in each plane of the n-body
/// problem.
fn nbody_symmetries(bodies: usize, dim: usize) -> Vec<Symmetry> {
    let axes = ["x", "y", "z"];
    let mut out = vec![];
    for a in 0..dim {
        let d: Vec<f64> = (0..bodies * dim)
            .map(|i| if i % dim == a { 1.0 } else { 0.0 })
            .collect();
        out.push(Symmetry::Translation(d));
    }
    for (a, b) in [(0usize, 1usize), (1, 2), (2, 0)] {
        if a < dim && b < dim && !(dim == 2 && a != 0) {
            let planes = (0..bodies).map(|k| (k * dim + a, k * dim + b)).collect();
            out.push(Symmetry::Rotations(
                planes,
                format!("rotation({},{})", axes[a], axes[b]),
            ));
        }
    }
    out
}
