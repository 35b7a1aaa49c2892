//! The integrator: a run's state (`RunState`, the last element), its grid and one step
//! solver (`solver.rs`), put together. [`Integrator::step`] asks the grid for the next step,
//! the solver for the element's increments, and commits them to the state; the energy mode
//! (`energy.rs`) searches the step instead of taking the grid's. Start-up is in `first.rs`,
//! tangent maps in `tangent.rs`.

use super::element_work::ElementBuffers;
use super::energy::EnergyState;
use super::explicit::block_radius;
use super::grid::TimeGrid;
use super::options::{SolverOptions, Start};
use super::solver::{choose, Kind, Solver, StepContext};
use super::state::{Increments, LastElement, Node, RunState};
use super::term::{StepTerm, TermAdvance, TermRun};
use crate::discrete::Element;
use crate::error::Result;
use crate::lagrangian::Lagrangian;

/// A Lagrangian or element the integrator borrows, or owns (`Integrator::owned`, so that it
/// can be returned from a function or moved to another thread).
pub(super) enum Held<'a, T> {
    Borrowed(&'a T),
    Owned(Box<T>),
}

impl<T> std::ops::Deref for Held<'_, T> {
    type Target = T;
    #[inline]
    fn deref(&self) -> &T {
        match self {
            Held::Borrowed(r) => r,
            Held::Owned(b) => b,
        }
    }
}

/// What every solver reads besides the state, borrowing only the fields it names (so that
/// the state and the solver can be borrowed mutably beside it).
macro_rules! context {
    ($s:expr) => {
        StepContext {
            lag: &*$s.lag,
            element: &*$s.element,
            opts: $s.opts,
        }
    };
}

/// Integrates the discrete Euler–Lagrange equations of an element over a time grid.
///
/// # Example
///
/// ```
/// use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
///
/// // The Kepler problem, degree 2 with 2-point Gauss, h = 0.01 over one period.
/// let kepler = models::kepler(1.0)?;
/// let element = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(2))?;
/// let grid = TimeGrid::uniform(0.0, 0.01, 2.0 * std::f64::consts::PI)?;
/// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
/// let mut it = Integrator::new(&kepler, &element, grid, start, SolverOptions::default())?;
/// while it.step()? {}
/// let end = it.node();
/// // Back where it started (circular orbit), to the method's order 4.
/// assert!((end.q[0] - 1.0).abs() < 1e-6 && end.q[1].abs() < 1e-6);
/// # Ok::<(), femvi::Error>(())
/// ```
pub struct Integrator<'a, L: Lagrangian> {
    pub(super) lag: Held<'a, L>,
    pub(super) element: Held<'a, Element>,
    pub(super) grid: TimeGrid,
    pub(super) opts: SolverOptions,
    pub(super) state: RunState,
    pub(super) last: LastElement,
    /// The solved element of the current step, before it is committed.
    pub(super) inc: Increments,
    pub(super) solver: Solver,
    /// Element derivatives for Newton, the first element, energies and tangent maps.
    pub(super) bufs: Option<ElementBuffers>,
    /// The node at t1 of a start from (q0, q1), returned by the first step.
    pub(super) pending: Option<(f64, Vec<f64>, Vec<f64>)>,
    pub(super) energy: Option<EnergyState>,
    /// A term that owns the solve of each step (forces, `term.rs`); None for a plain run.
    pub(super) term: Option<Box<dyn StepTerm + Send + 'a>>,
    /// The discrete work of the term accumulated from t0 (0 without a term).
    pub(super) work: f64,
    /// The mechanical tangent's tables and workspace, made at the first tangent map
    /// (`tangent_mechanical.rs`).
    pub(super) mech_tangent: Option<Box<super::tangent_mechanical::MechanicalTangent>>,
}

impl<'a, L: Lagrangian> Integrator<'a, L> {
    /// Sets up a run of `lag` discretised by `element` on `grid` from `start`.
    ///
    /// # Errors
    /// Wrong dimensions, invalid options, a degenerate element or Lagrangian, a method that
    /// does not fit the Lagrangian, or (for the start from (q0, q1)) a failed solve of the
    /// first element.
    pub fn new(lag: &'a L, element: &'a Element, grid: TimeGrid, start: Start, opts: SolverOptions) -> Result<Self> {
        Self::build(Held::Borrowed(lag), Held::Borrowed(element), grid, start, opts)
    }

    fn build(
        lag: Held<'a, L>,
        element: Held<'a, Element>,
        grid: TimeGrid,
        start: Start,
        opts: SolverOptions,
    ) -> Result<Self> {
        opts.validate()?;
        element.check_nondegenerate()?;
        let n = lag.dim();
        let s = element.degree();
        let solver = Solver::new(choose(opts.method, &*lag, &element)?, &element, n)?;
        let t0 = grid.t0();
        let mut me = Self {
            lag,
            element,
            opts,
            state: RunState::new(n, t0),
            last: LastElement::new(s, n, t0),
            inc: Increments::new(s, n),
            solver,
            bufs: None,
            pending: None,
            energy: None,
            term: None,
            work: 0.0,
            mech_tangent: None,
            grid,
        };
        me.start(start)?;
        Ok(me)
    }

    /// [`Integrator::new`] with `term` solving every step (`term.rs`): fixed or variable steps
    /// from (q0, v0) or (q0, p0), not the energy mode.
    ///
    /// # Errors
    /// As [`Integrator::new`].
    pub(crate) fn with_term(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start: Start,
        opts: SolverOptions,
        term: Box<dyn StepTerm + Send + 'a>,
    ) -> Result<Self> {
        let mut me = Self::build(Held::Borrowed(lag), Held::Borrowed(element), grid, start, opts)?;
        me.term = Some(term);
        Ok(me)
    }

    /// Advances one step. Returns `Ok(false)` at the end of the grid.
    ///
    /// # Errors
    /// [`crate::Error::Step`] with the step index, time and residual if the step equations
    /// cannot be solved; the integrator then stays at the last good node.
    pub fn step(&mut self) -> Result<bool> {
        if let Some((t1, q1, p1)) = self.pending.take() {
            self.state.q = q1;
            self.state.p = p1;
            self.state.t = t1;
            self.state.k = 1;
            self.state.steps += 1;
            return Ok(true);
        }
        if self.energy.is_some() {
            return self.step_energy();
        }
        if self.term.is_some() {
            return self.step_term();
        }
        if let Some(done) = self.fast_explicit(1, &mut every_node) {
            return done.map(|d| d > 0);
        }
        let Some((h, t_next)) = self.grid.next(self.state.k, self.state.t) else {
            return Ok(false);
        };
        self.solve_at(h)?;
        self.commit(h, t_next)?;
        Ok(true)
    }

    /// A step solved by the term: its increments are committed like the solvers', and its
    /// element's work is added to the run's.
    fn step_term(&mut self) -> Result<bool> {
        let Some((h, t_next)) = self.grid.next(self.state.k, self.state.t) else {
            return Ok(false);
        };
        self.solve_term(h, t_next)?;
        self.commit(h, t_next)?;
        Ok(true)
    }

    /// The term's solve of the step (h, t_next) (the grid's t_next: the constraints hold there).
    fn solve_term(&mut self, h: f64, t_next: f64) -> Result<()> {
        if let Some(term) = self.term.as_mut() {
            self.state.iterations += term.solve(&self.state, &mut self.last, (h, t_next), &mut self.inc)?;
        }
        Ok(())
    }

    /// Commits the step the term solved: its increments like the solvers', its element's
    /// work added to the run's, the momentum it sets.
    fn commit_term(&mut self, h: f64, t_next: f64) -> Result<()> {
        let Some(term) = self.term.as_mut() else {
            return Ok(());
        };
        term.accepted(self.state.n);
        let work = self.work + term.element_work();
        self.state.commit(&mut self.last, &mut self.inc, true, h, t_next)?;
        if let Some(p) = term.momentum() {
            // Set, not summed: the projection onto T*N of a constrained step (element by
            // element: a few numbers, not worth a call to memmove).
            self.state.p.iter_mut().zip(p).for_each(|(a, b)| *a = *b);
            self.state.comp_p.iter_mut().for_each(|c| *c = 0.0);
        }
        self.work = work;
        Ok(())
    }

    /// Solves the step equations from the current node with step h into `inc`, without
    /// moving the state.
    pub(super) fn solve_at(&mut self, h: f64) -> Result<()> {
        if self.term.is_some() {
            return self.solve_term(h, self.state.t + h);
        }
        let cx = context!(self);
        let iterations = self
            .solver
            .solve(&cx, &self.state, &mut self.last, &mut self.bufs, h, &mut self.inc)?;
        self.state.iterations += iterations;
        Ok(())
    }

    /// Moves the state to the node solved by [`Self::solve_at`] with step h.
    pub(super) fn commit(&mut self, h: f64, t_next: f64) -> Result<()> {
        if self.term.is_some() {
            return self.commit_term(h, t_next);
        }
        let swap = self.solver.kind() != Kind::Explicit;
        // The solver learns of the step only once the node is known to be finite: a step
        // that fails leaves it as it was at the last good node (nothing carried from the
        // failed solve but what `rejected` discards).
        if let Err(e) = self.state.commit(&mut self.last, &mut self.inc, swap, h, t_next) {
            self.solver.rejected();
            return Err(e);
        }
        let cx = context!(self);
        self.solver.accepted(&cx, self.state.n);
        Ok(())
    }

    /// Advances up to `max_steps` steps and returns how many were taken (0 at the end of the
    /// grid). Results are identical to calling [`Integrator::step`] that many times; for
    /// explicit stepping of small systems the steps run in a tight loop over fixed-size arrays,
    /// and for long chains with M = I and a local force ([`Lagrangian::force_radius`], n ≥ 2¹⁵)
    /// in blocks of space and time that stay in cache (the same bits).
    ///
    /// # Errors
    /// As [`Integrator::step`]; the steps before the failure are kept.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
    /// // Störmer–Verlet (degree 1, trapezoid): 1000 steps in chunks of 300.
    /// let kepler = models::kepler(1.0)?;
    /// let verlet = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid)?;
    /// let grid = TimeGrid::uniform(0.0, 0.001, 1.0)?;
    /// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
    /// let mut it = Integrator::new(&kepler, &verlet, grid, start, SolverOptions::default())?;
    /// let mut taken = vec![];
    /// loop {
    ///     match it.advance(300)? {
    ///         0 => break,
    ///         k => taken.push(k),
    ///     }
    /// }
    /// assert_eq!(taken, [300, 300, 300, 100]);
    /// assert!((it.node().q[0] - 1f64.cos()).abs() < 1e-6);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn advance(&mut self, max_steps: usize) -> Result<usize> {
        self.advance_with(max_steps, &mut every_node, true)
    }

    /// As [`Integrator::advance`], showing every node reached to `at_node`, which may stop
    /// the run after it by returning false. The explicit fast path calls it from inside its
    /// loop (the node's momentum materialised as [`Integrator::node`] would give it), so that
    /// per-node work such as an energy check runs without leaving the loop; the nodes and
    /// their bits are those of [`Integrator::step`].
    ///
    /// # Errors
    /// As [`Integrator::step`]; the steps before the failure are kept (and were shown).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
    /// let kepler = models::kepler(1.0)?;
    /// let verlet = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid)?;
    /// let start = Start::Momentum { q: vec![1.0, 0.0], p: vec![0.0, 1.0] };
    /// let grid = TimeGrid::uniform(0.0, 0.001, 1.0)?;
    /// let mut it = Integrator::new(&kepler, &verlet, grid, start, SolverOptions::default())?;
    /// // The largest |q| over the nodes; stop once t passes 0.5.
    /// let mut largest = 0.0f64;
    /// let done = it.advance_observed(usize::MAX, |node| {
    ///     largest = largest.max(node.q[0].hypot(node.q[1]));
    ///     node.t < 0.5
    /// })?;
    /// assert_eq!(done, it.node().k);
    /// assert!(it.node().t >= 0.5 && it.node().t < 0.502);
    /// assert!((largest - 1.0).abs() < 1e-5);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn advance_observed<F: FnMut(Node<'_>) -> bool>(&mut self, max_steps: usize, mut at_node: F) -> Result<usize> {
        self.advance_with(max_steps, &mut at_node, false)
    }

    /// [`Integrator::advance_observed`]; `unobserved`: the caller looks at no node, so the
    /// wide explicit loop may take a local force's steps in blocks of space and time.
    fn advance_with<F: FnMut(Node<'_>) -> bool>(
        &mut self,
        max_steps: usize,
        at_node: &mut F,
        unobserved: bool,
    ) -> Result<usize> {
        if let Some(done) = self.fast_explicit(max_steps, at_node) {
            return done;
        }
        if let Some(done) = self.wide_explicit(max_steps, at_node, unobserved) {
            return done;
        }
        if let Some(done) = self.term_loop(max_steps, at_node) {
            return done;
        }
        let mut done = 0;
        while done < max_steps && self.step()? {
            done += 1;
            if !at_node(self.node()) {
                break;
            }
        }
        Ok(done)
    }

    /// The explicit path with M = I for the other sizes, which fuses the commit of a step
    /// with the drift of the next (None if it does not apply). The same bits as `step`.
    fn wide_explicit<F: FnMut(Node<'_>) -> bool>(
        &mut self,
        max_steps: usize,
        at_node: &mut F,
        unobserved: bool,
    ) -> Option<Result<usize>> {
        let Solver::Explicit(ex) = &mut self.solver else {
            return None;
        };
        if self.pending.is_some()
            || self.energy.is_some()
            || self.term.is_some()
            || !self.lag.mass_matrix()?.is_identity()
        {
            return None;
        }
        let (lag, grid) = (&*self.lag, &self.grid);
        let radius = if unobserved {
            block_radius(lag, self.state.t, &self.state.q)
        } else {
            None
        };
        Some(ex.advance_wide(lag, grid, &mut self.state, &mut self.last, max_steps, at_node, radius))
    }

    /// The term's own loop ([`StepTerm::advance`]), where it has one (None otherwise). A step
    /// it could not take is taken again a step at a time, which reports its failure.
    fn term_loop<F: FnMut(Node<'_>) -> bool>(&mut self, max_steps: usize, at_node: &mut F) -> Option<Result<usize>> {
        if self.pending.is_some() || self.energy.is_some() {
            return None;
        }
        let term = self.term.as_mut()?;
        let run = TermRun {
            grid: &self.grid,
            state: &mut self.state,
            last: &mut self.last,
        };
        let TermAdvance { mut done, failed } = term.advance(run, max_steps, at_node)?;
        if failed && done < max_steps {
            match self.step_term() {
                Err(e) => return Some(Err(e)),
                Ok(true) => {
                    done += 1;
                    at_node(self.node());
                }
                Ok(false) => {}
            }
        }
        Some(Ok(done))
    }

    /// The fixed-size explicit path for the sizes it is compiled for (None otherwise).
    fn fast_explicit<F: FnMut(Node<'_>) -> bool>(
        &mut self,
        max_steps: usize,
        at_node: &mut F,
    ) -> Option<Result<usize>> {
        let Solver::Explicit(ex) = &mut self.solver else {
            return None;
        };
        if self.pending.is_some() || self.energy.is_some() || self.term.is_some() {
            return None;
        }
        let mass = self.lag.mass_matrix()?;
        let (lag, grid, state, last) = (&*self.lag, &self.grid, &mut self.state, &mut self.last);
        // The dimension and whether M = I fixed at compile time: the loop has no branch on the
        // mass and its arrays live in registers.
        macro_rules! fast {
            ($N:literal, $I:literal) => {
                ex.advance::<L, F, $N, $I>(lag, mass, grid, state, last, max_steps, at_node)
            };
        }
        Some(match (state.n, mass.is_identity()) {
            (1, true) => fast!(1, true),
            (1, false) => fast!(1, false),
            (2, true) => fast!(2, true),
            (2, false) => fast!(2, false),
            (3, true) => fast!(3, true),
            (3, false) => fast!(3, false),
            (4, true) => fast!(4, true),
            (4, false) => fast!(4, false),
            (6, true) => fast!(6, true),
            (6, false) => fast!(6, false),
            _ => return None,
        })
    }
}

impl<L: Lagrangian> Integrator<'static, L> {
    /// As [`Integrator::new`], owning the Lagrangian and the element: the integrator has no
    /// borrowed lifetime, so it can be returned from a function or moved to another thread
    /// (it is `Send` when L is `Send + Sync`).
    ///
    /// # Errors
    /// As [`Integrator::new`].
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, Integrator, Mechanical, SolverOptions, Start, TimeGrid};
    ///
    /// fn pendulum_run() -> femvi::Result<Integrator<'static, Mechanical<models::PendulumPotential>>> {
    ///     let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
    ///     Integrator::owned(models::pendulum(1.0, 1.0, 1.0)?, Element::with_order(4)?, TimeGrid::uniform(0.0, 0.1, 5.0)?, start, SolverOptions::default())
    /// }
    ///
    /// let mut it = pendulum_run()?;
    /// let q = std::thread::spawn(move || -> femvi::Result<f64> {
    ///     while it.step()? {}
    ///     Ok(it.node().q[0])
    /// })
    /// .join()
    /// .expect("no panic")?;
    /// assert!(q.abs() < 1.0);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn owned(lag: L, element: Element, grid: TimeGrid, start: Start, opts: SolverOptions) -> Result<Self> {
        Self::build(
            Held::Owned(Box::new(lag)),
            Held::Owned(Box::new(element)),
            grid,
            start,
            opts,
        )
    }
}

/// The callback of runs that look at no node: one function, so that `step` and `advance`
/// share one instance of the generic fast loops.
fn every_node(_: Node<'_>) -> bool {
    true
}
