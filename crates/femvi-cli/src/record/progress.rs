//! The progress bar of `femvi run`: on a terminal, once a run has taken a second, on stderr.

use crate::problem::Problem;
use std::time::Instant;

/// A progress bar that appears once a run has taken a second.
pub struct Progress {
    enabled: bool,
    total: u64,
    t_end: f64,
    clock: Instant,
    bar: Option<indicatif::ProgressBar>,
    /// The bar is next updated at this many steps or later.
    next: u64,
}

impl Progress {
    /// A bar for `problem` if `enabled` (else it draws nothing): its length is the number of
    /// steps of the grid (energy mode: of the first step's length).
    pub fn new(enabled: bool, problem: &Problem) -> Self {
        let grid = &problem.grid;
        let total = match problem.energy {
            None => grid.count() as u64,
            Some(_) => ((grid.end() - grid.t0()) / grid.nominal(0)).ceil() as u64,
        };
        Progress {
            enabled,
            total,
            t_end: grid.end(),
            clock: Instant::now(),
            bar: None,
            next: 0,
        }
    }

    /// Shows `steps` steps done, reaching time `t`, when at least 256 steps have passed
    /// since it last did.
    pub fn show(&mut self, steps: usize, t: f64) {
        let steps = steps as u64;
        if !self.enabled || steps < self.next {
            return;
        }
        self.next = steps + 256;
        if self.bar.is_none() && self.clock.elapsed().as_secs_f64() > 1.0 {
            let bar =
                indicatif::ProgressBar::with_draw_target(Some(self.total), indicatif::ProgressDrawTarget::stderr());
            let style = indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} steps, {msg}, ETA {eta}");
            if let Ok(style) = style {
                bar.set_style(style);
            }
            self.bar = Some(bar);
        }
        if let Some(bar) = &self.bar {
            bar.set_position(steps.min(self.total));
            let rate = steps as f64 / self.clock.elapsed().as_secs_f64().max(1e-9);
            bar.set_message(format!("t = {t:.6} of {}, {rate:.0} steps/s", self.t_end));
        }
    }
}

impl Progress {
    /// Removes the bar, if it was drawn.
    pub fn finish(&mut self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
