//! `femvi ensemble`: its options, the initial states it reads, the tables it writes
//! (ensemble.csv, ensemble.npy) and the command itself with its progress bar.

use super::{run_all, run_member, run_shared, start_of, with_body, Member};
use crate::problem::Problem;
use crate::record::write_table;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The column names of an ensemble table: `member`, `final_t`, the coordinates, `p_` and the
/// coordinates, for each rotation X its body angular velocity `X_w1` … `X_w3` and momentum
/// `p_X1` … `p_X3` (as `femvi run` writes them), `energy_error`, `steps`.
pub fn columns(coordinates: &[String], rotations: &[String]) -> Vec<String> {
    let mut c = vec!["member".to_string(), "final_t".to_string()];
    c.extend(coordinates.iter().cloned());
    c.extend(coordinates.iter().map(|x| format!("p_{x}")));
    for x in rotations {
        c.extend((1..=3).map(|i| format!("{x}_w{i}")));
        c.extend((1..=3).map(|i| format!("p_{x}{i}")));
    }
    c.push("energy_error".into());
    c.push("steps".into());
    c
}

/// Writes `ensemble.csv` (the [`columns`] and `error`, numbers in shortest round-trip form)
/// and `ensemble.npy` (the numeric columns, NaN for what a failed member lacks, with
/// `ensemble_columns.txt`) into `dir`.
///
/// # Errors
/// The files cannot be written.
pub fn write(dir: &Path, (coordinates, rotations): (&[String], &[String]), members: &[Member]) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let cols = columns(coordinates, rotations);
    let body = 6 * rotations.len();
    let mut table = Vec::with_capacity(members.len() * cols.len());
    let mut w = csv::Writer::from_path(dir.join("ensemble.csv"))?;
    let mut header = cols.clone();
    header.push("error".into());
    w.write_record(&header)?;
    for (i, m) in members.iter().enumerate() {
        let mut row = vec![i as f64, m.final_t];
        row.extend(&m.q);
        row.extend(&m.p);
        row.extend((0..body).map(|k| m.body.get(k).copied().unwrap_or(f64::NAN)));
        row.push(m.energy_error);
        row.push(m.steps as f64);
        let mut text: Vec<String> = row.iter().map(|x| x.to_string()).collect();
        text[0] = i.to_string();
        text.push(m.error.clone().unwrap_or_default());
        w.write_record(&text)?;
        table.extend(row);
    }
    w.flush()?;
    write_table(
        &dir.join("ensemble.npy"),
        &dir.join("ensemble_columns.txt"),
        &cols,
        &table,
    )
}

/// What `femvi ensemble` was asked for (its options; the doc comments are the `--help` text).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct EnsembleArgs {
    /// Override a value of the problem file for every member (repeatable), e.g.
    /// --set time.end=100.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Initial states: a CSV of rows q0 then p0 (2n numbers; a header row is allowed) or
    /// an (N, 2n) float64 .npy file.
    #[arg(long)]
    pub states: Option<std::path::PathBuf>,
    /// The second half of each state row is v0 instead of p0.
    #[arg(long)]
    pub velocity: bool,
    /// A parameter of the system table's parameters over the members: NAME=LO:HI:N.
    #[arg(long)]
    pub param: Option<String>,
    /// Threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    pub workers: usize,
    /// Output directory (default: the problem's).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
    /// No progress bar or report.
    #[arg(long)]
    pub quiet: bool,
}

/// Initial states from a CSV (rows of numbers; a first row that is not numbers is a header)
/// or an NPY file (a 2-D float64 array), as one row-major vector and its row count.
///
/// # Errors
/// The file cannot be read, a value is not a number, or the rows do not have `width` numbers.
pub fn read_states(path: &Path, width: usize) -> Result<(Vec<f64>, usize), String> {
    let at = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let values: Vec<f64> = if path.extension().is_some_and(|e| e == "npy") {
        let bytes = crate::bounded::read(path, crate::bounded::Limits::BINARY).map_err(|e| at(&e))?;
        let npy = npyz::NpyFile::new(&bytes[..]).map_err(|e| at(&e))?;
        let shape = npy.shape().to_vec();
        if shape.len() != 2 || shape[1] as usize != width {
            return Err(at(&format!("expected an (N, {width}) array, got shape {shape:?}")));
        }
        npy.into_vec::<f64>().map_err(|e| at(&e))?
    } else {
        let text = crate::bounded::read_to_string(path, crate::bounded::Limits::CSV).map_err(|e| at(&e))?;
        let mut v = Vec::new();
        for (k, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
            let row: Result<Vec<f64>, _> = line.split(',').map(|x| x.trim().parse::<f64>()).collect();
            match row {
                Ok(r) if r.len() == width => v.extend(r),
                Ok(r) => return Err(at(&format!("line {}: {} numbers, expected {width}", k + 1, r.len()))),
                Err(_) if k == 0 => {} // a header
                Err(e) => return Err(at(&format!("line {}: {e}", k + 1))),
            }
        }
        v
    };
    if values.iter().any(|x| !x.is_finite()) {
        return Err(at(&"initial states must be finite"));
    }
    let rows = values.len() / width.max(1);
    Ok((values, rows))
}

/// `femvi ensemble`: runs the members and writes ensemble.csv/.npy. Ok(true): every member
/// reached the end; Ok(false): some failed (their rows say why). Err: a message and exit code.
pub fn command(path: &Path, args: &EnsembleArgs) -> Result<bool, (String, u8)> {
    let bad = |e: String| (e, crate::BAD_INPUT);
    let problem = crate::problem::load_with(path, &args.set).map_err(|e| bad(e.to_string()))?;
    problem
        .refuse(crate::problem::capabilities::Use::Ensemble, "femvi ensemble")
        .map_err(|e| bad(format!("{}: {e}", path.display())))?;
    let n = problem.coordinates.len();
    let states = match &args.states {
        Some(f) => Some(read_states(f, 2 * n).map_err(bad)?),
        None => None,
    };
    let axis = args
        .param
        .as_deref()
        .map(crate::chaos::Axis::parse)
        .transpose()
        .map_err(bad)?;
    let size = match (&states, &axis) {
        (Some((_, a)), Some(b)) if *a != b.n => {
            return Err(bad(format!("--states has {a} rows but --param gives {} values", b.n)));
        }
        (Some((_, a)), _) => *a,
        (None, Some(b)) => b.n,
        (None, None) => {
            return Err(bad(format!(
                "{}: give --states FILE and/or --param NAME=LO:HI:N",
                path.display()
            )))
        }
    };
    let member_problem = |a: &crate::chaos::Axis, i: usize| -> Result<Problem, String> {
        let mut set = args.set.clone();
        set.push(format!("system.parameters.{}={:?}", a.name, a.value(i)));
        crate::problem::load_with(path, &set).map_err(|e| e.to_string())
    };
    // A parameter that the problem does not have is an input error, found on the first member.
    if let Some(a) = &axis {
        member_problem(a, 0).map_err(bad)?;
    }
    let rows = states.as_ref().map(|(v, _)| v.as_slice());
    let done = AtomicUsize::new(0);
    let member = |i: usize| {
        let owned;
        let p = match &axis {
            Some(a) => match member_problem(a, i) {
                Ok(p) => {
                    owned = p;
                    &owned
                }
                Err(e) => return Member::failed(n, f64::NAN, e),
            },
            None => &problem,
        };
        match start_of(p, rows, i, args.velocity) {
            Ok(start) => with_body(p, run_member(p, start)),
            Err(e) => Member::failed(n, f64::NAN, e),
        }
    };
    let members = match &axis {
        None => {
            let start = |i: usize| start_of(&problem, rows, i, args.velocity);
            with_progress(size, args.quiet, &done, || {
                run_shared(&problem, size, args.workers, &done, start)
                    .map(|all| all.into_iter().map(|m| with_body(&problem, m)).collect())
            })
        }
        Some(_) => with_progress(size, args.quiet, &done, || run_all(size, args.workers, &done, member)),
    }
    .map_err(|e| (e, crate::NUMERICAL))?;
    let dir = args.out.clone().unwrap_or_else(|| problem.directory.clone());
    let rotations = crate::record::rotation_names(&problem);
    write(&dir, (&problem.coordinates, &rotations), &members)
        .map_err(|e| (format!("cannot write {}: {e}", dir.display()), crate::BAD_INPUT))?;
    let failed = members.iter().filter(|m| m.error.is_some()).count();
    if !args.quiet {
        println!(
            "{size} members, {failed} failed; wrote {}",
            dir.join("ensemble.csv").display()
        );
    }
    Ok(failed == 0)
}

/// Runs `work` while a progress bar (unless `quiet`) follows `done` out of `size`.
fn with_progress<T: Send>(size: usize, quiet: bool, done: &AtomicUsize, work: impl FnOnce() -> T + Send) -> T {
    if quiet {
        return work();
    }
    let bar = indicatif::ProgressBar::new(size as u64);
    let out = std::thread::scope(|scope| {
        let worker = scope.spawn(work);
        while !worker.is_finished() {
            bar.set_position(done.load(Ordering::Relaxed) as u64);
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        worker.join()
    });
    bar.finish_and_clear();
    match out {
        Ok(t) => t,
        Err(p) => std::panic::resume_unwind(p),
    }
}
