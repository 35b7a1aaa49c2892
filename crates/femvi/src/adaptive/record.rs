//! The observer of an adaptive run: accumulates the physical time t(s) element by element
//! (`clock.rs`, compensated sum), keeps every `every`-th node with its s, t, q, p, physical
//! velocity and energy H, answers requested physical times (`saveat`) from the element
//! polynomial in s mapped through t(s), and stops the run at the first node at or past the
//! physical end time (steps are not clipped: a shorter last step in s would be a change of
//! the discrete Lagrangian, and nothing in s is aligned with t anyway). Events are located on
//! each step by the fixed-step detector (`events.rs`); a stopping event ends the run at the
//! step's end node.

use super::clock::Clock;
use super::events::AdaptivePiece;
use super::lagrangian::TimeTransformed;
use super::monitor::Monitor;
use crate::discrete::Element;
use crate::error::{energy_failed_at, finite_energy, Error, Result};
use crate::lagrangian::{hamiltonian, Lagrangian, PointDerivatives};
use crate::solution::{Detector, EventRecord, Saved};
use crate::step::{Integrator, Observer};

/// The observer of an adaptive run (the module documentation): the physical clock, the kept
/// nodes, the states at requested physical times and the events. [`super::solve_adaptive`]
/// keeps everything it records; a streaming run takes what was recorded after each node
/// ([`Recorder::take`]) and carries the recorder's state through checkpoints
/// ([`Recorder::state`], [`Recorder::restore`]).
///
/// # Example
///
/// ```
/// use femvi::adaptive::{setup, AdaptiveOptions, KeplerMonitor, Recorder};
/// use femvi::step::drive;
/// use femvi::{models, Element, Integrator, Problem, Start};
///
/// // A circular Kepler orbit, one period 2π, streamed: the rows are taken after each node.
/// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
/// let problem = Problem::new(models::kepler(1.0)?, start, 0.0, 2.0 * std::f64::consts::PI);
/// let (element, options) = (Element::with_order(4)?, AdaptiveOptions::step(0.05));
/// let run = setup(&problem, KeplerMonitor, &options)?;
/// let mut it = Integrator::new(&run.lagrangian, &element, run.grid.clone(), run.start.clone(), run.solver)?;
/// let mut recorder = Recorder::new(&element, 2, 0.0, problem.t_end, &options);
/// drive(&mut it, &mut [&mut recorder]);
/// let rows = recorder.take();
/// let last = rows.t.len() - 1;
/// // The run stops at the first node past the end; on the circle x = cos t, y = sin t.
/// let (t, x, y) = (rows.t[last], rows.q[2 * last], rows.q[2 * last + 1]);
/// assert!(t >= problem.t_end && (x - t.cos()).abs() < 1e-6 && (y - t.sin()).abs() < 1e-6);
/// # Ok::<(), femvi::Error>(())
/// ```
pub struct Recorder<'e> {
    element: &'e Element,
    every: usize,
    t_end: f64,
    max_steps: usize,
    /// Physical time of the current node and its compensation term.
    t: f64,
    t_comp: f64,
    pub(crate) s: Vec<f64>,
    pub(crate) time: Vec<f64>,
    pub(crate) q: Vec<f64>,
    pub(crate) p: Vec<f64>,
    pub(crate) v: Vec<f64>,
    pub(crate) energy: Vec<f64>,
    saveat: Vec<f64>,
    next_save: usize,
    pub(crate) saved: Saved,
    clock: Clock,
    work: PointDerivatives,
    node_v: Vec<f64>,
    scratch: (Vec<f64>, Vec<f64>, Vec<f64>),
    last_kept: Option<usize>,
    pub(crate) reached: bool,
    k: usize,
    detector: Option<Detector>,
    pub(crate) events: Vec<EventRecord>,
    /// The next node shown is the one a restored run continues from (recorded before).
    skip_next: bool,
}

/// What a [`Recorder`] recorded since it was last taken: the kept nodes (s, physical t, q, p,
/// physical v and H, row-major), the states at requested physical times and the events.
#[derive(Debug, Clone, Default)]
pub struct AdaptiveRows {
    /// Fictitious times s of the kept nodes.
    pub s: Vec<f64>,
    /// Physical times of the kept nodes.
    pub t: Vec<f64>,
    /// Positions, n per node.
    pub q: Vec<f64>,
    /// Momenta, n per node.
    pub p: Vec<f64>,
    /// Physical velocities, n per node.
    pub v: Vec<f64>,
    /// H at the kept nodes.
    pub energy: Vec<f64>,
    /// States at the requested physical times.
    pub saved: Saved,
    /// Located events.
    pub events: Vec<EventRecord>,
}

impl<'e> Recorder<'e> {
    /// The recorder of a run from physical time t0 to t_end in dimension n with `element` and
    /// the options' `every`, `saveat`, `events` and `max_steps`.
    pub fn new(element: &'e Element, n: usize, t0: f64, t_end: f64, options: &super::AdaptiveOptions) -> Self {
        Self {
            element,
            every: options.every,
            t_end,
            max_steps: options.max_steps,
            t: t0,
            t_comp: 0.0,
            s: vec![],
            time: vec![],
            q: vec![],
            p: vec![],
            v: vec![],
            energy: vec![],
            saveat: options.saveat.clone(),
            next_save: 0,
            saved: Saved::default(),
            clock: Clock::new(element, n),
            work: PointDerivatives::new(n),
            node_v: vec![0.0; n],
            scratch: (vec![0.0; n], vec![0.0; n], vec![0.0; n]),
            last_kept: None,
            reached: false,
            k: 0,
            detector: (!options.events.is_empty()).then(|| Detector::new(options.events.clone(), &element.basis, n)),
            events: vec![],
            skip_next: false,
        }
    }

    /// Moves what was recorded so far into `rows` (cleared first), keeping the capacity of
    /// both: a streaming run's way of taking the rows without an allocation per node.
    pub fn take_into(&mut self, rows: &mut AdaptiveRows) {
        fn swap(a: &mut Vec<f64>, b: &mut Vec<f64>) {
            b.clear();
            std::mem::swap(a, b);
        }
        swap(&mut self.s, &mut rows.s);
        swap(&mut self.time, &mut rows.t);
        swap(&mut self.q, &mut rows.q);
        swap(&mut self.p, &mut rows.p);
        swap(&mut self.v, &mut rows.v);
        swap(&mut self.energy, &mut rows.energy);
        swap(&mut self.saved.t, &mut rows.saved.t);
        swap(&mut self.saved.q, &mut rows.saved.q);
        swap(&mut self.saved.v, &mut rows.saved.v);
        swap(&mut self.saved.p, &mut rows.saved.p);
        rows.events.clear();
        std::mem::swap(&mut self.events, &mut rows.events);
    }

    /// Takes what was recorded so far (the recorder keeps its clock and state).
    pub fn take(&mut self) -> AdaptiveRows {
        AdaptiveRows {
            s: std::mem::take(&mut self.s),
            t: std::mem::take(&mut self.time),
            q: std::mem::take(&mut self.q),
            p: std::mem::take(&mut self.p),
            v: std::mem::take(&mut self.v),
            energy: std::mem::take(&mut self.energy),
            saved: std::mem::take(&mut self.saved),
            events: std::mem::take(&mut self.events),
        }
    }

    /// The physical time of the current node.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Whether the run reached its physical end time.
    pub fn reached(&self) -> bool {
        self.reached
    }

    /// The recorder's state for a checkpoint: the clock with its compensation, the next
    /// requested time, the last kept node, the step and the event detector's state.
    pub fn state(&self) -> Vec<u64> {
        let mut w = vec![
            self.t.to_bits(),
            self.t_comp.to_bits(),
            self.next_save as u64,
            self.last_kept.map_or(u64::MAX, |k| k as u64),
            u64::from(self.reached),
            self.k as u64,
        ];
        if let Some(d) = &self.detector {
            w.extend(d.last_g.iter().map(|g| g.to_bits()));
            w.push(u64::from(d.stop));
        }
        w
    }

    /// Restores [`Recorder::state`]; the next node shown is taken to be the checkpoint's,
    /// which was recorded before it.
    ///
    /// # Errors
    /// A state of another length (another run's).
    pub fn restore(&mut self, words: &[u64]) -> Result<()> {
        let m = self.detector.as_ref().map_or(0, |d| d.last_g.len() + 1);
        if words.len() != 6 + m {
            return Err(crate::error::invalid(
                "checkpoint",
                format!(
                    "an adaptive recorder state of {} words, this run has {}",
                    words.len(),
                    6 + m
                ),
            ));
        }
        self.t = f64::from_bits(words[0]);
        self.t_comp = f64::from_bits(words[1]);
        self.next_save = words[2] as usize;
        self.last_kept = (words[3] != u64::MAX).then_some(words[3] as usize);
        self.reached = words[4] != 0;
        self.k = words[5] as usize;
        if let Some(d) = self.detector.as_mut() {
            let n = d.last_g.len();
            for (g, w) in d.last_g.iter_mut().zip(&words[6..6 + n]) {
                *g = f64::from_bits(*w);
            }
            d.stop = words[6 + n] != 0;
        }
        self.skip_next = true;
        Ok(())
    }

    fn keep<L: Lagrangian>(&mut self, lag: &L, k: usize, s: f64, q: &[f64], p: &[f64]) -> Result<()> {
        if self.last_kept == Some(k) {
            return Ok(());
        }
        let h = finite_energy(
            hamiltonian(lag, self.t, q, p, &mut self.node_v, &mut self.work)?,
            k,
            self.t,
        )?;
        self.last_kept = Some(k);
        self.s.push(s);
        self.time.push(self.t);
        self.q.extend_from_slice(q);
        self.p.extend_from_slice(p);
        self.v.extend_from_slice(&self.node_v);
        self.energy.push(h);
        Ok(())
    }

    /// The saveat times in (t_prev, t] (t_prev: the previous node's) from the element.
    fn save_element<L: Lagrangian, G: Monitor>(
        &mut self,
        lg: &TimeTransformed<L, G>,
        el: &crate::step::ElementNodes<'_>,
        t_prev: f64,
        total: f64,
    ) {
        while let Some(&ts) = self.saveat.get(self.next_save) {
            if ts > self.t {
                break;
            }
            self.next_save += 1;
            let (q, qs, p) = (&mut self.scratch.0, &mut self.scratch.1, &mut self.scratch.2);
            let sigma = self.clock.locate(self.element, lg.monitor(), el, ts - t_prev, total);
            self.clock.interpolate(self.element, el, sigma, q, Some(qs));
            // The physical velocity v = q'/g and its momentum ∂L/∂v (= ∂L_g/∂q').
            let g = lg.monitor().value(q);
            qs.iter_mut().for_each(|x| *x /= g);
            lg.inner().first_derivatives(ts, q, qs, false, &mut self.work);
            p.copy_from_slice(self.work.l_v());
            self.saved.t.push(ts);
            self.saved.q.extend_from_slice(q);
            self.saved.v.extend_from_slice(qs);
            self.saved.p.extend_from_slice(p);
        }
    }
}

impl<L: Lagrangian, G: Monitor> Observer<TimeTransformed<L, G>> for Recorder<'_> {
    fn node(&mut self, it: &Integrator<'_, TimeTransformed<L, G>>, _last: bool) -> Result<()> {
        if std::mem::take(&mut self.skip_next) {
            return Ok(());
        }
        let node = it.node();
        let lg = it.lagrangian();
        self.k = node.k;
        if node.k == 0 {
            // Kept first: a start whose energy is not finite leaves nothing, not a saved state.
            self.keep(lg.inner(), node.k, node.t, node.q, node.p)?;
            while self.saveat.get(self.next_save).is_some_and(|&ts| ts < self.t) {
                self.next_save += 1; // before the start
            }
            if self.saveat.get(self.next_save) == Some(&self.t) {
                self.next_save += 1;
                hamiltonian(lg.inner(), self.t, node.q, node.p, &mut self.node_v, &mut self.work)?;
                self.saved.t.push(self.t);
                self.saved.q.extend_from_slice(node.q);
                self.saved.v.extend_from_slice(&self.node_v);
                self.saved.p.extend_from_slice(node.p);
            }
            return Ok(());
        }
        let Some(el) = it.last_element() else {
            return Ok(());
        };
        let total = self.clock.elapsed(self.element, lg.monitor(), &el, 1.0);
        if !(total.is_finite() && total > 0.0) {
            return Err(Error::Invalid {
                what: "monitor".into(),
                reason: format!(
                    "the physical time step {total} at s = {} (t = {}) is not positive and finite: g(q) must be > 0",
                    el.t, self.t
                ),
            });
        }
        let t_prev = self.t;
        let y = total + self.t_comp;
        let sum = self.t + y;
        self.t_comp = (self.t - sum) + y;
        self.t = sum;
        if self.saveat.get(self.next_save).is_some_and(|&ts| ts <= self.t) {
            self.save_element(lg, &el, t_prev, total);
        }
        if let Some(detector) = self.detector.as_mut() {
            let m = (self.element.nodes() - 1).max(2);
            let mut piece = AdaptivePiece {
                step: node.k - 1,
                element: self.element,
                monitor: lg.monitor(),
                el: &el,
                clock: &mut self.clock,
                t_prev,
            };
            let before = self.events.len();
            detector.scan_piece(lg.inner(), &mut piece, m, &mut self.events);
            // The last step overshoots t_end (it is not clipped): its events past t_end are
            // outside the span, as for fixed steps.
            let t_end = self.t_end;
            let mut i = before;
            while i < self.events.len() {
                if self.events[i].t > t_end {
                    self.events.remove(i);
                } else {
                    i += 1;
                }
            }
        }
        self.reached = self.t >= self.t_end;
        let keep = self.reached || (self.every > 0 && node.k.is_multiple_of(self.every));
        if keep {
            self.keep(lg.inner(), node.k, node.t, node.q, node.p)?;
        }
        Ok(())
    }

    fn finish(&mut self, it: &Integrator<'_, TimeTransformed<L, G>>, error: Option<&Error>) -> Result<()> {
        let node = it.node();
        // The node the run ended on is kept, whatever stopped it, if its energy can be had:
        // not the node whose energy failed the run; a run that ended without an error on a
        // node whose energy cannot be had fails there (no node is left out silently).
        if energy_failed_at(error, node.k) {
            return Ok(());
        }
        match self.keep(it.lagrangian().inner(), node.k, node.t, node.q, node.p) {
            Err(e) if error.is_none() => Err(e),
            _ => Ok(()),
        }
    }

    fn stop(&self) -> bool {
        self.reached || self.k >= self.max_steps || self.detector.as_ref().is_some_and(|d| d.stop)
    }
}
