//! How `femvi run` drives a run (issue 15, item 4): in chunks of steps through
//! [`Integrator::advance_observed`] up to the next node the trajectory keeps, the next
//! checkpoint due by step count, or a length that keeps the chunks 10–100 milliseconds long.
//! Every node still gets its energy, its finiteness check and its place as the last good node
//! ([`Recorders::each_node`], which the explicit fast path runs inside its loop, or its
//! call-free twin [`Recorders::each_node_lean`] where the energy is ½|p|² + V); the outputs,
//! the progress bar, flushes, time-based checkpoints and the stop signals are looked at when a
//! chunk ends ([`Recorders::boundary`]). The nodes, rows and summary are those of
//! [`femvi::step::drive()`] with the same recorders, bit for bit; only the moments a signal is
//! noticed and a time-based checkpoint is written move to the chunks' ends. Energy mode, whose
//! discrete energy is checked at every node too, goes a step at a time through
//! [`femvi::step::drive()`].

use super::Recorders;
use femvi::step::{drive, DriveReport, Observer};
use femvi::{Integrator, Lagrangian};
use std::time::{Duration, Instant};

/// The longest chunk (steps).
const MAX_CHUNK: usize = 1 << 22;
/// Chunks faster than this grow (×2).
const SHORT: Duration = Duration::from_millis(10);
/// Chunks slower than this shrink (÷2). Long enough for tens of steps of a chain of 10⁶
/// masses (a few ms each): a call of the explicit loop for large n keeps its start (about
/// one step's memory traffic) to take its steps in place; short enough for the progress bar
/// and for a signal to be noticed within a fraction of a second.
const LONG: Duration = Duration::from_millis(100);

/// The length limit of the chunks, adapted to their time.
struct Cap {
    len: usize,
    clock: Instant,
}

impl Cap {
    fn new() -> Self {
        Cap {
            len: 256,
            clock: Instant::now(),
        }
    }

    /// After a chunk of `n` steps.
    fn after(&mut self, n: usize) {
        let now = Instant::now();
        let took = now.duration_since(self.clock);
        self.clock = now;
        if took > LONG {
            self.len = (self.len / 2).max(1);
        } else if took < SHORT && n >= self.len {
            self.len = (self.len * 2).min(MAX_CHUNK);
        }
    }
}

/// Steps `it` (a run of `lag`) to the end of its grid in chunks, recording it with `rec`;
/// the report of [`femvi::step::drive()`]: a failure of a step or of the recorders stops the
/// run, the integrator stays at the last good node, and the recorders' `finish` still runs.
pub fn drive_in_chunks<L: Lagrangian>(lag: &L, it: &mut Integrator<'_, L>, rec: &mut Recorders<'_>) -> DriveReport {
    if !rec.chunked() {
        // Energy mode: a step at a time, the library's driver with the same recorders.
        return drive(it, &mut [rec as &mut dyn Observer<L>]);
    }
    let mut error = Observer::node(rec, it, it.finished()).err();
    let mut steps = 0;
    let mut stopped = Observer::<L>::stop(rec);
    let mut cap = Cap::new();
    while error.is_none() && !stopped {
        let mut failed = None;
        let n = rec.chunk(it.node().k, cap.len);
        let advanced = if rec.lean(lag) {
            let mut unrecorded = false;
            let advanced = it.advance_observed(
                n,
                #[inline(always)]
                |node| {
                    unrecorded = !rec.each_node_lean(lag, node);
                    !unrecorded
                },
            );
            // The node the lean path stopped at, again through the checked path: its error
            // (or, for a node it could not take, its record).
            if unrecorded && advanced.is_ok() {
                failed = rec.each_node(lag, it.node(), 0.0).err();
            }
            advanced
        } else {
            it.advance_observed(
                n,
                #[inline(always)]
                |node| match rec.each_node(lag, node, 0.0) {
                    Ok(()) => true,
                    Err(e) => {
                        failed = Some(e);
                        false
                    }
                },
            )
        };
        match advanced {
            Ok(0) => break,
            Ok(done) => {
                steps += done;
                if let Some(e) = failed {
                    error = Some(e);
                    break;
                }
                error = rec.boundary(it, it.finished()).err();
                stopped = Observer::<L>::stop(rec);
                cap.after(done);
            }
            Err(e) => error = Some(e),
        }
    }
    if let Err(e) = Observer::finish(rec, it, error.as_ref()) {
        error.get_or_insert(e);
    }
    DriveReport { steps, stopped, error }
}
