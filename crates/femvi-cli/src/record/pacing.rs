//! When a run looks at the clock: the flush policy of the outputs (rows on disk at least every
//! second, issue 16) and time-based checkpoints need the time, but reading the clock at every
//! node of a run of cheap steps would cost a measurable share of the step. [`Pacer`] reads it
//! every `stride` nodes and adapts the stride so that reads are about 1–20 ms apart.

use std::time::{Duration, Instant};

/// Reads the clock every few nodes; says when outputs are due for a flush.
#[derive(Debug, Clone)]
pub struct Pacer {
    stride: u32,
    count: u32,
    last_read: Instant,
    last_flush: Instant,
}

/// Longest stride (nodes between two clock reads).
const MAX_STRIDE: u32 = 4096;
/// Longest time rows may wait in a buffer (when nodes are faster than it).
const FLUSH_EVERY: Duration = Duration::from_secs(1);
/// Nodes this far apart are flushed at once: the next one may be far away.
const SLOW_NODE: Duration = Duration::from_millis(250);

impl Default for Pacer {
    fn default() -> Self {
        let now = Instant::now();
        Pacer {
            stride: 1,
            count: 0,
            last_read: now,
            last_flush: now,
        }
    }
}

impl Pacer {
    /// Called at every node: the time now and since the last read, if the clock was read at
    /// this node.
    ///
    /// # Example
    ///
    /// ```
    /// let mut pacer = femvi_cli::record::Pacer::default();
    /// let reads = (0..100_000).filter(|_| pacer.tick().is_some()).count();
    /// assert!(reads >= 1 && reads < 100_000);
    /// ```
    #[inline]
    pub fn tick(&mut self) -> Option<(Instant, Duration)> {
        self.count += 1;
        if self.count < self.stride {
            return None;
        }
        self.count = 0;
        let now = Instant::now();
        let gap = now.duration_since(self.last_read);
        if gap < Duration::from_millis(1) {
            self.stride = (self.stride * 2).min(MAX_STRIDE);
        } else if gap > Duration::from_millis(20) {
            self.stride = (self.stride / 2).max(1);
        }
        self.last_read = now;
        Some((now, gap))
    }

    /// Whether the outputs should be flushed now (`now` and `gap` from [`Pacer::tick`]): a
    /// second after the last flush, or at once when nodes come slowly. Counts the flush as done.
    pub fn flush_due(&mut self, now: Instant, gap: Duration) -> bool {
        if now.duration_since(self.last_flush) >= FLUSH_EVERY || gap >= SLOW_NODE {
            self.last_flush = now;
            true
        } else {
            false
        }
    }

    /// What is due after a node: (flush the outputs, write a checkpoint). A checkpoint is due
    /// at the first node of a fresh run (`(nodes, fresh)`: nodes recorded by this process,
    /// and whether it is not a resumed one), every `every_steps` steps (`steps`: the node's)
    /// and `every_seconds` after the last one (`since`); never without a `policy`.
    pub fn due(
        &mut self,
        policy: Option<&crate::resume::Policy>,
        (nodes, fresh): (usize, bool),
        steps: usize,
        since: Instant,
    ) -> (bool, bool) {
        let mut checkpoint = match (policy, nodes) {
            (None, _) => false,
            (Some(_), 1) => fresh,
            (Some(p), _) => p.every_steps.is_some_and(|n| n > 0 && steps.is_multiple_of(n)),
        };
        let mut flush = false;
        if let Some((now, gap)) = self.tick() {
            flush = self.flush_due(now, gap);
            let every = policy.and_then(|p| p.every_seconds);
            checkpoint |= every.is_some_and(|s| now.duration_since(since).as_secs_f64() >= s);
        }
        (flush, checkpoint)
    }
}
