//! The piecewise-polynomial trajectory q_h(t) of a run (the paper's (2.26)/(2.38b) interpolant),
//! recorded element by element, evaluated anywhere, and its L² distance to a reference — the
//! norm of the paper's error estimates (2.33) and (2.56).
//!
//! A trajectory can also be kept as a sliding window ([`PiecewiseTrajectory::push`],
//! [`PiecewiseTrajectory::forget_before`]) and an L² distance summed element by element as a
//! run goes ([`L2Sum`]), so that a convergence study needs memory independent of the length
//! of its runs. Rotation blocks ([`PiecewiseTrajectory::with_rotations`]) follow their
//! Lie-group elements' paths on SO(3) between nodes, as the dense output does.

use crate::error::{check_len, Result};
use crate::fem::{LagrangeBasis, QuadratureKind, QuadratureRule, MAX_POINTS};
use crate::lagrangian::Lagrangian;
use crate::step::{ElementNodes, Integrator};

/// The elements of a run (or of a window of it): start times, steps and nodal values.
#[derive(Debug, Clone, PartialEq)]
pub struct PiecewiseTrajectory {
    n: usize,
    basis: LagrangeBasis,
    t: Vec<f64>,
    h: Vec<f64>,
    /// Nodal values, (s+1)·n per element.
    nodes: Vec<f64>,
    /// Elements before this one have been forgotten (and are removed in batches).
    first: usize,
    /// The offsets of rotation blocks (nine entries each), which follow their elements'
    /// Lie-group paths ([`PiecewiseTrajectory::with_rotations`]).
    rotations: Vec<usize>,
}

impl PiecewiseTrajectory {
    /// An empty trajectory of dimension n with elements of `basis`, to be filled by
    /// [`PiecewiseTrajectory::push`].
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::diagnostics::PiecewiseTrajectory;
    /// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let (lag, el) = (models::harmonic(1.0, 1.0)?, Element::with_order(4)?);
    /// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
    /// let mut it = Integrator::new(&lag, &el, TimeGrid::uniform(0.0, 0.1, 10.0)?, start, SolverOptions::default())?;
    /// let mut window = PiecewiseTrajectory::new(&el.basis, 1);
    /// while it.step()? {
    ///     if let Some(e) = it.last_element() {
    ///         window.push(&e)?;
    ///     }
    ///     // Only what is needed from t - 1 on.
    ///     window.forget_before(it.node().t - 1.0);
    /// }
    /// assert!(window.len() <= 11);
    /// let mut q = [0.0];
    /// window.eval(9.95, &mut q);
    /// assert!((q[0] - 9.95f64.cos()).abs() < 1e-6);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn new(basis: &LagrangeBasis, n: usize) -> Self {
        Self {
            n,
            basis: basis.clone(),
            t: vec![],
            h: vec![],
            nodes: vec![],
            first: 0,
            rotations: vec![],
        }
    }

    /// The blocks of nine coordinates at `offsets` are rotations (the entries of R,
    /// row-major: [`crate::rotation::Rotations`]): between nodes they follow the element's
    /// path R_0 exp(Σ_j ℓ_j(τ) log(R_0ᵀ R_j)) on SO(3), as the dense output does, instead of
    /// the polynomial through their entries (which leaves SO(3) by O(h^{s+1})).
    ///
    /// ```
    /// use femvi::diagnostics::PiecewiseTrajectory;
    /// use femvi::rotation::{embedded_velocity, Rotations};
    /// use femvi::{models::RigidBody, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let body = RigidBody::free([1.0, 2.0, 3.0])?;
    /// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
    /// let element = Element::with_order(2)?;
    /// let grid = TimeGrid::uniform(0.0, 0.25, 1.0)?;
    /// let layout = Rotations::new(9, &[0])?;
    /// let mut it = Integrator::with_rotations(&body, &element, grid, start, SolverOptions::default(), layout)?;
    /// let path = PiecewiseTrajectory::record(&mut it, &element.basis, 9)?.with_rotations(&[0]);
    /// // Between nodes R stays on SO(3): RᵀR = 1 to round-off.
    /// let mut r = [0.0; 9];
    /// path.eval(0.6, &mut r);
    /// let rtr = |i: usize, j: usize| (0..3).map(|k| r[3 * k + i] * r[3 * k + j]).sum::<f64>();
    /// assert!((rtr(0, 0) - 1.0).abs() < 1e-14 && rtr(0, 1).abs() < 1e-14);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn with_rotations(mut self, offsets: &[usize]) -> Self {
        self.rotations = offsets.to_vec();
        self
    }

    /// Runs `it` to its end, recording every element; `basis` is its element's basis and n
    /// its dimension.
    ///
    /// # Errors
    /// [`crate::Error::Dimension`] if n is not the integrator's dimension or the basis not its
    /// element's; any step error.
    pub fn record<L: Lagrangian>(it: &mut Integrator<L>, basis: &LagrangeBasis, n: usize) -> Result<Self> {
        check_len("trajectory dimension", it.node().q.len(), n)?;
        let mut me = Self::new(basis, n);
        while it.step()? {
            if let Some(e) = it.last_element() {
                me.push(&e)?;
            }
        }
        Ok(me)
    }

    /// Appends an element (it must start at or after the last one).
    ///
    /// # Errors
    /// [`crate::Error::Dimension`] if its nodal values are not (basis nodes) × n.
    pub fn push(&mut self, e: &ElementNodes<'_>) -> Result<()> {
        let (n, w) = (self.n, self.basis.len());
        check_len("nodal values of the element (basis nodes x n)", e.incr.len(), w * n)?;
        check_len("element base point", e.base.len(), n)?;
        self.t.push(e.t);
        self.h.push(e.h);
        for j in 0..w {
            for c in 0..n {
                self.nodes.push(e.base[c] + e.incr[j * n + c]);
            }
        }
        Ok(())
    }

    /// Forgets the elements that [`PiecewiseTrajectory::eval`] no longer needs for times from
    /// `t` on: those followed by an element that starts at or before `t`. Values at t and later
    /// are unchanged.
    pub fn forget_before(&mut self, t: f64) {
        while self.first + 1 < self.t.len() && self.t[self.first + 1] <= t {
            self.first += 1;
        }
        // Remove in batches, so that forgetting costs O(1) per element on average.
        if self.first > 0 && self.first * 2 >= self.t.len() {
            let (k, w) = (self.first, self.basis.len() * self.n);
            self.t.drain(..k);
            self.h.drain(..k);
            self.nodes.drain(..k * w);
            self.first = 0;
        }
    }

    /// Number of elements kept.
    pub fn len(&self) -> usize {
        self.t.len() - self.first
    }

    /// Whether no element is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Start time of the last element kept, if any.
    pub fn last_start(&self) -> Option<f64> {
        (!self.is_empty()).then(|| self.t[self.t.len() - 1])
    }

    /// q_h(t) into `out` (t is clamped to the span kept); NaN if nothing is kept or `out`
    /// does not have the trajectory's dimension.
    pub fn eval(&self, t: f64, out: &mut [f64]) {
        if self.is_empty() || out.len() != self.n {
            out.iter_mut().for_each(|x| *x = f64::NAN);
            return;
        }
        let k = self.first + self.t[self.first..].partition_point(|&tk| tk <= t).saturating_sub(1);
        let w = self.basis.len();
        let nodes = &self.nodes[k * w * self.n..(k + 1) * w * self.n];
        element_value(&self.basis, (self.t[k], self.h[k]), nodes, &self.rotations, t, out);
    }

    /// (∫ |q_h(t) − q_ref(t)|² dt)^½ over the span kept, by a Gauss rule of `points` points
    /// per element (clamped to 1 ..= [`MAX_POINTS`]); `reference(t, out)` writes q_ref(t).
    pub fn l2_distance(&self, points: usize, mut reference: impl FnMut(f64, &mut [f64])) -> f64 {
        let mut sum = L2Sum::new(points, self.n).with_rotations(&self.rotations);
        let w = self.basis.len() * self.n;
        for k in self.first..self.t.len() {
            let nodes = &self.nodes[k * w..(k + 1) * w];
            sum.add(&self.basis, self.t[k], self.h[k], nodes, &mut reference);
        }
        sum.value()
    }
}

/// q_h(t) on one element starting at `t0` with step h and nodal values `nodes` ((s+1)·n),
/// the rotation blocks at `rotations` on their Lie-group paths (`rotation/dense.rs`).
fn element_value(
    basis: &LagrangeBasis,
    (t0, h): (f64, f64),
    nodes: &[f64],
    rotations: &[usize],
    t: f64,
    out: &mut [f64],
) {
    let n = out.len();
    let tau = ((t - t0) / h).clamp(0.0, 1.0);
    let w = basis.len();
    let mut l = vec![0.0; w];
    basis.values_in_place(tau, &mut l);
    for (c, o) in out.iter_mut().enumerate() {
        *o = (0..w).map(|j| l[j] * nodes[j * n + c]).sum();
    }
    for &o in rotations {
        crate::rotation::dense::path_block(&l, nodes, o, out);
    }
}

/// ∫ |q_h(t) − q_ref(t)|² dt summed element by element, by a Gauss rule on each: the L²
/// distance of [`PiecewiseTrajectory::l2_distance`] (the same sums in the same order) without
/// keeping the elements.
///
/// # Example
///
/// ```
/// use femvi::diagnostics::L2Sum;
/// use femvi::fem::{LagrangeBasis, NodeFamily};
/// // q_h = t on [0, 1] (degree 1), against q_ref = 0: ∫ t² = 1/3.
/// let basis = LagrangeBasis::new(1, NodeFamily::Equispaced)?;
/// let mut sum = L2Sum::new(2, 1);
/// sum.add(&basis, 0.0, 1.0, &[0.0, 1.0], |_, out: &mut [f64]| out[0] = 0.0);
/// assert!((sum.value() - (1.0f64 / 3.0).sqrt()).abs() < 1e-15);
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct L2Sum {
    rule: QuadratureRule,
    qh: Vec<f64>,
    qr: Vec<f64>,
    sum: f64,
    /// Rotation blocks of q_h ([`PiecewiseTrajectory::with_rotations`]).
    rotations: Vec<usize>,
}

impl L2Sum {
    /// A sum for a trajectory of dimension n with a Gauss rule of `points` points per element
    /// (clamped to 1 ..= [`MAX_POINTS`]).
    pub fn new(points: usize, n: usize) -> Self {
        let rule = QuadratureRule::new(QuadratureKind::GaussLegendre(points.clamp(1, MAX_POINTS)))
            .unwrap_or_else(|_| unreachable!("1 ..= MAX_POINTS points"));
        Self {
            rule,
            qh: vec![0.0; n],
            qr: vec![0.0; n],
            sum: 0.0,
            rotations: vec![],
        }
    }

    /// The blocks of nine coordinates at `offsets` are rotations: q_h follows their
    /// Lie-group paths between nodes ([`PiecewiseTrajectory::with_rotations`]).
    pub fn with_rotations(mut self, offsets: &[usize]) -> Self {
        self.rotations = offsets.to_vec();
        self
    }

    /// Adds the element starting at `t0` with step h and nodal values `nodes` ((basis
    /// nodes) × n); `reference(t, out)` writes q_ref(t). An element whose nodal values do not
    /// have that length adds NaN.
    pub fn add(
        &mut self,
        basis: &LagrangeBasis,
        t0: f64,
        h: f64,
        nodes: &[f64],
        mut reference: impl FnMut(f64, &mut [f64]),
    ) {
        if nodes.len() != basis.len() * self.qh.len() {
            self.sum = f64::NAN;
            return;
        }
        for (c, b) in self.rule.nodes.iter().zip(&self.rule.weights) {
            let t = t0 + c * h;
            element_value(basis, (t0, h), nodes, &self.rotations, t, &mut self.qh);
            reference(t, &mut self.qr);
            self.sum += h * b * self.qh.iter().zip(&self.qr).map(|(a, r)| (a - r).powi(2)).sum::<f64>();
        }
    }

    /// The distance so far, (Σ)^½.
    pub fn value(&self) -> f64 {
        self.sum.sqrt()
    }
}
