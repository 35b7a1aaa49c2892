//! The observer behind [`super::solve`]: keeps every `every`-th node with its velocity and
//! energy, answers `saveat` times from each new element's polynomial as the run passes them,
//! runs the event detector, appends to the dense output, and stops at the step limit. With
//! energy tracking on, the node's velocity and energy come from the tracker (`energy.rs`),
//! which sees every node, so nothing is computed twice; with [`super::EnergyNodes::Kept`] it
//! sees the kept nodes (and the one a stopped run ends on), each inversion started from the
//! velocity of the element ending there.

use super::dense::{momentum, DenseOutput, ElementEval};
use super::energy::EnergyTracker;
use super::energy_nodes::EnergyNodes;
use super::events::{Detector, EventRecord, Span};
use super::{Saved, SolveOptions};
use crate::error::{energy_failed_at, finite_energy, invalid, Error, Result};
use crate::fem::LagrangeBasis;
use crate::lagrangian::{hamiltonian, Lagrangian, PointDerivatives};
use crate::step::{Integrator, Observer, Start};

/// The node before the current one: (k, t, q, p, v).
struct PrevNode {
    k: usize,
    t: f64,
    q: Vec<f64>,
    p: Vec<f64>,
    v: Vec<f64>,
}

pub(crate) struct Recorder {
    n: usize,
    every: usize,
    pub(crate) step: Vec<usize>,
    pub(crate) t: Vec<f64>,
    pub(crate) q: Vec<f64>,
    pub(crate) p: Vec<f64>,
    pub(crate) v: Vec<f64>,
    pub(crate) energy: Vec<f64>,
    saveat: Vec<f64>,
    next_save: usize,
    pub(crate) saved: Saved,
    detector: Option<Detector>,
    pub(crate) events: Vec<EventRecord>,
    pub(crate) dense: Option<DenseOutput>,
    dense_wanted: bool,
    max_steps: Option<usize>,
    basis: LagrangeBasis,
    eval: ElementEval,
    work: PointDerivatives,
    prev: Option<PrevNode>,
    last_kept: Option<usize>,
    node_v: Vec<f64>,
    node_h: f64,
    pub(crate) tracker: Option<EnergyTracker>,
    /// The tracker sees only the kept nodes ([`EnergyNodes::Kept`]).
    kept_only: bool,
    /// The node the tracker saw last.
    tracked: Option<usize>,
}

impl Recorder {
    /// Errors: `saveat` times not increasing or not finite.
    pub(crate) fn new(
        options: &SolveOptions,
        basis: &LagrangeBasis,
        n: usize,
        (start, autonomous, nodes): (&Start, bool, EnergyNodes),
    ) -> Result<Self> {
        let saveat = options.saveat.clone();
        if saveat.iter().any(|t| !t.is_finite()) || saveat.windows(2).any(|w| w[0] >= w[1]) {
            return Err(invalid("saveat", "times must be finite and strictly increasing"));
        }
        let events = options.events.clone();
        let detector = (!events.is_empty()).then(|| Detector::new(events, basis, n));
        Ok(Self {
            n,
            every: options.every,
            step: vec![],
            t: vec![],
            q: vec![],
            p: vec![],
            v: vec![],
            energy: vec![],
            saveat,
            next_save: 0,
            saved: Saved::default(),
            detector,
            events: vec![],
            dense: None,
            dense_wanted: options.dense,
            max_steps: options.max_steps,
            basis: basis.clone(),
            eval: ElementEval::new(basis.len()),
            work: PointDerivatives::new(n),
            prev: None,
            last_kept: None,
            node_v: vec![0.0; n],
            node_h: f64::NAN,
            tracker: options
                .track_energy
                .then(|| EnergyTracker::new(n, start, autonomous).with_nodes(nodes, basis)),
            kept_only: nodes == EnergyNodes::Kept,
            tracked: None,
        })
    }

    fn keep(&mut self, k: usize, t: f64, q: &[f64], p: &[f64]) {
        if self.last_kept == Some(k) {
            return;
        }
        self.last_kept = Some(k);
        self.step.push(k);
        self.t.push(t);
        self.q.extend_from_slice(q);
        self.p.extend_from_slice(p);
        self.v.extend_from_slice(&self.node_v);
        self.energy.push(self.node_h);
    }

    /// The node before node `k`, whose energy failed the run, ends the arrays if it is not
    /// kept yet (a run that keeps every `every`-th node, or only its first and last, would
    /// otherwise end on an older node than it reached): its energy and velocity as the node
    /// had them, or computed now if the node was not tracked; left out if that energy is not
    /// finite.
    fn keep_previous<L: Lagrangian>(&mut self, lag: &L, k: usize) {
        let Some(prev) = self.prev.take() else { return };
        if prev.k + 1 == k && self.last_kept != Some(prev.k) {
            let tracked = self.tracker.is_some() && self.tracked == Some(prev.k);
            let h = if tracked {
                Ok(self.node_h)
            } else {
                let mut v = vec![0.0; self.n];
                let h = hamiltonian(lag, prev.t, &prev.q, &prev.p, &mut v, &mut self.work);
                self.node_v = v;
                h
            };
            if let Ok(h) = h.and_then(|h| finite_energy(h, prev.k, prev.t)) {
                self.node_h = h;
                if tracked {
                    self.node_v.copy_from_slice(&prev.v);
                }
                self.keep(prev.k, prev.t, &prev.q, &prev.p);
            }
        }
        self.prev = Some(prev);
    }

    fn save(&mut self, t: f64, q: &[f64], v: &[f64], p: &[f64]) {
        self.saved.t.push(t);
        self.saved.q.extend_from_slice(q);
        self.saved.v.extend_from_slice(v);
        self.saved.p.extend_from_slice(p);
    }

    /// The saveat times in (t_k, t_{k+1}] answered from the element; those equal to the
    /// node time from the node.
    fn save_element<L: Lagrangian>(&mut self, lag: &L, sp: &Span<'_>, prev: &PrevNode, node: (f64, &[f64], &[f64])) {
        // Nothing to answer in this element (the common case): no work, no allocation.
        if !matches!(self.saveat.get(self.next_save), Some(&ts) if ts <= node.0) {
            return;
        }
        let (mut q, mut v, mut p) = (vec![0.0; self.n], vec![0.0; self.n], vec![0.0; self.n]);
        while let Some(&ts) = self.saveat.get(self.next_save) {
            if ts > node.0 {
                break;
            }
            self.next_save += 1;
            if ts < prev.t {
                continue; // before the start
            }
            if ts == prev.t {
                let (pq, pv, pp) = (prev.q.clone(), prev.v.clone(), prev.p.clone());
                self.save(ts, &pq, &pv, &pp);
            } else if ts == node.0 {
                let nv = self.node_v.clone();
                self.save(ts, node.1, &nv, node.2);
            } else {
                self.eval
                    .eval(&self.basis, sp.t0, sp.h, sp.base, sp.incr, ts, &mut q, &mut v);
                momentum(lag, ts, &q, &v, &mut self.work, &mut p);
                self.save(ts, &q, &v, &p);
            }
        }
    }

    fn step_done<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) {
        let node = it.node();
        let Some(prev) = self.prev.take() else { return };
        let Some(el) = it.last_element() else {
            self.prev = Some(prev);
            return;
        };
        let sp = Span {
            step: prev.k,
            t0: el.t,
            h: el.h,
            base: el.base,
            incr: el.incr,
        };
        let lag = it.lagrangian();
        self.save_element(lag, &sp, &prev, (node.t, node.q, node.p));
        if let Some(d) = self.detector.as_mut() {
            d.scan(lag, &self.basis, &sp, &mut self.events);
        }
        if let Some(dense) = self.dense.as_mut() {
            dense.push(
                el.t,
                el.h,
                (&prev.p, &prev.v),
                el.base,
                el.incr,
                (node.t, node.q, node.p, &self.node_v),
            );
        }
        self.prev = Some(prev);
    }
}

impl Recorder {
    /// The tracker's energy and velocity at the node `it` is at (kept nodes only: each
    /// inversion from the end velocity of the element ending there, `node_after`).
    fn track<L: Lagrangian>(&mut self, it: &Integrator<'_, L>) -> Result<()> {
        let Some(tracker) = self.tracker.as_mut() else {
            return Ok(());
        };
        let node = it.node();
        let h = tracker
            .node_after(it.lagrangian(), it.last_element(), node.t, node.q, node.p)?
            .h;
        self.node_h = finite_energy(h, node.k, node.t)?;
        self.node_v.copy_from_slice(tracker.velocity());
        self.tracked = Some(node.k);
        Ok(())
    }
}

impl<L: Lagrangian> Observer<L> for Recorder {
    fn node(&mut self, it: &Integrator<'_, L>, last: bool) -> Result<()> {
        let node = it.node();
        let keep = node.k == 0 || last || (self.every > 0 && node.k.is_multiple_of(self.every));
        // The velocity and energy at the node (a Newton solve for general Lagrangians) only
        // where they are used: kept nodes, the dense output, a saveat time on the node.
        let saved_here = self.saveat.get(self.next_save).is_some_and(|&ts| ts <= node.t);
        if self.tracker.is_some() && (keep || !self.kept_only) {
            self.track(it)?;
        } else if keep || self.dense_wanted || saved_here || self.prev.is_none() {
            let lag = it.lagrangian();
            let h = hamiltonian(lag, node.t, node.q, node.p, &mut self.node_v, &mut self.work)?;
            self.node_h = finite_energy(h, node.k, node.t)?;
        }
        if self.prev.is_none() {
            // Rotations follow their elements' paths between nodes.
            let rotations = it.rotations().map_or(&[][..], |r| r.offsets());
            self.eval.set_rotations(rotations);
            if let Some(d) = self.detector.as_mut() {
                d.eval.set_rotations(rotations);
            }
            if self.dense_wanted {
                let dense = DenseOutput::new(self.basis.clone(), node.t, node.q, node.p, &self.node_v);
                self.dense = Some(dense.with_rotations(rotations));
            }
            self.prev = Some(PrevNode {
                k: node.k,
                t: node.t,
                q: node.q.to_vec(),
                p: node.p.to_vec(),
                v: self.node_v.clone(),
            });
            if let Some(&ts) = self.saveat.first() {
                if ts == node.t {
                    let nv = self.node_v.clone();
                    self.save(ts, node.q, &nv, node.p);
                    self.next_save = 1;
                }
            }
        } else {
            self.step_done(it);
        }
        if keep {
            self.keep(node.k, node.t, node.q, node.p);
        }
        if let Some(prev) = self.prev.as_mut() {
            prev.k = node.k;
            prev.t = node.t;
            prev.q.copy_from_slice(node.q);
            prev.p.copy_from_slice(node.p);
            prev.v.copy_from_slice(&self.node_v);
        }
        Ok(())
    }

    fn finish(&mut self, it: &Integrator<'_, L>, error: Option<&Error>) -> Result<()> {
        // The node the run ended on is kept, whatever stopped it, if its energy is finite:
        // not the node whose energy failed the run, and a run that ended without an error
        // on a node whose energy cannot be had fails there (no node is left out silently).
        let node = it.node();
        if energy_failed_at(error, node.k) {
            self.keep_previous(it.lagrangian(), node.k);
            return Ok(());
        }
        if error.is_none() && self.kept_only && self.tracker.is_some() && self.tracked != Some(node.k) {
            // A run stopped between kept nodes (an event, the step limit): its last node is
            // kept, so it is tracked; an energy that cannot be computed there is the run's error.
            self.track(it)?;
            self.keep(node.k, node.t, node.q, node.p);
            return Ok(());
        }
        let mut v = vec![0.0; self.n];
        let h = hamiltonian(it.lagrangian(), node.t, node.q, node.p, &mut v, &mut self.work);
        match h.and_then(|h| finite_energy(h, node.k, node.t)) {
            Ok(h) => {
                self.node_v = v;
                self.node_h = h;
                self.keep(node.k, node.t, node.q, node.p);
                Ok(())
            }
            Err(e) if error.is_none() => Err(e),
            Err(_) => Ok(()),
        }
    }

    fn stop(&self) -> bool {
        let by_event = self.detector.as_ref().is_some_and(|d| d.stop);
        let by_limit = self
            .max_steps
            .is_some_and(|m| self.prev.as_ref().is_some_and(|p| p.k >= m));
        by_event || by_limit
    }
}
