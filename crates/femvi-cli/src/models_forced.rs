//! The `femvi models` entries of systems with forces (issue 19): complete problem files with
//! a `[forces]` table (also in examples/forces/, run by the tests). They are expression
//! problems, so they have no entry in the library's model catalogue.

/// (name, description, file text) of the models with forces.
pub const FORCED_MODEL_FILES: &[(&str, &str, &str)] = &[
    (
        "damped-oscillator",
        "x'' + c x' + k x = 0, Rayleigh dissipation R = c x_dot^2 / 2",
        include_str!("../../../examples/forces/damped-oscillator.toml"),
    ),
    (
        "driven-damped-oscillator",
        "x'' + c x' + k x = f0 cos(w t), a generalized force",
        include_str!("../../../examples/forces/driven-damped-oscillator.toml"),
    ),
    (
        "forced-duffing",
        "x'' + d x' + a x + b x^3 = g cos(w t), double well for a < 0",
        include_str!("../../../examples/forces/forced-duffing.toml"),
    ),
];
