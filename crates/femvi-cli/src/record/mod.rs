//! What `femvi run` records as it goes: one [`Observer`](femvi::step::Observer) per output,
//! driven in chunks of steps by [`drive_in_chunks`] (or node by node by
//! [`femvi::solution::solve_with`] for runs with events). The relative energy error ([`EnergyError`]) is computed
//! once per node and shared with the trajectory writers ([`CsvRows`], [`NpyRows`],
//! [`PlotData`]), so [`Recorders`] runs them in the order they must run, stops the run at the
//! first non-finite node, flushes the rows at least every second ([`Pacer`]) and writes the
//! checkpoints; [`Progress`] draws the bar.

mod balance;
mod chunks;
mod csv_rows;
mod energy;
mod event_rows;
mod npy_rows;
mod pacing;
mod plot_data;
mod plot_rotations;
mod plot_trace;
mod progress;
mod recorders;

pub use balance::WorkBalance;
pub use chunks::drive_in_chunks;
pub use csv_rows::CsvRows;
pub use energy::{EnergyError, NodeEnergy};
pub use event_rows::{EventRows, EventsSaved};
pub use npy_rows::{write_table, NpyRows};
pub use pacing::Pacer;
pub use plot_data::{load_plot_state, save_plot_state, PlotData};
pub use plot_trace::{max_nodes, PlotTrace, SectionPoints, TraceNode, MAX_SECTION_POINTS};
pub use progress::Progress;
pub use recorders::{Checkpointing, Recorders};

use crate::problem::Problem;
use std::cell::RefCell;
use std::fs::File;
use std::path::Path;
use std::rc::Rc;

/// The column names of a trajectory: step, t, the coordinates, their momenta, the energy,
/// with forces the discrete work, and in energy mode the discrete energy.
pub fn columns(problem: &Problem) -> Vec<String> {
    let mut header = vec!["step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    if problem.terms.force.is_some() {
        // The discrete work W of the forces: energy − energy₀ − work is the balance error.
        header.push("work".into());
    }
    if problem.energy.is_some() {
        header.push("discrete_energy".into());
    }
    if let Some((c, _)) = &problem.terms.constraints {
        // The multipliers of the exact flow at the node (−Gᵀλ the constraint force) and
        // max |g(q)|.
        header.extend((1..=femvi::constraints::Constraints::count(c)).map(|l| format!("lambda_{l}")));
        header.push("residual".into());
    }
    for x in rotation_names(problem) {
        // The body angular velocity and momentum of each rotation.
        header.extend((1..=3).map(|c| format!("{x}_w{c}")));
        header.extend((1..=3).map(|c| format!("p_{x}{c}")));
    }
    header
}

/// The names of the problem's rotations: the coordinate name of each block's first entry
/// (X11) without its index.
pub fn rotation_names(problem: &Problem) -> Vec<String> {
    let Some(r) = &problem.terms.rotations else {
        return Vec::new();
    };
    r.offsets()
        .iter()
        .map(|&o| {
            let first = problem.coordinates.get(o).map(String::as_str).unwrap_or("R11");
            first.strip_suffix("11").unwrap_or(first).to_string()
        })
        .collect()
}

/// Which nodes a trajectory output keeps: every `every`-th (node 0 among them) and the last,
/// each once.
#[derive(Debug, Clone, Copy)]
pub struct Thinning {
    every: usize,
    last_kept: usize,
}

impl Thinning {
    /// Keeps every `every`-th node (at least 1).
    pub fn new(every: usize) -> Self {
        Thinning {
            every,
            last_kept: usize::MAX,
        }
    }

    /// Keeps every `every`-th node after node `k`, which was kept already (a resumed run).
    ///
    /// # Example
    ///
    /// ```
    /// let mut t = femvi_cli::record::Thinning::after(2, 4);
    /// assert!(!t.keep(4, false) && !t.keep(5, false) && t.keep(6, false) && t.keep(7, true));
    /// ```
    pub fn after(every: usize, k: usize) -> Self {
        Thinning { every, last_kept: k }
    }

    /// The node kept last (`usize::MAX` before the first).
    pub fn last_kept(&self) -> usize {
        self.last_kept
    }

    /// Whether to keep node `k` (`last`: the final node of the grid).
    pub fn keep(&mut self, k: usize, last: bool) -> bool {
        if (last || k.is_multiple_of(self.every)) && self.last_kept != k {
            self.last_kept = k;
            true
        } else {
            false
        }
    }
}

/// The first output file that could not be completed at the end of a run, shared by the
/// writers: once one has failed the later ones write nothing, and the run ends as an I/O
/// failure (exit 2, no summary.json) rather than a numerical one.
#[derive(Debug, Clone, Default)]
pub struct WriteFailure(Rc<RefCell<Option<std::io::Error>>>);

impl WriteFailure {
    /// Whether a writer has failed.
    pub fn happened(&self) -> bool {
        self.0.borrow().is_some()
    }

    /// Keeps `e` (if it is the first) and returns it as an observer's error.
    pub fn record(&self, e: std::io::Error) -> femvi::Error {
        let msg = e.to_string();
        self.0.borrow_mut().get_or_insert(e);
        femvi::Error::Observer(msg)
    }

    /// The failure, if any.
    pub fn take(&self) -> Option<std::io::Error> {
        self.0.borrow_mut().take()
    }
}

/// Opens an output file of a stopped run for writing, cut back to its first `len` bytes.
///
/// # Errors
/// The file is missing, cannot be written, or is shorter than `len` (changed since the
/// checkpoint that gave `len`).
pub(crate) fn reopen_at(path: &Path, len: u64) -> std::io::Result<File> {
    let file = std::fs::OpenOptions::new().write(true).open(path)?;
    let have = file.metadata()?.len();
    if have < len {
        return Err(std::io::Error::other(format!(
            "{} has {have} bytes, fewer than the {len} its checkpoint recorded: it was changed; run again without --resume",
            path.display()
        )));
    }
    file.set_len(len)?;
    Ok(file)
}
