//! Tangent maps of the last step by implicit differentiation of its equations at the solved
//! element: the map ∂(q_{k+1}, p_{k+1})/∂(q_k, p_k) with time steps as parameters, and, in
//! energy mode, the map on extended phase space (q, t; p, −E) whose preservation of
//! dq∧dp − dt∧dE is the paper's (3.6). Both need the element Hessian ∂²L_d/∂Q∂Q (the second
//! also the derivatives in t_k and t_{k+1}).

use super::element_work::{buffers, check_dense_newton};
use super::integrator::Integrator;
use crate::error::{invalid, Error, Result, StepError, StepFailure};
use crate::lagrangian::Lagrangian;

impl<L: Lagrangian> Integrator<'_, L> {
    /// The tangent map ∂(q_{k+1}, p_{k+1})/∂(q_k, p_k) of the last step (row-major 2n×2n), by
    /// implicit differentiation of the step equations at the solved element: with
    /// dQ^0 = dq, dQ^m = dq + dX^m,
    ///   Σ_{m≥1} H_jm dX^m = −δ_j0 dp − (Σ_m H_jm) dq  (j < s),
    ///   dq' = dq + dX^s,  dp' = Σ_m H_sm dQ^m,
    /// where H is the element Hessian ∂²L_d/∂Q∂Q. Exact up to the solver's tolerance. A run
    /// with forces ([`Integrator::with_force`]) adds the discrete forces' derivative ∂F_d/∂Q
    /// to H (`term_tangent.rs`); a constrained run's map lives on the manifold and is refused
    /// here.
    ///
    /// # Errors
    /// No step taken yet, a constrained run, or a singular step Jacobian.
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};
    /// let lag = models::pendulum(1.0, 1.0, 1.0)?;
    /// let element = Element::with_order(4)?;
    /// let start = Start::Velocity { q: vec![1.0], v: vec![0.0] };
    /// let mut it = Integrator::new(&lag, &element, TimeGrid::uniform(0.0, 0.1, 1.0)?, start, SolverOptions::default())?;
    /// it.step()?;
    /// let m = it.tangent_map()?; // 2×2, row-major
    /// // Symplectic in one degree of freedom: the determinant is 1.
    /// assert!((m[0] * m[3] - m[1] * m[2] - 1.0).abs() < 1e-13);
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn tangent_map(&mut self) -> Result<Vec<f64>> {
        if self.term.is_some() {
            return self.term_tangent_map();
        }
        if !self.last.valid {
            return Err(invalid("tangent map", "no step has been taken"));
        }
        let n = self.state.n;
        check_dense_newton(&self.element, n)?;
        let s = self.element.degree();
        let w = (s + 1) * n;
        let (t, h) = (self.last.t, self.last.h);
        let (ework, grad, hess) = buffers(&mut self.bufs, &self.element, n).with_hessian();
        self.element
            .hessian_in_place(&*self.lag, t, h, &self.last.base, &self.last.incr, ework, grad, hess);
        let hess = &*hess;
        let dim = s * n;
        let jac = nalgebra::DMatrix::from_fn(dim, dim, |a, b| hess[a * w + n + b]);
        let lu = jac.lu();
        // Row sums over node blocks: (Σ_m H_jm) for rows a, component c.
        let sum_cols = |a: usize, c: usize| (0..=s).map(|m| hess[a * w + m * n + c]).sum::<f64>();
        let mut out = vec![0.0; 4 * n * n];
        for col in 0..2 * n {
            // Direction: dq = e_col (col < n) or dp = e_{col-n}.
            let mut rhs = nalgebra::DVector::zeros(dim);
            for a in 0..dim {
                rhs[a] = if col < n {
                    -sum_cols(a, col)
                } else if a == col - n {
                    -1.0
                } else {
                    0.0
                };
            }
            let dx = lu.solve(&rhs).ok_or_else(|| {
                Error::Step(StepError {
                    step: self.state.k.saturating_sub(1),
                    t,
                    residual: f64::NAN,
                    iterations: 0,
                    failure: StepFailure::Singular,
                })
            })?;
            for c in 0..n {
                let dq0 = if col < n && c == col { 1.0 } else { 0.0 };
                // dq' = dq + dX^s.
                out[c * 2 * n + col] = dq0 + dx[(s - 1) * n + c];
                // dp' = Σ_m H_sm dQ^m, dQ^0 = dq, dQ^m = dq + dX^m.
                let row = (s * n + c) * w;
                let mut acc = 0.0;
                for m in 0..=s {
                    for e in 0..n {
                        let dq = if col < n && e == col { 1.0 } else { 0.0 };
                        let dqm = if m == 0 { dq } else { dq + dx[(m - 1) * n + e] };
                        acc += hess[row + m * n + e] * dqm;
                    }
                }
                out[(n + c) * 2 * n + col] = acc;
            }
        }
        Ok(out)
    }

    /// [`Integrator::tangent_map`] of a step under a force term (`term_tangent.rs`): the map
    /// applied to the 2n unit vectors, row-major.
    fn term_tangent_map(&mut self) -> Result<Vec<f64>> {
        let d = 2 * self.state.n;
        let mut w: Vec<f64> = (0..d * d).map(|i| if i % d == i / d { 1.0 } else { 0.0 }).collect();
        self.term_tangent_apply(&mut w)?;
        // Column j of w is the image of e_j: transpose into row-major.
        Ok((0..d * d).map(|i| w[(i % d) * d + i / d]).collect())
    }

    /// The tangent map of the last energy-mode step on extended phase space, in the canonical
    /// variables (q, t; p, −E) (row-major, 2(n+1) square, ordered q_1 … q_n, t, p_1 … p_n, −E).
    /// The step equations R_j = δ_j0 p_k + ∂L_d/∂Q^j (j < s) and R_E = ∂L_d/∂t_k − E_k are
    /// differentiated implicitly for (dX, dt_{k+1}), with the full Hessian F of L_d in
    /// (t_k, t_{k+1}, Q); then q' = q_k + X^s, t' = t_{k+1}, p' = ∂L_d/∂Q^s, E' = −∂L_d/∂t_{k+1}.
    /// The paper's (3.6) says this map preserves dq∧dp − dt∧dE. A step taken with h as a
    /// parameter (the first one, which fixes the discrete energy, or one counted as
    /// degenerate) has dt_{k+1} = dt_k in place of the energy equation, and its E' does not
    /// depend on the incoming E.
    ///
    /// For degree ≥ 2 the discrete energy depends on h only weakly (its slope g_h is
    /// O(h^{2s−1})), so entries of this map through dh are of size 1/g_h (~5·10⁵ for degree 2
    /// at h = 0.1) and a product of such maps loses digits to cancellation; to carry vectors
    /// through many steps use [`Integrator::extended_tangent_apply`], which solves the
    /// linearised step for each vector and keeps the vectors' rounding at O(ε).
    ///
    /// # Errors
    /// Not in energy mode, no variable step taken yet, or a singular system.
    pub fn extended_tangent_map(&mut self) -> Result<Vec<f64>> {
        let d = 2 * (self.state.n + 1);
        let mut out = vec![0.0; d * d];
        let sys = self.extended_system()?;
        let (mut x, mut y) = (vec![0.0; d], vec![0.0; d]);
        for col in 0..d {
            x.iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = if i == col { 1.0 } else { 0.0 });
            self.extended_solve(&sys, &x, &mut y)?;
            for (row, v) in y.iter().enumerate() {
                out[row * d + col] = *v;
            }
        }
        Ok(out)
    }

    /// Carries `vectors` (column-major, each of length 2(n+1) in the variables of
    /// [`Integrator::extended_tangent_map`]) through the last energy-mode step's tangent map,
    /// in place: one factorisation, then one linearised solve per vector. The result equals
    /// the map times the vectors, but its rounding stays O(ε) per step where the product with
    /// the assembled map loses digits to entries of size 1/g_h (see there).
    ///
    /// # Errors
    /// As [`Integrator::extended_tangent_map`]; a length that is not a multiple of 2(n+1).
    ///
    /// # Example
    ///
    /// ```
    /// use femvi::{models, Element, EnergyOptions, Integrator, SolverOptions, Start, TimeGrid};
    /// let lag = models::henon_heiles();
    /// let el = Element::with_order(4)?;
    /// let start = Start::Momentum { q: vec![0.1, -0.05], p: vec![0.2, 0.3] };
    /// let grid = TimeGrid::uniform(0.0, 0.1, 10.0)?;
    /// let mut it = Integrator::with_energy(&lag, &el, grid, start, SolverOptions::default(), EnergyOptions::from_step(0.1))?;
    /// it.step()?;
    /// it.step()?;
    /// // The unit vector in q_1, carried: the first column of the map.
    /// let mut v = vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    /// it.extended_tangent_apply(&mut v)?;
    /// let m = it.extended_tangent_map()?;
    /// for i in 0..6 {
    ///     assert!((v[i] - m[i * 6]).abs() <= 1e-9 * m[i * 6].abs().max(1.0));
    /// }
    /// # Ok::<(), femvi::Error>(())
    /// ```
    pub fn extended_tangent_apply(&mut self, vectors: &mut [f64]) -> Result<()> {
        let d = 2 * (self.state.n + 1);
        if !vectors.len().is_multiple_of(d) {
            return Err(Error::Dimension {
                what: "extended tangent vectors".into(),
                expected: d,
                got: vectors.len() % d,
            });
        }
        let sys = self.extended_system()?;
        let mut y = vec![0.0; d];
        for v in vectors.chunks_exact_mut(d) {
            self.extended_solve(&sys, v, &mut y)?;
            v.copy_from_slice(&y);
        }
        Ok(())
    }

    /// The full Hessian of the last element and the factorised linearised step equations.
    fn extended_system(&mut self) -> Result<ExtendedSystem> {
        if self.energy.is_none() || !self.last.valid {
            return Err(invalid("extended tangent map", "needs a step taken in energy mode"));
        }
        let n = self.state.n;
        check_dense_newton(&self.element, n)?;
        let s = self.element.degree();
        let (t0, h) = (self.last.t, self.last.h);
        let (_, _, f) = self
            .element
            .full_hessian(&*self.lag, t0, h, &self.last.base, &self.last.incr);
        let m = 2 + (s + 1) * n;
        let fz = |a: usize, b: usize| f[a * m + b];
        let qi = |j: usize, c: usize| 2 + j * n + c;
        let dim = s * n + 1;
        // Unknowns: dX^m (m = 1..=s), then dt_{k+1}. Rows: R_j (j < s), then R_E.
        let mut jac = nalgebra::DMatrix::from_fn(dim, dim, |row, col| {
            let rz = if row < s * n { qi(row / n, row % n) } else { 0 };
            if col < s * n {
                fz(rz, qi(col / n + 1, col % n))
            } else {
                fz(rz, 1)
            }
        });
        let fresh = self.state.k == 1 || self.energy.as_ref().is_some_and(|e| e.last_fresh);
        if fresh {
            // The step was taken with h as a parameter (the first one, or a degenerate one):
            // its row is dt_{k+1} − dt_k = 0 instead of the energy equation, and E' is the
            // element's own, independent of the incoming E.
            jac.row_mut(s * n).fill(0.0);
            jac[(s * n, s * n)] = 1.0;
        }
        Ok(ExtendedSystem {
            f,
            lu: jac.lu(),
            fresh,
            t0,
        })
    }

    /// One vector x = (dq, dt, dp, −dE) through the linearised step: y = the map times x.
    fn extended_solve(&self, sys: &ExtendedSystem, x: &[f64], y: &mut [f64]) -> Result<()> {
        let n = self.state.n;
        let s = self.element.degree();
        let m = 2 + (s + 1) * n;
        let fz = |a: usize, b: usize| sys.f[a * m + b];
        // Indices into z: τ0 = 0, τ1 = 1, Q^j component c = 2 + j n + c.
        let qi = |j: usize, c: usize| 2 + j * n + c;
        let dim = s * n + 1;
        let (dq, dt0, dp, neg_de) = (&x[..n], x[n], &x[n + 1..2 * n + 1], x[2 * n + 1]);
        // dQ^j = dq + dX^j contributes Σ_m F_{r,Q^m} dq through all nodes (translation).
        let translation = |rz: usize| {
            (0..=s)
                .map(|j| (0..n).map(|c| fz(rz, qi(j, c)) * dq[c]).sum::<f64>())
                .sum::<f64>()
        };
        let mut rhs = nalgebra::DVector::zeros(dim);
        for row in 0..dim {
            let rz = if row < s * n { qi(row / n, row % n) } else { 0 };
            let mut r = translation(rz) + fz(rz, 0) * dt0;
            if row < n {
                r += dp[row];
            }
            if row == s * n && neg_de != 0.0 {
                // −dE_k, the incoming variable being −E (skipped at zero, which keeps the
                // sign of a zero sum as it was).
                r += neg_de;
            }
            rhs[row] = if sys.fresh && row == s * n { dt0 } else { -r };
        }
        let sol = sys.lu.solve(&rhs).ok_or_else(|| {
            Error::Step(StepError {
                step: self.state.k.saturating_sub(1),
                t: sys.t0,
                residual: f64::NAN,
                iterations: 0,
                failure: StepFailure::Singular,
            })
        })?;
        let dx = |j: usize, c: usize| if j == 0 { 0.0 } else { sol[(j - 1) * n + c] };
        let dt1 = sol[s * n];
        // Differential of ∂L_d/∂z_r along the solution.
        let along = |rz: usize| {
            let mut acc = fz(rz, 0) * dt0 + fz(rz, 1) * dt1;
            for j in 0..=s {
                for c in 0..n {
                    acc += fz(rz, qi(j, c)) * (dq[c] + dx(j, c));
                }
            }
            acc
        };
        for c in 0..n {
            y[c] = dq[c] + dx(s, c);
            y[n + 1 + c] = along(qi(s, c));
        }
        y[n] = dt1;
        // E' = −∂L_d/∂t_{k+1}; the variable is −E' = ∂L_d/∂t_{k+1}.
        y[2 * n + 1] = along(1);
        Ok(())
    }
}

/// The linearised energy-mode step: the full Hessian of L_d in (t_k, t_{k+1}, Q) and the LU
/// of the step Jacobian for (dX, dt_{k+1}).
struct ExtendedSystem {
    f: Vec<f64>,
    lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    fresh: bool,
    t0: f64,
}
