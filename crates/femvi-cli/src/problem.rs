//! Problem files (TOML, version 1): parsing with unknown keys rejected, and conversion into
//! library types. Errors carry the file name, line and column of the offending text.

use femvi::expr::ExprLagrangian;
use femvi::models;
use femvi::{Element, Method, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A problem file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemFile {
    pub name: Option<String>,
    pub system: SystemTable,
    pub initial: Option<InitialTable>,
    #[serde(default)]
    pub scheme: SchemeTable,
    pub time: Option<TimeTable>,
    pub boundary: Option<BoundaryTable>,
    #[serde(default)]
    pub solver: SolverTable,
    #[serde(default)]
    pub output: OutputTable,
    pub symmetries: Option<SymmetriesTable>,
}

/// Continuous symmetries whose Noether momenta `femvi check` follows.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SymmetriesTable {
    /// Directions d of translation invariance: momentum p·d.
    #[serde(default)]
    pub translations: Vec<Vec<f64>>,
    /// Planes (i, j) of rotation invariance: momentum q_i p_j − q_j p_i.
    #[serde(default)]
    pub rotations: Vec<[usize; 2]>,
}

pub use femvi::diagnostics::Symmetry;

/// The symmetries a built-in model declares, with its resolved parameters.
pub fn model_symmetries(model: &str, p: &[f64]) -> Vec<Symmetry> {
    match model {
        "kepler" => vec![Symmetry::Rotation(0, 1)],
        "n-body" => nbody_symmetries(p[0] as usize, p[1] as usize),
        "outer-solar-system" => nbody_symmetries(6, 3),
        _ => vec![],
    }
}

/// Total momentum along each axis and total angular momentum in each plane of the n-body
/// problem.
fn nbody_symmetries(bodies: usize, dim: usize) -> Vec<Symmetry> {
    let axes = ["x", "y", "z"];
    let mut out = vec![];
    for a in 0..dim {
        let d: Vec<f64> = (0..bodies * dim)
            .map(|i| if i % dim == a { 1.0 } else { 0.0 })
            .collect();
        out.push(Symmetry::Translation(d));
    }
    for (a, b) in [(0usize, 1usize), (1, 2), (2, 0)] {
        if a < dim && b < dim && !(dim == 2 && a != 0) {
            let planes = (0..bodies).map(|k| (k * dim + a, k * dim + b)).collect();
            out.push(Symmetry::Rotations(
                planes,
                format!("rotation({},{})", axes[a], axes[b]),
            ));
        }
    }
    out
}

/// Dispatches `$body` with `$l` bound to the concrete Lagrangian of a [`System`].
#[macro_export]
macro_rules! with_system {
    ($sys:expr, $l:ident => $body:expr) => {
        match $sys {
            $crate::problem::System::Expr($l) => $body,
            $crate::problem::System::Harmonic($l) => $body,
            $crate::problem::System::Pendulum($l) => $body,
            $crate::problem::System::Kepler($l) => $body,
            $crate::problem::System::HenonHeiles($l) => $body,
            $crate::problem::System::DoublePendulum($l) => $body,
            $crate::problem::System::Forced($l) => $body,
            $crate::problem::System::Fpu($l) => $body,
            $crate::problem::System::Gravity($l) => $body,
        }
    };
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SystemTable {
    pub coordinates: Option<Vec<String>>,
    #[serde(default)]
    pub parameters: BTreeMap<String, f64>,
    pub lagrangian: Option<toml::Spanned<String>>,
    pub model: Option<String>,
}

/// The two-point boundary value problem of `femvi bvp`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryTable {
    pub t0: f64,
    pub q0: Vec<f64>,
    pub t1: f64,
    pub q1: Vec<f64>,
    pub elements: usize,
    /// A trajectory.csv to interpolate as the initial guess (default: the straight line).
    pub guess: Option<String>,
    #[serde(default)]
    pub time_mode: Mode,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialTable {
    pub t: Option<f64>,
    pub q: Vec<f64>,
    pub v: Option<Vec<f64>>,
    pub p: Option<Vec<f64>>,
    pub q1: Option<Vec<f64>>,
}

#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    #[default]
    Galerkin,
    Midpoint,
}

#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Nodes {
    #[default]
    Equispaced,
    Lobatto,
}

#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Quadrature {
    Midpoint,
    Trapezoid,
    Simpson,
    #[default]
    GaussLegendre,
    GaussLobatto,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SchemeTable {
    #[serde(default)]
    pub kind: Kind,
    /// Requested order 2s: picks degree s with s-point Gauss-Legendre (femvi's default choice).
    pub order: Option<usize>,
    pub degree: Option<usize>,
    #[serde(default)]
    pub nodes: Nodes,
    #[serde(default)]
    pub quadrature: Quadrature,
    pub points: Option<usize>,
}

#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    #[default]
    Fixed,
    Energy,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeTable {
    #[serde(default)]
    pub mode: Mode,
    pub step: Option<f64>,
    pub steps: Option<Vec<f64>>,
    /// Relative position error wanted at `end`: femvi chooses the step (and, without
    /// [scheme] order or degree, the degree) by pilot runs (femvi::step::auto).
    pub accuracy: Option<f64>,
    pub end: f64,
    pub min_step: Option<f64>,
    pub max_step: Option<f64>,
    pub on_degenerate: Option<OnDegenerate>,
}

#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum OnDegenerate {
    Error,
    Fixed,
}

#[derive(Debug, Deserialize, Default, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
pub enum SolverMethod {
    #[default]
    Auto,
    Newton,
    FixedPoint,
    Explicit,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SolverTable {
    pub tolerance: Option<f64>,
    pub max_iterations: Option<usize>,
    #[serde(default)]
    pub method: SolverMethod,
    pub polish: Option<bool>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct OutputTable {
    pub directory: Option<String>,
    pub every: Option<usize>,
    /// Draw plots (SVG) next to the trajectory.
    pub plots: Option<bool>,
}

/// A bad problem file: the message is complete (file, position, excerpt).
#[derive(Debug)]
pub struct InputError(pub String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

fn bad(msg: impl Into<String>) -> InputError {
    InputError(msg.into())
}

/// Line and column (1-based) of a byte offset, and the line's text.
fn locate(text: &str, offset: usize) -> (usize, usize, String) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    let col = text[start..offset].chars().count() + 1;
    let src = text[start..].lines().next().unwrap_or("").to_string();
    (line, col, src)
}

fn excerpt(file: &Path, text: &str, offset: usize, msg: &str) -> String {
    let (line, col, src) = locate(text, offset);
    format!(
        "{}:{line}:{col}: {msg}\n  {src}\n  {}^",
        file.display(),
        " ".repeat(col - 1)
    )
}

/// The system a problem describes: built-in or from an expression.
pub enum System {
    Expr(ExprLagrangian),
    Harmonic(femvi::Mechanical<models::HarmonicPotential>),
    Pendulum(femvi::Mechanical<models::PendulumPotential>),
    Kepler(femvi::Mechanical<models::KeplerPotential>),
    HenonHeiles(femvi::Mechanical<models::HenonHeilesPotential>),
    DoublePendulum(models::DoublePendulum),
    Forced(femvi::Mechanical<models::ForcedPotential>),
    Fpu(femvi::Mechanical<models::FpuPotential>),
    Gravity(femvi::Mechanical<models::GravityPotential>),
}

/// Everything a run needs, checked.
pub struct Problem {
    pub name: String,
    pub coordinates: Vec<String>,
    pub system: System,
    pub element: Element,
    pub scheme_label: String,
    pub grid: TimeGrid,
    pub start: Start,
    pub options: SolverOptions,
    pub directory: PathBuf,
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
            Some(span) => bad(excerpt(path, &text, span.start, &msg)),
            None => bad(format!("{}: {msg}", path.display())),
        }
    })?;
    Ok((text, file))
}

/// Reads and checks an initial value problem (for `run`, `check`, `convergence`).
pub fn load(path: &Path) -> Result<Problem, InputError> {
    let (text, file) = read(path)?;
    match build(path, &text, file, false)? {
        Loaded::Ivp(p) => Ok(p),
        Loaded::Bvp(_) => Err(bad(format!("{}: expected an initial value problem", path.display()))),
    }
}

/// Reads and checks a boundary value problem (for `bvp`).
pub fn load_bvp(path: &Path) -> Result<BvpProblem, InputError> {
    let (text, file) = read(path)?;
    match build(path, &text, file, true)? {
        Loaded::Bvp(p) => Ok(p),
        Loaded::Ivp(_) => Err(bad(format!("{}: expected a boundary value problem", path.display()))),
    }
}

/// A boundary value problem read from a file with a `[boundary]` table.
pub struct BvpProblem {
    pub name: String,
    pub coordinates: Vec<String>,
    pub system: System,
    pub element: Element,
    pub scheme_label: String,
    pub options: SolverOptions,
    pub directory: PathBuf,
    pub boundary: femvi::bvp::BoundaryValues,
    /// A trajectory file to interpolate as the initial guess.
    pub guess: Option<PathBuf>,
    /// `time_mode = "energy"`: the interior element end times are unknowns (a moving mesh).
    pub moving_mesh: bool,
}

/// What a problem file describes.
enum Loaded {
    Ivp(Problem),
    Bvp(BvpProblem),
}

fn build(path: &Path, text: &str, file: ProblemFile, want_bvp: bool) -> Result<Loaded, InputError> {
    let ctx = |msg: String| bad(format!("{}: {msg}", path.display()));
    let name = file.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "run".into())
    });
    // System.
    let sys = &file.system;
    let params: Vec<(String, f64)> = sys.parameters.iter().map(|(k, v)| (k.clone(), *v)).collect();
    let mut model_info = None;
    let (system, coordinates) = match (&sys.lagrangian, &sys.model) {
        (Some(_), Some(_)) => return Err(ctx("[system] has both `lagrangian` and `model`; give one".into())),
        (None, None) => {
            return Err(ctx(
                "[system] needs `lagrangian` (an expression) or `model` (a built-in system)".into(),
            ))
        }
        (None, Some(model)) => {
            models::info(model).ok_or_else(|| {
                let names: Vec<&str> = models::MODELS.iter().map(|m| m.name).collect();
                let hint = did_you_mean(model, &names);
                ctx(format!(
                    "unknown model '{model}'{hint}; built-in models: {}",
                    names.join(", ")
                ))
            })?;
            let p = models::parameters(model, &params).map_err(|e| ctx(e.to_string()))?;
            let coords = models::coordinates(model, &p);
            if let Some(given) = &sys.coordinates {
                if *given != coords {
                    return Err(ctx(format!(
                        "model '{model}' has coordinates [{}]; [system] coordinates = [{}] disagree (leave them out)",
                        coords.join(", "),
                        given.join(", ")
                    )));
                }
            }
            model_info = Some((model.clone(), p.clone()));
            let system = match model.as_str() {
                "harmonic" => {
                    System::Harmonic(models::harmonic(p[0], p[1]).map_err(|e| ctx(format!("model harmonic: {e}")))?)
                }
                "pendulum" => System::Pendulum(
                    models::pendulum(p[0], p[1], p[2]).map_err(|e| ctx(format!("model pendulum: {e}")))?,
                ),
                "kepler" => System::Kepler(models::kepler(p[0])),
                "henon-heiles" => System::HenonHeiles(models::henon_heiles()),
                "forced-oscillator" => System::Forced(
                    models::forced_oscillator(p[0], p[1], p[2], p[3])
                        .map_err(|e| ctx(format!("model forced-oscillator: {e}")))?,
                ),
                "fpu" => System::Fpu(models::fpu(p[0] as usize, p[1], p[2])),
                "n-body" => System::Gravity(
                    models::n_body(p[2], p[3..].to_vec(), p[1] as usize)
                        .map_err(|e| ctx(format!("model n-body: {e}")))?,
                ),
                "outer-solar-system" => System::Gravity(models::outer_solar_system()),
                _ => System::DoublePendulum(models::DoublePendulum {
                    m1: p[0],
                    m2: p[1],
                    l1: p[2],
                    l2: p[3],
                    g: p[4],
                }),
            };
            (system, coords)
        }
        (Some(expr), None) => {
            let coords = sys
                .coordinates
                .clone()
                .ok_or_else(|| ctx("[system] with a `lagrangian` needs `coordinates` (a list of names)".into()))?;
            if coords.is_empty() {
                return Err(ctx("[system] coordinates is empty".into()));
            }
            for c in &coords {
                let ok = c.chars().next().is_some_and(|ch| ch.is_ascii_alphabetic() || ch == '_')
                    && c.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_');
                if !ok || c == "t" || c == "pi" {
                    return Err(ctx(format!(
                        "coordinate name '{c}' is not allowed (letters, digits, _; not t or pi)"
                    )));
                }
            }
            if let Some(d) = coords.iter().enumerate().find(|(i, c)| coords[..*i].contains(c)) {
                return Err(ctx(format!("coordinate '{}' is named twice", d.1)));
            }
            if let Some((k, v)) = params.iter().find(|(_, v)| !v.is_finite()) {
                return Err(ctx(format!("parameter '{k}' = {v} is not finite")));
            }
            let lag =
                ExprLagrangian::new(expr.get_ref(), &coords, &params).map_err(|e| expr_error(path, text, expr, &e))?;
            (System::Expr(lag), coords)
        }
    };
    let n = coordinates.len();
    // Scheme.
    let sc = &file.scheme;
    let (element, scheme_label) = match sc.kind {
        Kind::Midpoint => {
            if sc.degree.is_some_and(|d| d != 1) || sc.points.is_some() || sc.order.is_some() {
                return Err(ctx("[scheme] kind = \"midpoint\" takes no degree or points".into()));
            }
            (Element::midpoint(), "midpoint (2.19)".to_string())
        }
        Kind::Galerkin => {
            if let Some(order) = sc.order {
                if sc.degree.is_some() || sc.points.is_some() || sc.quadrature != Quadrature::GaussLegendre {
                    return Err(ctx(
                        "[scheme] order chooses the element itself: give order, or degree/quadrature/points".into(),
                    ));
                }
                if order < 2 || order % 2 != 0 || order > 128 {
                    return Err(ctx(format!(
                        "[scheme] order = {order} must be an even number from 2 to 128"
                    )));
                }
            }
            let accuracy = file.time.as_ref().and_then(|t| t.accuracy);
            let degree = sc
                .order
                .map(|o| o / 2)
                .or(sc.degree)
                .or(accuracy
                    .filter(|a| a.is_finite() && *a > 0.0)
                    .map(femvi::step::auto::degree_for_accuracy))
                .unwrap_or(2);
            if degree == 0 || degree > 64 {
                return Err(ctx(format!("[scheme] degree = {degree} is out of range (1 to 64)")));
            }
            let rule = match sc.quadrature {
                Quadrature::Midpoint => QuadratureKind::Midpoint,
                Quadrature::Trapezoid => QuadratureKind::Trapezoid,
                Quadrature::Simpson => QuadratureKind::Simpson,
                Quadrature::GaussLegendre => QuadratureKind::GaussLegendre(sc.points.unwrap_or(degree)),
                Quadrature::GaussLobatto => QuadratureKind::GaussLobatto(sc.points.unwrap_or(degree + 1)),
            };
            if matches!(
                sc.quadrature,
                Quadrature::Midpoint | Quadrature::Trapezoid | Quadrature::Simpson
            ) && sc.points.is_some()
            {
                return Err(ctx(format!(
                    "[scheme] points does not apply to the {:?} rule",
                    sc.quadrature
                )));
            }
            if sc.points.is_some_and(|p| p > 1000) {
                return Err(ctx("[scheme] points must be at most 1000".into()));
            }
            let family = match sc.nodes {
                Nodes::Equispaced => NodeFamily::Equispaced,
                Nodes::Lobatto => NodeFamily::Lobatto,
            };
            let el = Element::galerkin(degree, family, rule).map_err(|e| ctx(format!("[scheme]: {e}")))?;
            el.check_nondegenerate().map_err(|e| ctx(format!("[scheme]: {e}")))?;
            (el, format!("galerkin degree {degree}, {:?} nodes, {rule:?}", sc.nodes))
        }
    };
    // Solver and output.
    let method = match file.solver.method {
        SolverMethod::Auto => Method::Auto,
        SolverMethod::Newton => Method::Newton,
        SolverMethod::FixedPoint => Method::FixedPoint,
        SolverMethod::Explicit => Method::Explicit,
    };
    let defaults = SolverOptions::default();
    let options = SolverOptions {
        tolerance: file.solver.tolerance.unwrap_or(defaults.tolerance),
        max_iterations: file.solver.max_iterations.unwrap_or(defaults.max_iterations),
        method,
        polish: file.solver.polish.unwrap_or(defaults.polish),
    };
    options.validate().map_err(|e| ctx(format!("[solver]: {e}")))?;
    let every = file.output.every.unwrap_or(1);
    if every == 0 {
        return Err(ctx("[output] every must be at least 1".into()));
    }
    let directory = PathBuf::from(file.output.directory.clone().unwrap_or_else(|| format!("out/{name}")));
    // Symmetries: declared in the file, else the built-in model's.
    let symmetries = match &file.symmetries {
        Some(table) => {
            let mut out = Vec::new();
            for d in &table.translations {
                if d.len() != n || d.iter().any(|x| !x.is_finite()) || d.iter().all(|x| *x == 0.0) {
                    return Err(ctx(format!(
                        "[symmetries] translation {d:?} must be a non-zero vector of {n} finite numbers"
                    )));
                }
                out.push(Symmetry::Translation(d.clone()));
            }
            for [i, j] in &table.rotations {
                if *i >= n || *j >= n || i == j {
                    return Err(ctx(format!(
                        "[symmetries] rotation [{i}, {j}] must name two different coordinate indices below {n}"
                    )));
                }
                out.push(Symmetry::Rotation(*i, *j));
            }
            out
        }
        None => match model_info.as_ref() {
            Some((m, p)) => model_symmetries(m, p),
            None => vec![],
        },
    };
    if want_bvp {
        if file.initial.is_some() || file.time.is_some() {
            return Err(ctx(
                "a boundary value problem takes [boundary] instead of [initial] and [time]".into(),
            ));
        }
        let b = file
            .boundary
            .as_ref()
            .ok_or_else(|| ctx("`femvi bvp` needs a [boundary] table (t0, q0, t1, q1, elements)".into()))?;
        if b.elements > 50_000_000 {
            return Err(ctx(format!(
                "[boundary] elements = {} is too many (at most 5e7)",
                b.elements
            )));
        }
        let boundary = femvi::bvp::BoundaryValues {
            t0: b.t0,
            q0: b.q0.clone(),
            t1: b.t1,
            q1: b.q1.clone(),
            elements: b.elements,
        };
        boundary.validate(n).map_err(|e| ctx(format!("[boundary]: {e}")))?;
        let guess = b
            .guess
            .as_ref()
            .map(|g| path.parent().unwrap_or(Path::new(".")).join(g));
        return Ok(Loaded::Bvp(BvpProblem {
            name,
            coordinates,
            system,
            element,
            scheme_label,
            options,
            directory,
            boundary,
            guess,
            moving_mesh: b.time_mode == Mode::Energy,
        }));
    }
    if file.boundary.is_some() {
        return Err(ctx(
            "[boundary] describes a boundary value problem: solve it with `femvi bvp`".into(),
        ));
    }
    let (Some(init), Some(tt)) = (file.initial.as_ref(), file.time.as_ref()) else {
        return Err(ctx(
            "an initial value problem needs [initial] and [time] (or [boundary] for `femvi bvp`)".into(),
        ));
    };
    // Time.
    let t0 = init.t.unwrap_or(0.0);
    let energy = match tt.mode {
        Mode::Fixed => {
            if tt.min_step.is_some() || tt.max_step.is_some() || tt.on_degenerate.is_some() {
                return Err(ctx(
                    "[time] min_step, max_step and on_degenerate apply only to mode = \"energy\"".into(),
                ));
            }
            None
        }
        Mode::Energy => {
            if tt.accuracy.is_some() {
                return Err(ctx(
                    "[time] accuracy chooses a uniform step; mode = \"energy\" takes the first `step` instead".into(),
                ));
            }
            let h = tt.step.ok_or_else(|| {
                ctx("[time] mode = \"energy\" needs `step` (the first step; later steps are variables)".into())
            })?;
            if tt.steps.is_some() {
                return Err(ctx(
                    "[time] mode = \"energy\" takes `step`, not a list of `steps`".into()
                ));
            }
            let d = femvi::EnergyOptions::from_step(h);
            Some(femvi::EnergyOptions {
                min_step: tt.min_step.unwrap_or(d.min_step),
                max_step: tt.max_step.unwrap_or(d.max_step),
                on_degenerate: match tt.on_degenerate {
                    Some(OnDegenerate::Fixed) => femvi::Degenerate::Fixed,
                    _ => femvi::Degenerate::Error,
                },
            })
        }
    };
    let grid = match (&tt.step, &tt.steps, &tt.accuracy) {
        (Some(h), None, None) => TimeGrid::uniform(t0, *h, tt.end),
        (None, Some(list), None) => TimeGrid::steps(t0, list.clone(), tt.end),
        // A placeholder until the step is chosen below (after the initial values).
        (None, None, Some(_)) => TimeGrid::uniform(t0, (tt.end - t0).abs().max(1.0), tt.end),
        _ => return Err(ctx("[time] needs exactly one of `step`, `steps` or `accuracy`".into())),
    }
    .map_err(|e| ctx(format!("[time]: {e}")))?;
    // Initial values.
    let check = |what: &str, v: &Vec<f64>| -> Result<(), InputError> {
        if v.len() != n {
            return Err(ctx(format!(
                "[initial] {what} has {} entries, but the system has {n} coordinates ({})",
                v.len(),
                coordinates.join(", ")
            )));
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(ctx(format!("[initial] {what} has a non-finite entry")));
        }
        Ok(())
    };
    check("q", &init.q)?;
    let start = match (&init.v, &init.p, &init.q1) {
        (Some(v), None, None) => {
            check("v", v)?;
            Start::Velocity {
                q: init.q.clone(),
                v: v.clone(),
            }
        }
        (None, Some(p), None) => {
            check("p", p)?;
            Start::Momentum {
                q: init.q.clone(),
                p: p.clone(),
            }
        }
        (None, None, Some(q1)) => {
            check("q1", q1)?;
            Start::Positions {
                q0: init.q.clone(),
                q1: q1.clone(),
            }
        }
        _ => return Err(ctx("[initial] needs exactly one of `v`, `p` or `q1`".into())),
    };
    // `[time] accuracy`: pilot runs choose the step (femvi::step::auto).
    let (grid, auto_step) = match tt.accuracy {
        None => (grid, None),
        Some(accuracy) => {
            let choice = crate::with_system!(&system, l => femvi::step::auto::choose_step(
                l, &element, &start, t0, tt.end, accuracy, options
            ))
            .map_err(|e| ctx(format!("[time] accuracy = {accuracy:e}: {e}")))?;
            let grid = TimeGrid::uniform(t0, choice.step, tt.end).map_err(|e| ctx(format!("[time]: {e}")))?;
            (grid, Some(choice))
        }
    };
    Ok(Loaded::Ivp(Problem {
        name,
        coordinates,
        system,
        element,
        scheme_label,
        grid,
        start,
        options,
        directory,
        every,
        energy,
        symmetries,
        model: model_info,
        plots: file.output.plots.unwrap_or(false),
        auto_step,
    }))
}

/// Maps an expression error to a position in the file where the string has no escapes.
fn expr_error(path: &Path, text: &str, expr: &toml::Spanned<String>, e: &femvi::expr::ExprError) -> InputError {
    let span = expr.span();
    let raw = text.get(span.clone()).unwrap_or("");
    let (mut open, close) = if raw.starts_with("\"\"\"") || raw.starts_with("'''") {
        (3, 3)
    } else {
        (1, 1)
    };
    if open == 3 && raw[3..].starts_with('\n') {
        open += 1;
    }
    let inner = raw.get(open..raw.len().saturating_sub(close)).unwrap_or("");
    if inner == expr.get_ref() {
        bad(excerpt(
            path,
            text,
            span.start + open + e.offset,
            &format!("in the lagrangian: {}", e.message),
        ))
    } else {
        bad(format!("{}: in the lagrangian: {}", path.display(), e.render()))
    }
}

/// serde's "unknown field `x`, expected one of `a`, `b`" (or "unknown variant …") with a
/// "did you mean" for the closest expected name.
fn with_suggestion(msg: &str) -> String {
    let unknown = ["unknown field `", "unknown variant `"]
        .iter()
        .find_map(|p| msg.strip_prefix(p));
    let Some(rest) = unknown else { return msg.to_string() };
    let Some((word, tail)) = rest.split_once('`') else {
        return msg.to_string();
    };
    let expected: Vec<&str> = tail.split('`').skip(1).step_by(2).collect();
    let hint = did_you_mean(word, &expected);
    if hint.is_empty() {
        msg.to_string()
    } else {
        format!("{msg}{hint}")
    }
}

/// " (did you mean 'x'?)" for the closest name within edit distance 2, else "".
pub fn did_you_mean(word: &str, names: &[&str]) -> String {
    let best = names.iter().map(|n| (strsim(word, n), n)).min_by_key(|(d, _)| *d);
    match best {
        Some((d, n)) if d <= 2 => format!(" (did you mean '{n}'?)"),
        _ => String::new(),
    }
}

/// Levenshtein distance (small strings).
fn strsim(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}
