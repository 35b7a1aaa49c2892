//! Events: the zeros of a user function g(t, q, v) along the run, located on the dense output
//! (the element polynomial of each step, `dense.rs`). After each step g is sampled at
//! τ = j/m (m = max(s, 2)) on the new element; a sign change brackets a zero, which regula
//! falsi (Illinois) narrows to a few units of round-off in t. The state recorded there is
//! (q_h, q̇_h) and p = ∂L/∂v(t, q_h, q̇_h) — of orders s + 1 and s in the step. Poincaré
//! sections are the headline use: g = a coordinate, direction rising.

use super::dense::{momentum, ElementEval};
use crate::fem::LagrangeBasis;
use crate::lagrangian::{Lagrangian, PointDerivatives};

/// Which sign changes of g count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// From negative to non-negative.
    Rising,
    /// From positive to non-positive.
    Falling,
    /// Both.
    Both,
}

/// The condition g(t, q, v) of an event (shared, so that options can be cloned and used from
/// several threads).
pub type Condition = std::sync::Arc<dyn Fn(f64, &[f64], &[f64]) -> f64 + Send + Sync>;

/// An event: a named function whose zeros are located, a direction filter, and whether the
/// first occurrence stops the run.
///
/// # Example
///
/// ```
/// use femvi::solution::{Direction, Event};
///
/// // Crossings of x = 0 from left to right, stopping the run at the first one.
/// let event = Event::new("x = 0", |_t, q, _v| q[0]).direction(Direction::Rising).stop(true);
/// assert_eq!(event.name, "x = 0");
/// ```
#[derive(Clone)]
pub struct Event {
    /// A label for the records.
    pub name: String,
    /// g(t, q, v).
    pub condition: Condition,
    /// The direction filter (default both).
    pub direction: Direction,
    /// Stop the run at the first located event (default false).
    pub stop: bool,
}

impl std::fmt::Debug for Event {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Event")
            .field("name", &self.name)
            .field("direction", &self.direction)
            .field("stop", &self.stop)
            .finish()
    }
}

impl Event {
    /// An event on the zeros of `g(t, q, v)`, in both directions, not stopping.
    pub fn new(name: impl Into<String>, g: impl Fn(f64, &[f64], &[f64]) -> f64 + Send + Sync + 'static) -> Self {
        Self {
            name: name.into(),
            condition: std::sync::Arc::new(g),
            direction: Direction::Both,
            stop: false,
        }
    }

    /// The same event with a direction filter.
    pub fn direction(self, direction: Direction) -> Self {
        Self { direction, ..self }
    }

    /// The same event, stopping the run at its first occurrence (or not).
    pub fn stop(self, stop: bool) -> Self {
        Self { stop, ..self }
    }
}

/// A located event.
#[derive(Debug, Clone, PartialEq)]
pub struct EventRecord {
    /// Index of the event in the list given.
    pub event: usize,
    /// The step (element) it was found in: between nodes `step` and `step + 1`.
    pub step: usize,
    /// Time of the zero.
    pub t: f64,
    /// q_h, q̇_h and p there.
    pub q: Vec<f64>,
    /// See `q`.
    pub v: Vec<f64>,
    /// See `q`.
    pub p: Vec<f64>,
}

/// A piece of the run on which events are sampled: a parameter x from `start` over `width`
/// (for fixed steps x is the time t on one element; for adaptive runs the fraction σ of a
/// step in fictitious time), mapped to the time and the state there.
pub(crate) trait Piece {
    /// The element's index (between nodes `step` and `step + 1`).
    fn step(&self) -> usize;
    /// The parameter's first value and the width of its range.
    fn range(&self) -> (f64, f64);
    /// q_h and q̇_h at parameter x into `q` and `v`; returns the time there.
    fn at(&mut self, x: f64, q: &mut [f64], v: &mut [f64]) -> f64;
}

/// One element seen by the detector: [t0, t0 + h] from `base` with increments `incr`.
pub(crate) struct Span<'e> {
    pub(crate) step: usize,
    pub(crate) t0: f64,
    pub(crate) h: f64,
    pub(crate) base: &'e [f64],
    pub(crate) incr: &'e [f64],
}

/// A fixed-step element as a [`Piece`]: x = t.
pub(crate) struct SpanPiece<'a, 'e> {
    pub(crate) span: &'a Span<'e>,
    pub(crate) basis: &'a LagrangeBasis,
    pub(crate) eval: &'a mut ElementEval,
}

impl Piece for SpanPiece<'_, '_> {
    fn step(&self) -> usize {
        self.span.step
    }
    fn range(&self) -> (f64, f64) {
        (self.span.t0, self.span.h)
    }
    fn at(&mut self, t: f64, q: &mut [f64], v: &mut [f64]) -> f64 {
        let sp = self.span;
        self.eval.eval(self.basis, sp.t0, sp.h, sp.base, sp.incr, t, q, v);
        t
    }
}

/// Samples the events on each new element and locates their zeros.
pub(crate) struct Detector {
    pub(crate) events: Vec<Event>,
    /// g of each event at the end of the last element (NaN before the first).
    pub(crate) last_g: Vec<f64>,
    /// Scratch for the fixed-step elements' interpolants.
    pub(crate) eval: ElementEval,
    q: Vec<f64>,
    v: Vec<f64>,
    work: PointDerivatives,
    pub(crate) stop: bool,
}

impl Detector {
    pub(crate) fn new(events: Vec<Event>, basis: &LagrangeBasis, n: usize) -> Self {
        let m = events.len();
        Self {
            events,
            last_g: vec![f64::NAN; m],
            eval: ElementEval::new(basis.len()),
            q: vec![0.0; n],
            v: vec![0.0; n],
            work: PointDerivatives::new(n),
            stop: false,
        }
    }

    /// g of event `e` at parameter x of the piece.
    fn g<P: Piece>(&mut self, e: usize, piece: &mut P, x: f64) -> f64 {
        let t = piece.at(x, &mut self.q, &mut self.v);
        (self.events[e].condition)(t, &self.q, &self.v)
    }

    /// Scans a fixed-step element (see [`Detector::scan_piece`]).
    pub(crate) fn scan<L: Lagrangian>(
        &mut self,
        lag: &L,
        basis: &LagrangeBasis,
        sp: &Span<'_>,
        out: &mut Vec<EventRecord>,
    ) {
        let mut eval = std::mem::replace(&mut self.eval, ElementEval::new(0));
        let mut piece = SpanPiece {
            span: sp,
            basis,
            eval: &mut eval,
        };
        self.scan_piece(lag, &mut piece, (basis.len() - 1).max(2), out);
        self.eval = eval;
    }

    /// Scans the piece for zeros of every event, sampling its parameter at m equal
    /// subintervals; appends what it finds to `out` (in time order per event, the momentum
    /// from `lag`) and sets `stop` if a stopping event occurred.
    pub(crate) fn scan_piece<L: Lagrangian, P: Piece>(
        &mut self,
        lag: &L,
        piece: &mut P,
        m: usize,
        out: &mut Vec<EventRecord>,
    ) {
        let (x0, width) = piece.range();
        for e in 0..self.events.len() {
            let (mut xa, mut ga) = (x0, self.last_g[e]);
            if ga.is_nan() {
                ga = self.g(e, piece, x0);
            }
            for j in 1..=m {
                let xb = if j == m {
                    x0 + width
                } else {
                    x0 + width * (j as f64 / m as f64)
                };
                let gb = self.g(e, piece, xb);
                let rising = ga < 0.0 && gb >= 0.0;
                let falling = ga > 0.0 && gb <= 0.0;
                let wanted = match self.events[e].direction {
                    Direction::Rising => rising,
                    Direction::Falling => falling,
                    Direction::Both => rising || falling,
                };
                if wanted {
                    let x = self.root(e, piece, (xa, ga), (xb, gb));
                    out.push(self.record(lag, piece, e, x));
                    if self.events[e].stop {
                        self.stop = true;
                    }
                }
                (xa, ga) = (xb, gb);
            }
            self.last_g[e] = ga;
        }
    }

    /// The zero of g in [xa, xb] (g(xa) and g(xb) of opposite signs, or g(xb) = 0) by
    /// regula falsi with the Illinois modification.
    fn root<P: Piece>(&mut self, e: usize, piece: &mut P, a: (f64, f64), b: (f64, f64)) -> f64 {
        let ((mut ta, _), (mut tb, mut gb)) = (a, b);
        if gb == 0.0 {
            return tb;
        }
        // g at ta on this element: at a node it may differ from the previous element's value
        // (q̇_h is not continuous there); a zero the new polynomial does not see is the node.
        let mut ga = self.g(e, piece, ta);
        if ga == 0.0 || ga.signum() == gb.signum() {
            return ta;
        }
        for _ in 0..200 {
            if (tb - ta).abs() <= 2.0 * f64::EPSILON * ta.abs().max(tb.abs()).max(f64::MIN_POSITIVE) {
                break;
            }
            let mut tc = (ta * gb - tb * ga) / (gb - ga);
            if !(tc > ta.min(tb) && tc < ta.max(tb)) {
                tc = 0.5 * (ta + tb);
            }
            let gc = self.g(e, piece, tc);
            if gc == 0.0 || !gc.is_finite() {
                return tc;
            }
            if gc.signum() != gb.signum() {
                (ta, ga) = (tb, gb);
            } else {
                ga *= 0.5;
            }
            (tb, gb) = (tc, gc);
        }
        if ga.abs() < gb.abs() {
            ta
        } else {
            tb
        }
    }

    fn record<L: Lagrangian, P: Piece>(&mut self, lag: &L, piece: &mut P, e: usize, x: f64) -> EventRecord {
        let t = piece.at(x, &mut self.q, &mut self.v);
        let mut p = vec![0.0; self.q.len()];
        momentum(lag, t, &self.q, &self.v, &mut self.work, &mut p);
        EventRecord {
            event: e,
            step: piece.step(),
            t,
            q: self.q.clone(),
            v: self.v.clone(),
            p,
        }
    }
}
