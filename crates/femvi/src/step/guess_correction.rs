//! The correction of the implicit solvers' starting values by the extrapolation's own errors
//! at the last steps (issue 15 item 2, for the simplified Newton iteration of
//! `newton_step.rs`): the guess extrapolates the last element's polynomial over the new step
//! (`guess.rs`), whose error, O(h^(s+1)), is a smooth function of the step's start; so the
//! errors at the last steps of equal h are extrapolated in turn and added. Also what a
//! checkpoint keeps of them, so that resumed runs take the same guesses bit for bit.

use super::checkpoint::{Reader, Words};
use super::state::LastElement;
use crate::error::{invalid, Result};

/// The extrapolation's errors at the last steps and the choice of their extrapolation.
#[derive(Debug, Clone)]
pub(crate) struct GuessCorrection {
    /// The extrapolation of the last element over this step, before any correction.
    raw: Vec<f64>,
    /// The extrapolation's error at the last step (solution − `raw`).
    err: Vec<f64>,
    /// The same at the step before (valid with `depth` 2 or more).
    err2: Vec<f64>,
    /// The same two steps before (valid with `depth` 3).
    err3: Vec<f64>,
    /// How many consecutive steps of equal h `err`, `err2` and `err3` hold (0 … 3).
    depth: usize,
    /// Whether the next correction extrapolates quadratically (with `depth` 3: the quadratic
    /// extrapolation predicted the last error better than the linear one, on a step the kept
    /// Jacobian solved).
    quadratic: bool,
    /// The bits of (t_k, h) of the step `err` belongs to.
    err_key: (u64, u64),
    /// Whether the current step's guess was corrected (its error continues the sequence).
    follows: bool,
}

impl GuessCorrection {
    /// Nothing known yet, for `len` unknowns.
    pub(crate) fn new(len: usize) -> Self {
        Self {
            raw: vec![0.0; len],
            err: vec![0.0; len],
            err2: vec![0.0; len],
            err3: vec![0.0; len],
            depth: 0,
            quadratic: false,
            err_key: (0, 0),
            follows: false,
        }
    }

    /// Corrects the extrapolated guess `x` by the extrapolation's errors at the last steps, when
    /// they were the last elements and had the same h: the error of extrapolating the last
    /// element's polynomial, O(h^(s+1)), is a smooth function of the step's start, so it is
    /// itself extrapolated from the last errors of equal-h steps: linearly (2e_{k−1} − e_{k−2})
    /// when two are known, as constant (e_{k−1}) with one, and with three quadratically
    /// (3e_{k−1} − 3e_{k−2} + e_{k−3}, exact for errors quadratic in k) if that would have
    /// predicted the last error better than the linear one did, on a step the kept Jacobian
    /// solved ([`GuessCorrection::keep`]). The
    /// relativistic Kepler run of `benches/general.rs` (degree 2): the guess's relative error,
    /// 1e-5 uncorrected, is 1e-7 with the constant correction; the corrections per step are
    /// 5.5 → 4.0 with the linear one (and θ measured above noise only, `solve/simplified.rs`),
    /// → 3.59 with the chosen order (degrees 1 / 3 / 4: 4.37 → 3.95, 3.45 → 2.94,
    /// 2.95 → 2.90; always quadratic, degree 4 took 2.98: the errors left there are near
    /// round-off, `examples/general_profile`).
    /// Corrects `x` in place and keeps the uncorrected guess.
    pub(crate) fn apply(&mut self, x: &mut [f64], last: &LastElement, h: f64) {
        self.raw.copy_from_slice(x);
        let key = (last.t.to_bits(), h.to_bits());
        self.follows = last.valid && last.h.to_bits() == h.to_bits() && self.depth > 0 && self.err_key == key;
        if !self.follows {
            return;
        }
        if self.depth >= 3 && self.quadratic {
            for (((x, e), e2), e3) in x.iter_mut().zip(&self.err).zip(&self.err2).zip(&self.err3) {
                *x += 3.0 * (e - e2) + e3;
            }
        } else if self.depth >= 2 {
            for ((x, e), e2) in x.iter_mut().zip(&self.err).zip(&self.err2) {
                *x += 2.0 * e - e2;
            }
        } else {
            for (x, e) in x.iter_mut().zip(&self.err) {
                *x += e;
            }
        }
    }

    /// Keeps the extrapolation's error of the step just solved (to `x`) from t0 with step h;
    /// `kept_solved`: whether the kept Jacobian solved it.
    pub(crate) fn keep(&mut self, x: &[f64], t0: f64, h: f64, kept_solved: bool) {
        // Which extrapolation of the errors would have predicted this one better (the
        // quadratic one amplifies the noise in them more: near round-off, at degree 4, it
        // cost iterations). Only after a step the kept Jacobian solved: where Jacobians are
        // refreshed step after step (adaptive e = 0.9 Kepler at ds = 0.1), the better guess
        // left too few corrections above noise to measure θ by, kept Jacobians that then
        // failed, and cost iterations (4.47 → 5.34 per step) and conservation (angular
        // momentum slope 6e-18 → −6.4e-17 per period, `examples/adaptive_drift`).
        self.quadratic = kept_solved && self.follows && self.depth >= 3 && {
            let (mut linear, mut quadratic) = (0.0f64, 0.0f64);
            let errs = self.err.iter().zip(&self.err2).zip(&self.err3);
            for ((((e, e2), e3), x), r) in errs.zip(x).zip(&self.raw) {
                let now = x - r;
                linear = linear.max((now - (2.0 * e - e2)).abs());
                quadratic = quadratic.max((now - (3.0 * (e - e2) + e3)).abs());
            }
            quadratic < linear
        };
        if self.follows {
            std::mem::swap(&mut self.err2, &mut self.err3);
            std::mem::swap(&mut self.err, &mut self.err2);
            self.depth = (self.depth + 1).min(3);
        } else {
            self.depth = 1;
        }
        for ((e, x), r) in self.err.iter_mut().zip(x).zip(&self.raw) {
            *e = x - r;
        }
        self.err_key = (t0.to_bits(), h.to_bits());
    }

    /// Writes the errors kept and the choice of extrapolation.
    pub(crate) fn save(&self, w: &mut Words) {
        w.u(self.depth);
        if self.depth > 0 {
            w.f(f64::from_bits(self.err_key.0));
            w.f(f64::from_bits(self.err_key.1));
            w.fs(&self.err);
            w.fs(&self.err2);
            if self.depth > 2 {
                w.fs(&self.err3);
                w.b(self.quadratic);
            }
        }
    }

    /// Reads what [`GuessCorrection::save`] wrote (checkpoints of depth 2 or less, from the
    /// builds before the quadratic extrapolation, read the same).
    pub(crate) fn load(&mut self, r: &mut Reader<'_>) -> Result<()> {
        self.depth = r.u()?;
        if self.depth > 3 {
            return Err(invalid("checkpoint", "a predictor depth past 3"));
        }
        if self.depth > 0 {
            let (t, h) = (r.f()?, r.f()?);
            r.fs(&mut self.err)?;
            r.fs(&mut self.err2)?;
            self.quadratic = false;
            if self.depth > 2 {
                r.fs(&mut self.err3)?;
                self.quadratic = r.b()?;
            }
            let third = if self.depth > 2 { &self.err3[..] } else { &[] };
            if !self.err.iter().chain(&self.err2).chain(third).all(|v| v.is_finite()) {
                return Err(invalid("checkpoint", "a non-finite predictor correction"));
            }
            self.err_key = (t.to_bits(), h.to_bits());
        }
        Ok(())
    }
}
