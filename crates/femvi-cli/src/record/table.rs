//! A trajectory known whole before it is written (runs solved to the end: adaptive steps,
//! constraints, forces in energy mode): trajectory.csv and trajectory.npy with columns.txt
//! from one row-major table, as the streaming writers (`csv_rows.rs`, `npy_rows.rs`) write a
//! run's rows.

use crate::run_output::RunOutput;
use std::path::Path;

/// Writes the table `header` × `rows` (row-major; the first column, the step or row index,
/// as a float) into `dir`: trajectory.csv if `out.csv`, trajectory.npy and columns.txt if
/// `out.npy`.
///
/// # Errors
/// A file that could not be written.
pub fn write_trajectory(dir: &Path, header: &[String], rows: &[f64], out: &RunOutput) -> std::io::Result<()> {
    if out.csv {
        write_csv(dir, header, rows)?;
    }
    if out.npy {
        super::write_table(&dir.join("trajectory.npy"), &dir.join("columns.txt"), header, rows)?;
    }
    Ok(())
}

/// trajectory.csv: the index column as an integer, the others in shortest round-trip form.
fn write_csv(dir: &Path, header: &[String], rows: &[f64]) -> std::io::Result<()> {
    let mut w = csv::Writer::from_path(dir.join("trajectory.csv"))?;
    w.write_record(header)?;
    let mut record = Vec::with_capacity(header.len());
    for row in rows.chunks_exact(header.len().max(1)) {
        record.clear();
        record.push(format!("{}", row[0] as u64));
        record.extend(row[1..].iter().map(|x| format!("{x:?}")));
        w.write_record(&record)?;
    }
    w.flush()
}
