//! Checkpoints: everything the next step of a run depends on, so that a run restored from a
//! checkpoint continues **bit for bit** as the uninterrupted run would (as REBOUND's
//! Simulationarchive does). That is the node with its compensation terms, the counters, the
//! last element (the solvers' starting values come from it), the pending first node of a
//! (q0, q1) start, each solver's carried data (the explicit path's lazy momentum and its
//! force at the node; the fixed-point start's last stage forces and node force) and the
//! energy mode's carried energy. Tables and workspaces that are recomputed from the step
//! are not stored. Numbers are stored as their bit patterns, so NaN and −0.0 survive.
//!
//! A checkpoint names what it belongs to: femvi's version, the element, the dimension, the
//! solver, the grid, the options and a tag the caller adds (the CLI adds a hash of the
//! problem); restoring into anything else is refused.

use super::integrator::Integrator;
use super::solver::Solver;
use crate::error::{invalid, Result};
use crate::lagrangian::Lagrangian;
use serde::{Deserialize, Serialize};

/// The format of [`Checkpoint::words`]; changed whenever their order changes.
const FORMAT: u32 = 4;

/// A run's state at a node, ready to be written (serde) and restored with
/// [`Integrator::restore`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// Format of `words`.
    pub format: u32,
    /// The femvi version that wrote it.
    pub version: String,
    /// What the run is: element, dimension, solver, grid, options and the caller's tag.
    pub fingerprint: String,
    /// Node index, for the reader's information.
    pub step: usize,
    /// Time of the node, for the reader's information.
    pub t: f64,
    /// The state, as 64-bit words in a fixed order (f64 as bit patterns).
    pub words: Vec<u64>,
}

/// Writes the state words.
#[derive(Default)]
pub(crate) struct Words(pub(crate) Vec<u64>);

impl Words {
    pub(crate) fn f(&mut self, x: f64) {
        self.0.push(x.to_bits());
    }
    pub(crate) fn u(&mut self, x: usize) {
        self.0.push(x as u64);
    }
    pub(crate) fn b(&mut self, x: bool) {
        self.0.push(x as u64);
    }
    pub(crate) fn fs(&mut self, xs: &[f64]) {
        self.u(xs.len());
        self.0.extend(xs.iter().map(|x| x.to_bits()));
    }
}

/// Reads the state words back, checking lengths.
pub(crate) struct Reader<'w> {
    words: &'w [u64],
    at: usize,
}

impl Reader<'_> {
    fn next(&mut self) -> Result<u64> {
        let w = self.words.get(self.at).copied();
        self.at += 1;
        w.ok_or_else(|| invalid("checkpoint", "truncated state"))
    }
    pub(crate) fn f(&mut self) -> Result<f64> {
        self.next().map(f64::from_bits)
    }
    pub(crate) fn u(&mut self) -> Result<usize> {
        let w = self.next()?;
        usize::try_from(w).map_err(|_| invalid("checkpoint", "a count out of range"))
    }
    pub(crate) fn b(&mut self) -> Result<bool> {
        match self.next()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(invalid("checkpoint", "a flag that is neither 0 nor 1")),
        }
    }
    /// A slice of exactly `into.len()` numbers.
    pub(crate) fn fs(&mut self, into: &mut [f64]) -> Result<()> {
        if self.u()? != into.len() {
            return Err(invalid("checkpoint", "a vector of another length"));
        }
        for x in into.iter_mut() {
            *x = self.f()?;
        }
        Ok(())
    }
}

impl<L: Lagrangian> Integrator<'_, L> {
    /// What the run is, for checking a checkpoint against the integrator it is restored into.
    fn fingerprint(&self, tag: &str) -> String {
        format!(
            "n={} element={:?}/{:?}/{} solver={:?} grid={:?} options={:?} energy={:?}{} tag={tag}",
            self.state.n,
            self.element.basis.nodes,
            self.element.rule.kind,
            self.element.points(),
            self.solver.kind(),
            self.grid,
            self.opts,
            self.energy.as_ref().map(|e| e.options()),
            self.term
                .as_ref()
                .map_or(String::new(), |t| format!(" term={}", t.name())),
        )
    }

    /// The run's state at the current node. `tag` names the problem (a hash of the problem
    /// file, say): restoring checks it.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let (lag, element) = (models::pendulum(1.0, 1.0, 1.0)?, Element::with_order(6)?);
    /// let new = || {
    ///     let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
    ///     Integrator::new(&lag, &element, TimeGrid::uniform(0.0, 0.1, 10.0).unwrap(), start, SolverOptions::default())
    /// };
    /// let mut whole = new()?;
    /// while whole.step()? {}
    /// let mut first = new()?;
    /// first.advance(37)?;
    /// let saved = first.checkpoint("pendulum");
    /// let mut resumed = new()?;
    /// resumed.restore(&saved, "pendulum")?;
    /// while resumed.step()? {}
    /// assert_eq!(resumed.node().q[0].to_bits(), whole.node().q[0].to_bits());
    /// assert!(resumed.restore(&saved, "another problem").is_err());
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn checkpoint(&self, tag: &str) -> Checkpoint {
        let mut w = Words::default();
        self.state.save(&mut w);
        self.last.save(&mut w);
        match &self.pending {
            None => w.b(false),
            Some((t1, q1, p1)) => {
                w.b(true);
                w.f(*t1);
                w.fs(q1);
                w.fs(p1);
            }
        }
        match &self.solver {
            Solver::Explicit(e) => e.save_state(&mut w),
            Solver::FixedPoint(f) => f.save(&mut w),
            Solver::Gyroscopic(g) => g.save(&mut w),
            Solver::Newton(nw) => nw.save(&mut w),
        }
        if let Some(e) = &self.energy {
            e.save(&mut w);
        }
        if let Some(term) = &self.term {
            w.f(self.work);
            term.save(&mut w);
        }
        Checkpoint {
            format: FORMAT,
            version: env!("CARGO_PKG_VERSION").to_string(),
            fingerprint: self.fingerprint(tag),
            step: self.state.k,
            t: self.state.t,
            words: w.0,
        }
    }

    /// Continues from `checkpoint`: the integrator must have been set up exactly as the one
    /// that wrote it (same Lagrangian, element, grid, options and mode; its start is
    /// replaced), and `tag` must be the one given to [`Integrator::checkpoint`].
    ///
    /// # Errors
    /// A checkpoint of another femvi version or format, of another run (fingerprint), or
    /// damaged (wrong lengths, truncated); the integrator is then unchanged.
    pub fn restore(&mut self, checkpoint: &Checkpoint, tag: &str) -> Result<()> {
        let version = env!("CARGO_PKG_VERSION");
        if checkpoint.format != FORMAT || checkpoint.version != version {
            return Err(invalid(
                "checkpoint",
                format!(
                    "written by femvi {} (format {}), this is femvi {version} (format {FORMAT})",
                    checkpoint.version, checkpoint.format
                ),
            ));
        }
        let mine = self.fingerprint(tag);
        if checkpoint.fingerprint != mine {
            return Err(invalid(
                "checkpoint",
                format!(
                    "it belongs to another run:\n  checkpoint: {}\n  this run:   {mine}",
                    checkpoint.fingerprint
                ),
            ));
        }
        // Restore into copies, so that a damaged checkpoint leaves the integrator unchanged.
        let (mut state, mut last, mut solver, mut energy) = (
            self.state.clone(),
            self.last.clone(),
            self.solver.clone(),
            self.energy.clone(),
        );
        let mut r = Reader {
            words: &checkpoint.words,
            at: 0,
        };
        state.load(&mut r)?;
        last.load(&mut r)?;
        let pending = if r.b()? {
            let (t1, mut q1, mut p1) = (r.f()?, vec![0.0; state.n], vec![0.0; state.n]);
            r.fs(&mut q1)?;
            r.fs(&mut p1)?;
            Some((t1, q1, p1))
        } else {
            None
        };
        match &mut solver {
            Solver::Explicit(e) => e.load_state(&mut r)?,
            Solver::FixedPoint(f) => f.load(&mut r)?,
            Solver::Gyroscopic(g) => g.load(&mut r)?,
            Solver::Newton(nw) => nw.load(&mut r, state.n)?,
        }
        if let Some(e) = energy.as_mut() {
            e.load(&mut r)?;
        }
        let work = match &self.term {
            Some(_) => r.f()?,
            None => 0.0,
        };
        // The term's state is read last, into the term itself: the checkpoint was checked up to
        // here, and its last part is the term's own fixed-size state.
        if let Some(term) = self.term.as_mut() {
            term.load(&mut r, &last)?;
        }
        if r.at != checkpoint.words.len() {
            return Err(invalid("checkpoint", "more state than this run has"));
        }
        (self.state, self.last, self.solver, self.energy, self.pending) = (state, last, solver, energy, pending);
        self.work = work;
        Ok(())
    }
}
