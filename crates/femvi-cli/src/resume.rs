//! Checkpoints of `femvi run` and `--resume` (issue 16): checkpoint.json in the output
//! directory holds the library's [`Checkpoint`] of the integrator (everything the next step
//! depends on, bit for bit) and the state of the outputs at that node: the length of
//! trajectory.csv, the rows of trajectory.npy, the steps driven and the energy observer's
//! state. It is written atomically (a temporary file renamed over the old one) at the first
//! node, every N steps and/or seconds ([`Policy`]) and when a signal stops the run.
//!
//! `femvi run PROBLEM --resume DIR` rebuilds the run from PROBLEM, checks that the checkpoint
//! belongs to it (same femvi version, same problem text by SHA-256, same output formats: else
//! a clear refusal, exit 2), restores the integrator, cuts the output files back to the
//! checkpoint and continues, so that the outputs are those of an uninterrupted run, byte for
//! byte; with `[[events]]`, events.csv too (its length and the event locator's state are in
//! the checkpoint). Runs with plots keep the bounded records their plots are drawn from
//! (`record::PlotTrace`, `record::SectionPoints`) in a binary side file of the checkpoint
//! ([`save_plots`]): two files written in turn, checkpoint.json naming the one it goes with
//! and its SHA-256, so that a run killed while writing one still has the other whole. A
//! resumed run draws the plots of an uninterrupted one.

use crate::problem::Problem;
use crate::run_output::RunOutput;
use femvi::step::Checkpoint;
use serde::{Deserialize, Serialize};
use sha2::Digest;
use std::path::Path;

/// The checkpoint file's name in the output directory.
pub const FILE: &str = "checkpoint.json";

/// The format of [`RunCheckpoint`]; changed whenever its meaning changes.
pub(crate) const FORMAT: u32 = 1;

/// When checkpoints are written (besides the first node and a stop by a signal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Policy {
    /// Every this many steps.
    pub every_steps: Option<usize>,
    /// Every this many seconds of run time.
    pub every_seconds: Option<f64>,
}

impl Default for Policy {
    /// Every 10 seconds.
    fn default() -> Self {
        Policy {
            every_steps: None,
            every_seconds: Some(10.0),
        }
    }
}

/// The energy observer's state in a checkpoint: its largest relative error so far (as bits).
/// The rest of its state is recomputed on resume ([`crate::record::Recorders`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct EnergySaved {
    /// Bits of the largest relative energy error over the nodes up to the checkpoint.
    pub max_rel_bits: u64,
    /// The energy tracker's whole state after the checkpoint's node
    /// ([`femvi::solution::EnergyTracker::words`]: reference energy, warm-start velocity,
    /// energy balance), so that a resumed run's energies are the uninterrupted run's bit for
    /// bit for any Lagrangian.
    #[serde(default)]
    pub tracker: Vec<u64>,
}

/// What checkpoint.json holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunCheckpoint {
    /// Format of this file.
    pub format: u32,
    /// The femvi version that wrote it.
    pub femvi_version: String,
    /// SHA-256 (hex) of the problem's text as run (after `--set` overrides).
    pub problem_sha256: String,
    /// The output formats of the run, e.g. "csv,npy".
    pub outputs: String,
    /// Steps driven up to the checkpoint's node.
    pub steps: usize,
    /// Length of trajectory.csv with the rows up to the node (csv output only).
    pub csv_bytes: Option<u64>,
    /// Rows of trajectory.npy up to the node (npy output only).
    pub npy_rows: Option<u64>,
    /// The energy observer's state.
    pub energy: EnergySaved,
    /// Runs with forces: the energy balance's state ([`crate::record::WorkBalance::words`]).
    #[serde(default)]
    pub balance: Option<[u64; 3]>,
    /// Problems with `[[events]]`: events.csv's length, the count and the locator's state.
    #[serde(default)]
    pub events: Option<crate::record::EventsSaved>,
    /// Adaptive runs: the recorder's state, the rows written and the last kept node.
    #[serde(default)]
    pub adaptive: Option<AdaptiveSaved>,
    /// Runs with plots: the side file holding their state.
    #[serde(default)]
    pub plots: Option<PlotsSaved>,
    /// The integrator's state.
    pub integrator: Checkpoint,
}

/// What a checkpoint keeps of an adaptive run beyond the integrator: the recorder's state,
/// the rows written (the index of the next output-time row) and the last kept node (t, q, p).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AdaptiveSaved {
    /// [`femvi::adaptive::Recorder::state`].
    pub recorder: Vec<u64>,
    /// Rows written.
    pub rows: usize,
    /// The last kept node: its step, t, q and p (bits).
    pub last: Option<(usize, Vec<u64>)>,
    /// The warm start of the inverse Legendre transform at the output-time rows (bits), so
    /// that a resumed run's energies there are the uninterrupted run's for any Lagrangian.
    #[serde(default)]
    pub v: Vec<u64>,
}

/// The side file of a checkpoint of a run with plots: which of the two files, how many
/// words it holds and their SHA-256 (hex).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlotsSaved {
    /// 0 or 1: the file `checkpoint-plots-<slot>.bin`.
    pub slot: u8,
    /// The words of the plots' state (little-endian u64 in the file).
    pub words: u64,
    /// SHA-256 of the file (hex).
    pub sha256: String,
}

/// The name of side file `slot` (0 or 1).
fn plots_file(slot: u8) -> String {
    format!("checkpoint-plots-{}.bin", slot & 1)
}

/// Writes the plots' state `sections` (each a list of words) into side file `slot` of `dir`,
/// atomically; what checkpoint.json then records of it.
///
/// # Errors
/// The write failed.
///
/// # Example
///
/// ```
/// use femvi_cli::resume::{load_plots, save_plots};
/// let dir = std::env::temp_dir().join(format!("femvi-doc-plots-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let sections = vec![vec![1, 2, 3], vec![], vec![u64::MAX]];
/// let saved = save_plots(&dir, 1, &sections)?;
/// assert_eq!((saved.slot, saved.words), (1, 7));
/// assert_eq!(load_plots(&dir, &saved).unwrap(), sections);
/// // A side file changed since: refused.
/// std::fs::write(dir.join("checkpoint-plots-1.bin"), [0u8; 56])?;
/// assert!(load_plots(&dir, &saved).is_err());
/// std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), std::io::Error>(())
/// ```
pub fn save_plots(dir: &Path, slot: u8, sections: &[Vec<u64>]) -> std::io::Result<PlotsSaved> {
    let words: Vec<u64> = sections
        .iter()
        .flat_map(|s| std::iter::once(s.len() as u64).chain(s.iter().copied()))
        .collect();
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    write_atomic(&dir.join(plots_file(slot)), &bytes)?;
    Ok(PlotsSaved {
        slot: slot & 1,
        words: words.len() as u64,
        sha256: hex(&sha2::Sha256::digest(&bytes)),
    })
}

/// Reads the side file `saved` names back into its sections.
///
/// # Errors
/// A message for the user: the file is missing, damaged or not the checkpoint's.
pub fn load_plots(dir: &Path, saved: &PlotsSaved) -> Result<Vec<Vec<u64>>, String> {
    let path = dir.join(plots_file(saved.slot));
    let bytes = crate::bounded::read(&path, crate::bounded::Limits::BINARY)
        .map_err(|e| format!("cannot resume the plots from {}: {e}", path.display()))?;
    if bytes.len() as u64 != saved.words.saturating_mul(8) || hex(&sha2::Sha256::digest(&bytes)) != saved.sha256 {
        return Err(format!(
            "cannot resume the plots: {} is not the one checkpoint.json was written with (run again without --resume)",
            path.display()
        ));
    }
    let words: Vec<u64> = bytes
        .chunks_exact(8)
        .map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default()))
        .collect();
    let mut sections = vec![];
    let mut rest = &words[..];
    while let Some((len, tail)) = rest.split_first() {
        let len = usize::try_from(*len).unwrap_or(usize::MAX);
        if len > tail.len() {
            return Err(format!("cannot resume the plots: {} is damaged", path.display()));
        }
        let (section, tail) = tail.split_at(len);
        sections.push(section.to_vec());
        rest = tail;
    }
    Ok(sections)
}

fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Removes a checkpoint left in `dir` by an earlier run, with its plot files.
///
/// # Errors
/// A file exists and cannot be removed.
pub fn remove_checkpoint(dir: &Path) -> std::io::Result<()> {
    for name in [FILE.to_string(), plots_file(0), plots_file(1)] {
        match std::fs::remove_file(dir.join(name)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
            _ => {}
        }
    }
    Ok(())
}

/// The SHA-256 (hex) of a problem's text: the tag of its checkpoints.
///
/// # Example
///
/// ```
/// let text = "[system]\nmodel = \"harmonic\"\n[initial]\nq = [1.0]\np = [0.0]\n[time]\nstep = 0.1\nend = 1.0\n";
/// let p = femvi_cli::problem::load_text("x.toml".as_ref(), text, &[]).unwrap();
/// assert_eq!(femvi_cli::resume::problem_hash(&p).len(), 64);
/// ```
pub fn problem_hash(problem: &Problem) -> String {
    hex(&sha2::Sha256::digest(problem.source.as_bytes()))
}

/// The output formats of a run as checkpoints name them.
pub fn outputs_label(out: &RunOutput) -> String {
    let mut v = vec![];
    if out.csv {
        v.push("csv");
    }
    if out.npy {
        v.push("npy");
    }
    v.join(",")
}

/// Writes `bytes` to `path` atomically: into a temporary file in the same directory, then
/// renamed over `path` (so a reader, or a run killed meanwhile, sees the old or the new file,
/// never a part).
///
/// # Errors
/// The write or the rename failed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("file");
    let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

/// Writes `dir`/checkpoint.json atomically.
///
/// # Errors
/// The write failed.
pub fn save(dir: &Path, checkpoint: &RunCheckpoint) -> std::io::Result<()> {
    let text = serde_json::to_vec(checkpoint).map_err(std::io::Error::other)?;
    write_atomic(&dir.join(FILE), &text)
}

/// Reads `dir`/checkpoint.json and checks that it belongs to `problem` run with outputs `out`.
///
/// # Errors
/// A message for the user: no checkpoint, a damaged one, or one of another run.
pub fn load(dir: &Path, problem: &Problem, out: &RunOutput) -> Result<RunCheckpoint, String> {
    let path = dir.join(FILE);
    let json = crate::bounded::Limits::JSON;
    let text = crate::bounded::read(&path, json).map_err(|e| {
        let summary = crate::bounded::read_to_string(&dir.join("summary.json"), json).unwrap_or_default();
        if summary.contains("\"status\": \"done\"") {
            format!("nothing to resume: the run in {} has finished", dir.display())
        } else {
            format!(
                "cannot resume from {}: {e} (is it the output directory of a stopped femvi run?)",
                path.display()
            )
        }
    })?;
    let cp: RunCheckpoint =
        serde_json::from_slice(&text).map_err(|e| format!("cannot resume: {} is damaged: {e}", path.display()))?;
    let version = env!("CARGO_PKG_VERSION");
    if cp.format != FORMAT || cp.femvi_version != version {
        return Err(format!(
            "cannot resume: {} was written by femvi {} (format {}), this is femvi {version} (format {FORMAT}); run the problem again without --resume",
            path.display(),
            cp.femvi_version,
            cp.format
        ));
    }
    if cp.problem_sha256 != problem_hash(problem) {
        return Err(format!(
            "cannot resume: {} belongs to another problem (its text, after --set overrides, differs from the one it was written for)",
            path.display()
        ));
    }
    let label = outputs_label(out);
    if cp.outputs != label {
        return Err(format!(
            "cannot resume: the stopped run wrote --format {}, this one asks for --format {label}",
            cp.outputs
        ));
    }
    match (cp.plots.is_some(), out.plots) {
        (false, true) => Err(
            "cannot resume with plots: the stopped run drew none (resume without --plot, and draw them from trajectory.csv)"
                .into(),
        ),
        (true, false) => Err(
            "cannot resume without plots: the stopped run draws them (add --plot, or set [output] plots = true)"
                .into(),
        ),
        _ => Ok(cp),
    }
}

/// Whether `dir` holds a run of `problem` that was killed before its first checkpoint: no
/// checkpoint, and a summary.json of the same problem text with `"status": "running"`. Such a
/// run is resumed by starting it again.
pub fn killed_before_first_checkpoint(dir: &Path, problem: &Problem) -> bool {
    if dir.join(FILE).exists() {
        return false;
    }
    let Ok(text) = crate::bounded::read_to_string(&dir.join("summary.json"), crate::bounded::Limits::JSON) else {
        return false;
    };
    let Ok(summary) = serde_json::from_str::<serde_json::Value>(&text) else {
        return false;
    };
    summary["status"] == "running" && summary["problem"] == problem.source.as_str()
}
