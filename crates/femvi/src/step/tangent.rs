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
    /// solved element: with dQ^0 = dq, dQ^m = dq + dX^m,
    ///   Σ_{m≥1} H_jm dX^m = −δ_j0 dp − (Σ_m H_jm) dq  (j < s),
    ///   dq' = dq + dX^s,  dp' = Σ_m H_sm dQ^m,
    /// where H is the element Hessian ∂²L_d/∂Q∂Q. Exact up to the solver's tolerance.
    ///
    /// # Errors
    /// No step taken yet, or a singular step Jacobian.
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
    /// # Errors
    /// Not in energy mode, no variable step taken yet, or a singular system.
    pub fn extended_tangent_map(&mut self) -> Result<Vec<f64>> {
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
        // Indices into z: τ0 = 0, τ1 = 1, Q^j component c = 2 + j n + c.
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
        let lu = jac.lu();
        let d = 2 * (n + 1);
        let mut out = vec![0.0; d * d];
        // Inputs in the order (q_1..q_n, t, p_1..p_n, −E).
        for col in 0..d {
            let dq = |c: usize| if col < n && c == col { 1.0 } else { 0.0 };
            let dt0 = if col == n { 1.0 } else { 0.0 };
            let dp = |c: usize| {
                if col > n && col < 2 * n + 1 && c == col - n - 1 {
                    1.0
                } else {
                    0.0
                }
            };
            let de = if col == 2 * n + 1 { -1.0 } else { 0.0 }; // the variable is −E
                                                                // dQ^j = dq + dX^j contributes Σ_m F_{r,Q^m} dq through all nodes (translation).
            let translation = |rz: usize| {
                (0..=s)
                    .map(|j| (0..n).map(|c| fz(rz, qi(j, c)) * dq(c)).sum::<f64>())
                    .sum::<f64>()
            };
            let mut rhs = nalgebra::DVector::zeros(dim);
            for row in 0..dim {
                let rz = if row < s * n { qi(row / n, row % n) } else { 0 };
                let mut r = translation(rz) + fz(rz, 0) * dt0;
                if row < n {
                    r += dp(row);
                }
                if row == s * n {
                    r -= de;
                }
                rhs[row] = if fresh && row == s * n { dt0 } else { -r };
            }
            let sol = lu.solve(&rhs).ok_or_else(|| {
                Error::Step(StepError {
                    step: self.state.k.saturating_sub(1),
                    t: t0,
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
                        acc += fz(rz, qi(j, c)) * (dq(c) + dx(j, c));
                    }
                }
                acc
            };
            for c in 0..n {
                out[c * d + col] = dq(c) + dx(s, c);
                out[(n + 1 + c) * d + col] = along(qi(s, c));
            }
            out[n * d + col] = dt1;
            // E' = −∂L_d/∂t_{k+1}; the variable is −E' = ∂L_d/∂t_{k+1}.
            out[(2 * n + 1) * d + col] = along(1);
        }
        Ok(out)
    }
}
