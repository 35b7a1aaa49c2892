//! Vectors into NumPy arrays without a copy (the array takes the vector's buffer).

use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;

/// A 1-D array owning `v`.
pub fn vec1(py: Python<'_>, v: Vec<f64>) -> Bound<'_, PyAny> {
    v.into_pyarray(py).into_any()
}

/// A 1-D array of indices owning `v`.
pub fn index1(py: Python<'_>, v: Vec<usize>) -> Bound<'_, PyAny> {
    let v: Vec<i64> = v.into_iter().map(|k| k as i64).collect();
    v.into_pyarray(py).into_any()
}

/// A (len / n, n) array owning the row-major `v` (a view of it, reshaped without a copy).
pub fn rows(py: Python<'_>, v: Vec<f64>, n: usize) -> PyResult<Bound<'_, PyAny>> {
    let n = n.max(1);
    let r = v.len() / n;
    Ok(v.into_pyarray(py).reshape([r, n])?.into_any())
}
