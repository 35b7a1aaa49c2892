//! `femvi models`: lists the built-in models (parameters, coordinates, symmetries) or prints
//! the complete problem file of one of them.

use crate::problem;
use crate::BAD_INPUT;
use std::process::ExitCode;

/// Complete problem files of the built-in models (also examples/models/, run by the tests):
/// (model name, file text). The Python package serves the same table.
pub const MODEL_FILES: &[(&str, &str)] = &[
    ("harmonic", include_str!("../../../examples/models/harmonic.toml")),
    ("pendulum", include_str!("../../../examples/models/pendulum.toml")),
    ("kepler", include_str!("../../../examples/models/kepler.toml")),
    (
        "henon-heiles",
        include_str!("../../../examples/models/henon-heiles.toml"),
    ),
    (
        "forced-oscillator",
        include_str!("../../../examples/models/forced-oscillator.toml"),
    ),
    ("fpu", include_str!("../../../examples/models/fpu.toml")),
    ("n-body", include_str!("../../../examples/models/n-body.toml")),
    (
        "outer-solar-system",
        include_str!("../../../examples/models/outer-solar-system.toml"),
    ),
    (
        "double-pendulum",
        include_str!("../../../examples/models/double-pendulum.toml"),
    ),
    ("rigid-body", include_str!("../../../examples/models/rigid-body.toml")),
    ("heavy-top", include_str!("../../../examples/models/heavy-top.toml")),
    (
        "rigid-chain",
        include_str!("../../../examples/rigid/double-pendulum-3d.toml"),
    ),
    (
        "spherical-pendulum",
        include_str!("../../../examples/constrained/spherical-pendulum.toml"),
    ),
    (
        "double-pendulum-cartesian",
        include_str!("../../../examples/constrained/double-pendulum-cartesian.toml"),
    ),
    ("chain", include_str!("../../../examples/constrained/chain.toml")),
    (
        "damped-spherical-pendulum",
        include_str!("../../../examples/constrained/damped-spherical-pendulum.toml"),
    ),
];

/// The models of [`MODEL_FILES`] that are problem files with `[constraints]` (expressions in
/// Cartesian coordinates, not entries of `femvi::models::MODELS`), in examples/constrained/
/// (not examples/models/, whose files the tests also run with `--plot`, which constrained
/// runs do not draw yet; `crates/femvi-cli/tests/constraints.rs` runs them).
const CONSTRAINED: &[(&str, &str)] = &[
    (
        "spherical-pendulum",
        "point mass on a sphere |q| = l, Cartesian x, y, z",
    ),
    (
        "double-pendulum-cartesian",
        "planar double pendulum, Cartesian x1, y1, x2, y2, two rods",
    ),
    (
        "chain",
        "three masses on rods from a pivot, planar, Cartesian, three rods",
    ),
    (
        "damped-spherical-pendulum",
        "spherical pendulum with friction and a drive ([forces] and [constraints])",
    ),
];

/// The models of [`MODEL_FILES`] that are problem files with several rotations (expressions in
/// the entries of rotations, in examples/rigid/).
const WITH_ROTATIONS: &[(&str, &str)] = &[(
    "rigid-chain",
    "two rigid links in space on ball joints (a 3-D double pendulum), rotations A and B",
)];

/// Lists the models, or prints the problem file of `name`.
pub fn cmd_models(name: Option<&str>) -> ExitCode {
    let Some(name) = name else {
        for m in femvi::models::MODELS {
            let params: Vec<String> = m.parameters.iter().map(|(k, v)| format!("{k} = {v}")).collect();
            let defaults = femvi::models::parameters(m.name, &[]).unwrap_or_default();
            let coords = femvi::models::coordinates(m.name, &defaults);
            let shown = if coords.len() > 6 {
                format!("{}, … ({} in all)", coords[..6].join(", "), coords.len())
            } else {
                coords.join(", ")
            };
            let labels: Vec<String> = problem::model_symmetries(m.name, &defaults)
                .iter()
                .map(|s| s.label(&coords))
                .collect();
            let symmetries = if labels.is_empty() {
                "none".to_string()
            } else {
                labels.join(", ")
            };
            println!("{:<20} {}", m.name, m.description);
            println!(
                "{:<20} parameters: {}",
                "",
                if params.is_empty() {
                    "none".into()
                } else {
                    params.join(", ")
                }
            );
            println!("{:<20} coordinates: {shown}; symmetries: {symmetries}", "");
        }
        println!("\nWith non-conservative forces ([forces], expression problems):");
        for (name, description, _) in crate::models_forced::FORCED_MODEL_FILES {
            println!("{name:<26} {description}");
        }
        println!("\nWith holonomic constraints ([constraints], problem files in Cartesian coordinates):");
        for (name, description) in CONSTRAINED {
            println!("{name:<26} {description}");
        }
        println!("\nWith rotations ([system] rotations, problem files in the entries of the rotations):");
        for (name, description) in WITH_ROTATIONS {
            println!("{name:<26} {description}");
        }
        println!("\n`femvi models NAME` prints a complete problem file for NAME.");
        return ExitCode::SUCCESS;
    };
    let forced = crate::models_forced::FORCED_MODEL_FILES
        .iter()
        .map(|(n, _, t)| (*n, *t));
    match MODEL_FILES.iter().copied().chain(forced).find(|(n, _)| *n == name) {
        Some((_, text)) => {
            print!("{text}");
            ExitCode::SUCCESS
        }
        None => {
            let forced = crate::models_forced::FORCED_MODEL_FILES.iter().map(|(n, _, _)| *n);
            let names: Vec<&str> = MODEL_FILES.iter().map(|(n, _)| *n).chain(forced).collect();
            eprintln!(
                "error: unknown model '{name}'{}; built-in models: {}",
                problem::did_you_mean(name, &names),
                names.join(", ")
            );
            ExitCode::from(BAD_INPUT)
        }
    }
}
