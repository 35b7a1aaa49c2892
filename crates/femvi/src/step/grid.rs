//! Time grids for steps as parameters: uniform, or a list of steps used in turn
//! (variable h_k, the paper's generalised Veselov mechanics (2.1)–(2.3)).
//!
//! A grid never has to be walked to be known: [`TimeGrid::count`] divides the span by a
//! step or by the sum of one cycle of steps. Construction rejects steps too small to move
//! the time (t + h == t in floating point) anywhere in the span, which would make a run
//! stand still.

use crate::error::{invalid, Result};

/// The nodes t_0 < t_1 < … ≤ end of a run with steps as parameters. The last step is
/// shortened to land on `end` exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeGrid {
    t0: f64,
    end: f64,
    steps: Vec<f64>,
}

/// Relative slack below which a remaining interval counts as zero (the run is at `end`).
const SNAP: f64 = 1e-9;

/// Grids of up to this many steps are counted by walking them (exactly as a run steps);
/// longer ones by whole cycles.
const WALKED_COUNT: f64 = (1u64 << 20) as f64;

impl TimeGrid {
    /// Uniform steps h from t0 to end: the nodes are t0 + k h, computed from k.
    ///
    /// # Errors
    /// A step that is not positive and finite, an end not after t0, or a step too small to
    /// move the time at t0 (t0 + h == t0).
    ///
    /// # Example
    ///
    /// ```
    /// let grid = femvi::TimeGrid::uniform(0.0, 0.25, 1.0)?;
    /// assert_eq!(grid.count(), 4);
    /// assert_eq!(grid.next(0, 0.0), Some((0.25, 0.25)));
    /// assert!(femvi::TimeGrid::uniform(0.0, -0.1, 1.0).is_err());
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn uniform(t0: f64, h: f64, end: f64) -> Result<Self> {
        Self::steps(t0, vec![h], end)
    }

    /// Steps taken from `steps` in turn, cyclically, from t0 to end.
    ///
    /// # Errors
    /// An empty list, a step that is not positive and finite, an end not after t0, or a step
    /// too small to move the time (t + h == t) at t0 or, for a list of several steps, near
    /// the end.
    ///
    /// # Example
    ///
    /// ```
    /// let grid = femvi::TimeGrid::steps(0.0, vec![0.5, 0.25], 2.0)?;
    /// assert_eq!(grid.nominal(0), 0.5);
    /// assert_eq!(grid.nominal(1), 0.25);
    /// assert_eq!(grid.nominal(2), 0.5);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn steps(t0: f64, steps: Vec<f64>, end: f64) -> Result<Self> {
        if steps.is_empty() {
            return Err(invalid("time steps", "the list of steps is empty"));
        }
        if let Some(h) = steps.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
            return Err(invalid("time step", format!("{h} is not a positive finite number")));
        }
        if !t0.is_finite() || !end.is_finite() {
            return Err(invalid("time span", "start and end must be finite"));
        }
        if end <= t0 {
            return Err(invalid(
                "time span",
                format!("end = {end} is not after the start t = {t0}"),
            ));
        }
        // The spacing of floating-point numbers grows with |t|, so the ends of the span are
        // where a step is most likely to vanish; the smallest step is the one to check. A list
        // of steps advances by t + h and would stand still there; a uniform grid computes its
        // nodes as t0 + k h, which only round to the spacing near the end, so there only the
        // first step is checked.
        let h = steps.iter().fold(f64::INFINITY, |m, &h| m.min(h));
        let near_end = if steps.len() > 1 { (end - h).max(t0) } else { t0 };
        for t in [t0, near_end] {
            if t + h == t {
                return Err(invalid(
                    "time step",
                    format!("{h} is too small to move the time at t = {t} (t + h == t in floating point)"),
                ));
            }
        }
        Ok(Self { t0, end, steps })
    }

    /// Start time.
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// End time.
    pub fn end(&self) -> f64 {
        self.end
    }

    /// The nominal step k (before shortening at the end).
    #[inline]
    pub fn nominal(&self, k: usize) -> f64 {
        if self.steps.len() == 1 {
            self.steps[0]
        } else {
            self.steps[k % self.steps.len()]
        }
    }

    /// The length of the list of steps taken in turn (1 for a uniform grid): the nominal steps
    /// repeat with this period.
    pub fn period(&self) -> usize {
        self.steps.len()
    }

    /// Whether all steps are equal.
    pub fn is_uniform(&self) -> bool {
        self.steps.len() == 1
    }

    /// The step from node k at time t: (h_k, t_{k+1}), or None at the end.
    #[inline]
    pub fn next(&self, k: usize, t: f64) -> Option<(f64, f64)> {
        if let Some(u) = self.uniform_rule() {
            // Through i64: the same value for any reachable k (< 2⁵³), in one instruction
            // instead of the unsigned conversion's several.
            return u.next((k + 1) as i64 as f64, t);
        }
        let h = self.nominal(k);
        let remaining = self.end - t;
        if remaining <= SNAP * h {
            return None;
        }
        let t_next = t + h;
        if t_next >= self.end - SNAP * h {
            return Some((self.end - t, self.end));
        }
        Some((h, t_next))
    }

    /// For a uniform grid, its step rule with the constants computed once, for loops that take
    /// many steps (the explicit fast path). It is the rule [`next`] itself applies, so both
    /// give the same values.
    ///
    /// [`next`]: Self::next
    #[inline]
    pub fn uniform_rule(&self) -> Option<UniformRule> {
        self.is_uniform().then(|| {
            let h = self.steps[0];
            UniformRule {
                t0: self.t0,
                h,
                end: self.end,
                snap: SNAP * h,
                last: self.end - SNAP * h,
            }
        })
    }

    /// Number of steps of the whole run, in O(1) for a uniform grid and O(length of the list)
    /// otherwise: a list of up to 2²⁰ steps is walked as a run steps (exact), a longer one is
    /// counted by whole cycles of the list (the span divided by the sum of one cycle) and a
    /// walk of the last, partial cycle, which can differ by one from the steps a run takes
    /// when rounding puts the end within a few ulps of a node. Saturates at `usize::MAX`.
    pub fn count(&self) -> usize {
        if self.is_uniform() {
            let h = self.steps[0];
            return ((self.end - self.t0) / h - SNAP).ceil().max(1.0) as usize;
        }
        let len = self.steps.len();
        let cycle: f64 = self.steps.iter().sum();
        let cycles = ((self.end - self.t0) / cycle).floor();
        let (mut k, mut t) = (0usize, self.t0);
        if cycles * len as f64 > WALKED_COUNT {
            // Whole cycles by division, but not past the end (then walk from one cycle before).
            let whole = if self.t0 + cycles * cycle < self.end {
                cycles
            } else {
                cycles - 1.0
            };
            k = (whole as usize).saturating_mul(len);
            t = self.t0 + whole * cycle;
        }
        while let Some((_, tn)) = self.next(k, t) {
            k = k.saturating_add(1);
            t = tn;
        }
        k
    }
}

/// The step rule of a uniform grid ([`TimeGrid::uniform_rule`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformRule {
    t0: f64,
    h: f64,
    end: f64,
    snap: f64,
    last: f64,
}

impl UniformRule {
    /// The step from the node at time t, which is node k = `k1` − 1 (`k1` is k + 1 as a
    /// float: exact up to 2⁵³ steps): (h, t0 + (k + 1) h), the last step shortened to land
    /// on the end, or None at the end.
    #[inline]
    pub fn next(&self, k1: f64, t: f64) -> Option<(f64, f64)> {
        if self.end - t <= self.snap {
            return None;
        }
        let t_next = self.t0 + k1 * self.h;
        if t_next >= self.last {
            return Some((self.end - t, self.end));
        }
        Some((self.h, t_next))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_grid_lands_on_end() {
        let g = TimeGrid::uniform(0.0, 0.1, 1.0).unwrap();
        let (mut k, mut t) = (0, 0.0);
        while let Some((h, tn)) = g.next(k, t) {
            assert!((h - 0.1).abs() < 1e-12);
            k += 1;
            t = tn;
        }
        assert_eq!(k, 10);
        assert_eq!(t, 1.0);
        assert_eq!(g.count(), 10);
        let g = TimeGrid::uniform(0.0, 0.3, 1.0).unwrap();
        assert_eq!(g.count(), 4);
    }

    /// The uniform rule gives node times t0 + (k + 1) h computed from k directly (the unsigned
    /// conversion), for small and huge k, and lands on the end.
    #[test]
    fn uniform_rule_is_the_direct_formula() {
        let (t0, h) = (0.3, 0.013);
        let g = TimeGrid::uniform(t0, h, 1e15).unwrap();
        let u = g.uniform_rule().unwrap();
        for k in (0..1000usize).chain([(1 << 40) + 7, (1 << 52) - 3]) {
            let t = t0 + k as f64 * h;
            let direct = Some((h, t0 + (k + 1) as f64 * h));
            assert_eq!(g.next(k, t), direct, "k = {k}");
            assert_eq!(u.next((k + 1) as f64, t), direct, "k = {k}");
        }
        let u = TimeGrid::uniform(0.0, 0.3, 1.0).unwrap().uniform_rule().unwrap();
        assert_eq!(u.next(4.0, 0.9), Some((1.0 - 0.9, 1.0)));
        assert_eq!(u.next(5.0, 1.0), None);
        assert!(TimeGrid::steps(0.0, vec![0.1, 0.2], 1.0)
            .unwrap()
            .uniform_rule()
            .is_none());
    }

    #[test]
    fn rejects_bad_steps() {
        assert!(TimeGrid::uniform(0.0, 0.0, 1.0).is_err());
        assert!(TimeGrid::uniform(0.0, -0.1, 1.0).is_err());
        assert!(TimeGrid::uniform(0.0, f64::NAN, 1.0).is_err());
        assert!(TimeGrid::uniform(1.0, 0.1, 1.0).is_err());
        assert!(TimeGrid::steps(0.0, vec![], 1.0).is_err());
        assert!(TimeGrid::steps(0.0, vec![0.1, -1.0], 1.0).is_err());
    }

    #[test]
    fn list_of_steps_is_cyclic() {
        let g = TimeGrid::steps(0.0, vec![0.1, 0.2], 1.0).unwrap();
        assert_eq!(g.count(), 7);
        assert_eq!(g.next(1, 0.1), Some((0.2, 0.1 + 0.2)));
    }
}
