//! A potential written in Python, for prototyping: V(q) and the force −∇V(q) as two Python
//! callables taking a NumPy array, with diagonal masses given from Python, make the
//! mechanical Lagrangian L = ½vᵀMv − V(q) (paper (2.18) with a mass matrix), which the
//! fixed-point and explicit solvers integrate from the force alone.
//!
//! Each call takes the GIL and converts q to an array: 3–4 µs with NumPy arithmetic inside,
//! far more than a Rust or expression force (`examples/callable_cost.py` measures it). What a
//! Python function cannot give, femvi does not invent silently:
//! - dual numbers: V is evaluated at the real part and extended to first order by the force
//!   (V(q + dq) = V(q) − F(q)·dq, exact for first derivatives); second-order parts are zero;
//! - the force Jacobian (iteration matrices only: Newton's when `method = "newton"` is asked
//!   for, constrained and adaptive steps) and its products by central differences of the
//!   force: convergence is still decided by the residual, so a rough matrix costs
//!   iterations, not accuracy;
//! - time steps as variables need exact second derivatives and are refused.
//!
//! The first exception a callable raises (or a result of the wrong length) is kept, the
//! value becomes NaN, which stops the run at that step, and the exception is re-raised.

use crate::events::Raised;
use crate::run::{run_on, run_with, Extras, Run};
use femvi::{MassMatrix, Mechanical, Potential, Scalar};
use femvi_cli::problem::Problem;
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use std::path::Path;

/// V(q) and F(q) = −∇V(q) from Python.
pub struct PyPotential {
    n: usize,
    potential: Py<PyAny>,
    force: Py<PyAny>,
    raised: Raised,
}

impl PyPotential {
    /// The potential of `n` coordinates; exceptions go to `raised`.
    pub fn new(n: usize, potential: Py<PyAny>, force: Py<PyAny>, raised: Raised) -> Self {
        Self {
            n,
            potential,
            force,
            raised,
        }
    }

    fn call_value(&self, q: &[f64]) -> f64 {
        Python::with_gil(|py| {
            let r = self
                .potential
                .call1(py, (q.to_vec().into_pyarray(py),))
                .and_then(|r| r.extract::<f64>(py));
            r.unwrap_or_else(|e| {
                self.raised.keep(e);
                f64::NAN
            })
        })
    }

    fn call_force(&self, q: &[f64], out: &mut [f64]) {
        let got = Python::with_gil(|py| -> PyResult<()> {
            let r = self.force.call1(py, (q.to_vec().into_pyarray(py),))?;
            let a: PyReadonlyArray1<'_, f64> = r.extract(py)?;
            let s = a.as_slice()?;
            if s.len() != out.len() {
                return Err(crate::input_error(format!(
                    "force(q) returned {} values; the system has {} coordinates",
                    s.len(),
                    out.len()
                )));
            }
            out.copy_from_slice(s);
            Ok(())
        });
        if let Err(e) = got {
            self.raised.keep(e);
            out.iter_mut().for_each(|x| *x = f64::NAN);
        }
    }
}

impl Potential for PyPotential {
    fn dim(&self) -> usize {
        self.n
    }

    fn is_autonomous(&self) -> bool {
        true
    }

    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        let re: Vec<f64> = q.iter().map(|x| x.re()).collect();
        let v = D::from(self.call_value(&re));
        if D::NDERIV == 0 {
            return v;
        }
        // First order from the force: V(q + dq) = V(q) − F(q)·dq.
        let mut f = vec![0.0; self.n];
        self.call_force(&re, &mut f);
        q.iter()
            .zip(&re)
            .zip(&f)
            .fold(v, |acc, ((&x, &r), &fi)| acc - (x - D::from(r)) * fi)
    }

    fn force(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        self.call_force(q, out);
    }

    /// Central differences of the force along dq, step 1e-6·max(1, |q|)/|dq| (see the module
    /// documentation), so that no product silently takes the zero second derivatives of
    /// [`PyPotential::value`]'s dual numbers.
    fn force_derivative(&self, _t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        let n = self.n;
        if q.len() != n || dq.len() != n || out.len() != n {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        let size = dq.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if size == 0.0 {
            out.iter_mut().for_each(|x| *x = 0.0);
            return;
        }
        let h = 1e-6 * q.iter().fold(1.0f64, |m, x| m.max(x.abs())) / size;
        let (mut x, mut fm) = (vec![0.0; n], vec![0.0; n]);
        x.iter_mut().zip(q).zip(dq).for_each(|((x, q), d)| *x = q + h * d);
        self.call_force(&x, out);
        x.iter_mut().zip(q).zip(dq).for_each(|((x, q), d)| *x = q - h * d);
        self.call_force(&x, &mut fm);
        out.iter_mut().zip(&fm).for_each(|(o, m)| *o = (*o - m) / (2.0 * h));
    }

    /// Central differences of the force, step 1e-6·max(1, |q_j|) (for iteration matrices
    /// only; see the module documentation).
    fn force_jacobian(&self, _t: f64, q: &[f64], out: &mut [f64]) {
        let n = self.n;
        if out.len() != n * n || q.len() != n {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        let (mut x, mut fp, mut fm) = (q.to_vec(), vec![0.0; n], vec![0.0; n]);
        for j in 0..n {
            let h = 1e-6 * q[j].abs().max(1.0);
            x[j] = q[j] + h;
            self.call_force(&x, &mut fp);
            x[j] = q[j] - h;
            self.call_force(&x, &mut fm);
            x[j] = q[j];
            for i in 0..n {
                out[i * n + j] = (fp[i] - fm[i]) / (2.0 * h);
            }
        }
    }
}

/// What the Python side passes: V(q), F(q) and the diagonal masses (None: all 1).
pub type PySystem = (Py<PyAny>, Py<PyAny>, Option<Vec<f64>>);

/// The mechanical Lagrangian of the Python potential `system` for a loaded problem (its
/// `[system]` a placeholder that names the coordinates). Err: the message as the command would
/// print it (energy mode refused: it needs exact second derivatives).
pub fn lagrangian(
    problem: &Problem,
    path: &Path,
    system: PySystem,
    raised: &Raised,
) -> Result<Mechanical<PyPotential>, String> {
    let bad = |e: String| format!("{}: {e}", path.display());
    if problem.energy.is_some() {
        return Err(bad(
            "time steps as variables ([time] mode = \"energy\") need exact second \
                        derivatives, which a Python potential cannot give; use an expression or a model"
                .into(),
        ));
    }
    let n = problem.coordinates.len();
    let (potential, force, masses) = system;
    let masses = masses.unwrap_or_else(|| vec![1.0; n]);
    if masses.len() != n {
        return Err(bad(format!(
            "masses has {} entries; the system has {n} coordinates",
            masses.len()
        )));
    }
    let mass = MassMatrix::diagonal(masses).map_err(|e| bad(e.to_string()))?;
    Mechanical::new(PyPotential::new(n, potential, force, raised.clone()), mass).map_err(|e| bad(e.to_string()))
}

/// Runs a loaded problem without terms with the Python potential's Lagrangian `lag`.
/// Err: the message as the command would print it.
pub fn run(problem: &Problem, path: &Path, extras: &Extras, lag: Mechanical<PyPotential>) -> Result<Run, String> {
    run_on(problem, path, extras, |options| run_with(lag, problem, options))
}
