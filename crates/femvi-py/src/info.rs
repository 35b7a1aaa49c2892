//! The model catalogue, the models' problem files, and `femvi check` / `femvi convergence` /
//! `femvi bvp` reports.

use crate::input_error;
use femvi_cli::models::MODEL_FILES;
use femvi_cli::problem;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// The built-in models: a list of dicts (name, description, parameters, coordinates).
#[pyfunction]
pub fn models(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for m in femvi::models::MODELS {
        let d = PyDict::new(py);
        d.set_item("name", m.name)?;
        d.set_item("description", m.description)?;
        let params = PyDict::new(py);
        for (k, v) in m.parameters {
            params.set_item(*k, *v)?;
        }
        d.set_item("parameters", params)?;
        let defaults = femvi::models::parameters(m.name, &[]).unwrap_or_default();
        let coords = femvi::models::coordinates(m.name, &defaults);
        let labels: Vec<String> = problem::model_symmetries(m.name, &defaults)
            .iter()
            .map(|s| s.label(&coords))
            .collect();
        d.set_item("coordinates", coords)?;
        d.set_item("symmetries", labels)?;
        list.append(d)?;
    }
    Ok(list)
}

/// The complete problem file of a built-in model, as `femvi models NAME` prints it.
#[pyfunction]
pub fn model_problem(name: &str) -> PyResult<&'static str> {
    MODEL_FILES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            let names: Vec<&str> = MODEL_FILES.iter().map(|(n, _)| *n).collect();
            input_error(format!(
                "unknown model '{name}'{}; built-in models: {}",
                problem::did_you_mean(name, &names),
                names.join(", ")
            ))
        })
}

/// `femvi check` on a problem file: its JSON report, as text.
#[pyfunction]
pub fn check_file(py: Python<'_>, path: PathBuf) -> PyResult<String> {
    py.allow_threads(|| {
        let p = problem::load(&path).map_err(|e| e.to_string())?;
        let report = femvi_cli::check::check(&p).map_err(|(msg, _)| format!("{}: {msg}", path.display()))?;
        serde_json::to_string(&report).map_err(|e| e.to_string())
    })
    .map_err(input_error)
}

/// `femvi bvp` on a problem file, with its output into `dir`: the summary's JSON text.
#[pyfunction]
pub fn bvp_file(py: Python<'_>, path: PathBuf, dir: PathBuf) -> PyResult<String> {
    py.allow_threads(|| {
        let p = problem::load_bvp(&path).map_err(|e| e.to_string())?;
        let s = femvi_cli::bvp::run(&p, &dir).map_err(|(msg, _)| format!("{}: {msg}", path.display()))?;
        serde_json::to_string(&s).map_err(|e| e.to_string())
    })
    .map_err(input_error)
}

/// `femvi optimize` on a problem file, with its output into `dir`: the summary's JSON text
/// and the optimum's arrays (node times, positions and momenta; the quadrature points'
/// times and controls).
#[pyfunction]
pub fn optimize_file<'py>(py: Python<'py>, path: PathBuf, dir: PathBuf) -> PyResult<(String, Bound<'py, PyDict>)> {
    let (text, best, n, m) = py
        .allow_threads(|| {
            let p = problem::load_optimize_with(&path, &[]).map_err(|e| e.to_string())?;
            let (s, best) =
                femvi_cli::optimize::run(&p, &dir, None).map_err(|(msg, _)| format!("{}: {msg}", path.display()))?;
            let text = serde_json::to_string(&s).map_err(|e| e.to_string())?;
            Ok::<_, String>((text, best, p.coordinates.len(), p.control.names.len()))
        })
        .map_err(input_error)?;
    let out = PyDict::new(py);
    out.set_item("t", crate::arrays::vec1(py, best.t))?;
    out.set_item("q", crate::arrays::rows(py, best.q, n)?)?;
    out.set_item("p", crate::arrays::rows(py, best.p, n)?)?;
    out.set_item("control_t", crate::arrays::vec1(py, best.control_t))?;
    out.set_item("u", crate::arrays::rows(py, best.u, m)?)?;
    out.set_item("u_nodes", crate::arrays::rows(py, best.u_nodes, m)?)?;
    Ok((text, out))
}

/// `femvi convergence` on a problem file (steps, `reference` as `--reference`, `l2` as
/// `--l2`): its JSON report, as text.
#[pyfunction]
#[pyo3(signature = (path, steps, reference=None, l2=false))]
pub fn convergence_file(
    py: Python<'_>,
    path: PathBuf,
    steps: Vec<f64>,
    reference: Option<String>,
    l2: bool,
) -> PyResult<String> {
    py.allow_threads(|| {
        let reference = reference.as_deref().map(str::parse).transpose()?;
        let p = problem::load(&path).map_err(|e| e.to_string())?;
        let study = femvi_cli::convergence::study(&p, &steps, reference, l2)
            .map_err(|(msg, _)| format!("{}: {msg}", path.display()))?;
        serde_json::to_string(&study).map_err(|e| e.to_string())
    })
    .map_err(input_error)
}
