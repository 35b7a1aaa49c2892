//! Built-in systems, written in Rust with hand-coded forces: the harmonic oscillator, the
//! pendulum, Kepler's problem, Hénon–Heiles, the forced oscillator (time-dependent), the
//! Fermi–Pasta–Ulam–Tsingou chain, the gravitational n-body problem and the outer solar system
//! (mechanical, L = ½vᵀMv − V) and the planar double pendulum (a general Lagrangian with a
//! configuration-dependent mass matrix).
//!
//! This file is the catalogue that problem files refer to ([`MODELS`]: names, coordinates,
//! parameters and their defaults, resolved by [`parameters`] and [`coordinates`]); the
//! systems themselves are in one file per family: `simple.rs` (harmonic oscillator, pendulum,
//! Kepler, Hénon–Heiles), `forced.rs`, `fpu.rs`, `gravity.rs` (n-body, with the data of
//! [`outer_solar_system`](mod@outer_solar_system) in `outer_solar_system.rs`),
//! `double_pendulum.rs` and `constrained.rs` (chains of particles on rods, in Cartesian
//! coordinates, for [`crate::constraints`]).

mod constrained;
mod double_pendulum;
mod forced;
mod fpu;
mod gravity;
pub mod outer_solar_system;
mod relativistic;
mod rigid;
mod simple;

pub use constrained::{chain, Chain, UniformGravity};
pub use double_pendulum::DoublePendulum;
pub use forced::{forced_oscillator, ForcedPotential};
pub use fpu::{fpu, FpuPotential};
pub use gravity::{n_body, outer_solar_system, GravityPotential};
pub use relativistic::RelativisticKepler;
pub use rigid::RigidBody;
pub use simple::{
    harmonic, henon_heiles, kepler, pendulum, HarmonicPotential, HenonHeilesPotential, KeplerPotential,
    PendulumPotential,
};

use crate::error::{invalid, Result};

/// The largest FPUT chain (n) that [`fpu`] and [`parameters`] accept: 10⁶ masses set up in
/// 0.1 s and about 140 MB through the library (440 MB through `femvi run`, which also holds the
/// problem file's 23 MB of initial values), measured by `examples/setup_scale.rs`; a larger n
/// is a typed error rather than an allocation that may fail.
pub const MAX_FPU_MASSES: usize = 1_000_000;
/// The most bodies that [`parameters`] accepts for n-body.
pub const MAX_BODIES: usize = 10_000;

/// Checks that every named parameter of `model` is finite.
fn finite(model: &str, params: &[(&str, f64)]) -> Result<()> {
    match params.iter().find(|(_, v)| !v.is_finite()) {
        Some((name, v)) => Err(invalid(model, format!("parameter {name} = {v} is not finite"))),
        None => Ok(()),
    }
}

/// Entry i of `vals` as a count: an integer from `lo` to `hi`.
fn count(vals: &[f64], i: usize, what: &str, lo: usize, hi: usize) -> Result<usize> {
    let v = vals
        .get(i)
        .copied()
        .ok_or_else(|| invalid("parameter", format!("{what} is missing")))?;
    if v.fract() != 0.0 || !(v >= lo as f64 && v <= hi as f64) {
        return Err(invalid(
            "parameter",
            format!("{what} = {v} must be an integer from {lo} to {hi}"),
        ));
    }
    Ok(v as usize)
}

/// Metadata of a built-in model: name, coordinates and parameters with defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelInfo {
    /// Name used in problem files.
    pub name: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Coordinate names.
    pub coordinates: &'static [&'static str],
    /// Parameters and their default values.
    pub parameters: &'static [(&'static str, f64)],
}

/// The built-in models.
pub const MODELS: &[ModelInfo] = &[
    ModelInfo {
        name: "harmonic",
        description: "harmonic oscillator, L = m/2 x_dot^2 - k/2 x^2",
        coordinates: &["x"],
        parameters: &[("m", 1.0), ("k", 1.0)],
    },
    ModelInfo {
        name: "pendulum",
        description: "pendulum, L = m l^2/2 theta_dot^2 + m g l cos(theta)",
        coordinates: &["theta"],
        parameters: &[("m", 1.0), ("g", 1.0), ("l", 1.0)],
    },
    ModelInfo {
        name: "kepler",
        description: "Kepler problem, L = |v|^2/2 + mu/|q|",
        coordinates: &["x", "y"],
        parameters: &[("mu", 1.0)],
    },
    ModelInfo {
        name: "henon-heiles",
        description: "Henon-Heiles, L = |v|^2/2 - (x^2 + y^2)/2 - x^2 y + y^3/3",
        coordinates: &["x", "y"],
        parameters: &[],
    },
    ModelInfo {
        name: "forced-oscillator",
        description: "forced oscillator, L = m/2 x_dot^2 - k/2 x^2 + f0 x cos(omega t) (time-dependent)",
        coordinates: &["x"],
        parameters: &[("m", 1.0), ("k", 1.0), ("f0", 0.5), ("omega", 1.3)],
    },
    ModelInfo {
        name: "fpu",
        description: "Fermi-Pasta-Ulam-Tsingou chain of n unit masses with fixed ends, V = sum d^2/2 + alpha d^3/3 + beta d^4/4 (coordinates q1..qn)",
        coordinates: &[],
        parameters: &[("n", 8.0), ("alpha", 0.25), ("beta", 0.0)],
    },
    ModelInfo {
        name: "n-body",
        description: "gravitational n-body problem in dim = 2 or 3, masses m0, m1, ... (default 1), V = -G sum m_i m_j / r_ij (coordinates x0, y0[, z0], x1, ...)",
        coordinates: &[],
        parameters: &[("bodies", 3.0), ("dim", 2.0), ("G", 1.0)],
    },
    ModelInfo {
        name: "outer-solar-system",
        description: "the Sun and the five outer planets (Hairer-Lubich-Wanner's data, 5 Sept 1994): AU, days, solar masses",
        coordinates: &[],
        parameters: &[],
    },
    ModelInfo {
        name: "double-pendulum",
        description: "planar double pendulum (masses m1, m2 on rods l1, l2, gravity g)",
        coordinates: &["theta1", "theta2"],
        parameters: &[("m1", 1.0), ("m2", 1.0), ("l1", 1.0), ("l2", 1.0), ("g", 1.0)],
    },
    ModelInfo {
        name: "rigid-body",
        description: "free rigid body with principal moments I1, I2, I3; rotation R (body to space), L = sum I_a R_w_a^2/2 (stepped by Lie-group elements)",
        coordinates: &ROTATION,
        parameters: &[("I1", 1.0), ("I2", 2.0), ("I3", 3.0)],
    },
    ModelInfo {
        name: "heavy-top",
        description: "heavy top on a fixed point: moments I1, I2, I3 about it, mass m, gravity g along -z, centre of mass (chi1, chi2, chi3) in the body; L = sum I_a R_w_a^2/2 - m g e3.(R chi)",
        coordinates: &ROTATION,
        parameters: &[
            ("I1", 1.0),
            ("I2", 2.0),
            ("I3", 3.0),
            ("m", 1.0),
            ("g", 9.81),
            ("chi1", 0.0),
            ("chi2", 0.0),
            ("chi3", 0.5),
        ],
    },
];

/// The coordinates of a model's rotation R: its entries, row-major.
pub const ROTATION: [&str; 9] = ["R11", "R12", "R13", "R21", "R22", "R23", "R31", "R32", "R33"];

/// The names of the rotations of `model` (those stepped by [`crate::rotation`]): `["R"]` for
/// the rigid bodies, none for the others.
///
/// # Example
/// ```
/// assert_eq!(femvi::models::rotations("heavy-top"), ["R"]);
/// assert!(femvi::models::rotations("kepler").is_empty());
/// ```
pub fn rotations(model: &str) -> &'static [&'static str] {
    match model {
        "rigid-body" | "heavy-top" => &["R"],
        _ => &[],
    }
}

/// Looks up a model's metadata.
pub fn info(name: &str) -> Option<&'static ModelInfo> {
    MODELS.iter().find(|m| m.name == name)
}

/// Resolves the parameters of `model` from `given` (name, value) pairs over the defaults.
/// For n-body the masses m0, m1, … follow the fixed parameters (default 1 each).
///
/// # Errors
/// An unknown model or parameter name, a non-finite value, or an out-of-range count.
pub fn parameters(model: &str, given: &[(String, f64)]) -> Result<Vec<f64>> {
    let m = info(model).ok_or_else(|| invalid("model", format!("unknown model '{model}'")))?;
    let mut vals: Vec<f64> = m.parameters.iter().map(|p| p.1).collect();
    if model == "n-body" {
        // Fixed parameters first, then the masses.
        for (name, v) in given.iter().filter(|(n, _)| !n.starts_with('m')) {
            let i = m.parameters.iter().position(|p| p.0 == name).ok_or_else(|| {
                invalid(
                    "parameter",
                    format!("model 'n-body' has no parameter '{name}' (it has: bodies, dim, G, m0, m1, ...)"),
                )
            })?;
            if !v.is_finite() {
                return Err(invalid("parameter", format!("'{name}' = {v} is not finite")));
            }
            vals[i] = *v;
        }
        let bodies = count(&vals, 0, "bodies", 1, MAX_BODIES)?;
        count(&vals, 1, "dim", 2, 3)?;
        let mut masses = vec![1.0; bodies];
        for (name, v) in given.iter().filter(|(n, _)| n.starts_with('m')) {
            let i: usize = name[1..]
                .parse()
                .ok()
                .filter(|i| *i < bodies)
                .ok_or_else(|| invalid("parameter", format!("'{name}' is not a mass m0 … m{}", bodies - 1)))?;
            if !(v.is_finite() && *v > 0.0) {
                return Err(invalid("parameter", format!("mass '{name}' = {v} must be positive")));
            }
            masses[i] = *v;
        }
        vals.extend(masses);
        return Ok(vals);
    }
    for (name, v) in given {
        let i = m.parameters.iter().position(|p| p.0 == name).ok_or_else(|| {
            let known: Vec<&str> = m.parameters.iter().map(|p| p.0).collect();
            invalid(
                "parameter",
                format!(
                    "model '{model}' has no parameter '{name}' (it has: {})",
                    known.join(", ")
                ),
            )
        })?;
        if !v.is_finite() {
            return Err(invalid("parameter", format!("'{name}' = {v} is not finite")));
        }
        vals[i] = *v;
    }
    if model == "fpu" {
        count(&vals, 0, "n", 1, MAX_FPU_MASSES)?;
    }
    Ok(vals)
}

/// Coordinate names of `model` with resolved parameters `p` (from [`parameters`]); empty
/// for an unknown model or a list that [`parameters`] would not produce (too short, or a
/// count out of its range), for which [`try_coordinates`] says what is wrong.
pub fn coordinates(model: &str, p: &[f64]) -> Vec<String> {
    try_coordinates(model, p).unwrap_or_default()
}

/// Coordinate names of `model` with resolved parameters `p` (from [`parameters`]).
///
/// # Errors
/// An unknown model, or a parameter list that [`parameters`] would not produce: a missing
/// count, or a count (fpu's n, n-body's bodies and dim) that is not an integer in its range.
pub fn try_coordinates(model: &str, p: &[f64]) -> Result<Vec<String>> {
    let m = info(model).ok_or_else(|| invalid("model", format!("unknown model '{model}'")))?;
    Ok(match model {
        "fpu" => (1..=count(p, 0, "n", 1, MAX_FPU_MASSES)?)
            .map(|i| format!("q{i}"))
            .collect(),
        "n-body" => nbody_names(count(p, 0, "bodies", 1, MAX_BODIES)?, count(p, 1, "dim", 2, 3)?),
        "outer-solar-system" => nbody_names(6, 3),
        _ => m.coordinates.iter().map(|s| s.to_string()).collect(),
    })
}

fn nbody_names(bodies: usize, dim: usize) -> Vec<String> {
    let axes = ["x", "y", "z"];
    (0..bodies)
        .flat_map(|b| axes.iter().take(dim).map(move |a| format!("{a}{b}")))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lagrangian::{Mechanical, PointDerivatives, Potential};

    /// The hand-coded forces agree with automatic differentiation of the potentials.
    #[test]
    fn hand_forces_match_ad() {
        fn check<P: Potential>(p: P, q: &[f64]) {
            let n = q.len();
            let (mut hand, mut ad) = (vec![0.0; n], vec![0.0; n]);
            p.force(0.0, q, &mut hand);
            let l = Mechanical::unit_mass(p);
            let mut d = PointDerivatives::new(n);
            d.first_by_ad(&l, 0.0, q, &vec![0.0; n], false);
            ad.copy_from_slice(d.l_q());
            for i in 0..n {
                assert!(
                    (hand[i] - ad[i]).abs() < 1e-14 * (1.0 + ad[i].abs()),
                    "{hand:?} vs {ad:?}"
                );
            }
            // The force Jacobian (hand-coded or not) against the AD Hessian of L.
            let mut jac = vec![0.0; n * n];
            l.potential.force_jacobian(0.0, q, &mut jac);
            d.second_by_ad(&l, 0.0, q, &vec![0.0; n], false);
            for i in 0..n {
                for j in 0..n {
                    let want = d.h(1 + i, 1 + j);
                    assert!(
                        (jac[i * n + j] - want).abs() < 1e-13 * (1.0 + want.abs()),
                        "({i},{j}): {} vs {want}",
                        jac[i * n + j]
                    );
                }
            }
        }
        check(HarmonicPotential { k: 2.5 }, &[0.7]);
        check(PendulumPotential { mgl: 3.0 }, &[1.1]);
        check(KeplerPotential { mu: 1.3 }, &[0.4, -0.9]);
        check(HenonHeilesPotential, &[0.3, -0.2]);
        check(
            ForcedPotential {
                k: 2.0,
                f0: 0.7,
                omega: 1.3,
            },
            &[0.4],
        );
        check(
            FpuPotential {
                n: 5,
                alpha: 0.25,
                beta: 0.1,
            },
            &[0.1, -0.2, 0.3, 0.05, -0.1],
        );
        check(
            GravityPotential {
                g: 1.3,
                masses: vec![1.0, 0.5, 2.0],
                dim: 3,
            },
            &[0.0, 0.1, 0.2, 1.0, -0.3, 0.5, -0.7, 0.9, 0.1],
        );
    }

    #[test]
    fn model_parameters_and_coordinates() {
        let p = parameters("n-body", &[("bodies".into(), 2.0), ("m1".into(), 3.0)]).unwrap();
        assert_eq!(p, vec![2.0, 2.0, 1.0, 1.0, 3.0]);
        assert_eq!(coordinates("n-body", &p), vec!["x0", "y0", "x1", "y1"]);
        assert!(parameters("n-body", &[("m5".into(), 1.0)]).is_err());
        assert!(parameters("n-body", &[("bodies".into(), 2.5)]).is_err());
        let p = parameters("fpu", &[("n".into(), 3.0)]).unwrap();
        assert_eq!(coordinates("fpu", &p), vec!["q1", "q2", "q3"]);
        assert!(parameters("fpu", &[("n".into(), 0.0)]).is_err());
        assert_eq!(coordinates("outer-solar-system", &[]).len(), 18);
    }

    #[test]
    fn parameters_resolve_and_reject_unknown_names() {
        assert_eq!(parameters("kepler", &[]).unwrap(), vec![1.0]);
        assert_eq!(parameters("kepler", &[("mu".into(), 2.0)]).unwrap(), vec![2.0]);
        assert!(parameters("kepler", &[("nu".into(), 2.0)]).is_err());
        assert!(parameters("kepplr", &[]).is_err());
    }
}
