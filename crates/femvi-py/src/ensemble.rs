//! Ensembles: N runs of one problem with other initial states and/or parameters, on a rayon
//! pool of `workers` threads with the GIL released, through the command's own ensemble runner
//! (`femvi_cli::ensemble`, which `femvi ensemble` uses): each member is driven exactly as a
//! single run (members of one problem with no saved times in SIMD lanes where the run takes
//! them, `femvi_cli::ensemble::run_shared`); a member's failure is its own error and does
//! not stop the others. A progress
//! callback, if given, is called from the calling thread with (done, total) about five
//! times a second while the members run.

use crate::arrays::{rows, vec1};
use crate::input_error;
use crate::run::load;
use femvi_cli::ensemble::{run_all, run_member, run_member_saving, run_shared, start_of, with_body, Member};
use numpy::{PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

/// Runs an ensemble. `path`: the problem file; `member_files`: one problem file per member
/// (other parameters), or None to share `path`'s; `states`: (N, 2n) rows of (q0, p0) (or
/// (q0, v0) with `velocity`); `count`: N when neither is given per member.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (path, member_files=None, states=None, velocity=false, count=1, workers=None, progress=None, saveat=None))]
pub fn ensemble_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    member_files: Option<Vec<PathBuf>>,
    states: Option<PyReadonlyArray2<'py, f64>>,
    velocity: bool,
    count: usize,
    workers: Option<usize>,
    progress: Option<Py<PyAny>>,
    saveat: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyDict>> {
    let saveat = saveat.unwrap_or_default();
    if saveat.iter().any(|t| !t.is_finite()) || saveat.windows(2).any(|w| w[0] >= w[1]) {
        return Err(input_error("saveat: times must be finite and strictly increasing"));
    }
    let problem = load(&path).map_err(input_error)?;
    if !saveat.is_empty() {
        let named = |e: String| format!("{}: {e}", path.display());
        let why = femvi_cli::problem::capabilities::Use::SaveatOrDense;
        problem
            .refuse(why, "femvi.ensemble")
            .map_err(named)
            .map_err(input_error)?;
    }
    let n = problem.coordinates.len();
    let states: Option<Vec<f64>> = match &states {
        None => None,
        Some(a) => {
            let shape = a.as_array().shape().to_vec();
            if shape[1] != 2 * n {
                return Err(input_error(format!(
                    "initial_states has {} columns; this system needs 2n = {} (q0 then p0 or v0)",
                    shape[1],
                    2 * n
                )));
            }
            Some(a.as_array().iter().copied().collect())
        }
    };
    let size = match (&member_files, &states) {
        (Some(f), _) => f.len(),
        (None, Some(s)) => s.len() / (2 * n).max(1),
        (None, None) => count,
    };
    if let (Some(f), Some(s)) = (&member_files, &states) {
        if s.len() != f.len() * 2 * n {
            return Err(input_error(
                "initial_states and parameters have different numbers of members",
            ));
        }
    }
    let bad_input = AtomicUsize::new(usize::MAX);
    let done = AtomicUsize::new(0);
    let member = |i: usize| -> Member {
        let loaded;
        let p = match &member_files {
            None => &problem,
            Some(files) => match load(&files[i]) {
                Ok(p) => {
                    loaded = p;
                    &loaded
                }
                Err(e) => {
                    bad_input.fetch_min(i, Ordering::Relaxed);
                    return Member::failed(n, f64::NAN, e);
                }
            },
        };
        match start_of(p, states.as_deref(), i, velocity) {
            Ok(start) if saveat.is_empty() => with_body(p, run_member(p, start)),
            Ok(start) => with_body(p, run_member_saving(p, start, &saveat)),
            Err(e) => {
                bad_input.fetch_min(i, Ordering::Relaxed);
                Member::failed(n, f64::NAN, e)
            }
        }
    };
    let workers = workers.unwrap_or(0);
    // One problem for all and no saved times: in SIMD lanes where the run takes them.
    let shared = member_files.is_none() && saveat.is_empty();
    let start = |i: usize| {
        start_of(&problem, states.as_deref(), i, velocity).inspect_err(|_| {
            bad_input.fetch_min(i, Ordering::Relaxed);
        })
    };
    let ran = py.allow_threads(|| {
        std::thread::scope(|scope| {
            let worker = scope.spawn(|| {
                if shared {
                    run_shared(&problem, size, workers, &done, start)
                        .map(|all| all.into_iter().map(|m| with_body(&problem, m)).collect())
                } else {
                    run_all(size, workers, &done, member)
                }
            });
            if let Some(cb) = &progress {
                while !worker.is_finished() {
                    std::thread::sleep(Duration::from_millis(200));
                    let k = done.load(Ordering::Relaxed);
                    // A failing progress callback only loses the display.
                    let _ = Python::with_gil(|py| cb.call1(py, (k, size)));
                }
            }
            worker
                .join()
                .unwrap_or_else(|_| Err("an ensemble worker panicked".into()))
        })
    });
    let members = ran.map_err(pyo3::exceptions::PyRuntimeError::new_err)?;
    if let Some(cb) = &progress {
        let _ = cb.call1(py, (size, size));
    }
    let first_bad = bad_input.load(Ordering::Relaxed);
    if first_bad != usize::MAX {
        let msg = members[first_bad].error.clone().unwrap_or_default();
        return Err(input_error(format!("member {first_bad}: {msg}")));
    }
    let body = 6 * femvi_cli::record::rotation_names(&problem).len();
    gather(py, members, (n, body), &saveat)
}

/// The members' results stacked into the arrays of `femvi.EnsembleResult` (n coordinates,
/// `body` numbers of [`Member::body`] per member: each rotation's w and Π).
fn gather<'py>(
    py: Python<'py>,
    members: Vec<Member>,
    (n, body): (usize, usize),
    saveat: &[f64],
) -> PyResult<Bound<'py, PyDict>> {
    let m = members.len();
    let (mut t, mut q, mut p, mut e, mut steps) = (
        Vec::with_capacity(m),
        Vec::with_capacity(m * n),
        Vec::with_capacity(m * n),
        Vec::with_capacity(m),
        Vec::with_capacity(m),
    );
    let mut errors: Vec<Option<String>> = Vec::with_capacity(m);
    let mut bodies = Vec::with_capacity(m * body);
    let (mut sq, mut sp) = (
        Vec::with_capacity(m * saveat.len() * n),
        Vec::with_capacity(m * saveat.len() * n),
    );
    for mb in members {
        // A member that never started has no saved rows: NaN.
        let rows = |v: Vec<f64>| {
            if v.is_empty() {
                vec![f64::NAN; saveat.len() * n]
            } else {
                v
            }
        };
        sq.extend(rows(mb.saved_q));
        sp.extend(rows(mb.saved_p));
        t.push(mb.final_t);
        q.extend(mb.q);
        p.extend(mb.p);
        e.push(mb.energy_error);
        steps.push(mb.steps);
        errors.push(mb.error);
        bodies.extend((0..body).map(|k| mb.body.get(k).copied().unwrap_or(f64::NAN)));
    }
    let d = PyDict::new(py);
    d.set_item("final_t", vec1(py, t))?;
    d.set_item("final_q", rows(py, q, n)?)?;
    d.set_item("final_p", rows(py, p, n)?)?;
    d.set_item("energy_error", vec1(py, e))?;
    d.set_item("steps", crate::arrays::index1(py, steps))?;
    d.set_item("errors", errors)?;
    if body > 0 {
        d.set_item("body", rows(py, bodies, body)?)?;
    }
    if !saveat.is_empty() {
        let shape = [m, saveat.len(), n];
        d.set_item("saved_t", vec1(py, saveat.to_vec()))?;
        d.set_item("saved_q", numpy::PyArray1::from_vec(py, sq).reshape(shape)?)?;
        d.set_item("saved_p", numpy::PyArray1::from_vec(py, sp).reshape(shape)?)?;
    }
    Ok(d)
}
