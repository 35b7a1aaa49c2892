//! Problem files (TOML, version 1): parsing with unknown keys rejected, and conversion into
//! library types. Errors carry the file name, line and column of the offending text.
//!
//! Each table has a module of its own with its serde struct and the check that turns it into
//! library values: `system`, `initial`, `boundary`, `scheme`, `time`, `solver`,
//! `output`, `symmetries` and [`events`]. A new table joins with a module, a field of [`ProblemFile`]
//! and a call in `build`, whose order of calls is the order in which a file with several
//! mistakes reports them. `errors` holds the messages' positions and "did you mean" hints.
//!
//! A problem comes from a file or standard input (`-`), and `--set key.path=value` overrides
//! ([`overrides`]) are applied to its text before anything is checked: [`load_with`],
//! [`load_bvp_with`] and [`load_text`] (text in hand, as the Python package has it).

mod boundary;
pub mod capabilities;
pub mod constraints;
mod control;
mod errors;
pub mod events;
pub mod forces;
mod initial;
mod integrator;
mod optimal;
mod output;
pub mod overrides;
pub mod rotations;
mod scheme;
mod solver;
mod symmetries;
mod system;
mod terms;
mod time;
mod torques;

pub use errors::{did_you_mean, InputError};
pub use events::EventSpec;
pub use overrides::apply_overrides;
pub use symmetries::{model_symmetries, Symmetry};
pub use system::System;
pub use terms::Terms;
pub use time::AdaptiveTime;

use capabilities::Use;
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
    /// `[[events]]`: conditions whose zeros `femvi run` locates.
    #[serde(default)]
    pub events: Vec<events::EventTable>,
    /// `[forces]`: non-conservative forces ([`Terms::force`]).
    pub forces: Option<forces::ForcesTable>,
    /// `[constraints]`: holonomic constraints ([`Terms::constraints`]).
    pub constraints: Option<constraints::ConstraintsTable>,
    /// `[controls]`: the controls of an optimal control problem (`femvi optimize`).
    pub controls: Option<control::ControlsTable>,
    /// `[objective]`: its running and terminal costs and the weight of t1.
    pub objective: Option<control::ObjectiveTable>,
    /// `[coordinate_bounds]`: bounds on the coordinates of an optimal control problem.
    pub coordinate_bounds: Option<control::CoordinateBoundsTable>,
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
    /// The nodes the energy error covers (`[output] energy_nodes`).
    pub energy_nodes: femvi::solution::EnergyNodes,
    /// Time steps as variables (paper §3), with these bounds and policy.
    pub energy: Option<femvi::EnergyOptions>,
    /// Declared symmetries (from the file, or the built-in model's).
    pub symmetries: Vec<Symmetry>,
    /// Built-in model name, if any, and its resolved parameters.
    pub model: Option<(String, Vec<f64>)>,
    /// `[output] plots = true`.
    pub plots: bool,
    /// `[time] accuracy`: the step femvi chose and what it rests on.
    pub auto_step: Option<femvi::step::auto::StepChoice>,
    /// The grid as the library's solve API describes it (same nodes as `grid`).
    pub steps: femvi::Steps,
    /// `[[events]]`, checked.
    pub events: Vec<EventSpec>,
    /// The terms beside the Lagrangian (forces, constraints, adaptive time), compiled once.
    pub terms: Terms,
    /// The `[system]` parameters (name, value), for expressions compiled after loading.
    pub parameters: Vec<(String, f64)>,
    /// The problem's TOML text as run (after `--set` overrides).
    pub source: String,
}

impl Problem {
    /// The library's problem for this file with the Lagrangian `lag` (span from the grid).
    pub fn library<L>(&self, lag: L) -> femvi::Problem<L> {
        femvi::Problem::new(lag, self.start.clone(), self.grid.t0(), self.grid.end())
    }

    /// The library's solve options for this file: its steps and solver, every `every`-th
    /// node kept.
    pub fn solve_options(&self, every: usize) -> femvi::SolveOptions {
        femvi::SolveOptions {
            steps: self.steps.clone(),
            solver: self.options,
            every,
            energy_nodes: self.energy_nodes,
            ..femvi::SolveOptions::step(1.0)
        }
    }
}

pub use boundary::ControlBoundary;
pub use control::ControlSpec;
pub use optimal::{load_optimize_with, OptimizeProblem};

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
    /// The terms beside the Lagrangian (forces, constraints), compiled once.
    pub terms: Terms,
    /// The problem's TOML text as solved (after `--set` overrides).
    pub source: String,
}

/// Reads and checks an initial value problem (for `run`, `check`, `convergence`).
pub fn load(path: &Path) -> Result<Problem, InputError> {
    load_with(path, &[])
}

/// Reads and checks a boundary value problem (for `bvp`).
pub fn load_bvp(path: &Path) -> Result<BvpProblem, InputError> {
    load_bvp_with(path, &[])
}

/// Reads an initial value problem from `path` (`-`: standard input), applies the `--set`
/// overrides (`key.path=value`) and checks it.
pub fn load_with(path: &Path, overrides: &[String]) -> Result<Problem, InputError> {
    load_text(path, &read_text(path)?, overrides)
}

/// [`load_with`] for a boundary value problem.
pub fn load_bvp_with(path: &Path, overrides: &[String]) -> Result<BvpProblem, InputError> {
    let text = read_text(path)?;
    match loaded(path, &text, overrides, true)? {
        Loaded::Bvp(p) => Ok(*p),
        Loaded::Optimize(_) => Err(bad(format!(
            "{}: [controls] make this an optimal control problem: solve it with `femvi optimize`",
            label(path).display()
        ))),
        Loaded::Ivp(_) => Err(bad(format!(
            "{}: expected a boundary value problem",
            label(path).display()
        ))),
    }
}

/// An initial value problem from its TOML text (`path` names it in messages and gives the
/// default name), with the overrides applied before it is checked.
pub fn load_text(path: &Path, text: &str, overrides: &[String]) -> Result<Problem, InputError> {
    match loaded(path, text, overrides, false)? {
        Loaded::Ivp(p) => Ok(*p),
        Loaded::Bvp(_) | Loaded::Optimize(_) => Err(bad(format!(
            "{}: expected an initial value problem",
            label(path).display()
        ))),
    }
}

/// How messages name the problem: `<stdin>` for `-`, else the path.
fn label(path: &Path) -> &Path {
    if path == Path::new("-") {
        Path::new("<stdin>")
    } else {
        path
    }
}

/// Parses `text` after the overrides and builds the problem.
fn loaded(path: &Path, text: &str, overrides: &[String], want_bvp: bool) -> Result<Loaded, InputError> {
    let shown = label(path);
    let text = apply_overrides(text, overrides).map_err(|e| bad(format!("{}: {e}", shown.display())))?;
    let named;
    let shown = if overrides.is_empty() {
        shown
    } else {
        named = PathBuf::from(format!("{} (after --set)", shown.display()));
        &named
    };
    let src = Source {
        path: shown,
        text: &text,
    };
    let file = parse(&src)?;
    let stem = if path == Path::new("-") { "stdin" } else { "" };
    build(&src, file, want_bvp, (path, stem))
}

/// The text of a problem file (`-`: standard input), checked to be UTF-8 and not empty.
fn read_text(path: &Path) -> Result<String, InputError> {
    let shown = label(path);
    let limits = crate::bounded::Limits::PROBLEM;
    let bytes = if path == Path::new("-") {
        crate::bounded::read_from(std::io::stdin(), limits)
    } else {
        crate::bounded::read(path, limits)
    }
    .map_err(|e| bad(format!("{}: cannot read the problem file: {e}", shown.display())))?;
    String::from_utf8(bytes).map_err(|e| {
        bad(format!(
            "{}: the problem file is not UTF-8 text (byte {})",
            shown.display(),
            e.utf8_error().valid_up_to()
        ))
    })
}

/// Parses a problem's text.
fn parse(src: &Source) -> Result<ProblemFile, InputError> {
    let (path, text) = (src.path, src.text);
    if text.trim().is_empty() {
        return Err(bad(format!(
            "{}: the problem file is empty (it needs [system], and [initial] and [time] or [boundary])",
            path.display()
        )));
    }
    toml::from_str(text).map_err(|e| {
        let msg = with_suggestion(e.message());
        match e.span() {
            Some(span) => bad(src.excerpt(span.start, &msg)),
            None => bad(format!("{}: {msg}", path.display())),
        }
    })
}

/// What a problem file describes.
enum Loaded {
    Ivp(Box<Problem>),
    Bvp(Box<BvpProblem>),
    Optimize(Box<OptimizeProblem>),
}

/// What initial and boundary value problems share, checked.
struct Common {
    name: String,
    system: system::Resolved,
    element: Element,
    scheme_label: String,
    options: SolverOptions,
    directory: PathBuf,
    terms: Terms,
    parameters: Vec<(String, f64)>,
    source: String,
}

/// Checks the tables in a fixed order (the first mistake is the one reported) and builds the
/// problem: a boundary value problem if `want_bvp`, else an initial value problem.
/// `origin` is the path the problem came from and a default name that overrides its stem
/// ("stdin" for `-`).
fn build(src: &Source, file: ProblemFile, want_bvp: bool, origin: (&Path, &str)) -> Result<Loaded, InputError> {
    let name = file.name.clone().unwrap_or_else(|| {
        if !origin.1.is_empty() {
            return origin.1.to_string();
        }
        origin
            .0
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "run".into())
    });
    let system = file.system.resolve(src)?;
    let n = system.coordinates.len();
    let parameters: Vec<(String, f64)> = file.system.parameters.iter().map(|(k, v)| (k.clone(), *v)).collect();
    let constraints = match &file.constraints {
        Some(c) => Some(c.resolve(&system.coordinates, &parameters, src)?),
        None => None,
    };
    let accuracy = file.time.as_ref().and_then(|t| t.accuracy);
    let (element, scheme_label) = file.scheme.element(accuracy, src)?;
    let options = file.solver.options(src)?;
    let every = file.output.every(src)?;
    let directory = file.output.directory(&name);
    let symmetries = symmetries::resolve(file.symmetries.as_ref(), n, system.model.as_ref(), src)?;
    let force = match &file.forces {
        Some(f) => Some(f.resolve((&system.coordinates, &system.rotations), &parameters, src)?),
        None => None,
    };
    let rotations = match system.rotations.len() {
        0 => None,
        m => {
            let offsets: Vec<usize> = (0..m).map(|r| 9 * r).collect();
            Some(femvi::rotation::Rotations::new(n, &offsets).map_err(|e| src.error(e))?)
        }
    };
    if rotations.is_some() && want_bvp {
        return Err(src.error(
            "[system] rotations: boundary value and optimal control problems on SO(3) are not solved yet (femvi run takes initial value problems with rotations)",
        ));
    }
    let terms = Terms {
        force,
        constraints,
        adaptive: None,
        energy_mode: false,
        rotations,
    };
    let common = Common {
        name,
        system,
        element,
        scheme_label,
        options,
        directory,
        terms,
        parameters,
        source: src.text.to_string(),
    };
    if want_bvp && file.controls.is_some() {
        return optimal::build_optimize(src, &file, common).map(|p| Loaded::Optimize(Box::new(p)));
    }
    if file.controls.is_some() || file.objective.is_some() || file.coordinate_bounds.is_some() {
        return Err(
            src.error("[controls], [objective] and [coordinate_bounds] describe an optimal control problem: solve it with `femvi optimize`")
        );
    }
    if want_bvp {
        return build_bvp(src, &file, common).map(|p| Loaded::Bvp(Box::new(p)));
    }
    build_ivp(src, &file, common, every, symmetries).map(|p| Loaded::Ivp(Box::new(p)))
}

/// `[boundary]` (and neither `[initial]` nor `[time]`).
fn build_bvp(src: &Source, file: &ProblemFile, c: Common) -> Result<BvpProblem, InputError> {
    if file.initial.is_some() || file.time.is_some() {
        return Err(src.error("a boundary value problem takes [boundary] instead of [initial] and [time]"));
    }
    if !file.events.is_empty() {
        return Err(src.error("[[events]] apply to initial value problems (`femvi run`), not to `femvi bvp`"));
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
        terms: c.terms,
        source: c.source,
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
    // Start and step choices that the capability table refuses for a term (rotations).
    let refuse = |asked: bool, what: Use| match asked {
        true => capabilities::check(&c.terms, what, "").map_err(|e| src.error(e)),
        false => Ok(()),
    };
    refuse(init.q1.is_some(), Use::TwoPositionStart)?;
    refuse(tt.accuracy.is_some(), Use::AccuracyStep)?;
    let start = init.start(&c.system.coordinates, &c.system.rotations, src)?;
    let (grid, auto_step) = match tt.choose_step(&c.system.system, &c.element, &start, t0, c.options, src)? {
        Some((grid, choice)) => (grid, Some(choice)),
        None => (grid, None),
    };
    let steps = tt.solve_steps(energy, auto_step.as_ref().map(|a| a.step));
    let events = events::resolve(&file.events, &c.system.coordinates, &c.parameters, src)?;
    let terms = Terms {
        adaptive: tt.adaptive(src)?,
        energy_mode: energy.is_some(),
        ..c.terms
    };
    capabilities::check_terms(&terms, energy.is_some()).map_err(|e| src.error(e))?;
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
        energy_nodes: file.output.energy_nodes(src)?,
        energy,
        symmetries,
        model: c.system.model,
        plots: file.output.plots(),
        auto_step,
        steps,
        events,
        terms,
        parameters: c.parameters,
        source: c.source,
    })
}
