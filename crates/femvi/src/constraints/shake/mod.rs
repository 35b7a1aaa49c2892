//! Constrained steps of any degree on a mechanical Lagrangian L = ½vᵀMv − V(t, q) (constant M,
//! [`Lagrangian::mass_matrix`]) without discrete forces, solved by a fixed-point iteration on
//! the forces and a linearised solve for the multipliers in each sweep: SHAKE's idea
//! (Ryckaert, Ciccotti, Berendsen 1977) on the stages of the element, where dense Newton
//! (`step.rs`) builds and factors the whole (s n + m + I m)² Jacobian with second derivatives.
//!
//! # Derivation
//!
//! Take the step equations of [`crate::constraints`] with the constraints enforced at the
//! element's quadrature points c_i (`Weak`, `Points`) or only at the ends (`Ends`), so that the
//! evaluation points are y_i = q(c_i) and a_ij = ℓ_j(c_i). For L = ½vᵀMv − V the node rows
//! 0 … s−1 differ from the unconstrained ones (`crate::step::fixed_point`) by the constraint
//! forces only: −G(q_k)ᵀλ̂ in row 0, which enters exactly as p_k − G(q_k)ᵀλ̂ does, and
//! −Σ_i ℓ_j(c_i) ω_i G(y_i)ᵀΛ(y_i) in row j, which has the form of the quadrature of a force,
//! h Σ_i b_i ℓ_j(c_i) f_i, with f_i replaced by f_i − (ω_i/(h b_i)) G(y_i)ᵀΛ(y_i). With the
//! element's fixed-point tables (a, B at the points, α, β at the nodes), u = M⁻¹p_k,
//! W(y) = M⁻¹G(y)ᵀ, κ_i = ω_i/b_i and the unknowns u₀ = hλ̂, U_c = hΛ̂_c (Λ_i = Σ_c Ψ_ic Λ̂_c):
//!
//!   Y_l = h a_l u + h² Σ_i B_li M⁻¹f_i − a_l W(q_k) u₀ − Σ_i B_li κ_i W(y_i) Σ_c Ψ_ic U_c,
//!   ΔQ^j = h α_j u + h² Σ_i β_ji M⁻¹f_i − α_j W(q_k) u₀ − Σ_i β_ji κ_i W(y_i) Σ_c Ψ_ic U_c,
//!
//! (Y_l = q(c_l) − q_k, ΔQ^j = Q^j − q_k) together with the constraint rows g(q_k + ΔQ^s) = 0
//! and Σ_i ω_i Ψ_ic g(q_k + Y_i) = 0. Each sweep evaluates f_i, g and G at the current points
//! and the end node; with those frozen, Y and ΔQ^s are affine in (u₀, U), and the constraint
//! rows linearised at the current points, g + G·(new − current) = 0, are m(1 + I) linear
//! equations for them. Their solution gives the new points. The forces converge as the
//! unconstrained fixed point does (contraction O(h²)), the constraints as Newton would with
//! the curvature term of the Jacobian (λ·∇²g, of size h²) left out. At the fixed point every
//! step equation holds, so the step is the dense Newton step's to the solver tolerance
//! (`tests/all/constraints_shake.rs` compares them); the new momentum is summed as there,
//! p̃ = p_k + h Σ_i b_i f_i − G(q_k)ᵀλ̂ − Σ_i ω_i G(y_i)ᵀΛ_i, and projected onto T*N by the
//! linear system G M⁻¹ Gᵀ μ̂ = G M⁻¹ p̃ at the end node.
//!
//! Work per sweep: r force evaluations, r + 1 constraint jets (g and G only), and a dense
//! solve of size m(1 + I); no second derivatives and no allocation. The first sweep starts
//! from the last element's polynomial extrapolated over the new step (the first step from the
//! node velocity). With `Method::Auto` a step on which the iteration fails falls back to
//! dense Newton (`stepper.rs`).
//!
//! Files: this one (the tables and the iteration), `sweep.rs` (one sweep: start, forces and
//! jets, the points), `system.rs` (the linearised multiplier system), `finish.rs` (the
//! unknowns and p̃ after convergence).

mod finish;
mod sweep;
mod system;

use super::jet::ConstraintJet;
use super::layout::Layout;
use super::small::{copy, mass_solve, solve_small};
use super::Constraints;
use crate::discrete::Element;
use crate::error::StepFailure;
use crate::fem::LagrangeBasis;
use crate::lagrangian::{Lagrangian, MassMatrix};
use crate::solve::NewtonFailure;
use crate::step::checkpoint::{Reader, Words};
use crate::step::fixed_point::FixedPointTables;

/// From this sweep on, a change at least as large as the one before ends the iteration as
/// diverging (the first sweeps also settle the multipliers, whose changes need not shrink).
const DIVERGENCE_SWEEPS: usize = 3;

/// Scratch and tables of the SHAKE-style step (n coordinates, m constraints, degree s, r
/// quadrature points, I interior multiplier blocks; K = m(1 + I) unknowns).
///
/// Rows l = 0 … r of the point tables are the stages (l < r) and the end node (l = r): the
/// displacements Y_l and ΔQ^s, their coefficients (a_l, B_l·) and (α_s, β_s·), and the jets
/// (g, G) there. Columns i = 0 … r of W = M⁻¹Gᵀ are the stages (i < r) and q_k (i = r).
#[derive(Debug, Clone)]
pub(crate) struct ShakeStep {
    n: usize,
    m: usize,
    s: usize,
    r: usize,
    sites: usize,
    /// Whether the constraints are enforced at the quadrature points (else only at the ends).
    points: bool,
    /// Rows [a_l, B_l0 … B_l,r−1], l = 0 … r ((r + 1) × (r + 1)), and the same scaled by h
    /// and h² for `h_tables`; α_j, β_j· of the interior nodes for the unknowns.
    tab: Vec<f64>,
    htab: Vec<f64>,
    h_tables: f64,
    fixed: FixedPointTables,
    lagrange: LagrangeBasis,
    c: Vec<f64>,
    b: Vec<f64>,
    omega: Vec<f64>,
    kappa: Vec<f64>,
    /// Ψ_ic, row-major r × I.
    psi: Vec<f64>,
    /// tab[l][1 + i] κ_i Ψ_ic at `[(l r + i) I + c]`.
    tb: Vec<f64>,
    /// ω_l Ψ_lc at `[c r + l]`.
    ta: Vec<f64>,
    /// u = M⁻¹p_k.
    u: Vec<f64>,
    /// Y_l and ΔQ^s ((r + 1) × n), and their parts without the multipliers.
    pts: Vec<f64>,
    free: Vec<f64>,
    /// f_i and M⁻¹f_i (r × n).
    f: Vec<f64>,
    mf: Vec<f64>,
    /// Jets at the stages (used with points) and the end node (row r).
    jets: Vec<ConstraintJet>,
    /// W at the stages and q_k ((r + 1) × m × n).
    w: Vec<f64>,
    /// G_l,e · W_i,e2 at `[((l m + e)(r + 1) + i) m + e2]`.
    dots: Vec<f64>,
    /// The multipliers at the points Λ_i (times h, r × m); W(q_k) u₀ and κ_i W_i Λ_i in the
    /// rows of `wl` ((r + 1) × n: stage i, then row r for q_k).
    lam: Vec<f64>,
    wl: Vec<f64>,
    /// The linearised constraint rows by row point: entries (K per row) for (l, e).
    rows: Vec<f64>,
    mat: Vec<f64>,
    rhs: Vec<f64>,
    /// (u₀, U) of the last sweep.
    z: Vec<f64>,
    pos: Vec<f64>,
    /// p̃ of the last step.
    pub ptilde: Vec<f64>,
    /// The last step's node increments (s+1) × n, its step and whether there is one.
    last: Vec<f64>,
    last_h: f64,
    have_last: bool,
    /// The same of the step before it: the start extrapolates the two (`sweep.rs`).
    last2: Vec<f64>,
    last_h2: f64,
    have_last2: bool,
    /// ℓ_p(c_l) on the 2s + 1 nodes of the last two elements, for the step ratios `rho2`,
    /// (r + 1) × (2s + 1); the nodes' times (in steps h from t_k) and values (scratch).
    extrap2: Vec<f64>,
    rho2: (f64, f64),
    xs: Vec<f64>,
    vals: Vec<f64>,
    /// ℓ_j(1 + ρ c_l) for the step ratio ρ of the last extrapolation, (r + 1) × (s + 1).
    extrap: Vec<f64>,
    rho: f64,
}

impl ShakeStep {
    /// Whether `layout` enforces the constraints at the quadrature points of `element` or only
    /// at the ends, and the rule's weights are positive (κ_i = ω_i/b_i exists).
    pub fn fits(element: &Element, layout: &Layout) -> bool {
        let (r, w) = (element.points(), element.nodes());
        let at_points =
            layout.points == r && (0..r).all(|i| (0..w).all(|j| layout.a.get(i * w + j) == Some(&element.phi(i, j))));
        (layout.points == 0 || at_points) && element.rule.weights.iter().all(|&b| b > 0.0)
    }
    /// The step for `element` and `layout` (which [`ShakeStep::fits`]); None if the element
    /// has no fixed-point tables.
    pub fn new(element: &Element, layout: &Layout, n: usize, m: usize) -> Option<Self> {
        let fixed = FixedPointTables::new(element).ok()?;
        let (s, r) = (element.degree(), element.points());
        let points = layout.points == r && r > 0;
        let sites = if points { layout.sites } else { 0 };
        let k = m * (1 + sites);
        let w = r + 1;
        let mut tab = vec![0.0; w * w];
        for l in 0..w {
            let (a, row) = if l < r {
                (fixed.a[l], &fixed.b[l * r..(l + 1) * r])
            } else {
                (fixed.alpha[s - 1], &fixed.beta[(s - 1) * r..s * r])
            };
            tab[l * w] = a;
            tab[l * w + 1..(l + 1) * w].copy_from_slice(row);
        }
        let b = element.rule.weights.clone();
        let omega = if points { layout.omega.clone() } else { vec![0.0; r] };
        let kappa: Vec<f64> = omega.iter().zip(&b).map(|(o, b)| o / b).collect();
        let psi = if points { layout.psi.clone() } else { vec![] };
        let mut tb = vec![0.0; w * r * sites];
        let mut ta = vec![0.0; sites * r];
        for l in 0..w {
            for i in 0..r {
                for c in 0..sites {
                    tb[(l * r + i) * sites + c] = tab[l * w + 1 + i] * kappa[i] * psi[i * sites + c];
                }
            }
        }
        for c in 0..sites {
            for l in 0..r {
                ta[c * r + l] = omega[l] * psi[l * sites + c];
            }
        }
        Some(Self {
            n,
            m,
            s,
            r,
            sites,
            points,
            htab: vec![0.0; w * w],
            tab,
            h_tables: f64::NAN,
            fixed,
            lagrange: element.basis.clone(),
            c: element.rule.nodes.clone(),
            b,
            omega,
            kappa,
            psi,
            tb,
            ta,
            u: vec![0.0; n],
            pts: vec![0.0; w * n],
            free: vec![0.0; w * n],
            f: vec![0.0; r * n],
            mf: vec![0.0; r * n],
            jets: (0..w).map(|_| ConstraintJet::new(m, n)).collect(),
            w: vec![0.0; w * m * n],
            dots: vec![0.0; w * m * w * m],
            lam: vec![0.0; r * m],
            wl: vec![0.0; w * n],
            rows: vec![0.0; w * m * k],
            mat: vec![0.0; k * k],
            rhs: vec![0.0; k],
            z: vec![0.0; k],
            pos: vec![0.0; n],
            ptilde: vec![0.0; n],
            last: vec![0.0; (s + 1) * n],
            last_h: f64::NAN,
            have_last: false,
            last2: vec![0.0; (s + 1) * n],
            last_h2: f64::NAN,
            have_last2: false,
            extrap2: vec![0.0; w * (2 * s + 1)],
            rho2: (f64::NAN, f64::NAN),
            xs: vec![0.0; 2 * s + 1],
            vals: vec![0.0; 2 * s + 1],
            extrap: vec![0.0; w * (s + 1)],
            rho: f64::NAN,
        })
    }
    /// What the next step reads of this one, into a checkpoint: its starting polynomials.
    pub fn save(&self, w: &mut Words) {
        w.fs(&self.last);
        w.f(self.last_h);
        w.b(self.have_last);
        w.fs(&self.last2);
        w.f(self.last_h2);
        w.b(self.have_last2);
    }
    /// Reads what [`ShakeStep::save`] wrote.
    ///
    /// # Errors
    /// A damaged checkpoint.
    pub fn load(&mut self, r: &mut Reader<'_>) -> crate::error::Result<()> {
        r.fs(&mut self.last)?;
        self.last_h = r.f()?;
        self.have_last = r.b()?;
        r.fs(&mut self.last2)?;
        self.last_h2 = r.f()?;
        self.have_last2 = r.b()?;
        Ok(())
    }
    /// Solves the step from (t, q_k, p_k) with velocity `v` (the first step's guess) and step
    /// h; `start` holds g and G at q_k. Returns the sweeps; then [`ShakeStep::finish`] gives
    /// the unknowns and p̃, and [`ShakeStep::end_jet`] the jet at the new node.
    ///
    /// # Errors
    /// A singular linear system, a non-finite value, changes of the points that stop
    /// shrinking above `tol · scale` (from the third sweep on), or no convergence within
    /// `max_iterations` sweeps.
    #[allow(clippy::too_many_arguments)]
    pub fn solve<L: Lagrangian, C: Constraints>(
        &mut self,
        (lag, mass, con): (&L, &MassMatrix, &C),
        start: &ConstraintJet,
        (t, h): (f64, f64),
        (q, p, v, comp): (&[f64], &[f64], &[f64], &[f64]),
        (tol, max_iterations, scale): (f64, usize, f64),
    ) -> Result<usize, NewtonFailure> {
        let (n, m, r) = (self.n, self.m, self.r);
        mass_solve(mass, p, &mut self.u);
        let wk = &mut self.w[r * m * n..];
        for (row, g) in wk.chunks_exact_mut(n).zip(start.jac.chunks_exact(n)) {
            mass_solve(mass, g, row);
        }
        self.scale_tables(h);
        self.guess(h, v);
        let fail = |failure, residual: f64, iterations| NewtonFailure {
            failure,
            residual,
            iterations,
        };
        let (mut sweeps, mut converged, mut last_change) = (0, false, f64::INFINITY);
        loop {
            if !self.evaluate((lag, mass, con), (t, h), q, comp) {
                return Err(fail(StepFailure::NonFinite, f64::NAN, sweeps));
            }
            if converged {
                return Ok(sweeps);
            }
            if sweeps == max_iterations {
                return Err(fail(StepFailure::NotConverged, self.end_jet().residual(), sweeps));
            }
            self.free_parts();
            self.dot_products();
            self.system();
            if !solve_small(&mut self.mat, &mut self.rhs, self.z.len()) {
                return Err(fail(StepFailure::Singular, self.end_jet().residual(), sweeps + 1));
            }
            copy(&mut self.z, &self.rhs);
            let change = self.update();
            sweeps += 1;
            if !change.is_finite() {
                return Err(fail(StepFailure::NonFinite, change, sweeps));
            }
            converged = change <= tol * scale;
            // A linear iteration whose changes stop shrinking diverges (steps too long for
            // it): stop early, so that `Method::Auto` falls back to Newton at little cost.
            if !converged && sweeps >= DIVERGENCE_SWEEPS && change >= last_change {
                return Err(fail(StepFailure::Stalled, change, sweeps));
            }
            last_change = change;
        }
    }
}

/// Whether g and G of `jet` are finite.
fn all_finite(jet: &ConstraintJet) -> bool {
    jet.g.iter().chain(&jet.jac).all(|x| x.is_finite())
}
