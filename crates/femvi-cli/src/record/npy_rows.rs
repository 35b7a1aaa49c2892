//! trajectory.npy and columns.txt: the kept nodes' rows (the numbers of trajectory.csv) as one
//! 2-D float64 array, and the column names, one per line.
//!
//! The array is written as the run goes (constant memory, issue 16): a header of fixed length
//! whose row count is rewritten in place at every checkpoint, stop and at the end, then the
//! rows, little-endian. So a stopped run leaves a loadable file, and a resumed run truncates
//! the file to its checkpoint's row count and appends. The header is written here rather than
//! by `npyz`, whose writer needs the shape before the first row and cannot rewrite it;
//! [`write_table`] (a whole table known in advance) still uses `npyz`.

use super::{NodeEnergy, Thinning, WriteFailure};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::cell::Cell;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::Path;
use std::rc::Rc;

/// Length of the header: magic, version, length, the dictionary padded with spaces and a
/// newline (a multiple of 64 bytes, room for 20-digit counts).
const HEADER: usize = 128;

/// Writes trajectory.npy as the run goes.
pub struct NpyRows {
    file: BufWriter<File>,
    columns: usize,
    thinning: Thinning,
    energy: Rc<Cell<NodeEnergy>>,
    failure: WriteFailure,
    rows: u64,
}

/// The NPY version 1.0 header of a float64 array of `rows` × `cols`, [`HEADER`] bytes.
fn header(rows: u64, cols: usize) -> Vec<u8> {
    let dict = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({rows}, {cols}), }}");
    let mut h = b"\x93NUMPY\x01\x00".to_vec();
    let len = (HEADER - 10) as u16;
    h.extend_from_slice(&len.to_le_bytes());
    h.extend_from_slice(dict.as_bytes());
    h.resize(HEADER - 1, b' ');
    h.push(b'\n');
    h
}

impl NpyRows {
    /// Creates `dir`/trajectory.npy (no rows yet) and `dir`/columns.txt.
    ///
    /// # Errors
    /// A file could not be written.
    pub fn create(
        dir: &Path,
        columns: &[String],
        every: usize,
        energy: Rc<Cell<NodeEnergy>>,
        failure: WriteFailure,
    ) -> std::io::Result<Self> {
        std::fs::write(dir.join("columns.txt"), columns.join("\n") + "\n")?;
        let mut file = BufWriter::new(File::create(dir.join("trajectory.npy"))?);
        file.write_all(&header(0, columns.len()))?;
        Ok(NpyRows {
            file,
            columns: columns.len(),
            thinning: Thinning::new(every),
            energy,
            failure,
            rows: 0,
        })
    }

    /// Reopens `dir`/trajectory.npy of a stopped run, cut back to its first `rows` rows (those
    /// up to node `k` of the checkpoint the run resumes from), to append the rows after node `k`.
    ///
    /// # Errors
    /// The file is missing, cannot be written, or is shorter than `rows` rows.
    pub fn resume(
        dir: &Path,
        columns: &[String],
        rows: u64,
        k: usize,
        every: usize,
        energy: Rc<Cell<NodeEnergy>>,
        failure: WriteFailure,
    ) -> std::io::Result<Self> {
        let bytes = rows
            .checked_mul(8 * columns.len() as u64)
            .and_then(|b| b.checked_add(HEADER as u64))
            .ok_or_else(|| std::io::Error::other("trajectory.npy: row count out of range"))?;
        let mut file = super::reopen_at(&dir.join("trajectory.npy"), bytes)?;
        file.seek(SeekFrom::End(0))?;
        Ok(NpyRows {
            file: BufWriter::new(file),
            columns: columns.len(),
            thinning: Thinning::after(every, k),
            energy,
            failure,
            rows,
        })
    }

    /// Puts the buffered rows on disk.
    ///
    /// # Errors
    /// The write failed.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }

    /// Flushes, rewrites the header with the rows written so far and returns their number:
    /// what a checkpoint at this node keeps.
    ///
    /// # Errors
    /// The write failed.
    pub fn sync(&mut self) -> std::io::Result<u64> {
        self.file.flush()?;
        let f = self.file.get_mut();
        f.seek(SeekFrom::Start(0))?;
        f.write_all(&header(self.rows, self.columns))?;
        f.seek(SeekFrom::End(0))?;
        Ok(self.rows)
    }

    /// Writes one row of a table whose rows are not the integrator's nodes (an adaptive run's
    /// rows in physical time): the index, then `values`.
    ///
    /// # Errors
    /// The write failed.
    pub fn values(&mut self, index: usize, values: &[f64]) -> std::io::Result<()> {
        self.push(index as f64)?;
        for &x in values {
            self.push(x)?;
        }
        self.rows += 1;
        Ok(())
    }

    fn push(&mut self, x: f64) -> std::io::Result<()> {
        self.file.write_all(&x.to_le_bytes())
    }

    fn row<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) -> std::io::Result<()> {
        let node = it.node();
        self.push(node.k as f64)?;
        self.push(node.t)?;
        for &x in node.q.iter().chain(node.p) {
            self.push(x)?;
        }
        self.push(self.energy.get().h)?;
        if it.has_work() {
            self.push(it.work())?;
        }
        if let Some(st) = it.energy_stats() {
            self.push(st.energy)?;
        }
        if let Some(at) = it.node_constraints() {
            for &x in &at.multipliers {
                self.push(x)?;
            }
            self.push(at.residual)?;
        }
        for body in it.node_rotations().unwrap_or_default() {
            for &x in body.w.iter().chain(&body.pi) {
                self.push(x)?;
            }
        }
        self.rows += 1;
        Ok(())
    }
}

/// Writes row-major `rows` as one 2-D float64 array (`columns.len()` columns) into `npy`, and
/// the column names, one per line, into `names`.
pub fn write_table(npy: &Path, names: &Path, columns: &[String], rows: &[f64]) -> std::io::Result<()> {
    use npyz::WriterBuilder;
    let cols = columns.len().max(1) as u64;
    let file = std::io::BufWriter::new(std::fs::File::create(npy)?);
    let mut w = npyz::WriteOptions::<f64>::new()
        .default_dtype()
        .shape(&[rows.len() as u64 / cols, cols])
        .writer(file)
        .begin_nd()?;
    w.extend(rows.iter().copied())?;
    w.finish()?;
    std::fs::write(names, columns.join("\n") + "\n")
}

impl<L: Lagrangian> Observer<L> for NpyRows {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        if self.failure.happened() || !self.thinning.keep(it.node().k, last) {
            return Ok(());
        }
        self.row(it).map_err(|e| self.failure.record(e))
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
        self.sync().map(|_| ()).map_err(|e| self.failure.record(e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_has_fixed_length_and_the_shape() {
        for (rows, cols) in [(0, 1), (12345, 7), (u64::MAX, 10_000)] {
            let h = header(rows, cols);
            assert_eq!(h.len(), HEADER);
            let text = String::from_utf8_lossy(&h[10..]);
            assert!(text.contains(&format!("'shape': ({rows}, {cols})")), "{text}");
            assert!(text.ends_with('\n'));
        }
    }
}
