//! The energy balance of a run with forces ([`femvi::forces`]): along the run
//! H_k − H_0 = W_k up to the method's error, W_k the discrete work the integrator accumulates
//! ([`femvi::Integrator::work`]). [`WorkBalance`] keeps max_k |H_k − H_0 − W_k| / |H_0|
//! (absolute where H_0 = 0) over every node, as `femvi::forces::solve_forced` reports it, and
//! the work at the last node recorded: summary.json's `max_rel_energy_balance_error` and
//! `final_work`.

/// The balance over the nodes recorded so far.
///
/// # Example
///
/// ```
/// use femvi_cli::record::WorkBalance;
/// let mut b = WorkBalance::default();
/// b.at(2.0, 0.0); // H_0 = 2
/// b.at(1.5, -0.49); // |1.5 − 2 + 0.49| / 2 = 0.005
/// assert!((b.max_rel() - 0.005).abs() < 1e-15);
/// assert_eq!(b.work(), -0.49);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WorkBalance {
    h0: Option<f64>,
    max_rel: f64,
    work: f64,
}

impl WorkBalance {
    /// Records a node with energy `h` and work `work` (the first node sets H_0).
    pub fn at(&mut self, h: f64, work: f64) {
        let h0 = *self.h0.get_or_insert(h);
        let scale = if h0 != 0.0 { h0.abs() } else { 1.0 };
        self.max_rel = self.max_rel.max((h - h0 - work).abs() / scale);
        self.work = work;
    }

    /// max |H_k − H_0 − W_k| / |H_0| over the nodes recorded.
    pub fn max_rel(&self) -> f64 {
        self.max_rel
    }

    /// The work at the last node recorded.
    pub fn work(&self) -> f64 {
        self.work
    }

    /// The state for a checkpoint: H_0 (NaN before the first node), the largest error, the
    /// work, as bits.
    pub fn words(&self) -> [u64; 3] {
        [
            self.h0.unwrap_or(f64::NAN).to_bits(),
            self.max_rel.to_bits(),
            self.work.to_bits(),
        ]
    }

    /// The state [`WorkBalance::words`] gave.
    pub fn from_words(w: [u64; 3]) -> Self {
        let h0 = f64::from_bits(w[0]);
        WorkBalance {
            h0: (!h0.is_nan()).then_some(h0),
            max_rel: f64::from_bits(w[1]),
            work: f64::from_bits(w[2]),
        }
    }
}
