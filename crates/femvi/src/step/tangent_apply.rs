//! The one entry for tangent vectors of runs in (q, p), [`Integrator::tangent_apply`]: it
//! picks the cheapest exact route the run allows (issue 39, item 1) — the forced step's
//! linearisation (`term_tangent.rs`), the (q, p) block of the energy-mode map (`tangent.rs`),
//! the mechanical tangent in the fixed-point step's structure (`tangent_mechanical.rs`), or
//! the dense map by implicit differentiation (`tangent.rs`).

use super::integrator::Integrator;
use super::tangent_mechanical::{MechanicalTangent, StepElement};
use crate::error::{invalid, Error, Result};
use crate::lagrangian::Lagrangian;

/// Index of (q, p) component i (i < 2n) among the extended variables (q, t, p, −E) of
/// [`Integrator::extended_tangent_map`].
pub(crate) fn extended_index(i: usize, n: usize) -> usize {
    if i < n {
        i
    } else {
        i + 1
    }
}

impl<L: Lagrangian> Integrator<'_, L> {
    /// The length of one tangent vector of [`Integrator::tangent_apply`]: 2n for (δq, δp);
    /// for a run with rotations ([`Integrator::with_rotations`]) 6 per rotation and 2 per
    /// ordinary coordinate, the canonical chart coordinates (ψ, p_ψ) of T*SO(3)
    /// (`rotation/tangent.rs`: R = R_k exp(ψ̂) about the node, ψ in the body frame).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::rotation::{embedded_velocity, Rotations};
    /// use femvi::{models::RigidBody, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let body = RigidBody::free([1.0, 2.0, 3.0])?;
    /// let r0 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let start = Start::Velocity { q: r0.to_vec(), v: embedded_velocity(&r0, &[0.5, 1.0, 0.3]).to_vec() };
    /// let element = Element::with_order(2)?;
    /// let grid = TimeGrid::uniform(0.0, 0.01, 1.0)?;
    /// let it = Integrator::with_rotations(&body, &element, grid, start, SolverOptions::default(), Rotations::new(9, &[0])?)?;
    /// assert_eq!(it.tangent_dim(), 6);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn tangent_dim(&self) -> usize {
        self.term
            .as_ref()
            .and_then(|term| term.chart_dim())
            .unwrap_or(2 * self.state.n)
    }

    /// Carries `vectors` (each (δq, δp) of length 2n, one after another) through the tangent
    /// map of the last step, in place: the one entry for tangent vectors of every run whose
    /// steps live in (q, p). It takes the cheapest exact route the run allows:
    /// - with rotations, the Lie-group step's Jacobian in canonical chart coordinates, on
    ///   vectors of length [`Integrator::tangent_dim`] (`rotation/tangent.rs`);
    /// - with forces, the forced step's linearisation (`term_tangent.rs`);
    /// - in energy mode, the (q, p) block of the extended map, each vector extended by
    ///   dt = dE = 0 and solved through the linearised step ([`Integrator::extended_tangent_apply`]);
    /// - for a mechanical Lagrangian (a mass matrix), the variational equations solved in the
    ///   structure of the fixed-point step on products of the force's derivative
    ///   ([`Lagrangian::force_derivative`], `tangent_mechanical.rs`), whichever solver took
    ///   the step;
    /// - otherwise (or when those sweeps do not converge), [`Integrator::tangent_map`] times
    ///   the vectors.
    ///
    /// All routes agree with the dense map to the solver's tolerance (tests: `tangent_routes`).
    ///
    /// # Errors
    /// A length that is not a multiple of 2n, no step taken yet, a constrained run (its map
    /// lives on the manifold: [`crate::chaos::constrained_indicators`]), or a singular
    /// linearised step.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let lag = models::henon_heiles();
    /// let element = Element::with_order(4)?;
    /// let start = Start::Momentum { q: vec![0.1, -0.05], p: vec![0.2, 0.3] };
    /// let mut it = Integrator::new(&lag, &element, TimeGrid::uniform(0.0, 0.1, 1.0)?, start, SolverOptions::default())?;
    /// it.step()?;
    /// // The unit vector in q_1: the first column of the map.
    /// let mut v = vec![1.0, 0.0, 0.0, 0.0];
    /// it.tangent_apply(&mut v)?;
    /// let m = it.tangent_map()?;
    /// for i in 0..4 {
    ///     assert!((v[i] - m[i * 4]).abs() < 1e-12);
    /// }
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn tangent_apply(&mut self, vectors: &mut [f64]) -> Result<()> {
        let d = self.tangent_dim();
        if d == 0 || !vectors.len().is_multiple_of(d) {
            return Err(Error::Dimension {
                what: "tangent vectors".into(),
                expected: d,
                got: if d == 0 { vectors.len() } else { vectors.len() % d },
            });
        }
        if let Some(chart) = self.term.as_mut().and_then(|term| term.chart_tangent()) {
            if !self.last.valid {
                return Err(invalid("tangent map", "no step has been taken"));
            }
            let m = chart?;
            let mut tmp = vec![0.0; d];
            for v in vectors.chunks_exact_mut(d) {
                for (i, t) in tmp.iter_mut().enumerate() {
                    *t = (0..d).map(|j| m[(i, j)] * v[j]).sum();
                }
                v.copy_from_slice(&tmp);
            }
            return Ok(());
        }
        if self.term.is_some() {
            return self.term_tangent_apply(vectors);
        }
        if !self.last.valid {
            return Err(invalid("tangent map", "no step has been taken"));
        }
        if self.energy.is_some() {
            return self.energy_block_apply(vectors);
        }
        if self.mechanical_tangent_apply(vectors)? {
            return Ok(());
        }
        let m = self.tangent_map()?;
        let mut tmp = vec![0.0; d];
        for v in vectors.chunks_exact_mut(d) {
            for (i, t) in tmp.iter_mut().enumerate() {
                *t = m[i * d..(i + 1) * d].iter().zip(v.iter()).map(|(a, b)| a * b).sum();
            }
            v.copy_from_slice(&tmp);
        }
        Ok(())
    }

    /// Carries `vectors` through the last step by the mechanical tangent
    /// (`tangent_mechanical.rs`, its tables made at the first call); Ok(false), vectors
    /// unchanged, when it does not apply (no mass matrix, a degenerate element) or its sweeps
    /// did not converge.
    fn mechanical_tangent_apply(&mut self, vectors: &mut [f64]) -> Result<bool> {
        let n = self.state.n;
        let Some(mass) = self.lag.mass_matrix() else {
            return Ok(false);
        };
        if n == 0 || self.element.degree() == 0 {
            return Ok(false);
        }
        if self.mech_tangent.is_none() {
            self.mech_tangent = MechanicalTangent::new(&self.element, n).map(Box::new);
        }
        let Some(mt) = self.mech_tangent.as_deref_mut() else {
            return Ok(false);
        };
        let el = StepElement {
            t0: self.last.t,
            h: self.last.h,
            base: &self.last.base,
            incr: &self.last.incr,
        };
        Ok(mt.apply((&*self.lag, mass, &self.element), el, &self.opts, vectors))
    }

    /// The (q, p) block of the energy-mode map on `vectors`: each extended by dt = dE = 0
    /// (variables q, t, p, −E) and solved through the linearised step.
    fn energy_block_apply(&mut self, vectors: &mut [f64]) -> Result<()> {
        let n = self.state.n;
        let (d, de) = (2 * n, 2 * n + 2);
        let at = |i: usize| extended_index(i, n);
        let count = vectors.len() / d;
        let mut ext = vec![0.0; count * de];
        for (k, col) in vectors.chunks_exact(d).enumerate() {
            for (i, x) in col.iter().enumerate() {
                ext[k * de + at(i)] = *x;
            }
        }
        self.extended_tangent_apply(&mut ext)?;
        for (k, col) in vectors.chunks_exact_mut(d).enumerate() {
            for (i, x) in col.iter_mut().enumerate() {
                *x = ext[k * de + at(i)];
            }
        }
        Ok(())
    }
}
