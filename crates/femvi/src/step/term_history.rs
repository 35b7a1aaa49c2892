//! The values a fixed-point solver evaluated at the quadrature points of the last one or two
//! accepted steps, and their extrapolation in time to the stages of the next step: the
//! polynomial through the k = r (or 2r) earlier stage values, evaluated at t_k + c_l h. One
//! sweep on extrapolated values starts the iteration closer to its fixed point than the last
//! element's polynomial does (step/gyroscopic/mod.rs measures it).

use super::checkpoint::{Reader, Words};
use crate::error::Result;

/// Rules with at most this many points extrapolate from the last two steps (2r points), the
/// others from the last step. Measured on the Arenstorf expression (h = T/10⁴, medians of 7
/// alternating runs): degree 2, 4.01 → 3.03 sweeps per step and 21 % less time; degree 4,
/// 2.04 → 2.03 sweeps and 9 % more time (the 8-point extrapolation costs more than it saves).
pub(crate) const TWO_STEP_POINTS: usize = 3;

/// The last two steps' values by point (`width` numbers per point, r points per step).
#[derive(Debug, Clone)]
pub(crate) struct TermHistory {
    /// The older step's values, then the last step's (r × width each).
    hist: Vec<f64>,
    /// How many of the two are valid.
    have: usize,
    /// Their steps (older, last).
    hist_h: [f64; 2],
    /// Extrapolation to the new stages, row-major r × (points used), for `key`.
    extrap: Vec<f64>,
    /// (older step, last step, new step, points used) as bits.
    key: [u64; 4],
}

impl TermHistory {
    /// An empty history for r points of `width` numbers.
    pub(crate) fn new(r: usize, width: usize) -> Self {
        Self {
            hist: vec![0.0; 2 * r * width],
            have: 0,
            hist_h: [f64::NAN; 2],
            extrap: vec![0.0; 2 * r * r],
            key: [0; 4],
        }
    }

    /// Whether a step of size h after a last step `last_h` can start from the history: a
    /// step is kept, it is the last one, and the step ratio is within [½, 2].
    pub(crate) fn usable(&self, last_valid: bool, last_h: f64, h: f64) -> bool {
        let rho = h / last_h;
        self.have > 0 && last_valid && last_h == self.hist_h[1] && (0.5..=2.0).contains(&rho)
    }

    /// The values extrapolated to the stages t_k + c_l h of the next step into `out`
    /// (r × width), c the rule's nodes.
    pub(crate) fn extrapolate(&mut self, c: &[f64], h: f64, out: &mut [f64]) {
        let r = c.len();
        let w = self.hist.len() / (2 * r).max(1);
        let steps = if self.have >= 2 && r <= TWO_STEP_POINTS { 2 } else { 1 };
        let k = steps * r;
        let [h_old, h_last] = self.hist_h;
        let key = [h_old.to_bits(), h_last.to_bits(), h.to_bits(), k as u64];
        if key != self.key {
            self.key = key;
            // Times from the start of the last step: the older step's stages, the last
            // step's, then the new ones.
            let known: Vec<f64> = (0..k)
                .map(|i| match (steps, i < r) {
                    (2, true) => -h_old + c[i] * h_old,
                    (2, false) => c[i - r] * h_last,
                    _ => c[i] * h_last,
                })
                .collect();
            for l in 0..r {
                let x = h_last + c[l] * h;
                for i in 0..k {
                    self.extrap[l * k + i] = (0..k)
                        .filter(|&j| j != i)
                        .map(|j| (x - known[j]) / (known[i] - known[j]))
                        .product();
                }
            }
        }
        let data = &self.hist[(2 - steps) * r * w..2 * r * w];
        for l in 0..r {
            for kk in 0..w {
                out[l * w + kk] = (0..k).map(|i| self.extrap[l * k + i] * data[i * w + kk]).sum();
            }
        }
    }

    /// The values of an accepted step of size h (r × width).
    pub(crate) fn push(&mut self, values: &[f64], h: f64) {
        let half = self.hist.len() / 2;
        self.hist.copy_within(half.., 0);
        self.hist[half..].copy_from_slice(values);
        self.hist_h = [self.hist_h[1], h];
        self.have = (self.have + 1).min(2);
    }

    /// The last step's values (r × width), to fill in place of [`TermHistory::push`].
    pub(crate) fn push_in_place(&mut self, h: f64) -> &mut [f64] {
        let half = self.hist.len() / 2;
        self.hist.copy_within(half.., 0);
        self.hist_h = [self.hist_h[1], h];
        self.have = (self.have + 1).min(2);
        &mut self.hist[half..]
    }

    /// The data the next step's start depends on (checkpoints).
    pub(crate) fn save(&self, w: &mut Words) {
        w.u(self.have);
        w.fs(&self.hist_h);
        w.fs(&self.hist);
    }

    pub(crate) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.have = r.u()?.min(2);
        r.fs(&mut self.hist_h)?;
        r.fs(&mut self.hist)
    }
}
