//! The output estimate of `femvi run` (issue 16): before the first step, the rows the run
//! will write (the grid's steps, or in energy mode the span over the first step, thinned by
//! `every`; for adaptive steps with `output_step` the rows at those times,
//! [`crate::adaptive::estimated_rows`]) times the bytes of a row in each format. A run whose estimate exceeds
//! `--max-output` (default 10 GB) or the free space of the output device (`statvfs`) is
//! refused with the estimate and the ways out (`[output] every`, `--max-output`).

use crate::problem::Problem;
use crate::run_output::RunOutput;
use std::path::Path;

/// The default `--max-output`: 10 GB.
pub const DEFAULT_MAX_OUTPUT: u64 = 10_000_000_000;

/// Bytes of one number in trajectory.csv, a typical shortest round-trip float and its comma
/// (`-0.12345678901234568,` is 21).
const CSV_NUMBER: f64 = 21.0;

/// What a run will write, roughly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Rows of the trajectory.
    pub rows: f64,
    /// Bytes of all trajectory files.
    pub bytes: f64,
}

/// The estimate for `problem` with outputs `out`.
///
/// # Example
///
/// ```
/// let text = "[system]\nmodel = \"harmonic\"\n[initial]\nq = [1.0]\np = [0.0]\n[time]\nstep = 0.001\nend = 10.0\n";
/// let p = femvi_cli::problem::load_text("x.toml".as_ref(), text, &[]).unwrap();
/// let out = femvi_cli::run::RunOutput { csv: false, npy: true, progress: false, plots: false, plot_format: femvi_cli::plot::Format::Svg };
/// let e = femvi_cli::estimate::estimate(&p, &out);
/// assert_eq!(e.rows, 10_001.0);
/// assert_eq!(e.bytes, 128.0 + 10_001.0 * 5.0 * 8.0); // header, then step, t, q, p, energy
/// ```
pub fn estimate(problem: &Problem, out: &RunOutput) -> Estimate {
    let grid = &problem.grid;
    let steps = match problem.energy {
        None => grid.count() as f64,
        Some(_) => ((grid.end() - grid.t0()) / grid.nominal(0)).ceil(),
    };
    // Node 0, every `every`-th node and the last.
    let every = problem.every.max(1) as f64;
    let rows = (steps / every).floor() + 1.0 + if steps % every == 0.0 { 0.0 } else { 1.0 };
    of_rows(problem, out, rows, steps)
}

/// The estimate for `rows` rows of `problem`'s columns, the step numbers up to `steps`: for
/// runs whose rows are not the grid's (adaptive steps, [`crate::adaptive::estimated_rows`]).
pub fn of_rows(problem: &Problem, out: &RunOutput, rows: f64, steps: f64) -> Estimate {
    let cols = crate::record::columns(problem).len() as f64;
    let mut bytes = 0.0;
    if out.csv {
        let header: usize = crate::record::columns(problem).iter().map(|c| c.len() + 1).sum();
        let step_column = steps.max(1.0).log10().ceil() + 1.0;
        bytes += header as f64 + rows * (step_column + (cols - 1.0) * CSV_NUMBER);
    }
    if out.npy {
        bytes += 128.0 + rows * cols * 8.0;
    }
    Estimate { rows, bytes }
}

/// Free bytes for an unprivileged user on the device of `dir` (or of its nearest existing
/// ancestor), if the system says.
pub fn free_space(dir: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let existing = dir.ancestors().find(|d| d.exists()).unwrap_or(Path::new("."));
    let existing = if existing.as_os_str().is_empty() {
        Path::new(".")
    } else {
        existing
    };
    let c = std::ffi::CString::new(existing.as_os_str().as_bytes()).ok()?;
    let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c` is a NUL-terminated path and `st` is a writable statvfs that the call fills
    // when it returns 0 (the only case in which it is read).
    let rc = unsafe { libc::statvfs(c.as_ptr(), st.as_mut_ptr()) };
    if rc != 0 {
        return None;
    }
    // SAFETY: statvfs returned 0, so it filled `st`.
    let st = unsafe { st.assume_init() };
    // The fields are 32 bits on some targets.
    #[allow(clippy::unnecessary_cast)]
    let (blocks, size) = (st.f_bavail as u64, st.f_frsize as u64);
    Some(blocks.saturating_mul(size))
}

/// Refuses a run whose estimate exceeds `max_output` bytes or the free space in `dir`
/// (`already`: bytes of outputs already there that the run continues).
///
/// # Errors
/// The message for the user: the estimate and the ways out.
pub fn check(problem: &Problem, out: &RunOutput, dir: &Path, max_output: u64, already: u64) -> Result<(), String> {
    check_estimate(problem, estimate(problem, out), dir, max_output, already)
}

/// [`check`] for the estimate `e`.
///
/// # Errors
/// The message for the user: the estimate and the ways out.
pub fn check_estimate(problem: &Problem, e: Estimate, dir: &Path, max_output: u64, already: u64) -> Result<(), String> {
    let need = (e.bytes - already as f64).max(0.0);
    let (limit, what) = match free_space(dir) {
        Some(free) if (free as f64) < need && free < max_output => {
            (free, format!("the {} free on the output device", size(free as f64)))
        }
        _ => (max_output, format!("--max-output {}", size(max_output as f64))),
    };
    if need <= limit as f64 {
        return Ok(());
    }
    let factor = need / limit.max(1) as f64;
    let fewer = match problem.terms.adaptive.as_ref().and_then(|a| a.output_step) {
        // Rows at uniform physical times: their spacing sets the count.
        Some(h) => format!(
            "a larger [time] output_step (e.g. --set time.output_step={:e})",
            h * factor.ceil()
        ),
        None => format!(
            "[output] every (e.g. --set output.every={:.0})",
            (problem.every as f64 * factor).ceil()
        ),
    };
    Err(format!(
        "the run would write about {} ({:.3e} rows), more than {what}; write fewer rows with {fewer}, shorten the run, or raise --max-output",
        size(e.bytes),
        e.rows
    ))
}

/// A byte count for people: 1.7 GB.
fn size(bytes: f64) -> String {
    let units = ["bytes", "kB", "MB", "GB", "TB", "PB", "EB"];
    let mut x = bytes;
    let mut u = 0;
    while x >= 1000.0 && u + 1 < units.len() {
        x /= 1000.0;
        u += 1;
    }
    if u == 0 {
        format!("{x:.0} bytes")
    } else {
        format!("{x:.1} {}", units[u])
    }
}

/// Parses a byte count: a number with an optional unit k, M, G, T (powers of 1000) or
/// KiB, MiB, GiB, TiB (powers of 1024), B optional.
///
/// # Errors
/// Not such a count (a message for the user).
///
/// # Example
///
/// ```
/// use femvi_cli::estimate::parse_size;
/// assert_eq!(parse_size("10G"), Ok(10_000_000_000));
/// assert_eq!(parse_size("1.5 MiB"), Ok(1_572_864));
/// assert_eq!(parse_size("4096"), Ok(4096));
/// assert_eq!(parse_size("2e9"), Ok(2_000_000_000));
/// assert!(parse_size("lots").is_err() && parse_size("-1G").is_err());
/// ```
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    // The unit starts at the first letter that is not an exponent (1e9, 2.5E+3).
    let bytes = t.as_bytes();
    let exponent = |i: usize| {
        matches!(bytes[i], b'e' | b'E')
            && i > 0
            && bytes[i - 1].is_ascii_digit()
            && bytes
                .get(i + 1)
                .is_some_and(|c| c.is_ascii_digit() || *c == b'+' || *c == b'-')
    };
    let split = (0..bytes.len())
        .find(|&i| bytes[i].is_ascii_alphabetic() && !exponent(i))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let scale: f64 = match unit.trim().to_ascii_lowercase().trim_end_matches('b') {
        "" => 1.0,
        "k" => 1e3,
        "m" => 1e6,
        "g" => 1e9,
        "t" => 1e12,
        "ki" => 1024.0,
        "mi" => 1024.0 * 1024.0,
        "gi" => 1024.0 * 1024.0 * 1024.0,
        "ti" => 1024.0f64.powi(4),
        _ => return Err(format!("'{text}' is not a size (use e.g. 500M, 10G, 2TiB)")),
    };
    match num.trim().parse::<f64>() {
        Ok(x) if x >= 0.0 && (x * scale).is_finite() && x * scale < u64::MAX as f64 => Ok((x * scale).round() as u64),
        _ => Err(format!("'{text}' is not a size (use e.g. 500M, 10G, 2TiB)")),
    }
}
