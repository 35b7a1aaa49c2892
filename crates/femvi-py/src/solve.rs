//! One run of a problem file, as `femvi run` does it: the problem is loaded with the
//! command's loader, its grid becomes the library's `Steps`, and `solve` drives the same
//! integrator the command builds. The library's energy tracker is the one behind the
//! command's energy observer, so the energies (and their largest relative error) are the
//! command's bit for bit, computed once per node. This file is the Python function
//! (`solve_file`) and the dense output class; the run itself is `run.rs`.

use crate::arrays::{index1, rows, vec1};
use crate::input_error;
use crate::recorded::Added;
use crate::run::{load_any, run, Extras, Run};
use crate::tables::Tables;
use femvi::solution::DenseOutput;
use femvi_cli::problem::capabilities::Use;
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// The dense output of a run: q and q̇ of the finite element solution at any time in its span.
#[pyclass(module = "femvi._core")]
pub struct Dense {
    out: DenseOutput,
    n: usize,
}

#[pymethods]
impl Dense {
    /// (t_start, t_end) of the dense output.
    fn span(&self) -> (f64, f64) {
        self.out.span()
    }

    /// q and v at the times `t` (1-D array): two (len(t), n) arrays.
    fn state_at<'py>(
        &self,
        py: Python<'py>,
        t: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let times = t.as_slice()?.to_vec();
        let n = self.n;
        let (mut q, mut v) = (vec![0.0; times.len() * n], vec![0.0; times.len() * n]);
        for (i, &ti) in times.iter().enumerate() {
            self.out
                .state_at(ti, &mut q[i * n..(i + 1) * n], &mut v[i * n..(i + 1) * n])
                .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?;
        }
        Ok((rows(py, q, n)?, rows(py, v, n)?))
    }
}

/// Runs the problem file at `path` (GIL released) and returns its results as a dict.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (path, every=None, saveat=None, dense=false, max_steps=None, events=None, potential=None))]
pub fn solve_file(
    py: Python<'_>,
    path: PathBuf,
    every: Option<usize>,
    saveat: Option<Vec<f64>>,
    dense: bool,
    max_steps: Option<usize>,
    events: Option<Vec<crate::events::Spec>>,
    potential: Option<crate::callable::PySystem>,
) -> PyResult<Bound<'_, PyDict>> {
    let raised = crate::events::Raised::default();
    let extras = Extras {
        every,
        saveat: saveat.unwrap_or_default(),
        dense,
        max_steps,
        events: crate::events::events(events.unwrap_or_default(), &raised)?,
    };
    type Done = (Run, Option<Vec<f64>>, Added, Vec<String>, String, String, Vec<String>);
    let done = py.allow_threads(|| -> Result<Done, String> {
        let problem = load_any(&path)?;
        let named = |e: String| format!("{}: {e}", path.display());
        let adaptive = problem.terms.adaptive.clone();
        if potential.is_some() {
            problem.refuse(Use::PythonPotential, "femvi.solve").map_err(named)?;
        }
        // A Python potential takes the place of the file's system, with the file's terms.
        let python = match potential {
            Some(system) => Some(crate::callable::lagrangian(&problem, &path, system, &raised)?),
            None => None,
        };
        if problem.terms.rotations.is_some() {
            // The Lie-group element (with its torques), through the library's recorder.
            let (r, added) = crate::rotations::run(&problem, &path, &extras)?;
            let labels = (
                problem.coordinates.clone(),
                problem.name.clone(),
                problem.scheme_label.clone(),
            );
            let names = femvi_cli::record::rotation_names(&problem);
            return Ok((r, None, added, labels.0, labels.1, labels.2, names));
        }
        if let Some(tables) = Tables::of(&problem) {
            let (r, added) = match python {
                Some(lag) => tables.run_lagrangian(lag, &problem, &path, &extras)?,
                None => tables.run(&problem, &path, &extras)?,
            };
            let labels = (
                problem.coordinates.clone(),
                problem.name.clone(),
                problem.scheme_label.clone(),
            );
            return Ok((r, None, added, labels.0, labels.1, labels.2, vec![]));
        }
        let (r, s) = match (python, adaptive) {
            (None, None) => (run(&problem, &path, &extras)?, None),
            (None, Some(a)) => {
                let (r, s) = crate::adaptive::run(&problem, &path, &extras, &a)?;
                (r, Some(s))
            }
            (Some(lag), Some(a)) => {
                let (r, s) = crate::adaptive::run_lagrangian(lag, &problem, &path, &extras, &a)?;
                (r, Some(s))
            }
            (Some(lag), None) => (crate::callable::run(&problem, &path, &extras, lag)?, None),
        };
        Ok((
            r,
            s,
            Added::default(),
            problem.coordinates.clone(),
            problem.name.clone(),
            problem.scheme_label.clone(),
            vec![],
        ))
    });
    if let Some(e) = raised.take() {
        return Err(e);
    }
    let (r, s, added, coordinates, name, scheme, rotations) = done.map_err(input_error)?;
    let d = to_dict(py, r, coordinates, name, scheme)?;
    // The rotations' names: their blocks of nine entries are the first coordinates.
    d.set_item("rotations", rotations)?;
    if let Some(s) = s {
        d.set_item("s", vec1(py, s))?;
    }
    if let Some((work, abs, rel)) = added.work {
        d.set_item("work", vec1(py, work))?;
        d.set_item("max_energy_balance_error", abs)?;
        d.set_item("max_rel_energy_balance_error", rel)?;
    }
    if let Some((m, multipliers, residual, max_residual)) = added.constraints {
        d.set_item("multipliers", rows(py, multipliers, m)?)?;
        d.set_item("constraint_residual", vec1(py, residual))?;
        d.set_item("max_constraint_residual", max_residual)?;
    }
    Ok(d)
}

fn to_dict(
    py: Python<'_>,
    r: Run,
    coordinates: Vec<String>,
    name: String,
    scheme: String,
) -> PyResult<Bound<'_, PyDict>> {
    let s = r.sol;
    let n = s.n;
    let d = PyDict::new(py);
    d.set_item("name", name)?;
    d.set_item("scheme", scheme)?;
    d.set_item("coordinates", coordinates)?;
    d.set_item("node", index1(py, s.step))?;
    d.set_item("t", vec1(py, s.t))?;
    d.set_item("q", rows(py, s.q, n)?)?;
    d.set_item("p", rows(py, s.p, n)?)?;
    d.set_item("v", rows(py, s.v, n)?)?;
    d.set_item("energy", vec1(py, s.energy))?;
    d.set_item("saved_t", vec1(py, s.saved.t))?;
    d.set_item("saved_q", rows(py, s.saved.q, n)?)?;
    d.set_item("saved_v", rows(py, s.saved.v, n)?)?;
    d.set_item("saved_p", rows(py, s.saved.p, n)?)?;
    d.set_item("steps", s.steps)?;
    d.set_item("mean_iterations", s.mean_iterations)?;
    d.set_item("max_rel_energy_error", r.max_rel_energy_error)?;
    if let Some(report) = s.energy_report {
        d.set_item("energy_nodes", report.nodes.name())?;
    }
    d.set_item("stopped", s.stopped)?;
    if let Some(st) = s.energy_stats {
        let e = PyDict::new(py);
        e.set_item("max_rel_residual", st.max_rel_residual)?;
        e.set_item("min_step", st.min_step)?;
        e.set_item("max_step", st.max_step)?;
        e.set_item("degenerate_steps", st.degenerate_steps)?;
        d.set_item("energy_stats", e)?;
    }
    let events = pyo3::types::PyList::empty(py);
    for ev in s.events {
        let e = PyDict::new(py);
        e.set_item("name", r.event_names.get(ev.event).cloned().unwrap_or_default())?;
        e.set_item("from_file", ev.event < r.file_events)?;
        e.set_item("event", ev.event)?;
        e.set_item("step", ev.step)?;
        e.set_item("t", ev.t)?;
        e.set_item("q", vec1(py, ev.q))?;
        e.set_item("v", vec1(py, ev.v))?;
        e.set_item("p", vec1(py, ev.p))?;
        events.append(e)?;
    }
    d.set_item("events", events)?;
    if let Some(out) = s.dense {
        d.set_item("dense", Dense { out, n })?;
    }
    match &s.error {
        None => d.set_item("error", None::<String>)?,
        Some(e) => {
            d.set_item("error", r.message.clone().unwrap_or_else(|| e.to_string()))?;
            match e {
                femvi::Error::Step(se) => {
                    d.set_item("error_step", se.step)?;
                    d.set_item("error_t", se.t)?;
                }
                femvi::Error::NonFiniteEnergy { step, t } => {
                    d.set_item("error_step", step)?;
                    d.set_item("error_t", t)?;
                }
                _ => {}
            }
        }
    }
    Ok(d)
}
