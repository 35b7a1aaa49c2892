//! Ensembles: N runs of one problem with other initial states and/or parameters, on a rayon
//! pool of `workers` threads with the GIL released. Each member is driven exactly as a single
//! run (and as `femvi run`): the same integrator, the command's energy observer; a member's
//! failure is its own error and does not stop the others.

use crate::arrays::{rows, vec1};
use crate::input_error;
use crate::solve::load;
use femvi::step::drive;
use femvi::{Integrator, Lagrangian, Start};
use femvi_cli::problem::Problem;
use femvi_cli::record::EnergyError;
use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

/// What one member ends with.
struct Member {
    final_t: f64,
    q: Vec<f64>,
    p: Vec<f64>,
    energy_error: f64,
    steps: usize,
    error: Option<String>,
}

impl Member {
    fn failed(n: usize, t: f64, error: String) -> Self {
        Member {
            final_t: t,
            q: vec![f64::NAN; n],
            p: vec![f64::NAN; n],
            energy_error: f64::NAN,
            steps: 0,
            error: Some(error),
        }
    }
}

/// Drives `problem` from `start` to its end (or its first failure).
fn run_member(problem: &Problem, start: Start) -> Member {
    femvi_cli::with_system!(&problem.system, l => drive_member(l, problem, start))
}

fn drive_member<L: Lagrangian>(lag: &L, problem: &Problem, start: Start) -> Member {
    let n = lag.dim();
    let mut energy = EnergyError::new(n, &start, lag.is_autonomous());
    let grid = problem.grid.clone();
    let made = match problem.energy {
        None => Integrator::new(lag, &problem.element, grid, start, problem.options),
        Some(e) => Integrator::with_energy(lag, &problem.element, grid, start, problem.options, e),
    };
    let mut it = match made {
        Ok(it) => it,
        Err(femvi::Error::Step(e)) => return Member::failed(n, problem.grid.t0(), format!("first element: {e}")),
        Err(e) => return Member::failed(n, problem.grid.t0(), e.to_string()),
    };
    let report = drive(&mut it, &mut [&mut energy]);
    let node = it.node();
    Member {
        final_t: node.t,
        q: node.q.to_vec(),
        p: node.p.to_vec(),
        energy_error: energy.max_rel(),
        steps: report.steps,
        error: report.error.map(|e| e.to_string()),
    }
}

/// The start of member i: row i of `states` as (q, p) or (q, v), else the problem's own.
fn start_of(problem: &Problem, states: Option<&[f64]>, i: usize, n: usize, velocity: bool) -> Start {
    match states {
        None => problem.start.clone(),
        Some(s) => {
            let row = &s[i * 2 * n..(i + 1) * 2 * n];
            let (q, x) = (row[..n].to_vec(), row[n..].to_vec());
            if velocity {
                Start::Velocity { q, v: x }
            } else {
                Start::Momentum { q, p: x }
            }
        }
    }
}

/// Runs an ensemble. `path`: the problem file; `member_files`: one problem file per member
/// (other parameters), or None to share `path`'s; `states`: (N, 2n) rows of (q0, p0) (or
/// (q0, v0) with `velocity`); `count`: N when neither is given per member.
#[pyfunction]
#[pyo3(signature = (path, member_files=None, states=None, velocity=false, count=1, workers=None))]
pub fn ensemble_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    member_files: Option<Vec<PathBuf>>,
    states: Option<PyReadonlyArray2<'py, f64>>,
    velocity: bool,
    count: usize,
    workers: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let (problem, _) = load(&path).map_err(input_error)?;
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
    let threads = workers.unwrap_or(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    let bad_input = AtomicUsize::new(usize::MAX);
    let members: Vec<Member> = py.allow_threads(|| {
        pool.install(|| {
            (0..size)
                .into_par_iter()
                .map(|i| match &member_files {
                    None => run_member(&problem, start_of(&problem, states.as_deref(), i, n, velocity)),
                    Some(files) => match load(&files[i]) {
                        Ok((p, _)) => {
                            let start = start_of(&p, states.as_deref(), i, n, velocity);
                            run_member(&p, start)
                        }
                        Err(e) => {
                            bad_input.fetch_min(i, Ordering::Relaxed);
                            Member::failed(n, f64::NAN, e)
                        }
                    },
                })
                .collect()
        })
    });
    let first_bad = bad_input.load(Ordering::Relaxed);
    if first_bad != usize::MAX {
        let msg = members[first_bad].error.clone().unwrap_or_default();
        return Err(input_error(format!("member {first_bad}: {msg}")));
    }
    gather(py, members, n)
}

fn gather(py: Python<'_>, members: Vec<Member>, n: usize) -> PyResult<Bound<'_, PyDict>> {
    let m = members.len();
    let (mut t, mut q, mut p, mut e, mut steps) = (
        Vec::with_capacity(m),
        Vec::with_capacity(m * n),
        Vec::with_capacity(m * n),
        Vec::with_capacity(m),
        Vec::with_capacity(m),
    );
    let mut errors: Vec<Option<String>> = Vec::with_capacity(m);
    for mb in members {
        t.push(mb.final_t);
        q.extend(mb.q);
        p.extend(mb.p);
        e.push(mb.energy_error);
        steps.push(mb.steps);
        errors.push(mb.error);
    }
    let d = PyDict::new(py);
    d.set_item("final_t", vec1(py, t))?;
    d.set_item("final_q", rows(py, q, n)?)?;
    d.set_item("final_p", rows(py, p, n)?)?;
    d.set_item("energy_error", vec1(py, e))?;
    d.set_item("steps", crate::arrays::index1(py, steps))?;
    d.set_item("errors", errors)?;
    Ok(d)
}
