//! The `[initial]` table: the start of an initial value problem (its time, q, and one of v,
//! p or the second node q1), checked against the system's coordinates and turned into the
//! library's [`Start`]. A system with rotations (`[system] rotations = ["R"]`, or a rigid-body
//! model) gives each rotation X its orientation, `X = [9 entries, row-major]` or
//! `X_quaternion = [w, x, y, z]` (scalar first, Hamilton), and its body angular velocity
//! `X_w = [3]` (with `v` for the other coordinates) or body angular momentum `p_X = [3]` (with
//! `p`); `q`, `v` and `p` then hold the other coordinates only, and may be left out if there
//! are none.

use super::errors::{InputError, Source};
use femvi::rotation::embedded_velocity;
use femvi::rotation::so3::{from_quaternion, hat, mul, Mat3};
use femvi::Start;
use serde::Deserialize;
use std::collections::BTreeMap;

/// `[initial]` as written.
#[derive(Debug, Deserialize)]
#[serde(try_from = "RawInitial")]
pub struct InitialTable {
    /// Start time (default 0).
    pub t: Option<f64>,
    /// Initial positions (of the coordinates that are not rotations; None if not given).
    pub q: Option<Vec<f64>>,
    /// Initial velocities.
    pub v: Option<Vec<f64>>,
    /// Initial momenta.
    pub p: Option<Vec<f64>>,
    /// Positions at the second node (the first step fixed by two positions).
    pub q1: Option<Vec<f64>>,
    /// The rotations' keys (`X`, `X_quaternion`, `X_w`, `p_X`), checked against the
    /// system's rotations; any other key is an error.
    pub rotations: BTreeMap<String, toml::Value>,
}

/// `[initial]` as parsed, before its extra keys are checked ([`InitialTable`]).
#[derive(Debug, Deserialize)]
struct RawInitial {
    t: Option<f64>,
    q: Option<Vec<f64>>,
    v: Option<Vec<f64>>,
    p: Option<Vec<f64>>,
    q1: Option<Vec<f64>>,
    #[serde(flatten)]
    rest: BTreeMap<String, toml::Value>,
}

impl TryFrom<RawInitial> for InitialTable {
    type Error = String;

    /// A key besides t, q, v, p and q1 must be a rotation's, with a list of numbers: other
    /// keys are refused here, as serde refuses unknown fields (with the list of keys); which
    /// rotations a system has is checked against the `[system]` table later.
    fn try_from(raw: RawInitial) -> Result<Self, String> {
        let named = |k: &str| {
            k.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        };
        if let Some((key, _)) = raw.rest.iter().find(|(k, v)| !(named(k) && v.is_array())) {
            return Err(format!(
                "unknown field `{key}`, expected one of `t`, `q`, `v`, `p`, `q1`, or for a rotation X of [system] rotations: `X`, `X_quaternion`, `X_w`, `p_X` (lists of numbers)"
            ));
        }
        Ok(Self {
            t: raw.t,
            q: raw.q,
            v: raw.v,
            p: raw.p,
            q1: raw.q1,
            rotations: raw.rest,
        })
    }
}

impl InitialTable {
    /// The start time.
    pub fn t0(&self) -> f64 {
        self.t.unwrap_or(0.0)
    }

    /// The start, each vector checked for its length and finiteness. `rotations` names the
    /// system's rotations, whose blocks of nine come first in `coordinates`.
    pub fn start(&self, coordinates: &[String], rotations: &[String], src: &Source) -> Result<Start, InputError> {
        let ordinary = coordinates.get(9 * rotations.len()..).unwrap_or_default();
        let check = |what: &str, v: &Vec<f64>| check_vector(what, v, ordinary, src);
        self.check_keys(rotations, src)?;
        let given = self.q.clone().unwrap_or_default();
        if rotations.is_empty() && self.q.is_none() {
            return Err(src.error("[initial]: missing field `q` (the initial positions)"));
        }
        check("q", &given)?;
        let bodies = rotations
            .iter()
            .map(|x| self.rotation(x, src))
            .collect::<Result<Vec<_>, _>>()?;
        if rotations.is_empty() {
            return self.plain_start(given, ordinary, src);
        }
        if self.q1.is_some() {
            // The loader asks the capability table first (Use::TwoPositionStart).
            return Err(src.error("[initial] q1 with rotations: give each rotation X its X_w or p_X"));
        }
        let mut q: Vec<f64> = bodies.iter().flat_map(|b| b.0).collect();
        q.extend_from_slice(&given);
        let by_velocity = bodies.iter().all(|b| matches!(b.1, Spin::Velocity(_)));
        let by_momentum = bodies.iter().all(|b| matches!(b.1, Spin::Momentum(_)));
        let ordinary_part = |given: &Option<Vec<f64>>, what: &str| -> Result<Vec<f64>, InputError> {
            let part = given.clone().unwrap_or_default();
            check(what, &part)?;
            Ok(part)
        };
        let mut full: Vec<f64> = Vec::with_capacity(q.len());
        for (r, spin) in &bodies {
            match spin {
                Spin::Velocity(w) if by_velocity => full.extend_from_slice(&embedded_velocity(r, w)),
                // P = ½ R Π̂, the momentum of the nine entries (femvi::rotation).
                Spin::Momentum(pi) if by_momentum => full.extend(mul(r, &hat(pi)).iter().map(|x| 0.5 * x)),
                _ => {
                    return Err(src.error(
                        "[initial]: give every rotation's X_w (with `v` for the other coordinates) or every rotation's p_X (with `p`), not a mixture",
                    ))
                }
            }
        }
        if by_velocity && self.p.is_none() {
            full.extend(ordinary_part(&self.v, "v")?);
            Ok(Start::Velocity { q, v: full })
        } else if by_momentum && self.v.is_none() {
            full.extend(ordinary_part(&self.p, "p")?);
            Ok(Start::Momentum { q, p: full })
        } else {
            Err(src.error("[initial]: the rotations' X_w go with `v` for the other coordinates, their p_X with `p`"))
        }
    }

    /// The start of a system without rotations: exactly one of v, p and q1.
    fn plain_start(&self, q: Vec<f64>, coordinates: &[String], src: &Source) -> Result<Start, InputError> {
        let check = |what: &str, v: &Vec<f64>| check_vector(what, v, coordinates, src);
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

    /// Every extra key is a rotation's.
    fn check_keys(&self, rotations: &[String], src: &Source) -> Result<(), InputError> {
        for key in self.rotations.keys() {
            let known = rotations.iter().any(|x| {
                *key == *x || *key == format!("{x}_quaternion") || *key == format!("{x}_w") || *key == format!("p_{x}")
            });
            if !known {
                let hint = match rotations.first() {
                    Some(x) => format!(" (rotation {x} takes {x}, {x}_quaternion, {x}_w or p_{x})"),
                    None => String::new(),
                };
                return Err(src.error(format!(
                    "[initial] has an unknown key '{key}'; it takes t, q, v, p, q1{hint}"
                )));
            }
        }
        Ok(())
    }

    /// Rotation `x`'s orientation and spin.
    fn rotation(&self, x: &str, src: &Source) -> Result<(Mat3<f64>, Spin), InputError> {
        let numbers = |key: &str, len: usize| -> Result<Option<Vec<f64>>, InputError> {
            let Some(value) = self.rotations.get(key) else {
                return Ok(None);
            };
            let list: Option<Vec<f64>> = value.as_array().and_then(|a| {
                a.iter()
                    .map(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
                    .collect()
            });
            match list {
                Some(l) if l.len() == len && l.iter().all(|v| v.is_finite()) => Ok(Some(l)),
                _ => Err(src.error(format!("[initial] {key} must be a list of {len} finite numbers"))),
            }
        };
        let r = match (numbers(x, 9)?, numbers(&format!("{x}_quaternion"), 4)?) {
            (Some(m), None) => std::array::from_fn(|k| m[k]),
            (None, Some(q)) => from_quaternion([q[0], q[1], q[2], q[3]])
                .ok_or_else(|| src.error(format!("[initial] {x}_quaternion has zero length")))?,
            _ => {
                return Err(src.error(format!(
                    "[initial] needs exactly one of {x} (nine entries, row-major) or {x}_quaternion for rotation {x}"
                )))
            }
        };
        let spin = match (numbers(&format!("{x}_w"), 3)?, numbers(&format!("p_{x}"), 3)?) {
            (Some(w), None) => Spin::Velocity([w[0], w[1], w[2]]),
            (None, Some(p)) => Spin::Momentum([p[0], p[1], p[2]]),
            _ => {
                return Err(src.error(format!(
                    "[initial] needs exactly one of {x}_w (body angular velocity) or p_{x} (body angular momentum) for rotation {x}"
                )))
            }
        };
        Ok((r, spin))
    }
}

/// A rotation's start: body angular velocity or momentum.
#[derive(Debug, Clone, Copy)]
enum Spin {
    Velocity([f64; 3]),
    Momentum([f64; 3]),
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
