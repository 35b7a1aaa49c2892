//! Dense output from the element polynomials: inside element k, the Galerkin interpolant
//! q_h(t) = q_k + Σ_j ℓ_j(τ) X^j with τ = (t − t_k)/h_k (the paper's (2.26)/(2.38b)), its
//! velocity q̇_h(t) = Σ_j ℓ_j'(τ) X^j / h_k, and the momentum p_h(t) = ∂L/∂v(t, q_h, q̇_h).
//! At node times the nodes themselves are returned, bit for bit (each element is evaluated
//! from its left node; the last node is kept). Orders: q_h is of order s + 1 between nodes
//! (the interpolation error), q̇_h and p_h of order s; the nodes keep the method's 2s.

use crate::error::{check_len, invalid, Result};
use crate::fem::LagrangeBasis;
use crate::lagrangian::{Lagrangian, PointDerivatives};

/// Evaluates one element's interpolant: scratch for the basis values and derivatives.
#[derive(Debug, Clone)]
pub(crate) struct ElementEval {
    l: Vec<f64>,
    dl: Vec<f64>,
    /// The offsets of the rotation blocks of a run with rotations: each follows its
    /// Lie-group element's path (`rotation/dense.rs`), not the polynomial in its entries.
    rotations: Vec<usize>,
}

impl ElementEval {
    pub(crate) fn new(nodes: usize) -> Self {
        Self {
            l: vec![0.0; nodes],
            dl: vec![0.0; nodes],
            rotations: Vec::new(),
        }
    }

    /// The rotation blocks at `offsets` follow their elements' paths (no allocation when
    /// they are already set).
    pub(crate) fn set_rotations(&mut self, offsets: &[usize]) {
        if self.rotations != offsets {
            self.rotations = offsets.to_vec();
        }
    }

    /// q_h and q̇_h at t in the element [t0, t0 + h] from `base` with increments `incr`
    /// (row-major (s+1)×n).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn eval(
        &mut self,
        basis: &LagrangeBasis,
        t0: f64,
        h: f64,
        base: &[f64],
        incr: &[f64],
        t: f64,
        q: &mut [f64],
        v: &mut [f64],
    ) {
        self.eval_at(basis, h, base, incr, (t - t0) / h, q, v);
    }

    /// [`ElementEval::eval`] at τ = (t − t0)/h given (τ = 1: the element's end).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn eval_at(
        &mut self,
        basis: &LagrangeBasis,
        h: f64,
        base: &[f64],
        incr: &[f64],
        tau: f64,
        q: &mut [f64],
        v: &mut [f64],
    ) {
        let n = base.len();
        basis.values_in_place(tau, &mut self.l);
        basis.derivatives_in_place(tau, &mut self.dl);
        for c in 0..n {
            let (mut dq, mut dv) = (0.0, 0.0);
            for j in 0..self.l.len() {
                dq += self.l[j] * incr[j * n + c];
                dv += self.dl[j] * incr[j * n + c];
            }
            q[c] = base[c] + dq;
            v[c] = dv / h;
        }
        for &o in &self.rotations {
            crate::rotation::dense::eval_block((&self.l, &self.dl), (h, base, incr), o, q, v);
        }
    }
}

/// The momentum ∂L/∂v(t, q, v) into `p`.
pub(crate) fn momentum<L: Lagrangian>(
    lag: &L,
    t: f64,
    q: &[f64],
    v: &[f64],
    work: &mut PointDerivatives,
    p: &mut [f64],
) {
    lag.first_derivatives(t, q, v, false, work);
    p.copy_from_slice(work.l_v());
}

/// The elements of a run kept for evaluation anywhere in its span.
///
/// # Example
///
/// ```
/// use femvi::{models, solve, Element, Problem, SolveOptions, Start};
///
/// let lag = models::harmonic(1.0, 1.0)?;
/// let problem = Problem::new(lag, Start::Velocity { q: vec![1.0], v: vec![0.0] }, 0.0, 2.0);
/// let element = Element::with_order(6)?;
/// let options = SolveOptions { dense: true, ..SolveOptions::step(0.1) };
/// let sol = solve(&problem, &element, &options)?;
/// let dense = sol.dense.as_ref().expect("asked for");
/// let mut q = [0.0];
/// dense.q_at(0.55, &mut q)?;
/// assert!((q[0] - 0.55f64.cos()).abs() < 1e-6); // order s + 1 = 4 between nodes
/// # Ok::<(), femvi::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct DenseOutput {
    n: usize,
    basis: LagrangeBasis,
    /// Element start times and steps.
    t: Vec<f64>,
    h: Vec<f64>,
    /// q_k, p_k and v_k (from p_k) at each element's left node, n each.
    base: Vec<f64>,
    p: Vec<f64>,
    v: Vec<f64>,
    /// Nodal increments, (s+1)·n per element.
    incr: Vec<f64>,
    /// The last node (t, q, p, v).
    end: (f64, Vec<f64>, Vec<f64>, Vec<f64>),
    /// The offsets of the rotation blocks (their elements' paths, `rotation/dense.rs`).
    rotations: Vec<usize>,
}

impl DenseOutput {
    /// An empty record for dimension n starting at the node (t0, q0, p0, v0).
    pub(crate) fn new(basis: LagrangeBasis, t0: f64, q0: &[f64], p0: &[f64], v0: &[f64]) -> Self {
        Self {
            n: q0.len(),
            basis,
            t: vec![],
            h: vec![],
            base: vec![],
            p: vec![],
            v: vec![],
            incr: vec![],
            end: (t0, q0.to_vec(), p0.to_vec(), v0.to_vec()),
            rotations: Vec::new(),
        }
    }

    /// The rotation blocks at `offsets` follow their elements' paths.
    pub(crate) fn with_rotations(mut self, offsets: &[usize]) -> Self {
        self.rotations = offsets.to_vec();
        self
    }

    /// Appends the element [t0, t0 + h] from the node (q_k, p_k, v_k) = (`base`, `pv.0`,
    /// `pv.1`), and the node (t, q, p, v) it ends on.
    pub(crate) fn push(
        &mut self,
        t0: f64,
        h: f64,
        pv: (&[f64], &[f64]),
        base: &[f64],
        incr: &[f64],
        node: (f64, &[f64], &[f64], &[f64]),
    ) {
        self.t.push(t0);
        self.h.push(h);
        self.base.extend_from_slice(base);
        self.p.extend_from_slice(pv.0);
        self.v.extend_from_slice(pv.1);
        self.incr.extend_from_slice(incr);
        self.end = (node.0, node.1.to_vec(), node.2.to_vec(), node.3.to_vec());
    }

    /// Number of elements kept.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether no element is kept.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The span [t_0, t_N] covered.
    pub fn span(&self) -> (f64, f64) {
        (self.t.first().copied().unwrap_or(self.end.0), self.end.0)
    }

    /// The element containing t (from its left node), or None at the last node.
    fn locate(&self, t: f64) -> Result<Option<usize>> {
        let (a, b) = self.span();
        if !(t >= a && t <= b) {
            return Err(invalid(
                "dense output time",
                format!("{t} is outside the span [{a}, {b}]"),
            ));
        }
        if t == b {
            return Ok(None);
        }
        Ok(Some(self.t.partition_point(|&tk| tk <= t).saturating_sub(1)))
    }

    /// q_h(t) and q̇_h(t) into `q` and `v`; at node times the node's q and its velocity from
    /// the inverse Legendre transform of p (q̇_h is not continuous at nodes).
    ///
    /// # Errors
    /// t outside the span, or buffers of the wrong length.
    pub fn state_at(&self, t: f64, q: &mut [f64], v: &mut [f64]) -> Result<()> {
        check_len("dense output q", self.n, q.len())?;
        check_len("dense output v", self.n, v.len())?;
        let n = self.n;
        let w = self.basis.len() * n;
        match self.locate(t)? {
            Some(k) => {
                let (base, incr) = (&self.base[k * n..(k + 1) * n], &self.incr[k * w..(k + 1) * w]);
                let mut eval = ElementEval::new(self.basis.len());
                eval.set_rotations(&self.rotations);
                eval.eval(&self.basis, self.t[k], self.h[k], base, incr, t, q, v);
                if t == self.t[k] {
                    q.copy_from_slice(base); // the node, bit for bit (also a −0.0)
                    v.copy_from_slice(&self.v[k * n..(k + 1) * n]);
                }
            }
            None => {
                q.copy_from_slice(&self.end.1);
                v.copy_from_slice(&self.end.3);
            }
        }
        Ok(())
    }

    /// q_h(t) into `q`.
    ///
    /// # Errors
    /// As [`Self::state_at`].
    pub fn q_at(&self, t: f64, q: &mut [f64]) -> Result<()> {
        let mut v = vec![0.0; self.n];
        self.state_at(t, q, &mut v)
    }

    /// p_h(t) = ∂L/∂v(t, q_h, q̇_h) into `p`, the discrete momentum p_k at node times.
    ///
    /// # Errors
    /// As [`Self::state_at`], or a Lagrangian of another dimension.
    pub fn p_at<L: Lagrangian>(&self, lag: &L, t: f64, p: &mut [f64]) -> Result<()> {
        check_len("Lagrangian dimension", self.n, lag.dim())?;
        check_len("dense output p", self.n, p.len())?;
        let n = self.n;
        match self.locate(t)? {
            None => p.copy_from_slice(&self.end.2),
            Some(k) if self.t[k] == t => p.copy_from_slice(&self.p[k * n..(k + 1) * n]),
            Some(_) => {
                let (mut q, mut v) = (vec![0.0; n], vec![0.0; n]);
                self.state_at(t, &mut q, &mut v)?;
                momentum(lag, t, &q, &v, &mut PointDerivatives::new(n), p);
            }
        }
        Ok(())
    }
}
