//! A trajectory known whole before it is written (runs solved to the end: adaptive steps,
//! constraints, forces in energy mode): trajectory.csv and trajectory.npy with columns.txt
//! from one row-major table, as the streaming writers (`csv_rows.rs`, `npy_rows.rs`) write a
//! run's rows, and its plots ([`plot_trajectory`]).

use crate::plot::{file, lines, log_lines, Format, Series};
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

/// The plots of a table whose columns are step, t, n coordinates, their n momenta, `energy`,
/// then optionally `work` and `residual`: coordinates against t; the relative energy error
/// |H − H0| / |H0| or, with a `work` column, the energy balance error |H − H0 − W| / |H0|; and
/// the constraint residual max |g(q)| if the table has it. `title` names the run.
///
/// # Errors
/// A plot that could not be drawn (the message).
pub fn plot_trajectory(
    dir: &Path,
    f: Format,
    title: &str,
    header: &[String],
    rows: &[f64],
    n: usize,
) -> Result<(), String> {
    let w = header.len().max(1);
    let column = |name: &str| header.iter().position(|h| h == name);
    let series = |name: String, y: &dyn Fn(&[f64]) -> f64| Series {
        name,
        points: rows.chunks_exact(w).map(|r| (r[1], y(r))).collect(),
    };
    let coords: Vec<Series> = (0..n)
        .filter_map(|c| header.get(2 + c).map(|name| series(name.clone(), &|r| r[2 + c])))
        .collect();
    lines(
        &file(dir, "coordinates", f),
        f,
        &format!("{title}: coordinates"),
        "t",
        "q",
        &coords,
    )?;
    let Some(e) = column("energy") else { return Ok(()) };
    let h0 = rows.get(e).copied().unwrap_or(0.0);
    let scale = if h0 == 0.0 { 1.0 } else { h0.abs() };
    let (what, y_label, energy) = match column("work") {
        Some(wk) => (
            "energy balance error",
            "|H - H0 - W| / |H0|",
            series("energy balance error".into(), &|r| (r[e] - h0 - r[wk]).abs() / scale),
        ),
        None => (
            "relative energy error",
            "|H - H0| / |H0|",
            series("relative energy error".into(), &|r| (r[e] - h0).abs() / scale),
        ),
    };
    let name = format!("{title}: {what}");
    log_lines(&file(dir, "energy_error", f), f, &name, "t", y_label, &[energy], false)?;
    if let Some(g) = column("residual") {
        let residual = [series("max |g(q)|".into(), &|r| r[g])];
        let name = format!("{title}: constraint residual");
        log_lines(&file(dir, "residual", f), f, &name, "t", "max |g(q)|", &residual, false)?;
    }
    Ok(())
}
