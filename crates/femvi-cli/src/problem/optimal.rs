//! An optimal control problem (`femvi optimize`): a file with `[boundary]` and `[controls]`,
//! optionally `[objective]`, `[coordinate_bounds]`, `[forces]` and `[constraints]`, checked
//! and built from what every problem shares (`Common`, read by `build` in the parent).

use super::errors::{bad, Source};
use super::{
    forces, label, loaded, read_text, Common, ControlBoundary, ControlSpec, InputError, Loaded, ProblemFile, System,
};
use femvi::Element;
use std::path::{Path, PathBuf};

/// An optimal control problem: a file with `[boundary]` and `[controls]` (`femvi optimize`).
pub struct OptimizeProblem {
    /// Its name.
    pub name: String,
    /// Coordinate names.
    pub coordinates: Vec<String>,
    /// The Lagrangian.
    pub system: System,
    /// The element.
    pub element: Element,
    /// The element, described.
    pub scheme_label: String,
    /// The optimiser's tolerance and iteration limit (`[solver] tolerance` and
    /// `max_iterations`; defaults 1e-9 and 200).
    pub options: femvi::optimize::OptimizeOptions,
    /// The default output directory.
    pub directory: PathBuf,
    /// The ends and the mesh.
    pub boundary: ControlBoundary,
    /// The controls and the objective.
    pub control: ControlSpec,
    /// `[coordinate_bounds]`: lower and upper bounds of the coordinates (empty: none).
    pub coordinate_bounds: (Vec<f64>, Vec<f64>),
    /// `[constraints]`, held at every node.
    pub constraints: Option<femvi::constraints::ExprConstraints>,
    /// `[forces]`: the system's own force, added to the controls' force.
    pub force: Option<forces::ProblemForce>,
    /// The problem file's text.
    pub source: String,
}

/// Reads and checks an optimal control problem (for `optimize`), with overrides.
pub fn load_optimize_with(path: &Path, overrides: &[String]) -> Result<OptimizeProblem, InputError> {
    let text = read_text(path)?;
    match loaded(path, &text, overrides, true)? {
        Loaded::Optimize(p) => Ok(*p),
        _ => Err(bad(format!(
            "{}: `femvi optimize` needs [boundary] and [controls] (the controls, their force and bounds) and optionally [objective]",
            label(path).display()
        ))),
    }
}

/// `[boundary]` and `[controls]` (and neither `[initial]`, `[time]` nor events).
pub(super) fn build_optimize(src: &Source, file: &ProblemFile, c: Common) -> Result<OptimizeProblem, InputError> {
    if file.initial.is_some() || file.time.is_some() || !file.events.is_empty() {
        return Err(src
            .error("an optimal control problem takes [boundary] and [controls], not [initial], [time] or [[events]]"));
    }
    // The optimiser holds the constraints at every node; the initial value problem's default
    // (weak) is taken to mean that, and the modes coincide for degree 1.
    let written = file.constraints.as_ref().and_then(|t| t.enforcement.as_deref());
    let constraints = match (&c.terms.constraints, written) {
        (None, _) => None,
        (Some((k, _)), None | Some("nodes")) => Some(k.clone()),
        (Some((k, _)), Some(_)) if c.element.degree() == 1 => Some(k.clone()),
        (Some(_), Some(e)) => {
            return Err(src.error(format!(
                "[constraints] enforcement = \"{e}\": `femvi optimize` holds the constraints at every node; leave enforcement out or write \"nodes\""
            )))
        }
    };
    let b = file
        .boundary
        .as_ref()
        .ok_or_else(|| src.error("`femvi optimize` needs a [boundary] table (t0, q0, v0, t1, q1, v1, elements)"))?;
    let boundary = b.resolve_control(c.system.coordinates.len(), src)?;
    let coordinate_bounds = match &file.coordinate_bounds {
        Some(t) => t.resolve(&c.system.coordinates, src)?,
        None => (vec![], vec![]),
    };
    let control = file
        .controls
        .as_ref()
        .ok_or_else(|| src.error("`femvi optimize` needs [controls]"))?
        .resolve(file.objective.as_ref(), &c.system.coordinates, &c.parameters, src)?;
    Ok(OptimizeProblem {
        name: c.name,
        coordinates: c.system.coordinates,
        system: c.system.system,
        element: c.element,
        scheme_label: c.scheme_label,
        options: femvi::optimize::OptimizeOptions {
            tolerance: file.solver.tolerance.unwrap_or(1e-9),
            max_iterations: file.solver.max_iterations.unwrap_or(200),
            guess: None,
            coarse: Vec::new(),
        },
        directory: c.directory,
        boundary,
        control,
        coordinate_bounds,
        constraints,
        force: c.terms.force,
        source: c.source,
    })
}
