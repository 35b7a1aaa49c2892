//! trajectory.npy and columns.txt: the kept nodes' rows (the numbers of trajectory.csv) as one
//! 2-D float64 array, written at the end of the run, and the column names, one per line.

use super::{NodeEnergy, Thinning, WriteFailure};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::cell::Cell;
use std::path::Path;
use std::rc::Rc;

/// Gathers the rows of trajectory.npy and writes the file when the run ends.
pub struct NpyRows<'a> {
    dir: &'a Path,
    columns: Vec<String>,
    thinning: Thinning,
    energy: Rc<Cell<NodeEnergy>>,
    failure: WriteFailure,
    rows: Vec<f64>,
}

impl<'a> NpyRows<'a> {
    /// Rows with these columns, written into `dir` at the end.
    pub fn new(
        dir: &'a Path,
        columns: Vec<String>,
        every: usize,
        energy: Rc<Cell<NodeEnergy>>,
        failure: WriteFailure,
    ) -> Self {
        NpyRows {
            dir,
            columns,
            thinning: Thinning::new(every),
            energy,
            failure,
            rows: vec![],
        }
    }

    /// Writes the buffered rows as one 2-D float64 array and the column names, one per line.
    fn write(&self) -> std::io::Result<()> {
        write_table(
            &self.dir.join("trajectory.npy"),
            &self.dir.join("columns.txt"),
            &self.columns,
            &self.rows,
        )
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

impl<L: Lagrangian> Observer<L> for NpyRows<'_> {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        let node = it.node();
        if !self.thinning.keep(node.k, last) {
            return Ok(());
        }
        self.rows.push(node.k as f64);
        self.rows.push(node.t);
        self.rows.extend_from_slice(node.q);
        self.rows.extend_from_slice(node.p);
        self.rows.push(self.energy.get().h);
        if let Some(st) = it.energy_stats() {
            self.rows.push(st.energy);
        }
        Ok(())
    }

    fn finish(&mut self, it: &Integrator<'_, L>, error: Option<&femvi::Error>) -> femvi::Result<()> {
        if self.failure.happened() {
            return Ok(());
        }
        // A run stopped early (an event with stop = true) ends on a node the thinning may
        // have skipped: keep it, as the last node of a finished run always is.
        if error.is_none() {
            Observer::<L>::node(self, it, true)?;
        }
        self.write().map_err(|e| self.failure.record(e))
    }
}
