//! How a run of `femvi run` ended ([`Outcome`]) and the summary.json written at its end
//! (`finish`, `interrupted`): shared by the run of a plain Lagrangian (`run.rs`) and the
//! runs of the terms (`forced`, `constrained`, `adaptive`, `events.rs`), which `run.rs`
//! dispatches to, so that none of them imports the dispatcher.

use crate::signals::Signal;
use crate::summary::{write_summary, Summary};
use std::path::Path;

/// How a run ended.
pub enum Outcome {
    /// Finished; the summary.
    Done(Summary),
    /// A numerical failure after some steps (written to disk); the summary has the error.
    Failed(Summary),
    /// Stopped by a signal at a step boundary (outputs complete up to there, a checkpoint
    /// written); the summary has the error "interrupted by …".
    Interrupted(Summary, Signal),
    /// The problem could not be started (bad input the library detected).
    Rejected(String),
}

/// Writes the summary of a run stopped by `sig`.
pub(crate) fn interrupted(dir: &Path, mut summary: Summary, sig: Signal) -> std::io::Result<Outcome> {
    summary.status = "interrupted".into();
    summary.error = Some(format!(
        "interrupted by {} at step {}, t = {}",
        sig.name(),
        summary.steps,
        summary.final_t
    ));
    write_summary(dir, &summary)?;
    Ok(Outcome::Interrupted(summary, sig))
}

/// Writes summary.json and classifies the outcome by its error.
pub(crate) fn finish(dir: &Path, summary: Summary) -> std::io::Result<Outcome> {
    write_summary(dir, &summary)?;
    Ok(if summary.error.is_some() {
        Outcome::Failed(summary)
    } else {
        Outcome::Done(summary)
    })
}
