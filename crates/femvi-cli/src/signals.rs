//! Stopping `femvi run` cleanly on SIGINT, SIGTERM and SIGHUP (issue 16): the handlers,
//! installed by the command (never by the library or the Python package, whose process owns
//! its signals), only set a flag; the run looks at it after each node ([`StopOnSignal`], an
//! observer's `stop()`), ends on a complete row, writes a checkpoint and summary.json, and the
//! command exits with 128 + the signal's number (130, 143, 129). A second signal while the
//! run is stopping ends the process at once. The handlers are `signal-hook`'s flag handlers
//! (async-signal-safe stores), not hand-written ones.

use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// The number of the first stop signal received (0: none).
static RECEIVED: AtomicUsize = AtomicUsize::new(0);
/// Set by the first signal: a second one then exits at once.
static ARMED: AtomicBool = AtomicBool::new(false);

/// The signals that stop a run, with their names.
pub const STOP_SIGNALS: [(i32, &str); 3] = [
    (signal_hook::consts::SIGINT, "SIGINT"),
    (signal_hook::consts::SIGTERM, "SIGTERM"),
    (signal_hook::consts::SIGHUP, "SIGHUP"),
];

/// Installs the handlers of [`STOP_SIGNALS`] for this process.
///
/// # Errors
/// The operating system refused a handler.
pub fn install() -> std::io::Result<()> {
    for (sig, _) in STOP_SIGNALS {
        // Registered first, so that it sees the flag of an earlier signal only.
        signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, &ARMED)?;
        signal_hook::flag::register_usize(sig, &RECEIVED, sig as usize)?;
        signal_hook::flag::register(sig, &ARMED)?;
    }
    Ok(())
}

/// A received stop signal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Signal(pub i32);

impl Signal {
    /// Its name (SIGINT, …).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi_cli::signals::Signal;
    /// assert_eq!(Signal(2).name(), "SIGINT");
    /// assert_eq!(Signal(15).exit_code(), 143);
    /// ```
    pub fn name(self) -> &'static str {
        STOP_SIGNALS
            .iter()
            .find(|(s, _)| *s == self.0)
            .map_or("a signal", |(_, n)| n)
    }

    /// The exit code of a process stopped by it: 128 + its number.
    pub fn exit_code(self) -> u8 {
        u8::try_from(128 + self.0).unwrap_or(u8::MAX)
    }
}

/// The stop signal received so far, if any (always none where [`install`] was not called).
pub fn received() -> Option<Signal> {
    // Relaxed: read at every node; the flag carries no other data.
    match RECEIVED.load(Ordering::Relaxed) {
        0 => None,
        s => i32::try_from(s).ok().map(Signal),
    }
}

/// An observer that stops a run once a stop signal has arrived.
#[derive(Debug, Default, Clone, Copy)]
pub struct StopOnSignal;

impl<L: Lagrangian> Observer<L> for StopOnSignal {
    fn node(&mut self, _it: &Integrator<'_, L>, _last: bool) -> femvi::Result<()> {
        Ok(())
    }

    fn stop(&self) -> bool {
        received().is_some()
    }
}
