//! The outer solar system of Hairer, Lubich and Wanner, Geometric Numerical Integration,
//! Sect. I.2.4 (5 September 1994): G in AU³/(day² solar mass), masses relative to the Sun (the
//! Sun's includes the inner planets), positions in AU, velocities in AU/day.

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
