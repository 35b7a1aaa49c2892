//! Built-in systems, written in Rust with hand-coded forces: the harmonic oscillator, the
//! pendulum, Kepler's problem, Hénon–Heiles (mechanical, L = ½vᵀMv − V) and the planar double
//! pendulum (a general Lagrangian with a configuration-dependent mass matrix).

use crate::error::{invalid, Result};
use crate::lagrangian::{Lagrangian, MassMatrix, Mechanical, Potential, Scalar};

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
        name: "double-pendulum",
        description: "planar double pendulum (masses m1, m2 on rods l1, l2, gravity g)",
        coordinates: &["theta1", "theta2"],
        parameters: &[("m1", 1.0), ("m2", 1.0), ("l1", 1.0), ("l2", 1.0), ("g", 1.0)],
    },
];

/// Looks up a model's metadata.
pub fn info(name: &str) -> Option<&'static ModelInfo> {
    MODELS.iter().find(|m| m.name == name)
}

/// Resolves the parameters of `model` from `given` (name, value) pairs over the defaults.
///
/// # Errors
/// An unknown model or parameter name, or a non-finite value.
pub fn parameters(model: &str, given: &[(String, f64)]) -> Result<Vec<f64>> {
    let m = info(model).ok_or_else(|| invalid("model", format!("unknown model '{model}'")))?;
    let mut vals: Vec<f64> = m.parameters.iter().map(|p| p.1).collect();
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
    Ok(vals)
}

/// V = k/2 x².
#[derive(Debug, Clone, Copy)]
pub struct HarmonicPotential {
    /// Spring constant k.
    pub k: f64,
}

impl Potential for HarmonicPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0] * q[0] * (0.5 * self.k)
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.k * q[0];
    }
}

/// V = −m g l cos θ.
#[derive(Debug, Clone, Copy)]
pub struct PendulumPotential {
    /// m g l.
    pub mgl: f64,
}

impl Potential for PendulumPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -q[0].cos() * self.mgl
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.mgl * q[0].sin();
    }
}

/// V = −μ/|q| in the plane.
#[derive(Debug, Clone, Copy)]
pub struct KeplerPotential {
    /// Gravitational parameter μ.
    pub mu: f64,
}

impl Potential for KeplerPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        2
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        -(q[0] * q[0] + q[1] * q[1]).sqrt().recip() * self.mu
    }
    #[inline]
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let r2 = q[0] * q[0] + q[1] * q[1];
        let k = -self.mu / (r2 * r2.sqrt());
        out[0] = k * q[0];
        out[1] = k * q[1];
    }
}

/// V = (x² + y²)/2 + x²y − y³/3.
#[derive(Debug, Clone, Copy)]
pub struct HenonHeilesPotential;

impl Potential for HenonHeilesPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        2
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (x, y) = (q[0], q[1]);
        (x * x + y * y) * 0.5 + x * x * y - y * y * y * (1.0 / 3.0)
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let (x, y) = (q[0], q[1]);
        out[0] = -(x + 2.0 * x * y);
        out[1] = -(y + x * x - y * y);
    }
}

/// The planar double pendulum, angles from the downward vertical.
#[derive(Debug, Clone, Copy)]
pub struct DoublePendulum {
    /// Mass of the first bob.
    pub m1: f64,
    /// Mass of the second bob.
    pub m2: f64,
    /// First rod.
    pub l1: f64,
    /// Second rod.
    pub l2: f64,
    /// Gravity.
    pub g: f64,
}

impl Lagrangian for DoublePendulum {
    fn dim(&self) -> usize {
        2
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let (m1, m2, l1, l2, g) = (self.m1, self.m2, self.l1, self.l2, self.g);
        let kin = v[0] * v[0] * (0.5 * (m1 + m2) * l1 * l1)
            + v[1] * v[1] * (0.5 * m2 * l2 * l2)
            + v[0] * v[1] * (q[0] - q[1]).cos() * (m2 * l1 * l2);
        let pot = -q[0].cos() * ((m1 + m2) * g * l1) - q[1].cos() * (m2 * g * l2);
        kin - pot
    }
}

/// The harmonic oscillator with mass m and spring constant k.
///
/// # Errors
/// A mass that is not positive.
pub fn harmonic(m: f64, k: f64) -> Result<Mechanical<HarmonicPotential>> {
    Mechanical::new(HarmonicPotential { k }, MassMatrix::diagonal(vec![m])?)
}

/// The pendulum with mass m, gravity g and length l.
///
/// # Errors
/// m l² not positive.
pub fn pendulum(m: f64, g: f64, l: f64) -> Result<Mechanical<PendulumPotential>> {
    Mechanical::new(
        PendulumPotential { mgl: m * g * l },
        MassMatrix::diagonal(vec![m * l * l])?,
    )
}

/// Kepler's problem with gravitational parameter μ, unit mass.
pub fn kepler(mu: f64) -> Mechanical<KeplerPotential> {
    Mechanical::unit_mass(KeplerPotential { mu })
}

/// Hénon–Heiles, unit masses.
pub fn henon_heiles() -> Mechanical<HenonHeilesPotential> {
    Mechanical::unit_mass(HenonHeilesPotential)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lagrangian::PointDerivatives;

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
        }
        check(HarmonicPotential { k: 2.5 }, &[0.7]);
        check(PendulumPotential { mgl: 3.0 }, &[1.1]);
        check(KeplerPotential { mu: 1.3 }, &[0.4, -0.9]);
        check(HenonHeilesPotential, &[0.3, -0.2]);
    }

    #[test]
    fn parameters_resolve_and_reject_unknown_names() {
        assert_eq!(parameters("kepler", &[]).unwrap(), vec![1.0]);
        assert_eq!(parameters("kepler", &[("mu".into(), 2.0)]).unwrap(), vec![2.0]);
        assert!(parameters("kepler", &[("nu".into(), 2.0)]).is_err());
        assert!(parameters("kepplr", &[]).is_err());
    }
}
