//! Lagrangians L(t, q, v) on Rⁿ (the paper's (1.1); its examples use (2.18), L = ½q̇² − V(q)).
//!
//! [`Lagrangian`] is generic over num-dual scalars, so one definition yields values, gradients
//! and Hessians by automatic differentiation ([`PointDerivatives`]). A Lagrangian may declare
//! mechanical structure, L = ½vᵀMv − V(t, q) with constant M ([`Mechanical`]): then the fast
//! solvers need only the force −∇V, which the user may hand-code for large systems.

mod directional;
mod lanes;
mod legendre;
mod mass;
mod mechanical;
mod one_pass;
mod point;
mod potential;

pub(crate) use lanes::{force_per_lane, lagrangian_per_lane};
pub use lanes::{Lanes, LANES};
pub use legendre::DEGENERATE_CONDITION;
pub use mass::MassMatrix;
pub use mechanical::Mechanical;
pub use point::{PointDerivatives, ONE_PASS_MAX_DIM};
pub use potential::Potential;

use crate::error::{check_len, invalid, Error, Result};
use num_dual::DualNum;

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

    /// For L = ½vᵀMv − V(t, q) written as [`Mechanical`] (kinetic part Σ (vᵢvᵢ)Mᵢᵢ from 0,
    /// then L = kin·½ − V): V(t, q). The energy tracker then takes L at v = p (M = I) from the
    /// sum p·p it has already formed, the same operations as [`Lagrangian::value`], so the
    /// same bits, one pass over p fewer per node. Default: None.
    ///
    /// ```
    /// use femvi::{models, Lagrangian};
    /// let kepler = models::kepler(1.0)?;
    /// assert_eq!(kepler.potential_value(0.0, &[2.0, 0.0]), Some(-0.5));
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn potential_value(&self, t: f64, q: &[f64]) -> Option<f64> {
        let _ = (t, q);
        None
    }

    /// The generalised force ∂L/∂q at v = 0 (for a mechanical Lagrangian, −∇V(t, q)).
    /// The default differentiates [`Lagrangian::value`]; mechanical systems override it.
    ///
    /// Like every method of this trait, it is called by the library with slices of length
    /// [`Lagrangian::dim`] only; implementations may assume so (and may panic otherwise).
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let n = self.dim();
        let mut d = PointDerivatives::new(n);
        let zeros = vec![0.0; n];
        self.first_derivatives(t, q, &zeros, false, &mut d);
        out.iter_mut().zip(d.l_q()).for_each(|(o, f)| *o = *f);
    }

    /// For a Lagrangian on the embedding of one rotation ([`crate::rotation`]): Some((I, has_V))
    /// if L = ½ Σ_a I_a w_a² − V(R) with the principal moments I = (I₁, I₂, I₃) about the body
    /// axes and a potential V whose gradient [`Lagrangian::force`] gives (−∂V/∂R at v = 0;
    /// `has_V` false for a free body). The Lie-group element then takes its degree-1 steps by
    /// a fixed-point iteration on the body's equations (`rotation/body.rs`) instead of Newton
    /// with automatic derivatives. Default: None.
    fn rigid_body(&self) -> Option<([f64; 3], bool)> {
        None
    }

    /// If the force is local with radius r (component i of [`Lagrangian::force`] depends on
    /// q_j only for |i − j| ≤ r: chains, lattices), that radius. If [`Lagrangian::force_range`]
    /// is implemented too, [`crate::Integrator::advance`] steps long chains with M = I in
    /// blocks of space and time that stay in cache, with the bits of whole steps. Default: None.
    ///
    /// ```
    /// use femvi::{models, Lagrangian};
    /// let chain = models::fpu(6, 0.25, 0.0)?;
    /// assert_eq!(chain.force_radius(), Some(1));
    /// let q = [0.1, -0.2, 0.3, 0.0, 0.5, -0.1];
    /// let (mut all, mut part) = ([0.0; 6], [0.0; 3]);
    /// chain.force(0.0, &q, &mut all);
    /// assert!(chain.force_range(0.0, &q, 2..5, &mut part));
    /// assert_eq!(part, all[2..5]);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn force_radius(&self) -> Option<usize> {
        None
    }

    /// Components `range` of [`Lagrangian::force`] at (t, q) into `out` (as long as the
    /// range), with the same bits as the whole force; false if the Lagrangian does not
    /// compute parts of its force. Default: false, nothing written (the blocked steps of
    /// [`Lagrangian::force_radius`] are then not taken).
    fn force_range(&self, t: f64, q: &[f64], range: std::ops::Range<usize>, out: &mut [f64]) -> bool {
        let _ = (t, q, range, out);
        false
    }

    /// The forces at several points at once: for point i, `out[i n..(i + 1) n]` is
    /// [`Lagrangian::force`] at `(t[i], q[i n..(i + 1) n])`, with the same bits (the ensemble
    /// lanes rely on it: a fixed-point member there takes [`Lagrangian::force_lanes`], its
    /// single run this). The fixed-point solver asks for all quadrature points of an element
    /// in one call, so that an implementation can vectorise across points. Default: one
    /// `force` call per point.
    fn forces(&self, t: &[f64], q: &[f64], out: &mut [f64]) {
        per_point(self.dim(), t, q, out, |ti, qi, oi| self.force(ti, qi, oi));
    }

    /// The force at [`LANES`] points at once, all at time t, coordinate by coordinate:
    /// `q[c][l]` is coordinate c of point l and `out[c][l]` receives component c of
    /// [`Lagrangian::force`] at point l, with the same bits. Ensembles advance [`LANES`]
    /// members a step at a time through it ([`crate::ensemble`]). Default: one `force`
    /// call per lane; mechanical systems take their potential's
    /// ([`Potential::force_lanes`]).
    ///
    /// ```
    /// use femvi::{models, Lagrangian, LANES};
    /// let kepler = models::kepler(1.0)?;
    /// let q = [[1.0, 2.0, 0.5, 3.0, -1.0, 0.25, 4.0, -2.0], [0.5; LANES]];
    /// let mut f = [[0.0; LANES]; 2];
    /// kepler.force_lanes(0.0, &q, &mut f);
    /// let mut one = [0.0; 2];
    /// kepler.force(0.0, &[q[0][3], q[1][3]], &mut one);
    /// assert_eq!([f[0][3], f[1][3]], one);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn force_lanes(&self, t: f64, q: &[Lanes], out: &mut [Lanes]) {
        lanes::force_per_lane(self, t, q, out);
    }

    /// [`Lagrangian::potential_value`] at [`LANES`] points at once (stored as for
    /// [`Lagrangian::force_lanes`]), with the same bits; None where that is None. Default:
    /// lane by lane.
    ///
    /// ```
    /// use femvi::{models, Lagrangian, LANES};
    /// let kepler = models::kepler(1.0)?;
    /// let v = kepler.potential_lanes(0.0, &[[2.0; LANES], [0.0; LANES]]);
    /// assert_eq!(v, Some([-0.5; LANES]));
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn potential_lanes(&self, t: f64, q: &[Lanes]) -> Option<Lanes> {
        lanes::value_per_lane(q, |x| self.potential_value(t, x))
    }

    /// [`Lagrangian::value`] in f64 at [`LANES`] points (q, v) at once, all at time t, stored
    /// as for [`Lagrangian::force_lanes`] (`q[c][l]`, `v[c][l]`), with the same bits: the
    /// energy of ensemble members without [`Lagrangian::potential_lanes`]. Default: lane by
    /// lane; expression Lagrangians evaluate their compiled value across lanes.
    ///
    /// ```
    /// use femvi::expr::ExprLagrangian;
    /// use femvi::{Lagrangian, LANES};
    /// let xy = ["x".to_string(), "y".to_string()];
    /// let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &xy, &[])?;
    /// let q = [[1.0, 2.0, 0.5, 3.0, -1.0, 0.25, 4.0, -2.0], [0.5; LANES]];
    /// let v = [[0.1; LANES], [-0.3, 0.0, 1.0, 2.0, 0.5, -1.0, 0.25, 3.0]];
    /// let all = lag.value_lanes(0.0, &q, &v);
    /// let one: f64 = lag.value(0.0, &[q[0][6], q[1][6]], &[v[0][6], v[1][6]]);
    /// assert_eq!(all[6].to_bits(), one.to_bits());
    /// # Ok::<(), femvi::expr::ExprError>(())
    /// ```
    fn value_lanes(&self, t: f64, q: &[Lanes], v: &[Lanes]) -> Lanes {
        lanes::lagrangian_per_lane(self, t, q, v)
    }

    /// The derivative of [`Lagrangian::force`] along dq, (∂f/∂q)(t, q)·dq (for a mechanical
    /// Lagrangian −∇²V dq), into `out`: the tangent maps of mechanical steps take one such
    /// product per quadrature point and vector (`step/tangent_mechanical.rs`). The default
    /// differentiates [`Lagrangian::value`] twice (n hyper-dual passes at v = 0); mechanical
    /// systems override it.
    ///
    /// ```
    /// use femvi::{models, Lagrangian};
    /// // Kepler: f = −q/|q|³; along q itself the derivative is 2q/|q|³.
    /// let kepler = models::kepler(1.0)?;
    /// let mut out = [0.0; 2];
    /// kepler.force_derivative(0.0, &[2.0, 0.0], &[2.0, 0.0], &mut out);
    /// assert!((out[0] - 0.5).abs() < 1e-15 && out[1] == 0.0);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn force_derivative(&self, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        force_derivative_by_ad(self, t, q, dq, out);
    }

    /// The Jacobian of [`Lagrangian::force`], ∂f/∂q (row-major n×n, for a mechanical
    /// Lagrangian −∇²V), into `out` and true, if the Lagrangian computes it directly; false
    /// (the default), nothing written, if not. The tangent maps of small mechanical systems
    /// form it once per quadrature point and step and then multiply, where
    /// [`Lagrangian::force_derivative`] would evaluate the model at every product.
    ///
    /// ```
    /// use femvi::{models, Lagrangian};
    /// let hh = models::henon_heiles();
    /// let mut jac = [0.0; 4];
    /// assert!(hh.force_jacobian(0.0, &[0.0, 0.0], &mut jac));
    /// assert_eq!(jac, [-1.0, 0.0, 0.0, -1.0]);
    /// ```
    fn force_jacobian(&self, t: f64, q: &[f64], out: &mut [f64]) -> bool {
        let _ = (t, q, out);
        false
    }

    /// Prepares repeated products [`Lagrangian::force_derivative`] at one point (t, q): if
    /// the Lagrangian can, writes what every product there shares (for the n-body model,
    /// each pair's separation and r⁻³ factor: the square roots and most divisions) into
    /// `cache` and returns true; then [`Lagrangian::prepared_force_derivative`] with that
    /// cache gives the bits of `force_derivative(t, q, dq, out)` for any dq. Default: false,
    /// nothing written. The tangent maps of mechanical steps take one product per vector and
    /// sweep at each quadrature point, and prefer this to forming ∂f/∂q
    /// ([`Lagrangian::force_jacobian`]) when the Lagrangian offers it and a step takes at
    /// least two products per point.
    ///
    /// ```
    /// use femvi::{models, Lagrangian};
    /// let bodies = models::n_body(1.0, vec![1.0, 1e-3, 3e-4], 2)?;
    /// let (q, dq) = ([0.0, 0.0, 1.0, 0.0, 0.0, 1.5], [0.1, -0.2, 0.3, 0.4, -0.5, 0.6]);
    /// let mut cache = Vec::new();
    /// assert!(bodies.prepare_force_derivative(0.0, &q, &mut cache));
    /// let (mut once, mut prepared) = ([0.0; 6], [0.0; 6]);
    /// bodies.force_derivative(0.0, &q, &dq, &mut once);
    /// bodies.prepared_force_derivative(&cache, &dq, &mut prepared);
    /// assert_eq!(once, prepared);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn prepare_force_derivative(&self, t: f64, q: &[f64], cache: &mut Vec<f64>) -> bool {
        let _ = (t, q, cache);
        false
    }

    /// The product (∂f/∂q)·dq at the point a `cache` was prepared for
    /// ([`Lagrangian::prepare_force_derivative`], which returned true), into `out`, with the
    /// bits of [`Lagrangian::force_derivative`] there. Default (for Lagrangians that do not
    /// prepare): NaN.
    fn prepared_force_derivative(&self, cache: &[f64], dq: &[f64], out: &mut [f64]) {
        let _ = (cache, dq);
        out.iter_mut().for_each(|x| *x = f64::NAN);
    }

    /// If L = ½vᵀMv + A(t, q)·v − V(t, q) with a constant positive definite mass matrix M
    /// (gyroscopic: magnetic fields, rotating frames), that matrix; then `Method::Auto` solves
    /// the steps by fixed-point iteration on [`Lagrangian::gyroscopic_terms`]
    /// (`step/gyroscopic/`) instead of Newton. Default: None. A Lagrangian that returns M
    /// here must have exactly this form (the solver never looks at [`Lagrangian::value`]),
    /// or ∂L/∂v = Mv/d + A(t, q, v) with the divisor d of
    /// [`Lagrangian::gyroscopic_divisor`] and A weakly dependent on v over a step.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{Element, Integrator, Lagrangian, MassMatrix, Scalar, SolverOptions, Start, TimeGrid};
    /// // A charge in a uniform magnetic field b = 1: L = ½|v|² + ½(x v_y − y v_x).
    /// struct Charge(MassMatrix);
    /// impl Lagrangian for Charge {
    ///     fn dim(&self) -> usize { 2 }
    ///     fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
    ///         (v[0] * v[0] + v[1] * v[1]) * 0.5 + (q[0] * v[1] - q[1] * v[0]) * 0.5
    ///     }
    ///     fn gyroscopic_mass(&self) -> Option<&MassMatrix> { Some(&self.0) }
    /// }
    /// let (lag, el) = (Charge(MassMatrix::identity(2)), Element::with_order(4)?);
    /// let start = Start::Velocity { q: vec![1.0, 0.0], v: vec![0.0, -1.0] };
    /// let grid = TimeGrid::uniform(0.0, 0.01, 1.0)?;
    /// let mut it = Integrator::new(&lag, &el, grid, start, SolverOptions::default())?;
    /// while it.step()? {}
    /// // The unit circle at unit angular speed: q(t) = (cos t, −sin t).
    /// let q = it.node().q;
    /// assert!((q[0] - 1f64.cos()).abs() < 1e-8 && (q[1] + 1f64.sin()).abs() < 1e-8);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn gyroscopic_mass(&self) -> Option<&MassMatrix> {
        None
    }

    /// The parts of a gyroscopic Lagrangian at several points: for point i, with 2n numbers
    /// per point, `out[2n i..2n i + n]` is A(t_i, q_i) and `out[2n i + n..2n (i + 1)]` is
    /// ∂L/∂q = (∂A/∂q)ᵀ v_i − ∇V(t_i, q_i), at `(t[i], q[i n..(i + 1) n], v[i n..(i + 1) n])`.
    /// Default: from [`Lagrangian::first_derivatives`] (A = ∂L/∂v − Mv); override it with
    /// hand-coded parts for speed.
    fn gyroscopic_terms(&self, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        terms_by_derivatives(self, 1.0, t, q, v, out);
    }

    /// The divisor d > 0 of the gyroscopic mass for the step that starts at (t, q): the
    /// gyroscopic fixed point takes the momentum as ∂L/∂v = Mv/d + A(t, q, v), with M from
    /// [`Lagrangian::gyroscopic_mass`] and d frozen over the step, and A from
    /// [`Lagrangian::gyroscopic_terms_divided`]. The iteration contracts when A depends
    /// weakly on v over a step. Default 1 (the gyroscopic form, A independent of v). The
    /// time-transformed Lagrangian of adaptive steps, ∂L_g/∂q' = Mq'/g(q), returns g(q) here
    /// (`adaptive/lagrangian.rs`).
    ///
    /// ```
    /// use femvi::adaptive::{KeplerMonitor, TimeTransformed};
    /// use femvi::{models, Lagrangian};
    /// assert_eq!(models::kepler(1.0)?.gyroscopic_divisor(0.0, &[4.0, 0.0]), 1.0);
    /// let lg = TimeTransformed::new(models::kepler(1.0)?, KeplerMonitor, -0.5)?;
    /// assert_eq!(lg.gyroscopic_divisor(0.0, &[4.0, 0.0]), 8.0); // |q|^{3/2}
    /// # Ok::<(), femvi::Error>(())
    /// ```
    fn gyroscopic_divisor(&self, _t: f64, _q: &[f64]) -> f64 {
        1.0
    }

    /// [`Lagrangian::gyroscopic_terms`] for the divisor d of
    /// [`Lagrangian::gyroscopic_divisor`]: A = ∂L/∂v − Mv/d and ∂L/∂q by point. Default: the
    /// gyroscopic terms for d = 1, otherwise from [`Lagrangian::first_derivatives`].
    fn gyroscopic_terms_divided(&self, d: f64, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        if d == 1.0 {
            self.gyroscopic_terms(t, q, v, out);
        } else {
            terms_by_derivatives(self, d, t, q, v, out);
        }
    }

    /// Value and gradient of L with respect to (q, v), and ∂L/∂t if `with_t`, into `out`.
    #[inline]
    fn first_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        out.first_by_ad(self, t, q, v, with_t);
    }

    /// Value, gradient and Hessian of L with respect to (q, v) (and t if `with_t`), into `out`.
    fn second_derivatives(&self, t: f64, q: &[f64], v: &[f64], with_t: bool, out: &mut PointDerivatives) {
        out.second_by_ad(self, t, q, v, with_t);
    }
}

/// The defaults of [`Lagrangian::forces`] and [`Potential::forces`]: `force(t[i], q_i, out_i)`
/// point by point, for points of n coordinates (none for n = 0).
pub(crate) fn per_point(
    n: usize,
    t: &[f64],
    q: &[f64],
    out: &mut [f64],
    mut force: impl FnMut(f64, &[f64], &mut [f64]),
) {
    if n == 0 {
        return;
    }
    for ((&ti, qi), oi) in t.iter().zip(q.chunks_exact(n)).zip(out.chunks_exact_mut(n)) {
        force(ti, qi, oi);
    }
}

/// The default of [`Lagrangian::force_derivative`]: ∂²L/∂q∂q · dq at v = 0 by n hyper-dual
/// passes over [`Lagrangian::value`] (for implementations that fall back to it).
pub(crate) fn force_derivative_by_ad<L: Lagrangian + ?Sized>(lag: &L, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
    directional::lagrangian_default(lag, t, q, dq, out);
}

/// The gyroscopic terms of `lag` by point from its first derivatives: A = ∂L/∂v − Mv/d (M
/// from [`Lagrangian::gyroscopic_mass`], zero without one; the division by d = 1 is exact)
/// and ∂L/∂q.
fn terms_by_derivatives<L: Lagrangian + ?Sized>(lag: &L, d: f64, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
    let n = lag.dim();
    if n == 0 {
        return;
    }
    let mut pd = PointDerivatives::new(n);
    let mut mv = vec![0.0; n];
    let points = q.chunks_exact(n).zip(v.chunks_exact(n));
    for ((&ti, (qi, vi)), oi) in t.iter().zip(points).zip(out.chunks_exact_mut(2 * n)) {
        lag.first_derivatives(ti, qi, vi, false, &mut pd);
        match lag.gyroscopic_mass() {
            Some(m) => m.apply(vi, &mut mv),
            None => mv.iter_mut().for_each(|x| *x = 0.0),
        }
        let (a, g) = oi.split_at_mut(n);
        a.iter_mut()
            .zip(pd.l_v())
            .zip(&mv)
            .for_each(|((a, lv), mv)| *a = lv - mv / d);
        g.copy_from_slice(pd.l_q());
    }
}

/// Solves p = ∂L/∂v(t, q, v) for v by Newton's method from `v` (which holds the guess and
/// receives the answer): the inverse Legendre transform.
///
/// # Errors
/// [`Error::DegenerateLagrangian`] if ∂²L/∂v² is singular or ill-conditioned (condition
/// number above [`DEGENERATE_CONDITION`]) where Newton stops; [`Error::LegendreNotConverged`]
/// if it is regular there but Newton did not converge; [`Error::Invalid`] for a system without coordinates; [`Error::Dimension`] if q, p, v or
/// `work` do not have the Lagrangian's dimension.
pub fn velocity_from_momentum<L: Lagrangian>(
    lag: &L,
    t: f64,
    q: &[f64],
    p: &[f64],
    v: &mut [f64],
    work: &mut PointDerivatives,
) -> Result<()> {
    let n = check_point(lag, q, ("v", v.len()))?;
    check_len("p", n, p.len())?;
    check_len("derivative buffers", n, work.n)?;
    if let Some(mass) = lag.mass_matrix() {
        mass.solve(p, v);
        return Ok(());
    }
    legendre::newton(lag, t, (q, p), v, work)
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
/// let kepler = femvi::models::kepler(1.0)?;
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

/// The dimension n of `lag` after checking that it is at least 1 and that q and the other
/// vector named in `other` (name, length) have n entries.
fn check_point<L: Lagrangian>(lag: &L, q: &[f64], other: (&str, usize)) -> Result<usize> {
    let n = lag.dim();
    if n == 0 {
        return Err(invalid("dimension", "the system has no coordinates (dimension 0)"));
    }
    check_len("q", n, q.len())?;
    check_len(other.0, n, other.1)?;
    Ok(n)
}

/// Checks that ∂²L/∂v² is non-singular at a point (the Lagrangian is regular there). A
/// Lagrangian with a constant mass matrix is regular everywhere (the matrix was checked to be
/// symmetric positive definite when it was built), so nothing is evaluated then: no Hessian,
/// no singular values, O(1) work for any n.
///
/// # Errors
/// [`Error::DegenerateLagrangian`] if it is singular, not finite, or its condition number is
/// at least [`DEGENERATE_CONDITION`]; [`Error::Invalid`] for a
/// system without coordinates; [`Error::Dimension`] if q or v do not have its dimension.
pub fn check_regular<L: Lagrangian>(lag: &L, t: f64, q: &[f64], v: &[f64]) -> Result<()> {
    let n = check_point(lag, q, ("v", v.len()))?;
    if lag.mass_matrix().is_some() {
        return Ok(());
    }
    let mut work = PointDerivatives::new(n);
    lag.second_derivatives(t, q, v, false, &mut work);
    let condition = legendre::condition(&work);
    if condition.is_nan() || condition >= DEGENERATE_CONDITION {
        return Err(Error::DegenerateLagrangian { t, condition });
    }
    Ok(())
}
