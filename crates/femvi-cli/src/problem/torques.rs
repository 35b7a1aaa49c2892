//! Torques on rotations in `[forces]` (issue 37: torques as forces): `torques = { R = ["τ1",
//! "τ2", "τ3"] }` gives the torque on rotation R in its body frame, in t, the coordinates,
//! their velocities, R_w1 … R_w3 and the parameters. It acts on the entries of R as the
//! generalized force F = ½ R τ̂, whose virtual work tr(Fᵀ δR) over δR = R η̂ is τ·η
//! (`femvi::Integrator::with_rotations_and_force`). The expressions of `generalized` and of
//! the torques are written out in the entries (`super::rotations::substitute`) and added per
//! coordinate.

use super::errors::{InputError, Source};
use super::rotations::substitute;
use std::collections::BTreeMap;

/// The torque table as written: rotation name → three body-frame expressions.
pub type TorqueTable = BTreeMap<String, Vec<toml::Spanned<String>>>;

/// The generalized-force expressions (one per coordinate) of `generalized` (if given) and
/// `torques`, written out for `rotations` (whose blocks of nine are the first coordinates).
///
/// # Errors
/// A torque for a name that is not a rotation, a torque without three expressions, or a count
/// of `generalized` expressions other than the number of coordinates.
pub fn generalized(
    generalized: Option<&[toml::Spanned<String>]>,
    torques: Option<&TorqueTable>,
    (coordinates, rotations): (&[String], &[String]),
    src: &Source,
) -> Result<Vec<String>, InputError> {
    let n = coordinates.len();
    let mut out: Vec<String> = match generalized {
        Some(list) if list.len() != n => {
            return Err(src.error(format!(
            "[forces] generalized has {} expressions for {} coordinates [{}]: give one per coordinate, in their order",
            list.len(),
            n,
            coordinates.join(", ")
        )))
        }
        Some(list) => list.iter().map(|s| substitute(s.get_ref(), rotations)).collect(),
        None => vec!["0".to_string(); n],
    };
    for (name, tau) in torques.into_iter().flatten() {
        let Some(r) = rotations.iter().position(|x| x == name) else {
            return Err(src.error(format!(
                "[forces] torques: '{name}' is not a rotation of [system] rotations [{}]",
                rotations.join(", ")
            )));
        };
        if tau.len() != 3 {
            return Err(src.error(format!(
                "[forces] torques: {name} needs 3 expressions (the torque in the body frame), not {}",
                tau.len()
            )));
        }
        let t: Vec<String> = tau
            .iter()
            .map(|e| format!("({})", substitute(e.get_ref(), rotations)))
            .collect();
        // τ̂ row by row.
        let zero = "0".to_string();
        let hat = [
            [zero.clone(), format!("(-{})", t[2]), t[1].clone()],
            [t[2].clone(), zero.clone(), format!("(-{})", t[0])],
            [format!("(-{})", t[1]), t[0].clone(), zero],
        ];
        for i in 0..3 {
            for j in 0..3 {
                let terms: Vec<String> = (0..3)
                    .map(|k| format!("{name}{}{}*{}", i + 1, k + 1, hat[k][j]))
                    .collect();
                let entry = &mut out[9 * r + 3 * i + j];
                *entry = format!("({entry}) + 0.5*({})", terms.join(" + "));
            }
        }
    }
    Ok(out)
}
