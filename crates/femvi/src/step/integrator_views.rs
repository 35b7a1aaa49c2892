//! What an [`Integrator`] shows of itself without stepping: the node, its energy and last
//! element, the grid and Lagrangian, the term's work, constraints and rotations, and which
//! solver takes its steps (for the ensemble lanes, `crate::ensemble`).

use super::grid::TimeGrid;
use super::integrator::Integrator;
use super::options::SolverOptions;
use super::solver::Solver;
use super::state::{ElementNodes, Node};
use crate::discrete::Element;
use crate::error::Result;
use crate::lagrangian::Lagrangian;

impl<L: Lagrangian> Integrator<'_, L> {
    /// The discrete work of the run's term (the forces of [`crate::forces`]) from t0 to the
    /// current node: Σ_k W_k, each element's h Σ_i b_i F·q̇_h(c_i) (and −h Σ_i b_i ∂L/∂t for a
    /// time-dependent L, so that H_k − H_0 − W_k is the balance error). 0 without a term.
    pub fn work(&self) -> f64 {
        self.work
    }

    /// The multipliers and residuals of a constrained run
    /// ([`Integrator::with_constraints`]) at the current node; None for a run without
    /// constraints.
    pub fn node_constraints(&self) -> Option<crate::constraints::NodeConstraints> {
        let (t, q) = (self.state.t, &self.state.q);
        self.term.as_ref().and_then(|term| term.constraints(t, q))
    }

    /// The term's body states of the rotations at (t, q, p) (`crate::rotation`).
    pub(crate) fn term_rotation_states(&self, t: f64, q: &[f64], p: &[f64]) -> Option<Vec<crate::rotation::BodyState>> {
        self.term.as_ref().and_then(|term| term.rotation_states(t, q, p))
    }

    /// The largest symplecticity defect on the manifold of the steps so far, for a
    /// constrained run set up to measure it (`femvi check`).
    pub(crate) fn term_discrete_energy(&self) -> Option<super::term::DiscreteEnergy> {
        self.term.as_ref().and_then(|term| term.discrete_energy())
    }

    pub(crate) fn term_defect(&self) -> Option<f64> {
        self.term.as_ref().and_then(|term| term.defect())
    }

    /// The rotation blocks of a run with rotations ([`Integrator::with_rotations`]); None
    /// otherwise.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::rotation::{embedded_velocity, Rotations};
    /// use femvi::{models::RigidBody, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let body = RigidBody::free([1.0, 2.0, 3.0])?;
    /// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
    /// let (element, grid) = (Element::with_order(2)?, TimeGrid::uniform(0.0, 0.1, 1.0)?);
    /// let it = Integrator::with_rotations(&body, &element, grid, start, SolverOptions::default(), Rotations::new(9, &[0])?)?;
    /// assert_eq!(it.rotations().map(|r| r.offsets().to_vec()), Some(vec![0]));
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn rotations(&self) -> Option<&crate::rotation::Rotations> {
        self.term.as_ref().and_then(|term| term.rotations())
    }

    /// Whether the run has a term that does work (forces, with or without constraints):
    /// [`Integrator::work`] is then its discrete work.
    pub fn has_work(&self) -> bool {
        self.term.as_ref().is_some_and(|t| t.works())
    }

    /// Whether a term (forces or constraints) solves the steps.
    pub fn has_term(&self) -> bool {
        self.term.is_some()
    }

    /// The current node.
    pub fn node(&self) -> Node<'_> {
        self.state.node()
    }

    /// The energy H = p·v − L at the current node (v from the inverse Legendre transform).
    ///
    /// # Errors
    /// A Legendre transform that cannot be inverted there.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let lag = models::harmonic(1.0, 1.0)?;
    /// let element = Element::with_order(4)?;
    /// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
    /// let mut it = Integrator::new(&lag, &element, TimeGrid::uniform(0.0, 0.1, 100.0)?, start, SolverOptions::default())?;
    /// let e0 = it.energy()?;
    /// while it.step()? {}
    /// // A quadratic energy, kept by Gauss elements to round-off.
    /// assert!((it.energy()? - e0).abs() < 1e-13 && (e0 - 0.5).abs() < 1e-15);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn energy(&self) -> Result<f64> {
        let n = self.state.n;
        let mut v = self.state.v0.clone();
        let mut work = crate::lagrangian::PointDerivatives::new(n);
        crate::lagrangian::hamiltonian(
            &*self.lag,
            self.state.t,
            &self.state.q,
            &self.state.p,
            &mut v,
            &mut work,
        )
    }

    /// The element solved by the last step, if any.
    pub fn last_element(&self) -> Option<ElementNodes<'_>> {
        self.last.view()
    }

    /// The grid.
    pub fn grid(&self) -> &TimeGrid {
        &self.grid
    }

    /// The Lagrangian.
    pub fn lagrangian(&self) -> &L {
        &self.lag
    }

    /// Mean solver iterations per step so far (0 for explicit steps).
    pub fn mean_iterations(&self) -> f64 {
        if self.state.steps == 0 {
            0.0
        } else {
            self.state.iterations as f64 / self.state.steps as f64
        }
    }

    /// Whether the run has reached the end of its grid.
    pub fn finished(&self) -> bool {
        if self.energy.is_some() {
            return self.pending.is_none() && self.state.t >= self.grid.end();
        }
        self.pending.is_none() && self.grid.next(self.state.k, self.state.t).is_none()
    }

    /// Whether the run's steps are plain Störmer–Verlet steps (the explicit solver with no
    /// term, no energy mode and no pending first element): what ensembles take in lanes
    /// ([`crate::ensemble`]).
    pub(crate) fn plain_explicit(&self) -> bool {
        matches!(self.solver, Solver::Explicit(_))
            && self.pending.is_none()
            && self.energy.is_none()
            && self.term.is_none()
    }

    /// Whether the run's steps are plain fixed-point steps (`fixed_point_step.rs`, with no
    /// term, no energy mode and no pending first element): what ensembles take in lanes for
    /// elements of degree 2 and more ([`crate::ensemble`]).
    pub(crate) fn plain_fixed_point(&self) -> bool {
        matches!(self.solver, Solver::FixedPoint(_))
            && self.pending.is_none()
            && self.energy.is_none()
            && self.term.is_none()
    }

    /// The run's element.
    pub(crate) fn element(&self) -> &Element {
        &self.element
    }

    /// The run's solver options.
    pub(crate) fn options(&self) -> &SolverOptions {
        &self.opts
    }
}
