//! [`Recorders`]: the observers of one `femvi run` as one observer. At each node it runs the
//! progress bar, the energy error and then the outputs that read it, in that order; it stops
//! the run at the first node whose state or energy is not finite (with the energy at the kept
//! nodes only, `energy_nodes`: the first non-finite state, or kept node's energy, the run then
//! ending on the node before), before any output writes it
//! (issue 16: no non-finite value is ever written); it flushes the rows to disk at least every
//! second ([`Pacer`]); it writes checkpoints ([`crate::resume`]) at the first node, on the
//! [`Policy`](crate::resume::Policy) and when a stop signal ends the run; and it resumes the
//! outputs of a stopped run from a checkpoint.

use super::plot_data::{load_plot_state, save_plot_state};
use super::{
    columns, CsvRows, EnergyError, EventRows, NodeEnergy, NpyRows, Pacer, PlotData, Progress, WorkBalance, WriteFailure,
};
use crate::problem::Problem;
use crate::resume::{self, EnergySaved, Policy, RunCheckpoint};
use crate::run_output::RunOutput;
use crate::signals::{self, Signal};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::cell::Cell;
use std::path::Path;
use std::rc::Rc;
use std::time::Instant;

mod per_node;
use per_node::Good;

/// Checkpoints of a run: when, and what they are tagged with.
#[derive(Debug, Clone)]
pub struct Checkpointing {
    /// When (besides the first node and a stop).
    pub policy: Policy,
    /// The problem's hash ([`resume::problem_hash`]).
    pub tag: String,
    /// The output formats ([`resume::outputs_label`]).
    pub outputs: String,
}

/// The observers of one run.
pub struct Recorders<'a> {
    progress: Progress,
    energy: EnergyError,
    /// The energy of the node being recorded (`energy.current()`).
    current: Rc<Cell<NodeEnergy>>,
    csv: Option<CsvRows>,
    npy: Option<NpyRows>,
    plots: Option<PlotData<'a>>,
    failure: WriteFailure,
    dir: &'a Path,
    pacer: Pacer,
    checkpoints: Option<Checkpointing>,
    last_checkpoint: Instant,
    /// Resumed runs: the steps and the largest energy error up to the checkpoint.
    resumed: Option<(usize, f64)>,
    /// The energy tracker was restored from a checkpoint: the first node shown (the
    /// checkpoint's) is already in it.
    restored: bool,
    /// Nodes recorded by this process (on resume, the checkpoint's node first); in a run
    /// driven in chunks ([`super::drive_in_chunks`]), the chunks' last nodes.
    nodes: usize,
    /// The index k of the first node shown (steps are counted from it).
    first_k: Option<usize>,
    /// The trajectory keeps every `every`-th node: the chunks end there.
    every: usize,
    /// Whether the run may be driven in chunks (not in energy mode, whose discrete energy is
    /// checked at every node).
    chunked: bool,
    good: Good,
    signal: Option<Signal>,
    /// Runs with forces: the energy balance H − H0 = W over every node.
    balance: Option<WorkBalance>,
    /// Problems with `[[events]]`: the events located on each element, into events.csv.
    events: Option<EventRows>,
    /// Runs with plots: the side file the next checkpoint writes its plots' state into (the
    /// other one holds the last checkpoint's).
    plot_slot: u8,
}

impl<'a> Recorders<'a> {
    /// The outputs `out` asks for, into `dir` (which exists), without checkpoints:
    /// trajectory.csv is created and its header written here. `dim` is the system's number of
    /// coordinates.
    ///
    /// # Errors
    /// An output file could not be created.
    pub fn attach(problem: &'a Problem, dir: &'a Path, out: RunOutput, dim: usize) -> std::io::Result<Self> {
        Self::start(problem, dir, out, dim, None)
    }

    /// As [`Recorders::attach`], with checkpoints.
    ///
    /// # Errors
    /// An output file could not be created.
    pub fn start(
        problem: &'a Problem,
        dir: &'a Path,
        out: RunOutput,
        dim: usize,
        checkpoints: Option<Checkpointing>,
    ) -> std::io::Result<Self> {
        let failure = WriteFailure::default();
        let autonomous = crate::with_system!(&problem.system, l => femvi::Lagrangian::is_autonomous(l));
        let energy = EnergyError::new(dim, &problem.start, autonomous).with_nodes(
            energy_nodes(problem),
            &problem.element.basis,
            problem.every,
        );
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
        let npy = if out.npy {
            Some(NpyRows::create(
                dir,
                &columns,
                problem.every,
                shared.clone(),
                failure.clone(),
            )?)
        } else {
            None
        };
        let plots = out
            .plots
            .then(|| PlotData::new(problem, dir, out.plot_format, shared, failure.clone()));
        Ok(Recorders {
            progress: Progress::new(out.progress, problem),
            current: energy.current(),
            energy,
            csv,
            npy,
            plots,
            failure,
            dir,
            pacer: Pacer::default(),
            checkpoints,
            last_checkpoint: Instant::now(),
            resumed: None,
            restored: false,
            nodes: 0,
            first_k: None,
            every: problem.every.max(1),
            chunked: chunked(problem),
            good: Good::new(0, f64::NAN),
            signal: None,
            balance: problem.terms.force.is_some().then(WorkBalance::default),
            events: if problem.events.is_empty() {
                None
            } else {
                Some(EventRows::create(problem, dir, dim, out.plots)?)
            },
            plot_slot: 0,
        })
    }

    /// The outputs of the stopped run in `dir`, cut back to checkpoint `cp` (checked by
    /// [`resume::load`]) to continue it. `fresh` is the run's integrator at its start node,
    /// before it is restored from `cp` (the energy observer takes its reference energy there).
    ///
    /// # Errors
    /// An output file is missing or was changed since the checkpoint (a message for the user),
    /// or the energy of the start node could not be computed.
    pub fn resume<L: Lagrangian>(
        problem: &'a Problem,
        dir: &'a Path,
        out: RunOutput,
        fresh: &Integrator<'_, L>,
        cp: &RunCheckpoint,
        checkpoints: Checkpointing,
    ) -> Result<Self, String> {
        let failure = WriteFailure::default();
        // The plots' side file is read and checked before any output is cut back, so that a
        // refusal leaves the stopped run's files as they were.
        let plot_sections = match (&cp.plots, out.plots) {
            (Some(saved), true) => Some(resume::load_plots(dir, saved)?),
            _ => None,
        };
        let mut energy = resumed_energy(problem, fresh)?;
        // The tracker as it was after the checkpoint's node, which the resumed run shows
        // again first: that node's energy is not recomputed (`restored`).
        if !cp.energy.tracker.is_empty() {
            energy
                .restore(&cp.energy.tracker)
                .map_err(|e| format!("checkpoint's energy state: {e}"))?;
        }
        let shared = energy.current();
        let columns = columns(problem);
        let (k, every) = (cp.integrator.step, problem.every);
        let csv = match (out.csv, cp.csv_bytes) {
            (true, Some(b)) => Some(CsvRows::resume(dir, b, k, every, shared.clone(), failure.clone())),
            _ => None,
        }
        .transpose()
        .map_err(|e| format!("cannot resume trajectory.csv: {e}"))?;
        let npy = match (out.npy, cp.npy_rows) {
            (true, Some(r)) => Some(NpyRows::resume(
                dir,
                &columns,
                r,
                k,
                every,
                shared.clone(),
                failure.clone(),
            )),
            _ => None,
        }
        .transpose()
        .map_err(|e| format!("cannot resume trajectory.npy: {e}"))?;
        let mut events = match (&cp.events, problem.events.is_empty()) {
            (_, true) => None,
            (Some(saved), false) => Some(
                EventRows::resume(problem, dir, fresh.lagrangian().dim(), saved)
                    .map_err(|e| format!("cannot resume events.csv: {e}"))?,
            ),
            (None, false) => return Err("cannot resume: the checkpoint has no events.csv state".into()),
        };
        let plots = match plot_sections {
            Some(sections) => {
                let trace = load_plot_state(sections, events.as_mut())?;
                let f = out.plot_format;
                Some(PlotData::resume(
                    problem,
                    dir,
                    f,
                    shared.clone(),
                    failure.clone(),
                    &trace,
                )?)
            }
            None => None,
        };
        Ok(Recorders {
            progress: Progress::new(out.progress, problem),
            current: energy.current(),
            energy,
            csv,
            npy,
            plots,
            failure,
            dir,
            pacer: Pacer::default(),
            checkpoints: Some(checkpoints),
            last_checkpoint: Instant::now(),
            resumed: Some((cp.steps, f64::from_bits(cp.energy.max_rel_bits))),
            restored: !cp.energy.tracker.is_empty(),
            nodes: 0,
            first_k: None,
            every: problem.every.max(1),
            chunked: chunked(problem),
            good: Good::new(cp.steps, cp.integrator.t),
            signal: None,
            balance: problem
                .terms
                .force
                .is_some()
                .then(|| cp.balance.map(WorkBalance::from_words).unwrap_or_default()),
            events,
            plot_slot: cp.plots.as_ref().map_or(0, |p| 1 - (p.slot & 1)),
        })
    }

    /// The observers for [`femvi::step::drive()`] or [`femvi::solution::solve_with`]: this one.
    pub fn observers<L: Lagrangian>(&mut self) -> Vec<&mut dyn Observer<L>> {
        vec![self]
    }

    /// The largest relative energy error over the nodes recorded.
    pub fn max_rel_energy_error(&self) -> f64 {
        let now = self.energy.max_rel();
        self.resumed.map_or(now, |(_, before)| before.max(now))
    }

    /// The nodes [`Recorders::max_rel_energy_error`] is over.
    pub fn energy_nodes(&self) -> femvi::solution::EnergyNodes {
        self.energy.nodes()
    }

    /// Time-dependent L: the largest relative error of the energy balance H − H0 = −∫∂L/∂t.
    pub fn max_rel_energy_balance_error(&self) -> Option<f64> {
        self.energy.max_rel_balance()
    }

    /// Runs with forces: the energy balance over the nodes recorded.
    pub fn work_balance(&self) -> Option<WorkBalance> {
        self.balance
    }

    /// An output file that could not be completed at the end of the run.
    pub fn write_failure(&self) -> Option<std::io::Error> {
        self.failure.take()
    }

    /// The signal that stopped the run, if one did.
    pub fn stopped_by(&self) -> Option<Signal> {
        self.signal
    }

    /// The last node with a finite state and energy, and the steps up to it (resumed runs:
    /// counted from the start of the first run).
    pub fn last_good(&self) -> (usize, f64, &[f64], &[f64]) {
        (self.good.steps, self.good.t, &self.good.q, &self.good.p)
    }

    /// Steps up to node `k`, counted from the start of the first run.
    #[inline]
    fn steps_at(&self, k: usize) -> usize {
        self.resumed.map_or(0, |(s, _)| s) + k.saturating_sub(self.first_k.unwrap_or(k))
    }

    /// Whether the run may be driven in chunks (not in energy mode: its nodes go through
    /// [`Observer::node`], which also checks the discrete energy).
    pub(super) fn chunked(&self) -> bool {
        self.chunked
    }

    /// How many steps the next chunk of a run at node `k` may take, at most `cap`: up to the
    /// next node the trajectory keeps and the next checkpoint due by step count.
    pub(super) fn chunk(&self, k: usize, cap: usize) -> usize {
        let mut n = cap.min(self.every - k % self.every);
        if let Some(e) = self.checkpoints.as_ref().and_then(|c| c.policy.every_steps) {
            if e > 0 {
                n = n.min(e - self.steps_at(k) % e);
            }
        }
        n.max(1)
    }

    /// What the node ending a chunk needs after [`Self::each_node`]: the progress bar, the
    /// outputs, flushes and checkpoints (`last`: the grid's final node).
    pub(super) fn boundary<L: Lagrangian>(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        self.nodes += 1;
        self.check_kept_energy(it, last)?;
        self.energy.publish();
        let node = it.node();
        self.progress.show(self.steps_at(node.k), node.t);
        if let Some(csv) = self.csv.as_mut() {
            csv.node(it, last)?;
        }
        if let Some(npy) = self.npy.as_mut() {
            npy.node(it, last)?;
        }
        if let Some(plots) = self.plots.as_mut() {
            plots.node(it, last)?;
        }
        self.pace(it, last)
    }

    /// Puts the buffered rows on disk.
    fn flush(&mut self) -> femvi::Result<()> {
        let csv = self.csv.as_mut().map_or(Ok(()), CsvRows::flush);
        let npy = self.npy.as_mut().map_or(Ok(()), NpyRows::flush);
        let events = self.events.as_mut().map_or(Ok(()), EventRows::flush);
        csv.and(npy).and(events).map_err(|e| self.failure.record(e))
    }

    /// The events of a problem with `[[events]]`.
    pub fn events(&self) -> Option<&EventRows> {
        self.events.as_ref()
    }

    /// Flushes the outputs and writes checkpoint.json for the node `it` is at.
    fn checkpoint<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) -> femvi::Result<()> {
        let Some(c) = &self.checkpoints else {
            return Ok(());
        };
        let csv = self.csv.as_mut().map(CsvRows::sync).transpose();
        let npy = self.npy.as_mut().map(NpyRows::sync).transpose();
        let events = self.events.as_mut().map(EventRows::sync).transpose();
        let plots = (self.plots.as_ref())
            .map(|plots| save_plot_state(self.dir, self.plot_slot, plots.words(), self.events.as_ref()));
        let cp = csv.and_then(|csv_bytes| {
            Ok(RunCheckpoint {
                format: resume::FORMAT,
                femvi_version: env!("CARGO_PKG_VERSION").to_string(),
                problem_sha256: c.tag.clone(),
                outputs: c.outputs.clone(),
                steps: self.steps_at(it.node().k),
                csv_bytes,
                npy_rows: npy?,
                energy: EnergySaved {
                    max_rel_bits: self.max_rel_energy_error().to_bits(),
                    tracker: self.energy.words(),
                },
                balance: self.balance.map(|b| b.words()),
                events: events?,
                adaptive: None,
                plots: plots.transpose()?,
                integrator: it.checkpoint(&c.tag),
            })
        });
        let saved = cp.and_then(|cp| resume::save(self.dir, &cp));
        if saved.is_ok() && self.plots.is_some() {
            self.plot_slot = 1 - self.plot_slot;
        }
        self.last_checkpoint = Instant::now();
        saved.map_err(|e| self.failure.record(e))
    }

    /// Flushes and checkpoints when due, after node `it` (`last`: the grid's final node).
    fn pace<L: Lagrangian>(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        let steps = self.steps_at(it.node().k);
        let policy = self.checkpoints.as_ref().map(|c| &c.policy);
        let fresh = self.resumed.is_none();
        let (flush, checkpoint) = self.pacer.due(policy, (self.nodes, fresh), steps, self.last_checkpoint);
        if flush {
            self.flush()?;
        }
        if checkpoint && !last {
            self.checkpoint(it)?;
        }
        Ok(())
    }
}

/// The energy observer of a resumed run, in the state of the checkpoint's node as far as
/// [`EnergyError`] lets it be set: its reference energy from the start node of `fresh`, and
/// a warm-start velocity that the tracker's saved state then replaces. The largest error before the checkpoint is kept by [`Recorders`]. With a
/// `state()/restore()` pair on the energy observer this becomes a restore of a saved state.
fn resumed_energy<L: Lagrangian>(problem: &Problem, fresh: &Integrator<'_, L>) -> Result<EnergyError, String> {
    let lag = fresh.lagrangian();
    let mut energy = EnergyError::new(lag.dim(), &problem.start, lag.is_autonomous());
    Observer::<L>::node(&mut energy, fresh, false).map_err(|e| format!("energy at the start node: {e}"))?;
    Ok(energy.with_nodes(energy_nodes(problem), &problem.element.basis, problem.every))
}

/// The nodes the energy error covers (`[output] energy_nodes` for the problem's Lagrangian);
/// every node with forces, whose energy balance is over every node.
fn energy_nodes(problem: &Problem) -> femvi::solution::EnergyNodes {
    if problem.terms.force.is_some() {
        return femvi::solution::EnergyNodes::Every;
    }
    crate::with_system!(&problem.system, l => problem.energy_nodes.resolve(l))
}

/// Whether a run of `problem` may be driven in chunks: not in energy mode (its discrete
/// energy is checked at every node) nor with forces (the balance needs the work at every
/// node, which only [`Observer::node`] sees).
fn chunked(problem: &Problem) -> bool {
    problem.energy.is_none() && problem.terms.force.is_none() && problem.events.is_empty()
}

/// The discrete energy of energy mode at the node `it` is at (0 otherwise): fixed by the
/// first step, NaN (undefined) before; with forces the one measured on the element before the
/// node (E⁺ + W⁺), whose balance against the work is the summary's.
fn discrete_energy<L: Lagrangian>(it: &Integrator<'_, L>) -> f64 {
    match it.discrete_energy() {
        Some(e) if it.node().k > 0 => return e,
        _ => {}
    }
    match it.energy_stats() {
        Some(s) if it.node().k > 0 => s.energy,
        _ => 0.0,
    }
}

impl<L: Lagrangian> Observer<L> for Recorders<'_> {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> femvi::Result<()> {
        self.each_node(it.lagrangian(), it.node(), discrete_energy(it))?;
        if let Some(b) = self.balance.as_mut() {
            self.energy.publish();
            b.at(self.current.get().h, it.work());
        }
        if let Some(events) = self.events.as_mut() {
            events.node(it, last).map_err(|e| match e {
                femvi::Error::Observer(msg) => self.failure.record(std::io::Error::other(msg)),
                other => other,
            })?;
        }
        self.boundary(it, last)
    }

    fn finish(&mut self, it: &Integrator<'_, L>, error: Option<&femvi::Error>) -> femvi::Result<()> {
        let mut first = Ok(());
        if error.is_none() && !it.finished() {
            self.signal = signals::received();
            if self.signal.is_some() {
                first = self.checkpoint(it);
            }
        }
        let mut note = |r: femvi::Result<()>| {
            if first.is_ok() {
                first = r;
            }
        };
        self.progress.finish();
        // A run stopped between kept nodes: the outputs keep its last node, whose energy is
        // computed now (if it cannot be, that is the run's error and the row is not written).
        let failed = if error.is_none() && self.energy.kept_only() {
            let failed = self.check_kept_energy(it, true).err();
            self.energy.publish();
            failed
        } else {
            None
        };
        if let Some(e) = &failed {
            note(Err(e.clone()));
        }
        let error = error.or(failed.as_ref());
        note(self.energy.finish(it, error));
        if let Some(csv) = self.csv.as_mut() {
            note(csv.finish(it, error));
        }
        if let Some(npy) = self.npy.as_mut() {
            note(npy.finish(it, error));
        }
        if let Some(plots) = self.plots.as_mut() {
            note(plots.finish(it, error));
        }
        if let Some(events) = self.events.as_mut() {
            note(events.finish(it, error));
        }
        first
    }

    fn stop(&self) -> bool {
        signals::received().is_some() || self.events.as_ref().is_some_and(|e| e.stopper().is_some())
    }
}
