//! Built-in systems, written in Rust with hand-coded forces: the harmonic oscillator, the
//! pendulum, Kepler's problem, Hénon–Heiles, the forced oscillator (time-dependent), the
//! Fermi–Pasta–Ulam–Tsingou chain, the gravitational n-body problem and the outer solar system
//! (mechanical, L = ½vᵀMv − V) and the planar double pendulum (a general Lagrangian with a
//! configuration-dependent mass matrix).

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
];

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
    let count = |vals: &[f64], i: usize, what: &str, lo: f64, hi: f64| -> Result<usize> {
        let v = vals[i];
        if v.fract() != 0.0 || v < lo || v > hi {
            return Err(invalid(
                "parameter",
                format!("{what} = {v} must be an integer from {lo} to {hi}"),
            ));
        }
        Ok(v as usize)
    };
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
        let bodies = count(&vals, 0, "bodies", 1.0, 10_000.0)?;
        count(&vals, 1, "dim", 2.0, 3.0)?;
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
        count(&vals, 0, "n", 1.0, 100_000.0)?;
    }
    Ok(vals)
}

/// Coordinate names of `model` with resolved parameters `p` (from [`parameters`]).
pub fn coordinates(model: &str, p: &[f64]) -> Vec<String> {
    match model {
        "fpu" => (1..=p[0] as usize).map(|i| format!("q{i}")).collect(),
        "n-body" => nbody_names(p[0] as usize, p[1] as usize),
        "outer-solar-system" => nbody_names(6, 3),
        _ => info(model)
            .map(|m| m.coordinates.iter().map(|s| s.to_string()).collect())
            .unwrap_or_default(),
    }
}

fn nbody_names(bodies: usize, dim: usize) -> Vec<String> {
    let axes = ["x", "y", "z"];
    (0..bodies)
        .flat_map(|b| axes[..dim].iter().map(move |a| format!("{a}{b}")))
        .collect()
}

/// The outer solar system of Hairer, Lubich and Wanner, Geometric Numerical Integration,
/// Sect. I.2.4 (5 September 1994): G in AU³/(day² solar mass), masses relative to the Sun (the
/// Sun's includes the inner planets), positions in AU, velocities in AU/day.
pub mod outer_solar_system {
    /// Gravitational constant.
    pub const G: f64 = 0.000295912208286;
    /// Sun, Jupiter, Saturn, Uranus, Neptune, Pluto.
    pub const NAMES: [&str; 6] = ["Sun", "Jupiter", "Saturn", "Uranus", "Neptune", "Pluto"];
    /// Masses.
    pub const MASSES: [f64; 6] = [
        1.00000597682,
        0.000954786104043,
        0.000285583733151,
        4.37273164546e-05,
        5.17759138449e-05,
        7.692307692307693e-09,
    ];
    /// Initial positions.
    pub const X0: [[f64; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [-3.5023653, -3.8169847, -1.5507963],
        [9.0755314, -3.0458353, -1.6483708],
        [8.310142, -16.2901086, -7.2521278],
        [11.4707666, -25.7294829, -10.8169456],
        [-15.5387357, -25.2225594, -3.1902382],
    ];
    /// Initial velocities.
    pub const V0: [[f64; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [0.00565429, -0.0041249, -0.00190589],
        [0.00168318, 0.00483525, 0.00192462],
        [0.00354178, 0.00137102, 0.00055029],
        [0.0028893, 0.00114527, 0.00039677],
        [0.00276725, -0.00170702, -0.00136504],
    ];
}

/// V = k/2 x² − f0 x cos(ω t): the forced oscillator (time-dependent).
#[derive(Debug, Clone, Copy)]
pub struct ForcedPotential {
    /// Spring constant.
    pub k: f64,
    /// Forcing amplitude.
    pub f0: f64,
    /// Forcing frequency.
    pub omega: f64,
}

impl Potential for ForcedPotential {
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D {
        q[0] * q[0] * (0.5 * self.k) - q[0] * (t * self.omega).cos() * self.f0
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.k * q[0] + self.f0 * libm::cos(self.omega * t);
    }
}

/// The α/β Fermi–Pasta–Ulam–Tsingou chain with fixed ends q_0 = q_{n+1} = 0:
/// V = Σ_{i=0}^{n} (d²/2 + α d³/3 + β d⁴/4), d = q_{i+1} − q_i.
#[derive(Debug, Clone, Copy)]
pub struct FpuPotential {
    /// Number of moving masses.
    pub n: usize,
    /// Cubic coefficient.
    pub alpha: f64,
    /// Quartic coefficient.
    pub beta: f64,
}

impl Potential for FpuPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        self.n
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let mut v = D::from(0.0);
        for i in 0..=self.n {
            let left = if i == 0 { D::from(0.0) } else { q[i - 1] };
            let right = if i == self.n { D::from(0.0) } else { q[i] };
            let d = right - left;
            v += d * d * 0.5 + d * d * d * (self.alpha / 3.0) + d * d * d * d * (self.beta / 4.0);
        }
        v
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        // −∂V/∂q_i = V'(d_i) − V'(d_{i−1}) with the bond d_i = q_{i+1} − q_i.
        let dv = |d: f64| d + self.alpha * d * d + self.beta * d * d * d;
        let bond = |i: usize| {
            let left = if i == 0 { 0.0 } else { q[i - 1] };
            let right = if i == self.n { 0.0 } else { q[i] };
            right - left
        };
        let mut prev = dv(bond(0));
        for i in 0..self.n {
            let next = dv(bond(i + 1));
            out[i] = next - prev;
            prev = next;
        }
    }
}

/// V = −G Σ_{i<j} m_i m_j / |x_i − x_j| for bodies in `dim` dimensions.
#[derive(Debug, Clone)]
pub struct GravityPotential {
    /// Gravitational constant.
    pub g: f64,
    /// Masses.
    pub masses: Vec<f64>,
    /// 2 or 3.
    pub dim: usize,
}

impl Potential for GravityPotential {
    fn is_autonomous(&self) -> bool {
        true
    }
    fn dim(&self) -> usize {
        self.masses.len() * self.dim
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let (nb, d) = (self.masses.len(), self.dim);
        let mut v = D::from(0.0);
        for i in 0..nb {
            for j in i + 1..nb {
                let mut r2 = D::from(0.0);
                for c in 0..d {
                    let x = q[i * d + c] - q[j * d + c];
                    r2 += x * x;
                }
                v -= r2.sqrt().recip() * (self.g * self.masses[i] * self.masses[j]);
            }
        }
        v
    }
    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let (nb, d) = (self.masses.len(), self.dim);
        out.iter_mut().for_each(|x| *x = 0.0);
        for i in 0..nb {
            for j in i + 1..nb {
                let mut dx = [0.0; 3];
                let mut r2 = 0.0;
                for c in 0..d {
                    dx[c] = q[j * d + c] - q[i * d + c];
                    r2 += dx[c] * dx[c];
                }
                let k = self.g * self.masses[i] * self.masses[j] / (r2 * r2.sqrt());
                for c in 0..d {
                    out[i * d + c] += k * dx[c];
                    out[j * d + c] -= k * dx[c];
                }
            }
        }
    }
}

/// The forced oscillator.
///
/// # Errors
/// A mass that is not positive.
pub fn forced_oscillator(m: f64, k: f64, f0: f64, omega: f64) -> Result<Mechanical<ForcedPotential>> {
    Mechanical::new(ForcedPotential { k, f0, omega }, MassMatrix::diagonal(vec![m])?)
}

/// The FPUT chain with unit masses.
pub fn fpu(n: usize, alpha: f64, beta: f64) -> Mechanical<FpuPotential> {
    Mechanical::unit_mass(FpuPotential { n, alpha, beta })
}

/// The gravitational n-body problem.
///
/// # Errors
/// A mass that is not positive.
pub fn n_body(g: f64, masses: Vec<f64>, dim: usize) -> Result<Mechanical<GravityPotential>> {
    let diag: Vec<f64> = masses.iter().flat_map(|m| std::iter::repeat_n(*m, dim)).collect();
    Mechanical::new(GravityPotential { g, masses, dim }, MassMatrix::diagonal(diag)?)
}

/// The outer solar system (Sun and five outer planets), 3-D.
pub fn outer_solar_system() -> Mechanical<GravityPotential> {
    n_body(outer_solar_system::G, outer_solar_system::MASSES.to_vec(), 3)
        .unwrap_or_else(|_| unreachable!("the masses are positive"))
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
///
/// The hand-coded force takes its sine from the `libm` crate (musl's algorithm, under 1 ulp)
/// rather than `f64::sin` (the platform's libm: glibc's on Linux): on P3 the force is most of
/// the work, and glibc's sine took 8.4 ns a call against 4.1 ns for `libm::sin` in a loop of
/// eight independent arguments in [−1.7, 1.7] (P3's range), the two differing by at most 1 ulp
/// (in 2.8 % of 10⁶ arguments). The AD paths ([`Potential::value`]) keep `f64::sin`/`cos`.
/// [`Potential::forces`] is written out as one loop over the points rather than the default
/// call of `force` per point, which the compiler did not inline: P3 with degree 10 at
/// h = 1.5, 13 100 → 11 700 instructions per step (cachegrind), results unchanged.
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
        out[0] = -self.mgl * libm::sin(q[0]);
    }
    fn forces(&self, _t: &[f64], q: &[f64], out: &mut [f64]) {
        for (o, &x) in out.iter_mut().zip(q) {
            *o = -self.mgl * libm::sin(x);
        }
    }
    fn force_jacobian(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        out[0] = -self.mgl * libm::cos(q[0]);
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
    fn force_jacobian(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        // f = −μ q / r³: ∂f_i/∂q_j = −μ (δ_ij − 3 q_i q_j / r²) / r³.
        let r2 = q[0] * q[0] + q[1] * q[1];
        let k = -self.mu / (r2 * r2.sqrt());
        let c = -3.0 / r2;
        out[0] = k * (1.0 + c * q[0] * q[0]);
        out[1] = k * c * q[0] * q[1];
        out[2] = out[1];
        out[3] = k * (1.0 + c * q[1] * q[1]);
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

    /// The pendulum's force uses `libm`'s sine and cosine: within 1 ulp of the platform's
    /// (an independent implementation, also under 1 ulp) for small, medium and huge angles.
    #[test]
    fn pendulum_trigonometry_agrees_with_the_platform_to_one_ulp() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let p = PendulumPotential { mgl: 1.0 };
        let (mut f, mut j) = ([0.0], [0.0]);
        let mut worst = 0;
        let mut differ = 0;
        let huge = [1e6, -3.5e9, 1e15, 2.0f64.powi(60), 1e300, f64::MAX];
        for x in (0..200_001).map(|i| -10.0 + 1e-4 * i as f64).chain(huge) {
            p.force(0.0, &[x], &mut f);
            p.force_jacobian(0.0, &[x], &mut j);
            let (ds, dc) = (ulps(-f[0], x.sin()), ulps(-j[0], x.cos()));
            worst = worst.max(ds).max(dc);
            differ += usize::from(ds + dc > 0);
        }
        assert!(worst <= 1, "{worst} ulps");
        // Two implementations, not one: they do differ somewhere.
        assert!(differ > 0);
    }

    /// `forces` (several points at once; the pendulum overrides it, the others take the
    /// per-point default) gives what `force` gives point by point, bit for bit, also through
    /// the `Lagrangian` of a `Mechanical` system with a non-unit mass.
    #[test]
    fn forces_at_several_points_are_the_force_at_each() {
        fn check<L: Lagrangian>(lag: &L, n: usize) {
            let k = 7;
            let t: Vec<f64> = (0..k).map(|i| 0.3 * i as f64).collect();
            let q: Vec<f64> = (0..k * n).map(|i| -2.0 + 0.61 * i as f64).collect();
            let mut all = vec![f64::NAN; k * n];
            lag.forces(&t, &q, &mut all);
            for i in 0..k {
                let mut one = vec![f64::NAN; n];
                lag.force(t[i], &q[i * n..(i + 1) * n], &mut one);
                assert_eq!(&all[i * n..(i + 1) * n], &one[..], "point {i}");
            }
        }
        check(&pendulum(2.0, 9.81, 0.5).unwrap(), 1);
        check(&Mechanical::unit_mass(PendulumPotential { mgl: 1.0 }), 1);
        check(&kepler(1.0), 2);
        check(&henon_heiles(), 2);
    }

    #[test]
    fn outer_solar_system_energy_matches_the_data() {
        // H0 = Σ|p|²/(2m) − G Σ m_i m_j / r_ij from ../shared/problems (an independent sum).
        let sys = outer_solar_system();
        let q: Vec<f64> = outer_solar_system::X0.iter().flatten().cloned().collect();
        let v: Vec<f64> = outer_solar_system::V0.iter().flatten().cloned().collect();
        let mut h = 0.0;
        for b in 0..6 {
            let m = outer_solar_system::MASSES[b];
            h += 0.5 * m * (0..3).map(|c| v[b * 3 + c].powi(2)).sum::<f64>();
        }
        h += sys.potential.value(0.0, &q);
        assert!((h - (-3.2154531832081636e-08)).abs() < 1e-20, "{h:e}");
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
