//! Events located by an observer of any driven run ([`crate::step::drive()`]): after each
//! accepted step the element just solved is scanned for the zeros of every event's g
//! (`events.rs`: sampled at τ = j/m, then regula falsi), as the recorder of
//! [`crate::solution::solve_with`] scans it, so that the same run locates the same events,
//! bit for bit, whether it is solved to the end or streamed with checkpoints. A stopping
//! event stops the drive ([`Observer::stop`]); [`EventLocator::state`] and
//! [`EventLocator::restore`] carry the detector's state (g at the end of the last element)
//! through a checkpoint.

use super::events::{Detector, Event, EventRecord, Span};
use crate::discrete::Element;
use crate::error::{invalid, Result};
use crate::fem::LagrangeBasis;
use crate::lagrangian::Lagrangian;
use crate::step::{Integrator, Observer};

/// Locates events on the elements of a driven run (the module documentation).
///
/// # Example
///
/// ```
/// use femvi::solution::{Event, EventLocator};
/// use femvi::step::drive;
/// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
///
/// // The oscillator x = cos t crosses x = 0 at π/2, 3π/2, 5π/2 before t = 9 (degree 4: the
/// // element polynomial between nodes is within O(h⁵) of the motion).
/// let (lag, element) = (models::harmonic(1.0, 1.0)?, Element::with_order(8)?);
/// let grid = TimeGrid::uniform(0.0, 0.05, 9.0)?;
/// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
/// let mut it = Integrator::new(&lag, &element, grid, start, SolverOptions::default())?;
/// let mut events = EventLocator::new(vec![Event::new("x = 0", |_t, q, _v| q[0])], &element, 1);
/// drive(&mut it, &mut [&mut events]);
/// let times: Vec<f64> = events.found().iter().map(|r| r.t).collect();
/// assert_eq!(times.len(), 3);
/// assert!((times[2] - 2.5 * std::f64::consts::PI).abs() < 1e-10);
/// # Ok::<(), femvi::Error>(())
/// ```
pub struct EventLocator {
    detector: Detector,
    basis: LagrangeBasis,
    found: Vec<EventRecord>,
    /// The next node shown is the one a restored run continues from: its element was scanned
    /// before the checkpoint.
    skip_next: bool,
}

impl EventLocator {
    /// A locator of `events` on the elements of `element` in dimension `n`.
    pub fn new(events: Vec<Event>, element: &Element, n: usize) -> Self {
        Self {
            detector: Detector::new(events, &element.basis, n),
            basis: element.basis.clone(),
            found: Vec::new(),
            skip_next: false,
        }
    }

    /// The events located and not yet taken, in the order found (per step, by event).
    pub fn found(&self) -> &[EventRecord] {
        &self.found
    }

    /// Takes the events located so far (to write them as the run goes).
    pub fn take(&mut self) -> Vec<EventRecord> {
        std::mem::take(&mut self.found)
    }

    /// The events looked for.
    pub fn events(&self) -> &[Event] {
        &self.detector.events
    }

    /// Whether a stopping event has occurred.
    pub fn stopped(&self) -> bool {
        self.detector.stop
    }

    /// The detector's state: g of each event at the end of the last element, and whether a
    /// stopping event occurred (for a checkpoint).
    pub fn state(&self) -> Vec<u64> {
        let mut words: Vec<u64> = self.detector.last_g.iter().map(|g| g.to_bits()).collect();
        words.push(u64::from(self.detector.stop));
        words
    }

    /// Restores what [`EventLocator::state`] gave; the next node shown is taken to be the
    /// checkpoint's, whose element was scanned before it.
    ///
    /// # Errors
    /// A state of another number of events.
    pub fn restore(&mut self, words: &[u64]) -> Result<()> {
        let m = self.detector.last_g.len();
        if words.len() != m + 1 {
            return Err(invalid(
                "checkpoint",
                format!("an event state of {} words, this run has {m} events", words.len()),
            ));
        }
        for (g, w) in self.detector.last_g.iter_mut().zip(words) {
            *g = f64::from_bits(*w);
        }
        self.detector.stop = words[m] != 0;
        self.skip_next = true;
        Ok(())
    }
}

impl<L: Lagrangian> Observer<L> for EventLocator {
    fn node(&mut self, it: &Integrator<'_, L>, _last: bool) -> Result<()> {
        if std::mem::take(&mut self.skip_next) {
            return Ok(());
        }
        let k = it.node().k;
        // Rotations follow their elements' paths between nodes (also after a restore).
        self.detector
            .eval
            .set_rotations(it.rotations().map_or(&[][..], |r| r.offsets()));
        let Some(el) = it.last_element().filter(|_| k > 0) else {
            return Ok(());
        };
        let span = Span {
            step: k - 1,
            t0: el.t,
            h: el.h,
            base: el.base,
            incr: el.incr,
        };
        self.detector.scan(it.lagrangian(), &self.basis, &span, &mut self.found);
        Ok(())
    }

    fn stop(&self) -> bool {
        self.detector.stop
    }
}
