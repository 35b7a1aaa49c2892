//! Lagrangians L(t, q, v) on Rⁿ (the paper's (1.1); its examples use (2.18), L = ½q̇² − V(q)).
//!
//! [`Lagrangian`] is generic over num-dual scalars, so one definition yields values, gradients
//! and Hessians by automatic differentiation ([`PointDerivatives`]). A Lagrangian may declare
//! mechanical structure, L = ½vᵀMv − V(t, q) with constant M ([`Mechanical`]): then the fast
//! solvers need only the force −∇V, which the user may hand-code for large systems.

use crate::error::{Error, Result};
use num_dual::{Dual64, DualNum, HyperDual64};

/// The number types a Lagrangian is evaluated with: f64 and num-dual's forward-mode numbers.
pub trait Scalar: DualNum<Primitive = f64> + Copy {}
impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}

/// A Lagrangian L(t, q, v) on Rⁿ.
pub trait Lagrangian {
    /// Dimension n of the configuration space.
    fn dim(&self) -> usize;

    /// L(t, q, v), for any scalar type (f64 or dual numbers).
    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D;

    /// Whether L does not depend on t (then ∂L/∂t = 0 is not computed, and the discrete
    /// energy is conserved in the energy-preserving mode). Default: false (t is differentiated).
    fn is_autonomous(&self) -> bool {
        false
    }

    /// If L = ½vᵀMv − V(t, q) with a constant mass matrix M, that matrix. The fixed-point and
    /// explicit solvers are available only then.
    fn mass_matrix(&self) -> Option<&MassMatrix> {
        None
    }

    /// The generalised force ∂L/∂q at v = 0 (for a mechanical Lagrangian, −∇V(t, q)).
    /// The default differentiates [`Lagrangian::value`]; mechanical systems override it.
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let n = self.dim();
        let mut d = PointDerivatives::new(n);
        let zeros = vec![0.0; n];
        self.first_derivatives(t, q, &zeros, false, &mut d);
        out.copy_from_slice(d.l_q());
    }

    /// The forces at several points at once: for point i, `out[i n..(i + 1) n]` is
    /// [`Lagrangian::force`] at `(t[i], q[i n..(i + 1) n])`. The fixed-point solver asks for
    /// all quadrature points of an element in one call, so that an implementation can
    /// vectorise across points. Default: one `force` call per point.
    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        let n = self.dim();
        for ((&ti, qi), oi) in t.iter().zip(q.chunks_exact(n)).zip(out.chunks_exact_mut(n)) {
            self.force(ti, qi, oi);
        }
    }

    /// Value and gradient of L with respect to (q, v), and ∂L/∂t if `with_t`, into `out`.
    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        out.first_by_ad(self, t, q, v, with_t);
    }

    /// Value, gradient and Hessian of L with respect to (q, v) (and t if `with_t`), into `out`.
    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        out.second_by_ad(self, t, q, v, with_t);
    }
}

/// Value, gradient and Hessian of L at one point with respect to z = (t, q, v), m = 2n + 1
/// entries: index 0 is t, 1 ..= n are q, n + 1 ..= 2n are v. Holds its own AD scratch so
/// that repeated evaluations do not allocate.
#[derive(Debug, Clone)]
pub struct PointDerivatives {
    n: usize,
    /// L at the point.
    pub value: f64,
    /// ∂L/∂z (length 2n + 1).
    pub grad: Vec<f64>,
    /// ∂²L/∂z∂z, row-major (2n + 1)².
    pub hess: Vec<f64>,
    d1: Vec<Dual64>,
    d2: Vec<HyperDual64>,
}

impl PointDerivatives {
    /// Buffers for a configuration space of dimension n.
    pub fn new(n: usize) -> Self {
        let m = 2 * n + 1;
        Self {
            n,
            value: 0.0,
            grad: vec![0.0; m],
            hess: vec![0.0; m * m],
            d1: vec![Dual64::from(0.0); m],
            d2: vec![HyperDual64::from(0.0); m],
        }
    }

    /// ∂L/∂t.
    pub fn l_t(&self) -> f64 {
        self.grad[0]
    }
    /// ∂L/∂q.
    pub fn l_q(&self) -> &[f64] {
        &self.grad[1..=self.n]
    }
    /// ∂L/∂v.
    pub fn l_v(&self) -> &[f64] {
        &self.grad[self.n + 1..]
    }
    /// ∂²L/∂z_a∂z_b with z = (t, q, v).
    pub fn h(&self, a: usize, b: usize) -> f64 {
        self.hess[a * (2 * self.n + 1) + b]
    }
    /// Number of entries of z.
    pub fn width(&self) -> usize {
        2 * self.n + 1
    }

    fn load<D: Scalar>(buf: &mut [D], t: f64, q: &[f64], v: &[f64]) {
        buf[0] = D::from(t);
        for (b, &x) in buf[1..].iter_mut().zip(q.iter().chain(v)) {
            *b = D::from(x);
        }
    }

    /// Fills value and gradient by forward-mode AD, one pass per direction.
    pub fn first_by_ad<L: Lagrangian + ?Sized>(&mut self, lag: &L, t: f64, q: &[f64], v: &[f64], with_t: bool) {
        let n = self.n;
        let m = 2 * n + 1;
        Self::load(&mut self.d1, t, q, v);
        let with_t = with_t && !lag.is_autonomous();
        let start = if with_t { 0 } else { 1 };
        if !with_t {
            self.grad[0] = 0.0;
        }
        for a in start..m {
            self.d1[a].eps = 1.0;
            let (zt, rest) = self.d1.split_at(1);
            let r = lag.value(zt[0], &rest[..n], &rest[n..]);
            self.d1[a].eps = 0.0;
            self.value = r.re;
            self.grad[a] = r.eps;
        }
    }

    /// Fills value, gradient and Hessian by hyper-dual numbers, one pass per pair of directions.
    pub fn second_by_ad<L: Lagrangian + ?Sized>(&mut self, lag: &L, t: f64, q: &[f64], v: &[f64], with_t: bool) {
        let n = self.n;
        let m = 2 * n + 1;
        Self::load(&mut self.d2, t, q, v);
        let with_t = with_t && !lag.is_autonomous();
        let start = if with_t { 0 } else { 1 };
        if !with_t {
            self.grad[0] = 0.0;
            for a in 0..m {
                self.hess[a] = 0.0;
                self.hess[a * m] = 0.0;
            }
        }
        for a in start..m {
            for b in a..m {
                self.d2[a].eps1 = 1.0;
                self.d2[b].eps2 = 1.0;
                let (zt, rest) = self.d2.split_at(1);
                let r = lag.value(zt[0], &rest[..n], &rest[n..]);
                self.d2[a].eps1 = 0.0;
                self.d2[b].eps2 = 0.0;
                self.value = r.re;
                if a == b {
                    self.grad[a] = r.eps1;
                }
                self.hess[a * m + b] = r.eps1eps2;
                self.hess[b * m + a] = r.eps1eps2;
            }
        }
    }
}

/// A constant symmetric positive definite mass matrix, with its inverse.
#[derive(Debug, Clone, PartialEq)]
pub struct MassMatrix {
    n: usize,
    /// Row-major entries.
    m: Vec<f64>,
    /// Row-major inverse.
    inv: Vec<f64>,
    /// Diagonal matrices (the identity among them) are applied entry by entry.
    diagonal: Option<Vec<f64>>,
    /// Reciprocals of the diagonal, so that solves multiply instead of dividing.
    inv_diagonal: Option<Vec<f64>>,
    identity: bool,
}

impl MassMatrix {
    /// The n×n identity.
    pub fn identity(n: usize) -> Self {
        Self::diagonal(vec![1.0; n]).unwrap_or_else(|_| unreachable!("ones are positive"))
    }

    /// A diagonal mass matrix.
    ///
    /// # Errors
    /// A diagonal entry that is not positive and finite.
    pub fn diagonal(d: Vec<f64>) -> Result<Self> {
        if d.iter().any(|&x| !(x > 0.0 && x.is_finite())) {
            return Err(Error::MassNotPositiveDefinite);
        }
        let n = d.len();
        let mut m = vec![0.0; n * n];
        let mut inv = vec![0.0; n * n];
        for i in 0..n {
            m[i * n + i] = d[i];
            inv[i * n + i] = 1.0 / d[i];
        }
        let identity = d.iter().all(|&x| x == 1.0);
        let inv_d = d.iter().map(|x| 1.0 / x).collect();
        Ok(Self {
            n,
            m,
            inv,
            diagonal: Some(d),
            inv_diagonal: Some(inv_d),
            identity,
        })
    }

    /// A dense mass matrix from its row-major entries.
    ///
    /// # Errors
    /// Wrong length, not symmetric, or not positive definite (Cholesky fails).
    pub fn dense(n: usize, m: Vec<f64>) -> Result<Self> {
        crate::error::check_len("mass matrix", n * n, m.len())?;
        let mat = nalgebra::DMatrix::from_row_slice(n, n, &m);
        if (&mat - mat.transpose()).amax() > 1e-14 * mat.amax() || m.iter().any(|x| !x.is_finite()) {
            return Err(Error::MassNotPositiveDefinite);
        }
        let chol = nalgebra::Cholesky::new(mat).ok_or(Error::MassNotPositiveDefinite)?;
        let inv = chol.inverse();
        let is_diag = (0..n).all(|i| (0..n).all(|j| i == j || m[i * n + j] == 0.0));
        if is_diag {
            return Self::diagonal((0..n).map(|i| m[i * n + i]).collect());
        }
        Ok(Self {
            n,
            inv: inv.transpose().as_slice().to_vec(),
            m,
            diagonal: None,
            inv_diagonal: None,
            identity: false,
        })
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Entry (i, j).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.m[i * self.n + j]
    }

    /// out = M x.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        match &self.diagonal {
            Some(d) => out.iter_mut().zip(x).zip(d).for_each(|((o, x), d)| *o = d * x),
            None => matvec(&self.m, x, out),
        }
    }

    /// out = M⁻¹ x.
    #[inline]
    pub fn solve(&self, x: &[f64], out: &mut [f64]) {
        if self.identity {
            out.copy_from_slice(x);
            return;
        }
        match &self.inv_diagonal {
            Some(d) => out.iter_mut().zip(x).zip(d).for_each(|((o, x), d)| *o = x * d),
            None => matvec(&self.inv, x, out),
        }
    }

    /// Whether M is the identity.
    pub fn is_identity(&self) -> bool {
        self.identity
    }
}

fn matvec(a: &[f64], x: &[f64], out: &mut [f64]) {
    let n = x.len();
    for (i, o) in out.iter_mut().enumerate() {
        *o = a[i * n..(i + 1) * n].iter().zip(x).map(|(a, x)| a * x).sum();
    }
}

/// A potential V(t, q) for a mechanical Lagrangian.
pub trait Potential {
    /// Dimension n.
    fn dim(&self) -> usize;

    /// V(t, q), for any scalar type.
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D;

    /// Whether V does not depend on t. Default: false.
    fn is_autonomous(&self) -> bool {
        false
    }

    /// The force −∇V(t, q) into `out`. The default differentiates [`Potential::value`]
    /// (n forward passes); override it with a hand-coded force for speed.
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let n = q.len();
        let mut stack = [Dual64::from(0.0); 16];
        let mut heap = Vec::new();
        let buf: &mut [Dual64] = if n <= 16 {
            &mut stack[..n]
        } else {
            heap.resize(n, Dual64::from(0.0));
            &mut heap
        };
        for (b, &x) in buf.iter_mut().zip(q) {
            *b = Dual64::from(x);
        }
        for i in 0..n {
            buf[i].eps = 1.0;
            out[i] = -self.value(Dual64::from(t), buf).eps;
            buf[i].eps = 0.0;
        }
    }

    /// The forces at several points at once (see [`Lagrangian::forces`]). Default: one
    /// [`Potential::force`] call per point.
    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        let n = self.dim();
        for ((&ti, qi), oi) in t.iter().zip(q.chunks_exact(n)).zip(out.chunks_exact_mut(n)) {
            self.force(ti, qi, oi);
        }
    }

    /// The Jacobian of the force, −∇²V, row-major n×n into `out`. Default: hyper-dual AD.
    fn force_jacobian(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let n = q.len();
        let mut buf: Vec<HyperDual64> = q.iter().map(|&x| HyperDual64::from(x)).collect();
        for i in 0..n {
            for j in i..n {
                buf[i].eps1 = 1.0;
                buf[j].eps2 = 1.0;
                let h = -self.value(HyperDual64::from(t), &buf).eps1eps2;
                buf[i].eps1 = 0.0;
                buf[j].eps2 = 0.0;
                out[i * n + j] = h;
                out[j * n + i] = h;
            }
        }
    }
}

/// L = ½vᵀMv − V(t, q) with a constant symmetric positive definite M.
#[derive(Debug, Clone)]
pub struct Mechanical<P> {
    /// The potential V.
    pub potential: P,
    mass: MassMatrix,
}

impl<P: Potential> Mechanical<P> {
    /// A mechanical Lagrangian with the given mass matrix.
    ///
    /// # Errors
    /// The mass matrix and the potential disagree on the dimension.
    pub fn new(potential: P, mass: MassMatrix) -> Result<Self> {
        crate::error::check_len("mass matrix", potential.dim(), mass.dim())?;
        Ok(Self { potential, mass })
    }

    /// Unit masses.
    pub fn unit_mass(potential: P) -> Self {
        let mass = MassMatrix::identity(potential.dim());
        Self { potential, mass }
    }
}

impl<P: Potential> Lagrangian for Mechanical<P> {
    fn dim(&self) -> usize {
        self.potential.dim()
    }

    fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        let n = self.dim();
        let mut kin = D::from(0.0);
        for i in 0..n {
            for j in 0..n {
                let mij = self.mass.get(i, j);
                if mij != 0.0 {
                    kin += v[i] * v[j] * mij;
                }
            }
        }
        kin * 0.5 - self.potential.value(t, q)
    }

    fn mass_matrix(&self) -> Option<&MassMatrix> {
        Some(&self.mass)
    }

    fn is_autonomous(&self) -> bool {
        self.potential.is_autonomous()
    }

    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.potential.force(t, q, out);
    }

    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        self.potential.forces(t, q, out);
    }

    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        let n = self.dim();
        let (gt, rest) = out.grad.split_at_mut(1);
        let (gq, gv) = rest.split_at_mut(n);
        self.potential.force(t, q, gq);
        self.mass.apply(v, gv);
        let kin: f64 = 0.5 * v.iter().zip(gv.iter()).map(|(a, b)| a * b).sum::<f64>();
        let vt = if with_t && !self.potential.is_autonomous() {
            // ∂V/∂t by a dual number in t, in the scratch this struct owns (no allocation).
            let qd = &mut out.d1[..n];
            for (d, &x) in qd.iter_mut().zip(q) {
                *d = Dual64::from(x);
            }
            let r = self.potential.value(Dual64::new(t, 1.0), qd);
            gt[0] = -r.eps;
            r.re
        } else {
            gt[0] = 0.0;
            self.potential.value(t, q)
        };
        out.value = kin - vt;
    }

    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        if with_t {
            // Time derivatives of V are rare: take the generic route.
            out.second_by_ad(self, t, q, v, true);
            return;
        }
        self.first_derivatives(t, q, v, false, out);
        let n = self.dim();
        let m = 2 * n + 1;
        out.hess.iter_mut().for_each(|h| *h = 0.0);
        let mut jac = vec![0.0; n * n];
        self.potential.force_jacobian(t, q, &mut jac);
        for i in 0..n {
            for j in 0..n {
                out.hess[(1 + i) * m + 1 + j] = jac[i * n + j];
                out.hess[(1 + n + i) * m + 1 + n + j] = self.mass.get(i, j);
            }
        }
    }
}

/// Solves p = ∂L/∂v(t, q, v) for v by Newton's method from `v` (which holds the guess and
/// receives the answer): the inverse Legendre transform.
///
/// # Errors
/// [`Error::DegenerateLagrangian`] if ∂²L/∂v² is singular or Newton does not converge.
pub fn velocity_from_momentum<L: Lagrangian>(
    lag: &L,
    t: f64,
    q: &[f64],
    p: &[f64],
    v: &mut [f64],
    work: &mut PointDerivatives,
) -> Result<()> {
    if let Some(mass) = lag.mass_matrix() {
        mass.solve(p, v);
        return Ok(());
    }
    let n = lag.dim();
    let mut hvv = nalgebra::DMatrix::zeros(n, n);
    let mut rhs = nalgebra::DVector::zeros(n);
    for _ in 0..50 {
        lag.second_derivatives(t, q, v, false, work);
        for i in 0..n {
            rhs[i] = p[i] - work.l_v()[i];
            for j in 0..n {
                hvv[(i, j)] = work.h(1 + n + i, 1 + n + j);
            }
        }
        let lu = hvv.clone().lu();
        let dv = lu.solve(&rhs).ok_or(Error::DegenerateLagrangian { t })?;
        let scale = v.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        for i in 0..n {
            v[i] += dv[i];
        }
        if !dv.iter().all(|x| x.is_finite()) {
            return Err(Error::DegenerateLagrangian { t });
        }
        if dv.amax() <= 1e-15 * scale {
            return Ok(());
        }
    }
    Err(Error::DegenerateLagrangian { t })
}

/// The Hamiltonian H = p·v − L(t, q, v) with v from the inverse Legendre transform
/// (`v` holds a guess on entry and the velocity on return).
///
/// # Errors
/// As [`velocity_from_momentum`].
///
/// # Example
///
/// ```
/// use femvi::lagrangian::{hamiltonian, PointDerivatives};
///
/// let kepler = femvi::models::kepler(1.0);
/// let (mut v, mut work) = (vec![0.0; 2], PointDerivatives::new(2));
/// // The circular orbit of radius 1: H = ½ − 1.
/// let h = hamiltonian(&kepler, 0.0, &[1.0, 0.0], &[0.0, 1.0], &mut v, &mut work)?;
/// assert!((h + 0.5).abs() < 1e-15);
/// assert_eq!(v, [0.0, 1.0]);
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn hamiltonian<L: Lagrangian>(
    lag: &L,
    t: f64,
    q: &[f64],
    p: &[f64],
    v: &mut [f64],
    work: &mut PointDerivatives,
) -> Result<f64> {
    velocity_from_momentum(lag, t, q, p, v, work)?;
    let pv: f64 = p.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
    Ok(pv - lag.value(t, q, v))
}

/// Checks that ∂²L/∂v² is non-singular at a point (the Lagrangian is regular there).
///
/// # Errors
/// [`Error::DegenerateLagrangian`] if it is singular or not finite.
pub fn check_regular<L: Lagrangian>(lag: &L, t: f64, q: &[f64], v: &[f64]) -> Result<()> {
    let n = lag.dim();
    let mut work = PointDerivatives::new(n);
    lag.second_derivatives(t, q, v, false, &mut work);
    let hvv = nalgebra::DMatrix::from_fn(n, n, |i, j| work.h(1 + n + i, 1 + n + j));
    if !hvv.iter().all(|x| x.is_finite()) {
        return Err(Error::DegenerateLagrangian { t });
    }
    let svd = hvv.singular_values();
    let max = svd.max();
    if max.is_nan() || max <= 0.0 || svd.min() <= 1e-12 * max {
        return Err(Error::DegenerateLagrangian { t });
    }
    Ok(())
}
