//! events.csv as the run goes: the `[[events]]` of a problem located by the library's
//! [`EventLocator`] on each element of the one run, each row (event, step, t, q, p) written
//! when it is found. Like trajectory.csv, [`EventRows::sync`] returns the length a checkpoint
//! keeps, with the locator's state, and [`EventRows::resume`] cuts the file back to it, so a
//! resumed run writes the same bytes as an uninterrupted one. When plots are on, the points
//! of the Poincaré plots are kept in memory, bounded ([`SectionPoints`]), and in checkpoints.

use femvi::solution::{EventLocator, EventRecord};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::fs::File;
use std::io::{Seek, SeekFrom};
use std::path::Path;

use super::SectionPoints;
use crate::problem::Problem;

/// The events of a run and events.csv.
pub struct EventRows {
    locator: EventLocator,
    writer: csv::Writer<File>,
    names: Vec<String>,
    row: Vec<String>,
    /// Events located (with those before a checkpoint, on resume).
    count: usize,
    /// The first stopping event's name, once one occurred.
    stopper: Option<String>,
    /// The points of the Poincaré plots (None without plots).
    kept: Option<SectionPoints>,
}

/// What a checkpoint keeps of the events: events.csv's length, the count and the locator's
/// state.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EventsSaved {
    /// Length of events.csv with the rows up to the checkpoint's node.
    pub bytes: u64,
    /// Events located up to it.
    pub count: usize,
    /// [`EventLocator::state`].
    pub state: Vec<u64>,
}

impl EventRows {
    /// Creates `dir`/events.csv with its header for the events of `problem` (dimension n).
    ///
    /// # Errors
    /// The file could not be created.
    pub fn create(problem: &Problem, dir: &Path, n: usize, plots: bool) -> std::io::Result<Self> {
        let mut writer = csv::Writer::from_path(dir.join("events.csv"))?;
        writer.write_record(crate::events::columns(problem))?;
        Ok(Self::with(problem, writer, n, plots))
    }

    /// Reopens events.csv of a stopped run cut back to the checkpoint's `saved` length, with
    /// the locator in the checkpoint's state.
    ///
    /// # Errors
    /// The file is missing or shorter than the checkpoint recorded, or the state does not fit.
    pub fn resume(problem: &Problem, dir: &Path, n: usize, saved: &EventsSaved) -> Result<Self, String> {
        let mut file = super::reopen_at(&dir.join("events.csv"), saved.bytes).map_err(|e| e.to_string())?;
        file.seek(SeekFrom::End(0)).map_err(|e| e.to_string())?;
        let writer = csv::WriterBuilder::new().from_writer(file);
        let mut me = Self::with(problem, writer, n, false);
        me.locator.restore(&saved.state).map_err(|e| e.to_string())?;
        me.count = saved.count;
        Ok(me)
    }

    fn with(problem: &Problem, writer: csv::Writer<File>, n: usize, plots: bool) -> Self {
        let events = problem.events.iter().map(|e| e.event()).collect();
        EventRows {
            locator: EventLocator::new(events, &problem.element, n),
            writer,
            names: problem.events.iter().map(|e| e.name.clone()).collect(),
            row: Vec::new(),
            count: 0,
            stopper: None,
            kept: plots.then(SectionPoints::default),
        }
    }

    /// Events located so far.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The stopping event that ended the run, if one did.
    pub fn stopper(&self) -> Option<&str> {
        self.stopper.as_deref()
    }

    /// The points kept for the Poincaré plots: (event index, q₁, p₁).
    pub fn kept(&self) -> &[(usize, f64, f64)] {
        self.kept.as_ref().map_or(&[], |k| &k.points)
    }

    /// The state of the Poincaré points, for a checkpoint (None without plots).
    pub fn kept_words(&self) -> Option<Vec<u64>> {
        self.kept.as_ref().map(SectionPoints::words)
    }

    /// Restores the Poincaré points of a resumed run with plots from
    /// [`EventRows::kept_words`].
    ///
    /// # Errors
    /// The words are not those of such points.
    pub fn restore_kept(&mut self, words: &[u64]) -> Result<(), String> {
        self.kept = Some(SectionPoints::from_words(words)?);
        Ok(())
    }

    /// Flushes and returns what a checkpoint at this node keeps.
    ///
    /// # Errors
    /// The write failed.
    pub fn sync(&mut self) -> std::io::Result<EventsSaved> {
        self.writer.flush()?;
        Ok(EventsSaved {
            bytes: self.writer.get_ref().metadata()?.len(),
            count: self.count,
            state: self.locator.state(),
        })
    }

    /// Puts the buffered rows on disk.
    ///
    /// # Errors
    /// The write failed.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }

    /// Writes the events located since the last call.
    fn write_found(&mut self) -> std::io::Result<()> {
        let found = self.locator.take();
        self.write(found)
    }

    /// Writes events located by another run (an adaptive run's recorder).
    ///
    /// # Errors
    /// The write failed.
    pub fn write(&mut self, records: Vec<EventRecord>) -> std::io::Result<()> {
        for r in records {
            let name = self.names.get(r.event).cloned().unwrap_or_default();
            if self.stopper.is_none() && self.locator.events().get(r.event).is_some_and(|e| e.stop) {
                self.stopper = Some(name.clone());
            }
            self.row.clear();
            self.row.extend([name, r.step.to_string(), format!("{:?}", r.t)]);
            self.row.extend(r.q.iter().chain(&r.p).map(|x| format!("{x:?}")));
            self.writer.write_record(&self.row)?;
            self.count += 1;
            if let Some(kept) = self.kept.as_mut() {
                let first = |x: &[f64]| x.first().copied().unwrap_or(f64::NAN);
                kept.offer(r.event, first(&r.q), first(&r.p));
            }
        }
        Ok(())
    }
}

impl<L: Lagrangian> Observer<L> for EventRows {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        self.locator.node(it, last)?;
        self.write_found()
            .map_err(|e| femvi::Error::Observer(format!("events.csv: {e}")))
    }

    fn finish(&mut self, _it: &Integrator<'_, L>, _error: Option<&femvi::Error>) -> femvi::Result<()> {
        self.writer
            .flush()
            .map_err(|e| femvi::Error::Observer(format!("events.csv: {e}")))
    }

    fn stop(&self) -> bool {
        Observer::<L>::stop(&self.locator)
    }
}
