//! Events given from Python: `(name, g, direction, stop)` with g(t, q, v) -> float a Python
//! callable, turned into the library's [`Event`]s. g is called with the GIL taken for each
//! sample; the first exception it raises is kept (g then counts as NaN, which brackets no
//! zero) and re-raised when the run is over.

use femvi::solution::{Direction, Event};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// The first exception raised by an event function, shared by all of a run's events.
#[derive(Clone, Default)]
pub struct Raised(Arc<Mutex<Option<PyErr>>>);

impl Raised {
    pub(crate) fn keep(&self, e: PyErr) {
        if let Ok(mut slot) = self.0.lock() {
            slot.get_or_insert(e);
        }
    }

    /// The exception, if one was raised.
    pub fn take(&self) -> Option<PyErr> {
        self.0.lock().ok().and_then(|mut s| s.take())
    }
}

/// One event as the Python side gives it.
pub type Spec = (String, Py<PyAny>, String, bool);

/// The library's events for `specs`. Err: an unknown direction.
pub fn events(specs: Vec<Spec>, raised: &Raised) -> PyResult<Vec<Event>> {
    specs
        .into_iter()
        .map(|(name, g, direction, stop)| {
            let direction = match direction.as_str() {
                "rising" => Direction::Rising,
                "falling" => Direction::Falling,
                "both" => Direction::Both,
                other => {
                    return Err(crate::input_error(format!(
                        "event '{name}': direction must be rising, falling or both, not '{other}'"
                    )))
                }
            };
            let raised = raised.clone();
            let condition = move |t: f64, q: &[f64], v: &[f64]| -> f64 {
                Python::with_gil(|py| {
                    let args = (t, q.to_vec().into_pyarray(py), v.to_vec().into_pyarray(py));
                    match g.call1(py, args).and_then(|r| r.extract::<f64>(py)) {
                        Ok(x) => x,
                        Err(e) => {
                            raised.keep(e);
                            f64::NAN
                        }
                    }
                })
            };
            Ok(Event::new(name, condition).direction(direction).stop(stop))
        })
        .collect()
}
