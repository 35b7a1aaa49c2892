//! Driving a run and recording it: [`drive`] steps an [`Integrator`] to the end of its grid
//! and calls every [`Observer`] at each accepted node, at the end, and after a failure. Every
//! output of a run (CSV and NPY rows, plot data, the energy maximum, summaries, and later
//! checkpoints or Python arrays) is an observer, so the loop that drives a run is written
//! once, here.

use super::Integrator;
use crate::error::{Error, Result};
use crate::lagrangian::Lagrangian;

/// Something that records a run as it goes.
///
/// [`drive`] calls [`Observer::node`] at the start node and after every accepted step, then
/// [`Observer::finish`] once, with the error that stopped the run if any. An observer that
/// fails (an output that cannot be written) stops the run: its error is reported like a
/// step's.
///
/// # Example
///
/// ```
/// use femvi::step::{drive, Observer};
/// use femvi::{models, Element, Integrator, Lagrangian, SolverOptions, Start, TimeGrid};
///
/// /// Counts the nodes of a run and keeps the largest |q|.
/// #[derive(Default)]
/// struct Largest { nodes: usize, max_q: f64 }
///
/// impl<L: Lagrangian> Observer<L> for Largest {
///     fn node(&mut self, it: &Integrator<'_, L>, _last: bool) -> femvi::Result<()> {
///         self.nodes += 1;
///         self.max_q = it.node().q.iter().fold(self.max_q, |m, x| m.max(x.abs()));
///         Ok(())
///     }
/// }
///
/// let lag = models::harmonic(1.0, 1.0)?;
/// let element = Element::midpoint();
/// let grid = TimeGrid::uniform(0.0, 0.01, 1.0)?;
/// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
/// let mut it = Integrator::new(&lag, &element, grid, start, SolverOptions::default())?;
/// let mut largest = Largest::default();
/// let report = drive(&mut it, &mut [&mut largest]);
/// assert!(report.error.is_none());
/// assert_eq!(report.steps, 100);
/// assert_eq!(largest.nodes, 101);
/// assert!((largest.max_q - 1.0).abs() < 1e-12);
/// # Ok::<(), femvi::Error>(())
/// ```
pub trait Observer<L: Lagrangian> {
    /// Records a node: the start node, then the node after each accepted step. `last` is
    /// true at the final node of the grid (not after a failure).
    ///
    /// # Errors
    /// Whatever stops the run (typically [`Error::Observer`] for output that failed).
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> Result<()>;

    /// Called once when the run ends, at the node it ended on, with the error that stopped
    /// it (a step's or an observer's), if any.
    ///
    /// # Errors
    /// Output that could not be completed.
    fn finish(&mut self, it: &Integrator<'_, L>, error: Option<&Error>) -> Result<()> {
        let _ = (it, error);
        Ok(())
    }

    /// Whether the run should stop after the node just recorded, without an error (an
    /// event that stops the run, a step limit). Default: never.
    fn stop(&self) -> bool {
        false
    }
}

/// How a driven run ended.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveReport {
    /// Steps taken.
    pub steps: usize,
    /// Whether an observer stopped the run before the end of the grid.
    pub stopped: bool,
    /// The first error: a step that failed, or an observer that failed (also in `finish`).
    pub error: Option<Error>,
}

/// Steps `it` to the end of its grid, calling the observers at every node (in the order
/// given), and `finish` on each at the end; an observer's [`Observer::stop`] ends the run
/// early. A failure of a step or of an observer stops the
/// run; the integrator stays at the last good node and every observer's `finish` still runs.
/// See [`Observer`] for an example.
pub fn drive<L: Lagrangian>(it: &mut Integrator<'_, L>, observers: &mut [&mut dyn Observer<L>]) -> DriveReport {
    let mut error = notify(it, observers, it.finished()).err();
    let mut steps = 0;
    let stop = |observers: &[&mut dyn Observer<L>]| observers.iter().any(|o| o.stop());
    let mut stopped = stop(observers);
    while error.is_none() && !stopped {
        match it.step() {
            Ok(true) => {
                steps += 1;
                error = notify(it, observers, it.finished()).err();
                stopped = stop(observers);
            }
            Ok(false) => break,
            Err(e) => error = Some(e),
        }
    }
    for o in observers.iter_mut() {
        if let Err(e) = o.finish(it, error.as_ref()) {
            error.get_or_insert(e);
        }
    }
    DriveReport { steps, stopped, error }
}

fn notify<L: Lagrangian>(it: &Integrator<'_, L>, observers: &mut [&mut dyn Observer<L>], last: bool) -> Result<()> {
    for o in observers.iter_mut() {
        o.node(it, last)?;
    }
    Ok(())
}
