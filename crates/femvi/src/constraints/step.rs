//! One constrained step: the residual and Jacobian of the augmented element equations (the
//! `//!` of [`crate::constraints`] derives them), assembled over all columns (Q^0 … Q^s and the
//! multipliers) and all node rows (0 … s), so that the Newton matrix (Q^0 columns and node-s
//! rows left out), the new momentum p̃ = ∂L_d^aug/∂Q^s and the tangent map (which also needs the
//! Q^0 columns and the node-s rows) come from one assembly.

use super::jet::ConstraintJet;
use super::layout::Layout;
use super::Constraints;
use crate::bvp::ElementTerm;
use crate::discrete::{Element, ElementWork};
use crate::lagrangian::Lagrangian;

/// Buffers and sizes of the constrained step equations of one element.
#[derive(Debug, Clone)]
pub(crate) struct StepSystem {
    pub n: usize,
    pub m: usize,
    pub s: usize,
    pub layout: Layout,
    /// Rows (= columns) of the full system: (s+1)n + m + I m.
    pub full: usize,
    /// Full residual: node rows 0 … s, then g(Q^s), then the interior constraint rows.
    pub res: Vec<f64>,
    /// Full Jacobian, row-major `full` × `full` (columns Q^0 … Q^s, λ̂, Λ̂).
    pub jac: Vec<f64>,
    incr: Vec<f64>,
    grad: Vec<f64>,
    hess: Vec<f64>,
    ework: ElementWork,
    /// Jets at the evaluation points, at q_k (start) and at Q^s (end).
    pub jets: Vec<ConstraintJet>,
    pub start: ConstraintJet,
    pub end: ConstraintJet,
    lam_at: Vec<f64>,
    y: Vec<f64>,
    /// The multipliers λ̂, Λ̂ of the last evaluation (the unknowns hold h·λ̂, h·Λ̂, so that
    /// their round-off is on the scale of the positions and the Newton tolerance fits both).
    pub mult: Vec<f64>,
    /// p̃ by the sums of the node rows ([`StepSystem::momentum_by_sums`]).
    ptilde: Vec<f64>,
    /// The element term of the last [`StepSystem::add_term`] (the discrete forces F_d^j of
    /// the node rows) and its derivative in the nodal values.
    term_grad: Vec<f64>,
    term_hess: Vec<f64>,
    /// Whether a term was added since the last [`StepSystem::eval`].
    forced: bool,
}

impl StepSystem {
    pub fn new(element: &Element, layout: Layout, n: usize, m: usize) -> Self {
        let s = element.degree();
        let w = s + 1;
        let full = w * n + m + layout.sites * m;
        Self {
            n,
            m,
            s,
            full,
            res: vec![0.0; full],
            jac: vec![0.0; full * full],
            incr: vec![0.0; w * n],
            grad: vec![0.0; w * n],
            hess: vec![0.0; w * n * w * n],
            ework: ElementWork::new(element, n),
            jets: (0..layout.points).map(|_| ConstraintJet::new(m, n)).collect(),
            start: ConstraintJet::new(m, n),
            end: ConstraintJet::new(m, n),
            lam_at: vec![0.0; layout.points * m],
            ptilde: vec![0.0; n],
            y: vec![0.0; n],
            mult: vec![0.0; m + layout.sites * m],
            term_grad: vec![],
            term_hess: vec![],
            forced: false,
            layout,
        }
    }

    /// Number of Newton unknowns: s n + m + I m.
    pub fn unknowns(&self) -> usize {
        self.full - self.n
    }

    /// Full row of Newton row `i`: node rows 0 … s−1 and the constraint rows (node-s rows
    /// left out). Newton column j is full column j + n (the Q^0 columns left out).
    pub fn newton_row(&self, i: usize) -> usize {
        if i < self.s * self.n {
            i
        } else {
            i + self.n
        }
    }

    /// Evaluates the full residual (and the full Jacobian if `with_jac`) at the Newton
    /// unknowns `x` (increments Q^j − q_k, then h·λ̂, h·Λ̂). `start` must hold the jet at q_k (with
    /// second derivatives if `with_jac`).
    #[allow(clippy::too_many_arguments)]
    pub fn eval<L: Lagrangian, C: Constraints>(
        &mut self,
        element: &Element,
        lag: &L,
        con: &C,
        t0: f64,
        h: f64,
        qk: &[f64],
        pk: &[f64],
        x: &[f64],
        with_jac: bool,
    ) {
        let (n, m, s) = (self.n, self.m, self.s);
        let w = s + 1;
        self.forced = false;
        self.incr[..n].iter_mut().for_each(|v| *v = 0.0);
        self.incr[n..].copy_from_slice(&x[..s * n]);
        if with_jac {
            element.hessian_in_place(
                lag,
                t0,
                h,
                qk,
                &self.incr,
                &mut self.ework,
                &mut self.grad,
                &mut self.hess,
            );
        } else {
            element.gradient_in_place(lag, t0, h, qk, &self.incr, false, &mut self.ework, &mut self.grad);
        }
        for (l, xl) in self.mult.iter_mut().zip(&x[s * n..]) {
            *l = xl / h;
        }
        let (lam_start, sites) = self.mult.split_at(m);
        let lay = &self.layout;
        // Points, jets and multipliers there.
        for i in 0..lay.points {
            self.y.copy_from_slice(qk);
            for j in 1..w {
                let a = lay.a[i * w + j];
                for c in 0..n {
                    self.y[c] += a * self.incr[j * n + c];
                }
            }
            self.jets[i].eval(con, &self.y, with_jac);
            let li = &mut self.lam_at[i * m..(i + 1) * m];
            li.iter_mut().for_each(|v| *v = 0.0);
            for c in 0..lay.sites {
                let psi = lay.psi[i * lay.sites + c];
                for l in 0..m {
                    li[l] += psi * sites[c * m + l];
                }
            }
        }
        self.y.copy_from_slice(qk);
        for c in 0..n {
            self.y[c] += self.incr[s * n + c];
        }
        self.end.eval(con, &self.y, with_jac);
        // Node rows.
        self.res[..w * n].copy_from_slice(&self.grad);
        for (r, p) in self.res[..n].iter_mut().zip(pk) {
            *r += p;
        }
        self.start.add_transpose_times(lam_start, -1.0, &mut self.res[..n]);
        for i in 0..lay.points {
            let li = &self.lam_at[i * m..(i + 1) * m];
            for j in 0..w {
                let coef = -lay.a[i * w + j] * lay.omega[i];
                if coef != 0.0 {
                    self.jets[i].add_transpose_times(li, coef, &mut self.res[j * n..(j + 1) * n]);
                }
            }
        }
        // Constraint rows.
        let (end_row, site_row) = (w * n, w * n + m);
        self.res[end_row..site_row].copy_from_slice(&self.end.g);
        self.res[site_row..].iter_mut().for_each(|v| *v = 0.0);
        for i in 0..lay.points {
            for c in 0..lay.sites {
                let f = lay.omega[i] * lay.psi[i * lay.sites + c];
                for l in 0..m {
                    self.res[site_row + c * m + l] += f * self.jets[i].g[l];
                }
            }
        }
        if with_jac {
            self.assemble_jacobian(h);
        }
    }

    fn assemble_jacobian(&mut self, h: f64) {
        let lam_start = &self.mult[..self.m];
        let (n, m, s) = (self.n, self.m, self.s);
        let (w, f) = (s + 1, self.full);
        let wn = w * n;
        let lay = &self.layout;
        let jac = &mut self.jac;
        jac.iter_mut().for_each(|v| *v = 0.0);
        for rj in 0..wn {
            jac[rj * f..rj * f + wn].copy_from_slice(&self.hess[rj * wn..(rj + 1) * wn]);
        }
        self.start.add_contracted_hessian(lam_start, -1.0, jac, f, 0, 0);
        for i in 0..lay.points {
            let li = &self.lam_at[i * m..(i + 1) * m];
            let jet = &self.jets[i];
            for j in 0..w {
                for mm in 0..w {
                    let coef = -lay.a[i * w + j] * lay.a[i * w + mm] * lay.omega[i];
                    if coef != 0.0 {
                        jet.add_contracted_hessian(li, coef, jac, f, j * n, mm * n);
                    }
                }
            }
        }
        // Node row 0, column λ̂: −G(q_k)ᵀ.
        for a in 0..n {
            for l in 0..m {
                jac[a * f + wn + l] = -self.start.jac[l * n + a];
            }
        }
        // Node rows, columns Λ̂_c; constraint rows c, columns Q^m.
        let site_col = wn + m;
        for i in 0..lay.points {
            let jet = &self.jets[i];
            for c in 0..lay.sites {
                let wp = lay.omega[i] * lay.psi[i * lay.sites + c];
                for j in 0..w {
                    let coef = lay.a[i * w + j] * wp;
                    if coef == 0.0 {
                        continue;
                    }
                    for a in 0..n {
                        for l in 0..m {
                            let g = coef * jet.jac[l * n + a];
                            jac[(j * n + a) * f + site_col + c * m + l] -= g;
                            jac[(site_col + c * m + l) * f + j * n + a] += g;
                        }
                    }
                }
            }
        }
        // End row: G(Q^s) in columns Q^s.
        for l in 0..m {
            for a in 0..n {
                jac[(wn + l) * f + s * n + a] = self.end.jac[l * n + a];
            }
        }
        // The unknowns are h times the multipliers.
        for row in jac.chunks_exact_mut(f) {
            row[wn..].iter_mut().for_each(|v| *v /= h);
        }
    }

    /// Adds `term` of the element [t0, t0 + h] with first node `qk` (the discrete forces) to
    /// the node rows of the last [`StepSystem::eval`] (same `qk`, `t0`, `h`) and, if
    /// `with_jac`, its derivatives in the nodal values to the Jacobian (Q^0 columns included,
    /// for the tangent map). [`StepSystem::momentum_by_sums`] then adds the term too.
    pub fn add_term(&mut self, term: &dyn ElementTerm, t0: f64, h: f64, qk: &[f64], with_jac: bool) {
        let wn = (self.s + 1) * self.n;
        self.term_grad.resize(wn, 0.0);
        self.term_grad.iter_mut().for_each(|v| *v = 0.0);
        let hess = if with_jac {
            self.term_hess.resize(wn * wn, 0.0);
            self.term_hess.iter_mut().for_each(|v| *v = 0.0);
            Some(&mut self.term_hess[..])
        } else {
            None
        };
        term.add(t0, h, qk, &self.incr, &mut self.term_grad, hess);
        for (r, g) in self.res[..wn].iter_mut().zip(&self.term_grad) {
            *r += g;
        }
        if with_jac {
            let f = self.full;
            for i in 0..wn {
                for j in 0..wn {
                    self.jac[i * f + j] += self.term_hess[i * wn + j];
                }
            }
        }
        self.forced = true;
    }

    /// −h Σ_i b_i ∂L/∂t(c_i) along the element of the last [`StepSystem::eval`] (first node
    /// `qk`); overwrites the element's scratch (evaluate again before reading the rows).
    pub fn time_work<L: Lagrangian>(&mut self, element: &Element, lag: &L, t0: f64, h: f64, qk: &[f64]) -> f64 {
        element.gradient_in_place(lag, t0, h, qk, &self.incr, true, &mut self.ework, &mut self.grad);
        (0..element.points())
            .map(|i| -h * element.rule.weights[i] * self.ework.pts[i].l_t())
            .sum()
    }

    /// The nodal increments Q^j − q_k (j = 0 … s, the first block zero) of the last
    /// [`StepSystem::eval`].
    pub fn increments(&self) -> &[f64] {
        &self.incr
    }

    /// Copies the Newton residual (node rows 0 … s−1 and the constraint rows) into `r`.
    pub fn newton_residual(&self, r: &mut [f64]) {
        for (i, ri) in r.iter_mut().enumerate() {
            *ri = self.res[self.newton_row(i)];
        }
    }

    /// Copies the Newton Jacobian into `jac` (row-major, `unknowns()`²).
    pub fn newton_jacobian(&self, jac: &mut [f64]) {
        let k = self.unknowns();
        for i in 0..k {
            let ri = self.newton_row(i);
            for j in 0..k {
                jac[i * k + j] = self.jac[ri * self.full + j + self.n];
            }
        }
    }

    /// p̃ = ∂L_d^aug/∂Q^s without the end multiplier (node row s of the last evaluation).
    pub fn momentum_before_projection(&self) -> &[f64] {
        &self.res[self.s * self.n..(self.s + 1) * self.n]
    }

    /// The same p̃ from the sums of all node rows, for a last evaluation at a solution of rows
    /// 0 … s−1 (the basis values at each point sum to 1 and their derivatives to 0):
    ///
    ///   p̃ = p_k + [h Σ_i b_i ∂L/∂q(c_i) − G(q_k)ᵀλ̂ − Σ_i ω_i G(y_i)ᵀλ_i],
    ///
    /// as the unconstrained Newton step updates p; with a term added ([`StepSystem::add_term`])
    /// also its sum over the nodes, Σ_j F_d^j = h Σ_i b_i F(c_i) (`crate::forces`). Equal to node row s in exact arithmetic,
    /// but a small correction added to p_k: row s sums terms of the size of p that cancel, and
    /// their rounding, a deterministic function of the state, made the vertical angular
    /// momentum of the spherical pendulum drift by 3e-17 per step at degree ≥ 2.
    /// Read it with [`StepSystem::summed_momentum`].
    pub fn momentum_by_sums(&mut self, element: &Element, pk: &[f64], h: f64) {
        let (n, m) = (self.n, self.m);
        let d = &mut self.ptilde;
        for (c, dc) in d.iter_mut().enumerate() {
            *dc = h
                * (0..element.points())
                    .map(|i| element.rule.weights[i] * self.ework.pts[i].l_q()[c])
                    .sum::<f64>();
        }
        if self.forced {
            for (c, dc) in d.iter_mut().enumerate() {
                *dc += (0..=self.s).map(|j| self.term_grad[j * n + c]).sum::<f64>();
            }
        }
        self.start.add_transpose_times(&self.mult[..m], -1.0, d);
        for i in 0..self.layout.points {
            let li = &self.lam_at[i * m..(i + 1) * m];
            self.jets[i].add_transpose_times(li, -self.layout.omega[i], d);
        }
        for (dc, p) in d.iter_mut().zip(pk).take(n) {
            *dc += p;
        }
    }

    /// Replaces node row 0 of the last evaluation (and term) by its equal in exact arithmetic
    /// p̃ − Σ_{j≥1} (node row j), p̃ by [`StepSystem::momentum_by_sums`] (issue 21's residual
    /// form, as in `crate::step`'s Newton step): the basis functions sum to 1, so the node rows
    /// without p_k sum to p̃ − p_k. Then the momentum the step returns, p̃ by the sums, is the
    /// one the solved equations define, to round-off of p̃'s size rather than of the cancelling
    /// row terms: with p_k + row 0 the difference had the same sign every step and the
    /// vertical angular momentum of the spherical pendulum (degree 1, trapezoid, h = 2⁻⁷)
    /// drifted by 2e-18 per step. Initial value steps only: the BVP keeps row 0 as it is
    /// (its rows of neighbouring elements are added, and there is no p_k).
    pub fn summed_row_zero(&mut self, element: &Element, pk: &[f64], h: f64) {
        self.momentum_by_sums(element, pk, h);
        let (n, w) = (self.n, self.s + 1);
        for c in 0..n {
            let rows: f64 = (1..w).map(|j| self.res[j * n + c]).sum();
            self.res[c] = self.ptilde[c] - rows;
        }
    }

    /// p̃ of the last [`StepSystem::momentum_by_sums`].
    pub fn summed_momentum(&self) -> &[f64] {
        &self.ptilde
    }
}
