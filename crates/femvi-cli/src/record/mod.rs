//! What `femvi run` records as it goes: one [`Observer`] per output, driven by
//! [`femvi::step::drive`]. The relative energy error ([`EnergyError`]) is computed once per
//! node and shared with the trajectory writers ([`CsvRows`], [`NpyRows`], [`PlotData`]), so
//! [`Recorders`] attaches them in the order they must run; [`Progress`] draws the bar.

mod csv_rows;
mod energy;
mod npy_rows;
mod plot_data;
mod progress;

pub use csv_rows::CsvRows;
pub use energy::{EnergyError, NodeEnergy};
pub use npy_rows::{write_table, NpyRows};
pub use plot_data::PlotData;
pub use progress::Progress;

use crate::problem::Problem;
use crate::run::RunOutput;
use femvi::step::Observer;
use femvi::Lagrangian;
use std::cell::RefCell;
use std::path::Path;
use std::rc::Rc;

/// The column names of a trajectory: step, t, the coordinates, their momenta, the energy and,
/// in energy mode, the discrete energy.
pub fn columns(problem: &Problem) -> Vec<String> {
    let mut header = vec!["step".to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    if problem.energy.is_some() {
        header.push("discrete_energy".into());
    }
    header
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

/// The observers of one run.
pub struct Recorders<'a> {
    progress: Progress,
    energy: EnergyError,
    csv: Option<CsvRows>,
    npy: Option<NpyRows<'a>>,
    plots: Option<PlotData<'a>>,
    failure: WriteFailure,
}

impl<'a> Recorders<'a> {
    /// The outputs `out` asks for, into `dir` (which exists): trajectory.csv is created and
    /// its header written here. `dim` is the system's number of coordinates.
    pub fn attach(problem: &'a Problem, dir: &'a Path, out: RunOutput, dim: usize) -> std::io::Result<Self> {
        let failure = WriteFailure::default();
        let autonomous = crate::with_system!(&problem.system, l => femvi::Lagrangian::is_autonomous(l));
        let energy = EnergyError::new(dim, &problem.start, autonomous);
        let shared = energy.current();
        let columns = columns(problem);
        let csv = if out.csv {
            Some(CsvRows::create(
                dir,
                &columns,
                problem.every,
                shared.clone(),
                failure.clone(),
            )?)
        } else {
            None
        };
        let npy = out
            .npy
            .then(|| NpyRows::new(dir, columns, problem.every, shared.clone(), failure.clone()));
        let plots = out
            .plots
            .then(|| PlotData::new(problem, dir, out.plot_format, shared, failure.clone()));
        Ok(Recorders {
            progress: Progress::new(out.progress, problem),
            energy,
            csv,
            npy,
            plots,
            failure,
        })
    }

    /// The observers in the order [`femvi::step::drive`] must call them: the progress bar,
    /// the energy error, then the outputs that read it.
    pub fn observers<L: Lagrangian>(&mut self) -> Vec<&mut dyn Observer<L>> {
        let mut list: Vec<&mut dyn Observer<L>> = vec![&mut self.progress, &mut self.energy];
        if let Some(csv) = self.csv.as_mut() {
            list.push(csv);
        }
        if let Some(npy) = self.npy.as_mut() {
            list.push(npy);
        }
        if let Some(plots) = self.plots.as_mut() {
            list.push(plots);
        }
        list
    }

    /// The largest relative energy error over the nodes recorded.
    pub fn max_rel_energy_error(&self) -> f64 {
        self.energy.max_rel()
    }

    /// Time-dependent L: the largest relative error of the energy balance H − H0 = −∫∂L/∂t.
    pub fn max_rel_energy_balance_error(&self) -> Option<f64> {
        self.energy.max_rel_balance()
    }

    /// An output file that could not be completed at the end of the run.
    pub fn write_failure(&self) -> Option<std::io::Error> {
        self.failure.take()
    }
}
