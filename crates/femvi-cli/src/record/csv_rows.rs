//! trajectory.csv: one row per kept node (step, t, q, p, energy and, in energy mode, the
//! discrete energy), each number written as the shortest text that reads back to it. Rows go
//! through the `csv` crate's buffer; [`CsvRows::flush`] (called by the run at least every
//! second) and [`CsvRows::sync`] (at a checkpoint, returning the length the checkpoint keeps)
//! put them on disk, and [`CsvRows::resume`] truncates the file back to a checkpoint's length
//! and appends from there, so that a resumed run writes the same bytes as an uninterrupted one.

use super::{NodeEnergy, Thinning, WriteFailure};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::cell::Cell;
use std::fs::File;
use std::io::{Seek, SeekFrom};
use std::path::Path;
use std::rc::Rc;

/// Writes trajectory.csv as the run goes.
pub struct CsvRows {
    writer: csv::Writer<File>,
    thinning: Thinning,
    energy: Rc<Cell<NodeEnergy>>,
    failure: WriteFailure,
    row: Vec<String>,
}

impl CsvRows {
    /// Creates `dir`/trajectory.csv and writes the header.
    pub fn create(
        dir: &Path,
        columns: &[String],
        every: usize,
        energy: Rc<Cell<NodeEnergy>>,
        failure: WriteFailure,
    ) -> std::io::Result<Self> {
        let mut writer = csv::Writer::from_path(dir.join("trajectory.csv"))?;
        writer.write_record(columns)?;
        Ok(CsvRows {
            writer,
            thinning: Thinning::new(every),
            energy,
            failure,
            row: Vec::with_capacity(columns.len()),
        })
    }

    /// Reopens `dir`/trajectory.csv of a stopped run, cut back to its first `bytes` bytes (the
    /// rows up to node `k` of the checkpoint the run resumes from), to append the rows after
    /// node `k`.
    ///
    /// # Errors
    /// The file is missing, cannot be written, or is shorter than `bytes` (it was changed
    /// since the checkpoint).
    pub fn resume(
        dir: &Path,
        bytes: u64,
        k: usize,
        every: usize,
        energy: Rc<Cell<NodeEnergy>>,
        failure: WriteFailure,
    ) -> std::io::Result<Self> {
        let mut file = super::reopen_at(&dir.join("trajectory.csv"), bytes)?;
        file.seek(SeekFrom::End(0))?;
        let writer = csv::WriterBuilder::new().from_writer(file);
        Ok(CsvRows {
            writer,
            thinning: Thinning::after(every, k),
            energy,
            failure,
            row: vec![],
        })
    }

    /// Puts the buffered rows on disk (in the operating system's hands).
    ///
    /// # Errors
    /// The write failed.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }

    /// Flushes and returns the file's length: what a checkpoint at this node keeps.
    ///
    /// # Errors
    /// The write failed.
    pub fn sync(&mut self) -> std::io::Result<u64> {
        self.writer.flush()?;
        Ok(self.writer.get_ref().metadata()?.len())
    }
}

impl CsvRows {
    /// Writes one row of a table whose rows are not the integrator's nodes (an adaptive run's
    /// rows in physical time): the index as an integer, then `values`.
    ///
    /// # Errors
    /// The write failed.
    pub fn values(&mut self, index: usize, values: &[f64]) -> std::io::Result<()> {
        self.row.clear();
        self.row.push(index.to_string());
        self.row.extend(values.iter().map(|&x| num(x)));
        self.writer.write_record(&self.row).map_err(std::io::Error::other)
    }
}

/// Debug formatting of f64 is the shortest string that reads back to the same number.
fn num(x: f64) -> String {
    format!("{x:?}")
}

impl<L: Lagrangian> Observer<L> for CsvRows {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        let node = it.node();
        if !self.thinning.keep(node.k, last) {
            return Ok(());
        }
        self.row.clear();
        self.row.push(node.k.to_string());
        self.row.push(num(node.t));
        self.row.extend(node.q.iter().map(|&x| num(x)));
        self.row.extend(node.p.iter().map(|&x| num(x)));
        self.row.push(num(self.energy.get().h));
        if it.has_work() {
            self.row.push(num(it.work()));
        }
        if let Some(st) = it.energy_stats() {
            self.row.push(num(st.energy));
        }
        if let Some(at) = it.node_constraints() {
            self.row.extend(at.multipliers.iter().map(|&x| num(x)));
            self.row.push(num(at.residual));
        }
        for body in it.node_rotations().unwrap_or_default() {
            self.row.extend(body.w.iter().chain(&body.pi).map(|&x| num(x)));
        }
        self.writer
            .write_record(&self.row)
            .map_err(|e| femvi::Error::Observer(e.to_string()))
    }

    fn finish(&mut self, it: &Integrator<'_, L>, error: Option<&femvi::Error>) -> femvi::Result<()> {
        if self.failure.happened() {
            return Ok(());
        }
        // A run stopped early (an event with stop = true, a signal) ends on a node the
        // thinning may have skipped: keep it, as the last node of a finished run always is.
        if error.is_none() {
            Observer::<L>::node(self, it, true)?;
        }
        self.writer.flush().map_err(|e| self.failure.record(e))
    }
}
