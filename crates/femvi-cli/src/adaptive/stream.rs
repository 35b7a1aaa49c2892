//! The observer that streams an adaptive run (issue 33): the library's adaptive
//! [`Recorder`] keeps the physical clock, the kept nodes, the states at the output times and
//! the events; after each node [`Writer`] takes what it recorded and writes it. The rows go to
//! trajectory.csv and trajectory.npy (`CsvRows`, `NpyRows`: the table's format, written as the
//! run goes) and the events to events.csv. The writer flushes at least every second and
//! writes checkpoint.json at the first node, by the `--checkpoint-every-*` policy and when a
//! signal stops the run. A checkpoint holds:
//! - the integrator's checkpoint (L_g's steps);
//! - the recorder's state (clock, next output time, events);
//! - the outputs' lengths, the row count and the last kept node.
//!
//! So `--resume` continues to the same bytes. Memory stays bounded: the plots keep their
//! nodes and Poincaré points in bounded records (`record::PlotTrace`, `record::SectionPoints`),
//! whose state a checkpoint of a run with plots keeps in its side file.

use super::AdaptiveTime;
use crate::problem::Problem;
use crate::record::{
    load_plot_state, save_plot_state, Checkpointing, CsvRows, EventRows, NodeEnergy, NpyRows, Pacer, PlotTrace,
    Progress, TraceNode, WriteFailure,
};
use crate::resume::{self, AdaptiveSaved, EnergySaved, RunCheckpoint};
use crate::signals::{self, Signal};
use femvi::adaptive::{AdaptiveRows, Monitor, Recorder, TimeTransformed};
use femvi::step::Observer;
use femvi::{Integrator, Lagrangian};
use std::cell::Cell;
use std::path::Path;
use std::rc::Rc;
use std::time::Instant;

/// The last kept node: (step, t, q, p).
type LastNode = (usize, f64, Vec<f64>, Vec<f64>);

/// Writes an adaptive run as it goes (the module documentation).
pub struct Writer<'a> {
    pub(super) recorder: Recorder<'a>,
    csv: Option<CsvRows>,
    npy: Option<NpyRows>,
    pub(super) events: Option<EventRows>,
    uniform: bool,
    ds: f64,
    e0: f64,
    n: usize,
    rows: usize,
    pub(super) max_rel: f64,
    pub(super) last: Option<LastNode>,
    /// The kept nodes for the plots (None without plots).
    pub(super) kept: Option<PlotTrace>,
    /// Runs with plots: the side file the next checkpoint writes into.
    plot_slot: u8,
    checkpoints: Option<Checkpointing>,
    dir: &'a Path,
    pacer: Pacer,
    last_checkpoint: Instant,
    nodes: usize,
    resumed: bool,
    progress: Progress,
    failure: WriteFailure,
    pub(super) signal: Option<Signal>,
    /// Warm start of the inverse Legendre transform at the output-time rows, and its
    /// workspace.
    v: Vec<f64>,
    work: femvi::lagrangian::PointDerivatives,
    /// The rows taken from the recorder, and one row's values (reused, no allocation per node).
    taken: AdaptiveRows,
    values: Vec<f64>,
}

/// How a [`Writer`] starts: the outputs asked for, the energy level and the checkpoints.
pub(super) struct Start<'a> {
    pub(super) problem: &'a Problem,
    pub(super) settings: &'a AdaptiveTime,
    pub(super) dir: &'a Path,
    pub(super) out: crate::run_output::RunOutput,
    pub(super) e0: f64,
    pub(super) checkpoints: Option<Checkpointing>,
}

/// The column names: step (or row), t, q, p, energy and, for nodes, s.
pub(super) fn columns(problem: &Problem, uniform: bool) -> Vec<String> {
    let mut header = vec![if uniform { "row" } else { "step" }.to_string(), "t".to_string()];
    header.extend(problem.coordinates.iter().cloned());
    header.extend(problem.coordinates.iter().map(|c| format!("p_{c}")));
    header.push("energy".into());
    if !uniform {
        header.push("s".into());
    }
    header
}

fn shared() -> Rc<Cell<NodeEnergy>> {
    Rc::new(Cell::new(NodeEnergy::default()))
}

impl<'a> Writer<'a> {
    /// A fresh run's writer: the output files created with their headers.
    pub(super) fn create(s: Start<'a>, recorder: Recorder<'a>) -> std::io::Result<Self> {
        let uniform = s.settings.output_step.is_some();
        let columns = columns(s.problem, uniform);
        let failure = WriteFailure::default();
        let csv = match s.out.csv {
            true => Some(CsvRows::create(s.dir, &columns, 1, shared(), failure.clone())?),
            false => None,
        };
        let npy = match s.out.npy {
            true => Some(NpyRows::create(s.dir, &columns, 1, shared(), failure.clone())?),
            false => None,
        };
        let events = match s.problem.events.is_empty() {
            true => None,
            false => Some(EventRows::create(s.problem, s.dir, columns_n(s.problem), s.out.plots)?),
        };
        Ok(Self::with(s, recorder, (csv, npy, events), failure, false))
    }

    /// A resumed run's writer: the outputs cut back to checkpoint `cp`, the recorder restored.
    ///
    /// # Errors
    /// A message for the user: an output changed since the checkpoint, or a checkpoint
    /// without an adaptive run's state.
    pub(super) fn resume(s: Start<'a>, mut recorder: Recorder<'a>, cp: &RunCheckpoint) -> Result<Self, String> {
        let Some(saved) = &cp.adaptive else {
            return Err("cannot resume: the checkpoint is not an adaptive run's".into());
        };
        // The plots' side file is read and checked before any output is cut back.
        let plot_sections = match (&cp.plots, s.out.plots) {
            (Some(p), true) => Some(resume::load_plots(s.dir, p)?),
            _ => None,
        };
        recorder
            .restore(&saved.recorder)
            .map_err(|e| format!("cannot resume: {e}"))?;
        let uniform = s.settings.output_step.is_some();
        let columns = columns(s.problem, uniform);
        let failure = WriteFailure::default();
        let k = cp.integrator.step;
        let csv = match (s.out.csv, cp.csv_bytes) {
            (true, Some(b)) => Some(CsvRows::resume(s.dir, b, k, 1, shared(), failure.clone())),
            _ => None,
        }
        .transpose()
        .map_err(|e| format!("cannot resume trajectory.csv: {e}"))?;
        let npy = match (s.out.npy, cp.npy_rows) {
            (true, Some(r)) => Some(NpyRows::resume(s.dir, &columns, r, k, 1, shared(), failure.clone())),
            _ => None,
        }
        .transpose()
        .map_err(|e| format!("cannot resume trajectory.npy: {e}"))?;
        let mut events = match (&cp.events, s.problem.events.is_empty()) {
            (_, true) => None,
            (Some(e), false) => Some(
                EventRows::resume(s.problem, s.dir, columns_n(s.problem), e)
                    .map_err(|e| format!("cannot resume events.csv: {e}"))?,
            ),
            (None, false) => return Err("cannot resume: the checkpoint has no events.csv state".into()),
        };
        let kept = match plot_sections {
            Some(sections) => {
                let trace = load_plot_state(sections, events.as_mut())?;
                Some(PlotTrace::from_words(columns_n(s.problem), &trace)?)
            }
            None => None,
        };
        let mut me = Self::with(s, recorder, (csv, npy, events), failure, true);
        me.kept = kept;
        me.plot_slot = cp.plots.as_ref().map_or(0, |p| 1 - (p.slot & 1));
        me.rows = saved.rows;
        if saved.v.len() == me.n {
            me.v = saved.v.iter().map(|b| f64::from_bits(*b)).collect();
        }
        me.max_rel = f64::from_bits(cp.energy.max_rel_bits);
        me.last = saved.last.as_ref().and_then(|(k, bits)| {
            let n = me.n;
            let x: Vec<f64> = bits.iter().map(|b| f64::from_bits(*b)).collect();
            (x.len() == 1 + 2 * n).then(|| (*k, x[0], x[1..=n].to_vec(), x[n + 1..].to_vec()))
        });
        Ok(me)
    }

    fn with(
        s: Start<'a>,
        recorder: Recorder<'a>,
        (csv, npy, events): (Option<CsvRows>, Option<NpyRows>, Option<EventRows>),
        failure: WriteFailure,
        resumed: bool,
    ) -> Self {
        let n = columns_n(s.problem);
        Writer {
            recorder,
            csv,
            npy,
            events,
            uniform: s.settings.output_step.is_some(),
            ds: s.settings.ds,
            e0: s.e0,
            n,
            rows: 0,
            max_rel: 0.0,
            last: None,
            kept: s.out.plots.then(|| PlotTrace::new(n)),
            plot_slot: 0,
            checkpoints: s.checkpoints,
            dir: s.dir,
            pacer: Pacer::default(),
            last_checkpoint: Instant::now(),
            nodes: 0,
            resumed,
            progress: Progress::new(s.out.progress, s.problem),
            failure,
            signal: None,
            v: vec![0.0; n],
            work: femvi::lagrangian::PointDerivatives::new(n),
            taken: AdaptiveRows::default(),
            values: Vec::with_capacity(2 * n + 3),
        }
    }

    /// The write failure that stopped the run, if any.
    pub(super) fn write_failure(&self) -> Option<std::io::Error> {
        self.failure.take()
    }

    /// Writes what the recorder recorded since the last call.
    fn write_taken<L: Lagrangian>(&mut self, lag: &L) -> std::io::Result<()> {
        self.recorder.take_into(&mut self.taken);
        let rows = std::mem::take(&mut self.taken);
        let written = self.write_rows(lag, &rows);
        self.taken = rows;
        written
    }

    fn write_rows<L: Lagrangian>(&mut self, lag: &L, rows: &AdaptiveRows) -> std::io::Result<()> {
        let n = self.n;
        let scale = if self.e0 == 0.0 { 1.0 } else { self.e0.abs() };
        let mut values = std::mem::take(&mut self.values);
        for (i, &t) in rows.t.iter().enumerate() {
            let (q, p) = (&rows.q[i * n..(i + 1) * n], &rows.p[i * n..(i + 1) * n]);
            let h = rows.energy[i];
            self.max_rel = self.max_rel.max((h - self.e0).abs() / scale);
            let k = (rows.s[i] / self.ds).round() as usize;
            if let Some(kept) = self.kept.as_mut() {
                let rel_energy = (h - self.e0).abs() / scale;
                kept.offer(
                    TraceNode {
                        t,
                        q,
                        p,
                        rel_energy,
                        residual: None,
                    },
                    false,
                );
            }
            match self.last.as_mut() {
                Some(last) => {
                    (last.0, last.1) = (k, t);
                    last.2.copy_from_slice(q);
                    last.3.copy_from_slice(p);
                }
                None => self.last = Some((k, t, q.to_vec(), p.to_vec())),
            }
            if !self.uniform {
                values.clear();
                values.push(t);
                values.extend_from_slice(q);
                values.extend_from_slice(p);
                values.extend([h, rows.s[i]]);
                self.write_row(k, &values)?;
            }
        }
        if self.uniform {
            for (i, &t) in rows.saved.t.iter().enumerate() {
                let (q, p) = (&rows.saved.q[i * n..(i + 1) * n], &rows.saved.p[i * n..(i + 1) * n]);
                let h = femvi::lagrangian::hamiltonian(lag, t, q, p, &mut self.v, &mut self.work).unwrap_or(f64::NAN);
                values.clear();
                values.push(t);
                values.extend_from_slice(q);
                values.extend_from_slice(p);
                values.push(h);
                self.write_row(self.rows, &values)?;
            }
        }
        self.values = values;
        if let (Some(events), false) = (self.events.as_mut(), rows.events.is_empty()) {
            events.write(rows.events.clone())?;
        }
        Ok(())
    }

    fn write_row(&mut self, index: usize, values: &[f64]) -> std::io::Result<()> {
        if let Some(csv) = self.csv.as_mut() {
            csv.values(index, values)?;
        }
        if let Some(npy) = self.npy.as_mut() {
            npy.values(index, values)?;
        }
        self.rows += 1;
        Ok(())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if let Some(csv) = self.csv.as_mut() {
            csv.flush()?;
        }
        if let Some(npy) = self.npy.as_mut() {
            npy.sync()?;
        }
        if let Some(events) = self.events.as_mut() {
            events.flush()?;
        }
        Ok(())
    }

    /// Flushes the outputs and writes checkpoint.json for the node `it` is at.
    fn checkpoint<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) -> std::io::Result<()> {
        let Some(c) = &self.checkpoints else {
            return Ok(());
        };
        let (tag, outputs) = (c.tag.clone(), c.outputs.clone());
        let csv_bytes = self.csv.as_mut().map(CsvRows::sync).transpose()?;
        let npy_rows = self.npy.as_mut().map(NpyRows::sync).transpose()?;
        let events = self.events.as_mut().map(EventRows::sync).transpose()?;
        let plots = match &self.kept {
            Some(trace) => Some(save_plot_state(
                self.dir,
                self.plot_slot,
                trace.words(),
                self.events.as_ref(),
            )?),
            None => None,
        };
        let last = self.last.as_ref().map(|(k, t, q, p)| {
            let bits = std::iter::once(t).chain(q).chain(p).map(|x| x.to_bits()).collect();
            (*k, bits)
        });
        let cp = RunCheckpoint {
            format: resume::FORMAT,
            femvi_version: env!("CARGO_PKG_VERSION").to_string(),
            problem_sha256: tag.clone(),
            outputs,
            steps: it.node().k,
            csv_bytes,
            npy_rows,
            energy: EnergySaved {
                max_rel_bits: self.max_rel.to_bits(),
                tracker: vec![],
            },
            balance: None,
            events,
            adaptive: Some(AdaptiveSaved {
                recorder: self.recorder.state(),
                rows: self.rows,
                last,
                v: self.v.iter().map(|x| x.to_bits()).collect(),
            }),
            plots,
            integrator: it.checkpoint(&tag),
        };
        resume::save(self.dir, &cp)?;
        if self.kept.is_some() {
            self.plot_slot = 1 - self.plot_slot;
        }
        self.last_checkpoint = Instant::now();
        Ok(())
    }

    /// Flushes and checkpoints when due.
    fn pace<L: Lagrangian>(&mut self, it: &Integrator<'_, L>, last: bool) -> std::io::Result<()> {
        let policy = self.checkpoints.as_ref().map(|c| &c.policy);
        let due = (self.nodes, !self.resumed);
        let (flush, checkpoint) = self.pacer.due(policy, due, it.node().k, self.last_checkpoint);
        if flush {
            self.flush()?;
        }
        if checkpoint && !last {
            self.checkpoint(it)?;
        }
        Ok(())
    }
}

/// The number of coordinates of a problem.
fn columns_n(problem: &Problem) -> usize {
    problem.coordinates.len()
}

impl<L: Lagrangian, G: Monitor> Observer<TimeTransformed<L, G>> for Writer<'_> {
    fn node(&mut self, it: &Integrator<'_, TimeTransformed<L, G>>, last: bool) -> femvi::Result<()> {
        self.recorder.node(it, last)?;
        self.nodes += 1;
        let written = self
            .write_taken(it.lagrangian().inner())
            .and_then(|()| self.pace(it, last));
        written.map_err(|e| self.failure.record(e))?;
        self.progress.show(it.node().k, self.recorder.time());
        Ok(())
    }

    fn finish(
        &mut self,
        it: &Integrator<'_, TimeTransformed<L, G>>,
        error: Option<&femvi::Error>,
    ) -> femvi::Result<()> {
        let kept = self.recorder.finish(it, error);
        if error.is_none() && !self.recorder.reached() {
            self.signal = signals::received();
        }
        let mut written = self.write_taken(it.lagrangian().inner());
        if self.signal.is_some() {
            written = written.and_then(|()| self.checkpoint(it));
        }
        written = written.and_then(|()| self.flush());
        self.progress.finish();
        if let Err(e) = written {
            return Err(self.failure.record(e));
        }
        kept
    }

    fn stop(&self) -> bool {
        Observer::<TimeTransformed<L, G>>::stop(&self.recorder) || signals::received().is_some()
    }
}
