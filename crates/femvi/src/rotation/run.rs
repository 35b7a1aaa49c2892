//! [`Integrator::with_rotations`]: a run whose configuration holds rotations, stepped by the
//! Lie-group element (`term.rs`) with every part of an ordinary run.

use super::action::EmbeddedForce;
use super::body_state::{block, body_momentum, BodyState};
use super::layout::Rotations;
use super::so3::{hat, mul, orthogonality_defect, Mat3};
use super::term::{embedded_momentum, RotationTerm};
use crate::discrete::Element;
use crate::error::{check_len, invalid, Result};
use crate::forces::Force;
use crate::lagrangian::{Lagrangian, PointDerivatives};
use crate::step::{Integrator, Method, SolverOptions, Start, TimeGrid};

/// How far from orthogonal (max |RᵀR − 1|) a start's rotation may be.
pub const ORTHOGONALITY_TOLERANCE: f64 = 1e-12;

/// The embedded velocity Ṙ = R ŵ of a body angular velocity w (the nine entries of the
/// start's v for a rotation block).
///
/// # Example
/// ```
/// use femvi::rotation::embedded_velocity;
/// let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let v = embedded_velocity(&identity, &[0.0, 0.0, 2.0]);
/// assert_eq!(v[3], 2.0); // spinning about z: the x axis moves towards y
/// ```
pub fn embedded_velocity(r: &Mat3<f64>, w: &[f64; 3]) -> Mat3<f64> {
    mul(r, &hat(w))
}

/// The rotation R and body angular momentum Π of the block at `offset` of a node (q, p).
///
/// # Example
/// ```
/// use femvi::rotation::{body_state, embedded_velocity};
/// use femvi::{models::RigidBody, Lagrangian, lagrangian::PointDerivatives};
/// let body = RigidBody::free([1.0, 2.0, 3.0])?;
/// let r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let v = embedded_velocity(&r, &[0.5, 1.0, 0.3]);
/// let mut d = PointDerivatives::new(9);
/// body.first_derivatives(0.0, &r, &v, false, &mut d);
/// let (_, pi) = body_state(&r, d.l_v(), 0);
/// assert!((pi[1] - 2.0).abs() < 1e-15); // Π = I w
/// # Ok::<(), femvi::Error>(())
/// ```
pub fn body_state(q: &[f64], p: &[f64], offset: usize) -> (Mat3<f64>, [f64; 3]) {
    let r = block(q, offset);
    (r, body_momentum(&r, &block(p, offset)))
}

impl<L: Lagrangian> Integrator<'_, L> {
    /// The body angular velocity and momentum of each rotation at the current node, for a run
    /// of [`Integrator::with_rotations`]; None for other runs.
    ///
    /// # Example
    /// ```
    /// use femvi::rotation::{embedded_velocity, Rotations};
    /// use femvi::{models::RigidBody, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let body = RigidBody::free([1.0, 2.0, 3.0])?;
    /// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
    /// let (element, grid) = (Element::with_order(2)?, TimeGrid::uniform(0.0, 0.01, 0.1)?);
    /// let it = Integrator::with_rotations(&body, &element, grid, start, SolverOptions::default(), Rotations::new(9, &[0])?)?;
    /// let at = it.node_rotations().expect("a run with rotations");
    /// assert!((at[0].w[1] - 1.0).abs() < 1e-15 && (at[0].pi[1] - 2.0).abs() < 1e-15);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn node_rotations(&self) -> Option<Vec<BodyState>> {
        let node = self.node();
        self.term_rotation_states(node.t, node.q, node.p)
    }
}

impl<'a, L: Lagrangian + Sync> Integrator<'a, L> {
    /// Sets up a run of `lag` whose coordinates hold the rotations of `rotations`, stepped by
    /// the Lie-group Galerkin element of `element`'s degree and quadrature (module docs of
    /// [`crate::rotation`]): each rotation stays on SO(3) to round-off, and the flow is
    /// symplectic on T*SO(3). `lag` is the Lagrangian on the embedding (the entries of R and
    /// Ṙ = R ŵ), as [`crate::models::RigidBody`] writes it. The start's rotations must be
    /// orthogonal (to [`ORTHOGONALITY_TOLERANCE`]); a start momentum (or the momentum of a
    /// start velocity) is projected onto T*SO(3): P = ½ R Π̂ with Π = 2 vee(RᵀP). The steps
    /// are solved by Newton's method on the nodes in the algebra.
    ///
    /// # Errors
    /// Sizes; a rotation that is not orthogonal; a start from (q0, q1); an explicit or
    /// fixed-point method; as [`Integrator::new`].
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::rotation::{body_state, embedded_velocity, Rotations};
    /// use femvi::{models::RigidBody, Element, Integrator, SolverOptions, Start, TimeGrid};
    ///
    /// let body = RigidBody::free([1.0, 2.0, 3.0])?;
    /// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
    /// let element = Element::with_order(4)?;
    /// let grid = TimeGrid::uniform(0.0, 0.01, 1.0)?;
    /// let mut it = Integrator::with_rotations(&body, &element, grid, start, SolverOptions::default(), Rotations::new(9, &[0])?)?;
    /// while it.step()? {}
    /// let node = it.node();
    /// let (_, pi) = body_state(node.q, node.p, 0);
    /// let norm = (pi[0] * pi[0] + pi[1] * pi[1] + pi[2] * pi[2]).sqrt();
    /// assert!((norm - (0.25f64 + 4.0 + 0.81).sqrt()).abs() < 1e-14);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_rotations(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start: Start,
        opts: SolverOptions,
        rotations: Rotations,
    ) -> Result<Self> {
        Self::rotations_run(lag, element, grid, start, opts, (rotations, false, None))
    }

    /// [`Integrator::with_rotations`] measuring the symplecticity defect of every step on
    /// T*SO(3): max |JᵀΩJ − Ω| of the step's Jacobian J in canonical coordinates (the chart
    /// R = R_k exp(ψ̂) with p_ψ = dexp_ψ μ, module `rotation/tangent.rs`), read by
    /// [`Integrator::symplecticity_defect`]. Each step then costs a few times more.
    ///
    /// # Errors
    /// As [`Integrator::with_rotations`].
    ///
    /// # Example
    /// ```
    /// use femvi::rotation::{embedded_velocity, Rotations};
    /// use femvi::{models::RigidBody, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let top = RigidBody::heavy_top([1.0, 2.0, 3.0], 1.0, 9.81, [0.1, 0.2, 0.5])?;
    /// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
    /// let (element, grid) = (Element::with_order(4)?, TimeGrid::uniform(0.0, 0.01, 0.5)?);
    /// let layout = Rotations::new(9, &[0])?;
    /// let mut it = Integrator::with_rotations_measured(&top, &element, grid, start, SolverOptions::default(), layout)?;
    /// while it.step()? {}
    /// assert!(it.symplecticity_defect().expect("measured") < 1e-12);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_rotations_measured(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start: Start,
        opts: SolverOptions,
        rotations: Rotations,
    ) -> Result<Self> {
        Self::rotations_run(lag, element, grid, start, opts, (rotations, true, None))
    }

    /// [`Integrator::with_rotations`] under a non-conservative force F(t, q, v) on the embedded
    /// coordinates (discrete Lagrange–d'Alembert, [`crate::forces`]): the nine entries of each
    /// rotation and the ordinary coordinates. A body torque τ (body frame) on rotation R is
    /// the force ½ R τ̂ on its entries (its virtual work tr(Fᵀ δR) with δR = R η̂ is τ·η); a
    /// force f on a point of the body at χ (body frame) is f χᵀ. The action of each element
    /// gains h Σ_i b_i F_i·q(c_i) with F_i frozen at the iterate, so the step equations are
    /// the forced ones and Newton's Jacobian omits the force's derivatives (it converges
    /// linearly, fast for forces small against the inertia). [`Integrator::work`] accumulates
    /// the discrete work h Σ_i b_i F_i·q̇(c_i); the energy balance E_k − E_0 − W_k is then of
    /// the element's order. The tangent map of such a step is not derived: chaos indicators
    /// refuse forced runs with rotations.
    ///
    /// # Errors
    /// As [`Integrator::with_rotations`]; a force of another dimension.
    ///
    /// # Example
    /// ```
    /// use femvi::forces::Force;
    /// use femvi::rotation::{body_state, embedded_velocity, Rotations};
    /// use femvi::{models::RigidBody, Element, Integrator, Scalar, SolverOptions, Start, TimeGrid};
    /// /// The torque τ = −c Π on a body with moments I: on the entries, F = ½ R τ̂.
    /// struct Drag { c: f64, inertia: [f64; 3] }
    /// impl Force for Drag {
    ///     fn dim(&self) -> usize { 9 }
    ///     fn force<D: Scalar>(&self, _t: D, q: &[D], v: &[D], out: &mut [D]) {
    ///         let a = |i: usize, j: usize| q[i] * v[j] + q[3 + i] * v[3 + j] + q[6 + i] * v[6 + j];
    ///         let w = [(a(2, 1) - a(1, 2)) * 0.5, (a(0, 2) - a(2, 0)) * 0.5, (a(1, 0) - a(0, 1)) * 0.5];
    ///         let tau: Vec<D> = (0..3).map(|k| w[k] * (-self.c * self.inertia[k])).collect();
    ///         let hat = [D::from(0.0), -tau[2], tau[1], tau[2], D::from(0.0), -tau[0], -tau[1], tau[0], D::from(0.0)];
    ///         for i in 0..3 {
    ///             for j in 0..3 {
    ///                 out[3 * i + j] = (q[3 * i] * hat[j] + q[3 * i + 1] * hat[3 + j] + q[3 * i + 2] * hat[6 + j]) * 0.5;
    ///             }
    ///         }
    ///     }
    /// }
    /// let inertia = [1.0, 2.0, 3.0];
    /// let body = RigidBody::free(inertia)?;
    /// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
    /// let (element, grid) = (Element::with_order(4)?, TimeGrid::uniform(0.0, 0.01, 1.0)?);
    /// let drag = Drag { c: 0.5, inertia };
    /// let mut it = Integrator::with_rotations_and_force(&body, &element, grid, start, SolverOptions::default(), Rotations::new(9, &[0])?, &drag)?;
    /// while it.step()? {}
    /// // |Π| decays as e^{−ct}: Π̇ = Π × w − c Π.
    /// let (_, pi) = body_state(it.node().q, it.node().p, 0);
    /// let norm = (pi[0] * pi[0] + pi[1] * pi[1] + pi[2] * pi[2]).sqrt();
    /// assert!((norm - (0.25f64 + 4.0 + 0.81).sqrt() * (-0.5f64).exp()).abs() < 1e-8);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn with_rotations_and_force<F: Force + Sync>(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start: Start,
        opts: SolverOptions,
        rotations: Rotations,
        force: &'a F,
    ) -> Result<Self> {
        check_len("force", lag.dim(), force.dim())?;
        Self::rotations_run(lag, element, grid, start, opts, (rotations, false, Some(force)))
    }

    /// The largest symplecticity defect of the steps so far of a run of
    /// [`Integrator::with_rotations_measured`] (or of a constrained run that measures it); None
    /// otherwise.
    pub fn symplecticity_defect(&self) -> Option<f64> {
        self.term_defect()
    }

    /// The run of [`Integrator::with_rotations`], measuring the defect if asked, under a force
    /// if given.
    fn rotations_run(
        lag: &'a L,
        element: &'a Element,
        grid: TimeGrid,
        start: Start,
        opts: SolverOptions,
        (rotations, measured, force): (Rotations, bool, Option<&'a (dyn EmbeddedForce + Sync)>),
    ) -> Result<Self> {
        opts.validate()?;
        element.check_nondegenerate()?;
        let n = lag.dim();
        check_len("rotation layout", n, rotations.dim())?;
        if matches!(opts.method, Method::Explicit | Method::FixedPoint) {
            return Err(invalid(
                "method",
                "runs with rotations are solved by Newton's method in the algebra; choose auto or newton",
            ));
        }
        let (q, p) = match start {
            Start::Velocity { q, v } => {
                check_len("initial q", n, q.len())?;
                check_len("initial v", n, v.len())?;
                if !q.iter().chain(&v).all(|x| x.is_finite()) {
                    return Err(invalid("initial state", "contains a non-finite number"));
                }
                let mut d = PointDerivatives::new(n);
                lag.first_derivatives(grid.t0(), &q, &v, false, &mut d);
                let p = d.l_v().to_vec();
                (q, p)
            }
            Start::Momentum { q, p } => {
                check_len("initial q", n, q.len())?;
                check_len("initial p", n, p.len())?;
                (q, p)
            }
            Start::Positions { .. } => {
                return Err(invalid(
                    "start",
                    "a run with rotations starts from (R0, w0) or (R0, p0), not from two positions",
                ))
            }
        };
        let mut p = p;
        for &o in rotations.offsets() {
            let r = block(&q, o);
            let defect = orthogonality_defect(&r);
            if defect.is_nan() || defect > ORTHOGONALITY_TOLERANCE {
                return Err(invalid(
                    "initial rotation",
                    format!(
                        "the block at coordinate {o} is not a rotation: max |R^T R - 1| = {defect:.3e} (at most {ORTHOGONALITY_TOLERANCE:e})"
                    ),
                ));
            }
            let pi = body_momentum(&r, &block(&p, o));
            p[o..o + 9].copy_from_slice(&embedded_momentum(&r, &pi));
        }
        let mut term = Box::new(RotationTerm::new(lag, element, rotations, opts, force));
        term.defect = measured.then_some(0.0);
        let plain = SolverOptions {
            method: Method::Auto,
            ..opts
        };
        Integrator::with_term(lag, element, grid, Start::Momentum { q, p }, plain, term)
    }
}
