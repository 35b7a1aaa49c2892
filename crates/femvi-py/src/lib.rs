//! `femvi._core`: the Rust half of the Python package. Problem files are loaded with the
//! command's own loader (`femvi_cli::problem`) and run through the library's `solve_with`
//! (`solve.rs`) or, for ensembles, member by member on a rayon pool (`ensemble.rs`), with the
//! GIL released. The Python half (python/femvi/) turns paths, TOML text, dicts and overrides
//! into a problem file, and wraps the results in `Solution` and typed exceptions.
//!
//! The crate has no Rust tests (pytest's are in tests/). `cargo test --workspace` builds it in
//! test mode only so that dependency features resolve as for the wheel (scripts/test-all.sh):
//! there the module entry point is left out, so nothing is generated for it.
#![cfg_attr(test, allow(dead_code, unused_imports))]

mod adaptive;
mod arrays;
mod callable;
mod ensemble;
mod events;
mod info;
mod recorded;
mod rotations;
mod run;
mod solve;
mod tables;

use pyo3::create_exception;
use pyo3::prelude::*;

create_exception!(
    _core,
    InputError,
    pyo3::exceptions::PyValueError,
    "A bad problem: the message is the one `femvi run` prints."
);

/// The Rust extension of the femvi package.
#[cfg(not(test))]
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add_function(wrap_pyfunction!(solve::solve_file, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::ensemble_file, m)?)?;
    m.add_function(wrap_pyfunction!(info::models, m)?)?;
    m.add_function(wrap_pyfunction!(info::model_problem, m)?)?;
    m.add_function(wrap_pyfunction!(info::check_file, m)?)?;
    m.add_function(wrap_pyfunction!(info::bvp_file, m)?)?;
    m.add_function(wrap_pyfunction!(info::optimize_file, m)?)?;
    m.add_function(wrap_pyfunction!(info::convergence_file, m)?)?;
    m.add_class::<solve::Dense>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

/// An [`InputError`] with this message.
pub(crate) fn input_error(msg: impl Into<String>) -> PyErr {
    InputError::new_err(msg.into())
}
