//! Problem files (TOML, version 1): parsing with unknown keys rejected, and conversion into
//! library types. Errors carry the file name, line and column of the offending text.
//!
//! Each table has a module of its own with its serde struct and the check that turns it into
//! library values: [`system`], [`initial`], [`boundary`], [`scheme`], [`time`], [`solver`],
//! [`output`] and [`symmetries`]. A new table joins with a module, a field of [`ProblemFile`]
//! and a call in `build`, whose order of calls is the order in which a file with several
//! mistakes reports them. [`errors`] holds the messages' positions and "did you mean" hints.

mod boundary;
mod errors;
mod initial;
mod output;
mod scheme;
mod solver;
mod symmetries;
mod system;
mod time;

pub use errors::{did_you_mean, InputError};
pub use symmetries::{model_symmetries, Symmetry};
pub use system::System;

use errors::{bad, with_suggestion, Source};
use femvi::{Element, SolverOptions, Start, TimeGrid};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A problem file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemFile {
    /// The problem's name (default: the file's stem).
    pub name: Option<String>,
    /// `[system]`: the Lagrangian.
    pub system: system::SystemTable,
    /// `[initial]`: the start of an initial value problem.
    pub initial: Option<initial::InitialTable>,
    /// `[scheme]`: the element.
    #[serde(default)]
    pub scheme: scheme::SchemeTable,
    /// `[time]`: the time grid of an initial value problem.
    pub time: Option<time::TimeTable>,
    /// `[boundary]`: a boundary value problem instead of `[initial]` and `[time]`.
    pub boundary: Option<boundary::BoundaryTable>,
    /// `[solver]`: how the step equations are solved.
    #[serde(default)]
    pub solver: solver::SolverTable,
    /// `[output]`: where and how often a run writes.
    #[serde(default)]
    pub output: output::OutputTable,
    /// `[symmetries]`: the Noether momenta `femvi check` follows.
    pub symmetries: Option<symmetries::SymmetriesTable>,
}

/// Everything a run needs, checked.
pub struct Problem {
    /// The problem's name.
    pub name: String,
    /// Coordinate names.
    pub coordinates: Vec<String>,
    /// The Lagrangian.
    pub system: System,
    /// The element.
    pub element: Element,
    /// The element as summaries describe it.
    pub scheme_label: String,
    /// The time grid.
    pub grid: TimeGrid,
    /// The initial values.
    pub start: Start,
    /// How the step equations are solved.
    pub options: SolverOptions,
    /// Output directory (`[output] directory`, else out/NAME).
    pub directory: PathBuf,
    /// Write every n-th node.
    pub every: usize,
    /// Time steps as variables (paper §3), with these bounds and policy.
    pub energy: Option<femvi::EnergyOptions>,
    /// Declared symmetries (from the file, or the built-in model's).
    pub symmetries: Vec<Symmetry>,
    /// Built-in model name, if any, and its resolved parameters.
    pub model: Option<(String, Vec<f64>)>,
    /// [output] plots = true.
    pub plots: bool,
    /// `[time] accuracy`: the step femvi chose and what it rests on.
    pub auto_step: Option<femvi::step::auto::StepChoice>,
}

/// A boundary value problem read from a file with a `[boundary]` table.
pub struct BvpProblem {
    /// The problem's name.
    pub name: String,
    /// Coordinate names.
    pub coordinates: Vec<String>,
    /// The Lagrangian.
    pub system: System,
    /// The element.
    pub element: Element,
    /// The element as summaries describe it.
    pub scheme_label: String,
    /// Tolerance and iteration cap of Newton's method.
    pub options: SolverOptions,
    /// Output directory.
    pub directory: PathBuf,
    /// The boundary values and mesh size.
    pub boundary: femvi::bvp::BoundaryValues,
    /// A trajectory file to interpolate as the initial guess.
    pub guess: Option<PathBuf>,
    /// `time_mode = "energy"`: the interior element end times are unknowns (a moving mesh).
    pub moving_mesh: bool,
}

/// Reads and checks an initial value problem (for `run`, `check`, `convergence`).
pub fn load(path: &Path) -> Result<Problem, InputError> {
    let (text, file) = read(path)?;
    match build(&Source { path, text: &text }, file, false)? {
        Loaded::Ivp(p) => Ok(p),
        Loaded::Bvp(_) => Err(bad(format!("{}: expected an initial value problem", path.display()))),
    }
}

/// Reads and checks a boundary value problem (for `bvp`).
pub fn load_bvp(path: &Path) -> Result<BvpProblem, InputError> {
    let (text, file) = read(path)?;
    match build(&Source { path, text: &text }, file, true)? {
        Loaded::Bvp(p) => Ok(p),
        Loaded::Ivp(_) => Err(bad(format!("{}: expected a boundary value problem", path.display()))),
    }
}

/// Reads and parses a problem file.
fn read(path: &Path) -> Result<(String, ProblemFile), InputError> {
    let bytes =
        std::fs::read(path).map_err(|e| bad(format!("{}: cannot read the problem file: {e}", path.display())))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        bad(format!(
            "{}: the problem file is not UTF-8 text (byte {})",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })?;
    if text.trim().is_empty() {
        return Err(bad(format!(
            "{}: the problem file is empty (it needs [system], and [initial] and [time] or [boundary])",
            path.display()
        )));
    }
    let file: ProblemFile = toml::from_str(&text).map_err(|e| {
        let msg = with_suggestion(e.message());
        match e.span() {
            Some(span) => bad(Source { path, text: &text }.excerpt(span.start, &msg)),
            None => bad(format!("{}: {msg}", path.display())),
        }
    })?;
    Ok((text, file))
}

/// What a problem file describes.
enum Loaded {
    Ivp(Problem),
    Bvp(BvpProblem),
}

/// What initial and boundary value problems share, checked.
struct Common {
    name: String,
    system: system::Resolved,
    element: Element,
    scheme_label: String,
    options: SolverOptions,
    directory: PathBuf,
}

/// Checks the tables in a fixed order (the first mistake is the one reported) and builds the
/// problem: a boundary value problem if `want_bvp`, else an initial value problem.
fn build(src: &Source, file: ProblemFile, want_bvp: bool) -> Result<Loaded, InputError> {
    let name = file.name.clone().unwrap_or_else(|| {
        src.path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "run".into())
    });
    let system = file.system.resolve(src)?;
    let n = system.coordinates.len();
    let accuracy = file.time.as_ref().and_then(|t| t.accuracy);
    let (element, scheme_label) = file.scheme.element(accuracy, src)?;
    let options = file.solver.options(src)?;
    let every = file.output.every(src)?;
    let directory = file.output.directory(&name);
    let symmetries = symmetries::resolve(file.symmetries.as_ref(), n, system.model.as_ref(), src)?;
    let common = Common {
        name,
        system,
        element,
        scheme_label,
        options,
        directory,
    };
    if want_bvp {
        return build_bvp(src, &file, common).map(Loaded::Bvp);
    }
    build_ivp(src, &file, common, every, symmetries).map(Loaded::Ivp)
}

/// `[boundary]` (and neither `[initial]` nor `[time]`).
fn build_bvp(src: &Source, file: &ProblemFile, c: Common) -> Result<BvpProblem, InputError> {
    if file.initial.is_some() || file.time.is_some() {
        return Err(src.error("a boundary value problem takes [boundary] instead of [initial] and [time]"));
    }
    let b = file
        .boundary
        .as_ref()
        .ok_or_else(|| src.error("`femvi bvp` needs a [boundary] table (t0, q0, t1, q1, elements)"))?;
    let boundary = b.resolve(c.system.coordinates.len(), src)?;
    Ok(BvpProblem {
        name: c.name,
        coordinates: c.system.coordinates,
        system: c.system.system,
        element: c.element,
        scheme_label: c.scheme_label,
        options: c.options,
        directory: c.directory,
        boundary: boundary.values,
        guess: boundary.guess,
        moving_mesh: boundary.moving_mesh,
    })
}

/// `[initial]` and `[time]` (and no `[boundary]`).
fn build_ivp(
    src: &Source,
    file: &ProblemFile,
    c: Common,
    every: usize,
    symmetries: Vec<Symmetry>,
) -> Result<Problem, InputError> {
    if file.boundary.is_some() {
        return Err(src.error("[boundary] describes a boundary value problem: solve it with `femvi bvp`"));
    }
    let (Some(init), Some(tt)) = (file.initial.as_ref(), file.time.as_ref()) else {
        return Err(src.error("an initial value problem needs [initial] and [time] (or [boundary] for `femvi bvp`)"));
    };
    let t0 = init.t0();
    let energy = tt.energy(src)?;
    let grid = tt.grid(t0, src)?;
    let start = init.start(&c.system.coordinates, src)?;
    let (grid, auto_step) = match tt.choose_step(&c.system.system, &c.element, &start, t0, c.options, src)? {
        Some((grid, choice)) => (grid, Some(choice)),
        None => (grid, None),
    };
    Ok(Problem {
        name: c.name,
        coordinates: c.system.coordinates,
        system: c.system.system,
        element: c.element,
        scheme_label: c.scheme_label,
        grid,
        start,
        options: c.options,
        directory: c.directory,
        every,
        energy,
        symmetries,
        model: c.system.model,
        plots: file.output.plots(),
        auto_step,
    })
}
