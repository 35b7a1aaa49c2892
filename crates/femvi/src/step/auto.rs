//! The step (and, by default, the degree) for a requested accuracy: femvi's own choice for
//! runs with steps as parameters on a uniform grid.
//!
//! The accuracy is the relative position error at the end of the run,
//! max_c |q_c(T) − q_c,exact(T)| / max |q| (the largest coordinate over the pilot runs). It is
//! estimated, not bounded: pilot runs of 200 steps with h and h/2 from the same start give
//! e(h) ≈ |q_h − q_{h/2}| (the finer run's error is 2^{-p} of it for an element of order p),
//! which is extrapolated to the end of the run linearly in time — the growth of the phase
//! error of a symplectic method on a (nearly) periodic motion, whose energy error stays
//! bounded. On chaotic motion the error grows exponentially and the estimate is too small;
//! on motion whose errors stay bounded it is too large. The step is iterated until the
//! estimate at the step is within a factor of 1.3 of the target (half the accuracy).
//!
//! The degree for an accuracy ([`degree_for_accuracy`]) follows the work-precision
//! measurements of benches/peers/README.md: degree 4 (order 8) down to 1e-5, degree 6
//! (order 12) down to 1e-8, degree 8 (order 16) below — the cheapest elements found there on
//! the Kepler, outer solar system and pendulum problems at 1e-6 and 1e-10.

use crate::discrete::Element;
use crate::error::{invalid, Error, Result};
use crate::fem::QuadratureKind;
use crate::lagrangian::Lagrangian;
use crate::step::{Integrator, SolverOptions, Start, TimeGrid};

/// Steps per pilot run (with h; the check run takes twice as many with h/2).
pub const PILOT_STEPS: usize = 200;

/// Accuracies accepted: below ~1e-12 the rounding errors' random walk, not the step, sets
/// the error of long runs (P1: ~1e-10 after 1.6e5 steps, benches/peers/README.md).
pub const MIN_ACCURACY: f64 = 1e-12;

/// The element degree femvi picks for a requested accuracy (with Gauss–Legendre points of
/// the same number: order 2s).
pub fn degree_for_accuracy(accuracy: f64) -> usize {
    if accuracy >= 1e-5 {
        4
    } else if accuracy >= 1e-8 {
        6
    } else {
        8
    }
}

/// The nominal order of an element: 2s, or the order of its quadrature rule if that is
/// lower (midpoint and trapezoid 2, Simpson 4, Gauss–Legendre r points 2r, Gauss–Lobatto
/// r points 2r − 2).
pub fn nominal_order(element: &Element) -> usize {
    let quadrature = match element.rule.kind {
        QuadratureKind::Midpoint | QuadratureKind::Trapezoid => 2,
        QuadratureKind::Simpson => 4,
        QuadratureKind::GaussLegendre(r) => 2 * r,
        QuadratureKind::GaussLobatto(r) => 2 * r - 2,
    };
    quadrature.min(2 * element.degree())
}

/// The step femvi chose, and what it rests on.
#[derive(Debug, Clone, PartialEq)]
pub struct StepChoice {
    /// The accuracy requested.
    pub accuracy: f64,
    /// The step h (the run's end is a whole number of steps away when the run has more than
    /// a few steps: the grid shortens only its last step).
    pub step: f64,
    /// The estimated relative position error at the end of the run with this step.
    pub estimated_error: f64,
    /// The error estimate from the last pilot pair, at its own step and horizon.
    pub pilot_error: f64,
    /// The last pilot pair's step and horizon (end time of the pilot runs).
    pub pilot_step: f64,
    /// See `pilot_step`.
    pub pilot_end: f64,
    /// Steps taken by all pilot runs together (their cost, in steps of the run).
    pub pilot_steps: usize,
}

/// A pilot pair: runs with h and h/2 side by side to `end`; returns the largest difference
/// of the positions at their common nodes, the largest |q| there, and the steps taken.
fn pilot_pair<L: Lagrangian>(
    lag: &L,
    element: &Element,
    start: &Start,
    t0: f64,
    h: f64,
    end: f64,
    opts: SolverOptions,
) -> Result<(f64, f64, usize)> {
    let mut a = Integrator::new(lag, element, TimeGrid::uniform(t0, h, end)?, start.clone(), opts)?;
    let mut b = Integrator::new(lag, element, TimeGrid::uniform(t0, 0.5 * h, end)?, start.clone(), opts)?;
    let mut qmax = a.node().q.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut diff = 0.0f64;
    let mut steps = 0;
    while a.step()? {
        // Two half steps reach the same node (the last one may be shortened in both).
        b.step()?;
        b.step()?;
        steps += 3;
        let (qa, qb) = (a.node().q, b.node().q);
        qmax = qa.iter().fold(qmax, |m, v| m.max(v.abs()));
        diff = qa.iter().zip(qb).fold(diff, |m, (x, y)| m.max((x - y).abs()));
    }
    Ok((diff, qmax, steps))
}

/// Chooses the uniform step for a run from `t0` to `end` to reach the relative position
/// error `accuracy` at `end` (see the module documentation for what the estimate assumes).
///
/// # Errors
/// An accuracy outside [[`MIN_ACCURACY`], 0.1], a start from (q0, q1) (its q1 fixes the first
/// step), an invalid time span, or no step at which the pilot runs succeed (the last step
/// error is returned).
pub fn choose_step<L: Lagrangian>(
    lag: &L,
    element: &Element,
    start: &Start,
    t0: f64,
    end: f64,
    accuracy: f64,
    opts: SolverOptions,
) -> Result<StepChoice> {
    check_request(start, t0, end, accuracy)?;
    let span = end - t0;
    let p = nominal_order(element) as i32;
    let richardson = 2f64.powi(p) / (2f64.powi(p) - 1.0);
    let target = 0.5 * accuracy;
    let mut search = Search {
        span,
        h: span / PILOT_STEPS as f64,
        pilot_steps: 0,
        last_error: None,
        best: None,
        at_noise: None,
        failed_at: f64::INFINITY,
    };
    for _ in 0..40 {
        let h = search.h;
        let horizon = (PILOT_STEPS as f64 * h).min(span);
        let pilot_end = t0 + horizon;
        let runs = pilot_pair(lag, element, start, t0, h, pilot_end, opts);
        let (diff, qmax, steps) = match runs {
            Ok(r) => r,
            Err(e) => match search.failed(e) {
                Retry::Done(choice) => return Ok(choice),
                Retry::GiveUp => break,
                Retry::Again => continue,
            },
        };
        search.pilot_steps += steps;
        let pilot_error = richardson * diff / qmax.max(f64::MIN_POSITIVE);
        let at_end = pilot_error * span / horizon;
        let pilot_steps = search.pilot_steps;
        let choice = |step: f64, estimated_error: f64| StepChoice {
            accuracy,
            step,
            estimated_error,
            pilot_error,
            pilot_step: h,
            pilot_end,
            pilot_steps,
        };
        // Below this the difference is round-off, not truncation: the step can grow.
        let noise = 100.0 * f64::EPSILON * (steps as f64).sqrt();
        if pilot_error <= noise {
            match search.at_round_off(choice(h, at_end)) {
                Some(done) => return Ok(done),
                None => continue,
            }
        }
        // The step that puts the end's error at the target, from the order p (the error at
        // the end scales like h^p; the pilot horizon grows with h, which the linear
        // extrapolation cancels).
        let factor = (target / at_end).powf(1.0 / p as f64);
        let mut next = h * factor.clamp(1.0 / 16.0, 4.0);
        if next >= search.failed_at {
            next = (h * search.failed_at).sqrt();
        }
        let choice = choice(next, at_end * (next / h).powi(p));
        if (1.0 / 1.3..=1.3).contains(&factor) {
            return Ok(choice);
        }
        search.best = Some(choice);
        search.h = next.min(span);
    }
    match (search.best, search.last_error) {
        (Some(b), _) => Ok(b),
        (None, Some(e)) => Err(e),
        (None, None) => Err(invalid("accuracy", "no step found")),
    }
}

/// Checks a request of [`choose_step`]: the accuracy, the kind of start and the time span.
fn check_request(start: &Start, t0: f64, end: f64, accuracy: f64) -> Result<()> {
    if !(MIN_ACCURACY..=0.1).contains(&accuracy) {
        return Err(invalid(
            "accuracy",
            format!("{accuracy} is outside [{MIN_ACCURACY:e}, 0.1]: below ~1e-12 round-off, not the step, sets the error of long runs"),
        ));
    }
    if matches!(start, Start::Positions { .. }) {
        return Err(invalid(
            "accuracy",
            "a start from (q0, q1) fixes the first step; give the velocity or the momentum",
        ));
    }
    if !(t0.is_finite() && end.is_finite() && end > t0) {
        return Err(invalid(
            "time span",
            format!("end = {end} is not after the start t = {t0}"),
        ));
    }
    Ok(())
}

/// The state of [`choose_step`]'s search: the step to try next and what the pilots so far
/// have shown.
struct Search {
    /// The run's time span.
    span: f64,
    /// The step of the next pilot pair.
    h: f64,
    /// Steps taken by all pilot runs so far.
    pilot_steps: usize,
    /// The error of the last pilot pair that failed.
    last_error: Option<Error>,
    /// The choice from the last pilot pair whose difference was above round-off.
    best: Option<StepChoice>,
    /// The largest step whose pilots were at round-off, and the smallest that failed.
    at_noise: Option<StepChoice>,
    failed_at: f64,
}

/// What the search does after a pilot pair failed.
enum Retry {
    /// Take this choice (a step at round-off, close below the failing one).
    Done(StepChoice),
    /// Another step (set in [`Search::h`]).
    Again,
    /// The step has become too small to try.
    GiveUp,
}

impl Search {
    /// The pilot pair with step h failed with `e`: too large a step for the solver (or the
    /// motion). Goes back towards the largest step that worked, or down by 4.
    fn failed(&mut self, e: Error) -> Retry {
        self.last_error = Some(e);
        self.failed_at = self.failed_at.min(self.h);
        match &self.at_noise {
            Some(ok) if self.failed_at < 1.5 * ok.step => return Retry::Done(ok.clone()),
            Some(ok) => self.h = (ok.step * self.h).sqrt(),
            None => self.h *= 0.25,
        }
        if self.h < self.span * 1e-12 {
            Retry::GiveUp
        } else {
            Retry::Again
        }
    }

    /// The pilot pair with step h differed by round-off only (`choice` at h): returns the
    /// choice if the step cannot grow, else grows the step by 4 (the geometric mean with the
    /// smallest step that failed, if that is closer) and returns None.
    fn at_round_off(&mut self, choice: StepChoice) -> Option<StepChoice> {
        let h = self.h;
        let grow = (4.0 * h).min(self.span / 8.0);
        if grow <= h {
            return Some(choice); // the whole run in a few steps is at round-off
        }
        self.at_noise = Some(choice);
        self.h = if 4.0 * h >= self.failed_at {
            (h * self.failed_at).sqrt()
        } else {
            grow
        };
        None
    }
}
