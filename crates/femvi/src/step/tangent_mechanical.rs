//! Tangent vectors through a step of a mechanical Lagrangian L = ½vᵀMv − V(t, q) in the
//! structure of the fixed-point step (issue 39: tangent maps at the cost of a step). The step
//! solves (`fixed_point.rs`, DESIGN.md §2), with u = M⁻¹p_k and f_i = f(t_k + c_i h, q_k + Y_i),
//!
//!   Y_l = h a_l u + h² Σ_i B_li M⁻¹ f_i,
//!   q_{k+1} = q_k + h α_s u + h² Σ_i β_si M⁻¹ f_i,   p_{k+1} = p_k + h Σ_i b_i f_i,
//!
//! which is the element's Euler–Lagrange system rewritten, whichever solver took the step.
//! Differentiating at the solved stages, with J_i = ∂f/∂q at stage i and g_i = J_i (δq + δY_i),
//!
//!   δY_l = h a_l δu + h² Σ_i B_li M⁻¹ g_i,   δu = M⁻¹ δp,
//!   δq_{k+1} = δq + h α_s δu + h² Σ_i β_si M⁻¹ g_i,   δp_{k+1} = δp + h Σ_i b_i g_i:
//!
//! the variational equations solved by the step's own iteration, on products J_i·x
//! ([`crate::Lagrangian::force_derivative`]: the model's or the compiled expression's code)
//! instead of the dense element Hessian and its LU. Three ways to take the products, chosen
//! per step: when the vectors take at least two products per stage, a Lagrangian that
//! prepares them at a point ([`crate::Lagrangian::prepare_force_derivative`]: the n-body
//! model's pair separations and r⁻³ factors, once per stage and step) gives the same bits
//! without the work they share; else,
//! for n ≤ [`JACOBIAN_MAX_DIM`], when the Lagrangian computes ∂f/∂q itself
//! ([`crate::Lagrangian::force_jacobian`]) and a step takes at least n/2 products per stage
//! (vectors × sweeps, the sweeps counted on the step before), J_i is formed once per stage and
//! step and the products are matrix–vector products; else the model at every product. When
//! B is strictly lower triangular (the trapezoid rule: Störmer–Verlet, whose map this is the
//! variational Störmer–Verlet of) one sweep in order solves it exactly, r products per
//! vector, and the first stage is the last step's last (first same as last, as the plain
//! step's first force is), so that one point per step is prepared or has its Jacobian
//! formed; otherwise the sweeps repeat until the step's own stopping rule
//! (`fixed_point_judge.rs`: tolerance, polish, rounding floor) says converged, and a vector
//! whose sweeps it fails (not finite, stalled, over the iteration cap) sends the whole step
//! back to the dense map (`tangent.rs`). The h-scaled tables are the step's own
//! (`StepTables`, with the rounding errors of h α_s, h² β_si and h b_i applied as a second
//! sum, as the polished step does), and the sweep is its affine kernel
//! (`fixed_point::affine`). Equal to the dense map up to the tolerance and rounding.

use super::fixed_point::{affine, FixedPointTables, StepTables};
use super::fixed_point_judge::{Judge, Verdict};
use super::options::SolverOptions;
use crate::discrete::Element;
use crate::lagrangian::{Lagrangian, MassMatrix};

/// The largest n for which the stage Jacobians are formed (r n² numbers per step) rather than
/// the model evaluated at every product.
pub(crate) const JACOBIAN_MAX_DIM: usize = 16;

/// The tables and workspace of the mechanical tangent (kept by the integrator across steps).
#[derive(Debug, Clone)]
pub(crate) struct MechanicalTangent {
    tab: FixedPointTables,
    /// Quadrature weights b_i.
    weights: Vec<f64>,
    /// The tables scaled by the last step's h.
    st: StepTables,
    /// B strictly lower triangular: one ordered sweep is exact.
    lower: bool,
    /// Stage times and positions of the last step (r, r×n).
    t: Vec<f64>,
    q: Vec<f64>,
    /// M = I: z is g and is not kept apart.
    identity: bool,
    /// The vectors as they came, to restore when the sweeps fail.
    saved: Vec<f64>,
    /// The stage Jacobians J_i (r × n×n, column-major), when `route` says formed, and one as the
    /// Lagrangian gives it (row-major).
    jac: Vec<f64>,
    row_major: Vec<f64>,
    /// The stages' prepared products ([`Lagrangian::prepare_force_derivative`]), when
    /// `route` says so.
    prepared: Vec<Vec<f64>>,
    route: Products,
    /// The route of the last step carried, None if there is none to follow (no step yet, or
    /// its sweeps failed).
    last_route: Option<Products>,
    /// Sweeps per vector on the last step (to choose how the products are taken), and
    /// the count on the current one.
    sweeps_per_vector: f64,
    sweeps_total: usize,
    /// Per vector: δu, the stage displacements δY, g_i and M⁻¹ g_i (r×n), a point's argument
    /// δq + δY_i.
    du: Vec<f64>,
    dy: Vec<f64>,
    g: Vec<f64>,
    z: Vec<f64>,
    x: Vec<f64>,
}

impl MechanicalTangent {
    /// Tables of `element` for n coordinates; None for a degenerate element (the dense map
    /// then reports it).
    pub(crate) fn new(element: &Element, n: usize) -> Option<Self> {
        let tab = FixedPointTables::new(element).ok()?;
        let (s, r) = (element.degree(), element.points());
        let lower = (0..r).all(|l| (l..r).all(|i| tab.b[l * r + i] == 0.0));
        Some(Self {
            tab,
            weights: element.rule.weights.clone(),
            st: StepTables::new(s, r),
            lower,
            t: vec![0.0; r],
            q: vec![0.0; r * n],
            identity: false,
            saved: Vec::new(),
            jac: Vec::new(),
            row_major: Vec::new(),
            prepared: Vec::new(),
            route: Products::Model,
            last_route: None,
            sweeps_per_vector: if lower { 1.0 } else { 4.0 },
            sweeps_total: 0,
            du: vec![0.0; n],
            dy: vec![0.0; r * n],
            g: vec![0.0; r * n],
            z: vec![0.0; r * n],
            x: vec![0.0; n],
        })
    }

    /// The stages of the element [t0, t0 + h] with nodes `base` + `incr[j]`, and the tables
    /// for h; with `keep`, the first stage is the last step's last stage (its time and
    /// position: [`MechanicalTangent::keeps_last_stage`]).
    fn set_stages(&mut self, element: &Element, (t0, h): (f64, f64), (base, incr): (&[f64], &[f64]), keep: bool) {
        let (n, w, r) = (base.len(), element.nodes(), self.t.len());
        if self.st.h_bits != h.to_bits() {
            self.st.build(&self.tab, &self.weights, h);
        }
        if keep {
            self.t[0] = self.t[r - 1];
            self.q.copy_within((r - 1) * n..r * n, 0);
        }
        let from = usize::from(keep);
        let stages = self.t.iter_mut().zip(self.q.chunks_exact_mut(n.max(1))).enumerate();
        for (l, (tl, ql)) in stages.skip(from) {
            *tl = t0 + element.rule.nodes[l] * h;
            ql.copy_from_slice(base);
            for (j, dj) in incr.chunks_exact(n.max(1)).enumerate().take(w) {
                let a = element.phi(l, j);
                ql.iter_mut().zip(dj).for_each(|(x, d)| *x += a * d);
            }
        }
    }

    /// Whether this step's first stage can be the last step's last stage, as the plain
    /// step's first force is its last step's last (first same as last): the ordered pass
    /// (trapezoid) with stages at both ends of the element, a last step carried
    /// ([`MechanicalTangent::apply`] succeeded), whose last stage time has the bits of this
    /// step's first and whose last stage position is this step's first node up to the
    /// rounding of its compensated sum (a run that jumped elsewhere does not qualify).
    fn keeps_last_stage(&self, element: &Element, (t0, h): (f64, f64), base: &[f64]) -> bool {
        let (r, n) = (self.t.len(), base.len());
        let nodes = &element.rule.nodes;
        if !self.lower || r < 2 || self.last_route.is_none() || nodes[0] != 0.0 || nodes[r - 1] != 1.0 {
            return false;
        }
        let last = &self.q[(r - 1) * n..r * n];
        let scale = base.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        (t0 + nodes[0] * h).to_bits() == self.t[r - 1].to_bits()
            && base
                .iter()
                .zip(last)
                .all(|(a, b)| (a - b).abs() <= KEEP_TOLERANCE * scale)
    }

    /// How this step's products are taken: prepared by the Lagrangian at each stage if it
    /// can ([`Lagrangian::prepare_force_derivative`]: its products, same bits, without the
    /// work they share) and `vectors` are expected to take at least two products per stage
    /// to prepare; else by formed stage Jacobians if n is small, `vectors` are expected to
    /// take at least n/2 products per stage and `lag` computes them; else by the model.
    /// With `keep` the first stage is the last step's last: its preparation or Jacobian is
    /// moved over when the last step took the same route, and only the others are made.
    fn choose_products<L: Lagrangian>(&mut self, lag: &L, n: usize, vectors: usize, keep: bool) {
        let r = self.t.len();
        self.prepared.resize_with(r, Vec::new);
        // Stages whose preparation or Jacobian the last step left (the first, moved over).
        let from = |route| usize::from(keep && self.last_route == Some(route));
        // Preparing pays from two products per stage prepared on (one costs about a product).
        let products = vectors as f64 * self.sweeps_per_vector * r as f64;
        let fresh = (r - usize::from(keep)) as f64;
        if n > 0 && products >= 2.0 * fresh {
            let skip = from(Products::Prepared);
            if skip == 1 {
                self.prepared.swap(0, r - 1);
            }
            let (t, q) = (&self.t, &self.q);
            let stages = self.prepared.iter_mut().enumerate().skip(skip);
            if stages.fold(true, |ok, (i, c)| {
                ok && lag.prepare_force_derivative(t[i], &q[i * n..(i + 1) * n], c)
            }) {
                self.route = Products::Prepared;
                return;
            }
        }
        self.route = Products::Model;
        if n > JACOBIAN_MAX_DIM || 2.0 * vectors as f64 * self.sweeps_per_vector < n as f64 {
            return;
        }
        let skip = from(Products::Formed);
        self.jac.resize(r * n * n, 0.0);
        self.row_major.resize(n * n, 0.0);
        if skip == 1 {
            self.jac.copy_within((r - 1) * n * n..r * n * n, 0);
        }
        for (i, ji) in self.jac.chunks_exact_mut(n * n).enumerate().skip(skip) {
            if !lag.force_jacobian(self.t[i], &self.q[i * n..(i + 1) * n], &mut self.row_major) {
                return;
            }
            // Column-major, so that a product runs down the columns in vector registers.
            for (a, row) in self.row_major.chunks_exact(n).enumerate() {
                for (b, x) in row.iter().enumerate() {
                    ji[b * n + a] = *x;
                }
            }
        }
        self.route = Products::Formed;
    }

    /// g_i = J_i (δq + δY_i) and z_i = M⁻¹ g_i at stage i.
    #[inline]
    fn stage<L: Lagrangian>(&mut self, lag: &L, mass: &MassMatrix, i: usize, dq: &[f64]) {
        let n = dq.len();
        let span = i * n..(i + 1) * n;
        for ((x, a), b) in self.x.iter_mut().zip(dq).zip(&self.dy[span.clone()]) {
            *x = a + b;
        }
        match self.route {
            // g_a = Σ_b J_ab x_b summed over b in order from −0 (the bits of a row's
            // `Iterator::sum`), all rows at once down the stored columns.
            Products::Formed => column_product(
                &self.jac[i * n * n..(i + 1) * n * n],
                &self.x,
                &mut self.g[span.clone()],
            ),
            Products::Prepared => lag.prepared_force_derivative(&self.prepared[i], &self.x, &mut self.g[span.clone()]),
            Products::Model => {
                lag.force_derivative(self.t[i], &self.q[span.clone()], &self.x, &mut self.g[span.clone()])
            }
        }
        if !self.identity {
            mass.solve(&self.g[span.clone()], &mut self.z[span]);
        }
    }

    /// One vector (δq, δp) through the step, in place; false if the sweeps failed by the
    /// step's stopping rule (not finite, stalled, over `max_iterations`; the vector is then
    /// left as it was).
    fn carry<L: Lagrangian>(&mut self, lag: &L, mass: &MassMatrix, opts: &SolverOptions, v: &mut [f64]) -> bool {
        let n = v.len() / 2;
        let r = self.t.len();
        let (dq, dp) = v.split_at_mut(n);
        mass.solve(dp, &mut self.du);
        if self.lower {
            // δY_l from the stages before it: one pass in order.
            for l in 0..r {
                let z = if self.identity { &self.g } else { &self.z };
                let dy = &mut self.dy[l * n..(l + 1) * n];
                let ha = self.st.ha[l];
                dy.iter_mut().zip(&self.du).for_each(|(y, u)| *y = ha * u);
                for (i, zi) in z.chunks_exact(n.max(1)).enumerate().take(l) {
                    let b = self.st.h2b[i * r + l];
                    dy.iter_mut().zip(zi).for_each(|(y, z)| *y += b * z);
                }
                self.stage(lag, mass, l, dq);
            }
        } else {
            for (l, row) in self.dy.chunks_exact_mut(n).enumerate() {
                row.iter_mut().zip(&self.du).for_each(|(y, u)| *y = self.st.ha[l] * u);
            }
            match self.sweeps(lag, mass, dq, opts) {
                Some(count) => self.sweeps_total += count,
                None => return false,
            }
        }
        self.end_update(dq, dp);
        true
    }

    /// δq' = δq + h α_s δu + h² Σ β_si z_i and δp' = δp + h Σ b_i g_i, the coefficients'
    /// rounding errors as a second sum: the last row of the kernel's node increments
    /// (`fixed_point::affine`: the same operations in the same order, component by
    /// component; the inner nodes are not needed here). One pass over the components, with
    /// the stage count a compile-time constant up to four (the loop then vectorises over the
    /// components).
    fn end_update(&mut self, dq: &mut [f64], dp: &mut [f64]) {
        let (n, r) = (dq.len(), self.t.len());
        let Some(last) = self.st.h_alpha.len().checked_sub(1) else {
            return;
        };
        let (s, st) = (last + 1, &self.st);
        let z = if self.identity { &self.g } else { &self.z };
        let rows = EndRows {
            a: [st.h_alpha[last], st.h_alpha_lo[last]],
            beta: [&st.h2_beta, &st.h2_beta_lo],
            weights: [&st.hw, &st.hw_lo],
            s,
        };
        let (z, g, du) = (&z[..r * n], &self.g[..r * n], &self.du[..n]);
        macro_rules! fixed {
            ($($r:literal)*) => {
                match r {
                    $($r => end_rows::<$r>(rows, (du, z, g), dq, dp),)*
                    _ => end_rows_any(rows, (du, z, g), dq, dp),
                }
            };
        }
        fixed!(1 2 3 4)
    }

    /// Jacobi sweeps on the stage displacements until the step's own stopping rule
    /// ([`Judge`]: the increments at most `tolerance` times the vector's scale, with the
    /// polish of [`crate::SolverOptions::polish`] on while they still decrease, at most three
    /// more sweeps, down to the rounding floor) says converged, since a truncated iteration's
    /// error accumulates over a run (the whole-run map of `tests/all/chaos.rs` kept its
    /// symplecticity to 2.1e-10 without the polish, 5.9e-12 with it). Returns the sweeps,
    /// None if the rule says failed (not finite, stalled, over the cap). g and z are left at
    /// the displacements the last sweep started from, which it moved by at most that much.
    fn sweeps<L: Lagrangian>(&mut self, lag: &L, mass: &MassMatrix, dq: &[f64], opts: &SolverOptions) -> Option<usize> {
        let (n, r) = (dq.len(), self.t.len());
        let dq_size = dq.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut judge = Judge::new(opts);
        for sweep in 1.. {
            for i in 0..r {
                self.stage(lag, mass, i, dq);
            }
            let z = if self.identity { &self.g } else { &self.z };
            let (change, size, sum) = affine(r, n, &self.st.ha, &self.du, &self.st.h2b, r, z, &mut self.dy, true);
            if sum.is_nan() {
                return None;
            }
            match judge.sweep(change, size, dq_size, sweep) {
                Verdict::Continue => {}
                Verdict::Converged => return Some(sweep),
                Verdict::Failed(_) => return None,
            }
        }
        None
    }
}

/// g = J x for J column-major (n × n, n = x.len()): g_a = Σ_b J_ab x_b summed over b in
/// order from −0, the bits of each row's `Iterator::sum`. With n a compile-time constant (up
/// to [`JACOBIAN_MAX_DIM`]) g stays in registers while the columns stream past.
#[inline]
fn column_product(jt: &[f64], x: &[f64], g: &mut [f64]) {
    macro_rules! fixed {
        ($($n:literal)*) => {
            match x.len() {
                $($n => column_product_n::<$n>(jt, x, g),)*
                _ => {
                    let n = x.len();
                    g.iter_mut().for_each(|v| *v = -0.0);
                    for (col, xb) in jt.chunks_exact(n.max(1)).zip(x) {
                        g.iter_mut().zip(col).for_each(|(ga, j)| *ga += j * xb);
                    }
                }
            }
        };
    }
    const _: () = assert!(JACOBIAN_MAX_DIM == 16);
    fixed!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16)
}

/// [`column_product`] with n = `N`.
#[inline(always)]
fn column_product_n<const N: usize>(jt: &[f64], x: &[f64], g: &mut [f64]) {
    let mut acc = [-0.0f64; N];
    for (col, xb) in jt.chunks_exact(N).zip(x) {
        let col: &[f64; N] = col.try_into().expect("chunks of N");
        for a in 0..N {
            acc[a] += col[a] * xb;
        }
    }
    g.copy_from_slice(&acc);
}

/// How far (relative to the largest |q|) the last step's last stage may be from this step's
/// first node for the stage to be kept: the compensated sum of the node moves it by a few
/// roundings; a run that jumped elsewhere is far beyond.
const KEEP_TOLERANCE: f64 = 1e-12;

/// The end update's coefficients ([`MechanicalTangent::end_update`]): h α_s, the s-row
/// tables h² β (column-major: stage j's row s − 1 at j s + s − 1) and the weights h b, each
/// with its rounding errors.
struct EndRows<'t> {
    a: [f64; 2],
    beta: [&'t [f64]; 2],
    weights: [&'t [f64]; 2],
    s: usize,
}

impl EndRows<'_> {
    /// h² β_sj and its rounding error.
    #[inline(always)]
    fn beta(&self, j: usize) -> [f64; 2] {
        let k = j * self.s + self.s - 1;
        [self.beta[0][k], self.beta[1][k]]
    }

    /// h b_i and its rounding error.
    #[inline(always)]
    fn weight(&self, i: usize) -> [f64; 2] {
        [self.weights[0][i], self.weights[1][i]]
    }
}

/// The end update with `R` stages: δq_c += (h α_s δu_c + Σ_j h² β_sj z_jc) + (the same with
/// the rounding errors), δp_c += (Σ_i h b_i g_ic) + (the same), each sum in stage order.
#[inline(always)]
fn end_rows<const R: usize>(rows: EndRows<'_>, (du, z, g): (&[f64], &[f64], &[f64]), dq: &mut [f64], dp: &mut [f64]) {
    let n = du.len();
    let beta: [[f64; 2]; R] = std::array::from_fn(|j| rows.beta(j));
    let w: [[f64; 2]; R] = std::array::from_fn(|i| rows.weight(i));
    let zs: [&[f64]; R] = std::array::from_fn(|j| &z[j * n..(j + 1) * n]);
    let gs: [&[f64]; R] = std::array::from_fn(|i| &g[i * n..(i + 1) * n]);
    let [a, a_lo] = rows.a;
    for (c, ((q, p), u)) in dq.iter_mut().zip(dp.iter_mut()).zip(du).enumerate() {
        let (mut hi, mut lo) = (a * u, a_lo * u);
        for j in 0..R {
            hi += beta[j][0] * zs[j][c];
            lo += beta[j][1] * zs[j][c];
        }
        *q += hi + lo;
        let (mut hi, mut lo) = (0.0, 0.0);
        for i in 0..R {
            hi += w[i][0] * gs[i][c];
            lo += w[i][1] * gs[i][c];
        }
        *p += hi + lo;
    }
}

/// [`end_rows`] for any number of stages (`z` and `g` hold r rows of n).
fn end_rows_any(rows: EndRows<'_>, (du, z, g): (&[f64], &[f64], &[f64]), dq: &mut [f64], dp: &mut [f64]) {
    let n = du.len();
    let r = z.len() / n.max(1);
    let [a, a_lo] = rows.a;
    for (c, ((q, p), u)) in dq.iter_mut().zip(dp.iter_mut()).zip(du).enumerate() {
        let (mut hi, mut lo) = (a * u, a_lo * u);
        for j in 0..r {
            let [b, b_lo] = rows.beta(j);
            hi += b * z[j * n + c];
            lo += b_lo * z[j * n + c];
        }
        *q += hi + lo;
        let (mut hi, mut lo) = (0.0, 0.0);
        for i in 0..r {
            let [b, b_lo] = rows.weight(i);
            hi += b * g[i * n + c];
            lo += b_lo * g[i * n + c];
        }
        *p += hi + lo;
    }
}

/// How a step's products J_i·x are taken ([`MechanicalTangent::choose_products`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Products {
    /// [`Lagrangian::force_derivative`] at every product.
    Model,
    /// [`Lagrangian::prepared_force_derivative`] from each stage's cache.
    Prepared,
    /// The formed stage Jacobians times the vector.
    Formed,
}

/// The last step as the mechanical tangent needs it: its element [t0, t0 + h] with nodes
/// `base` + `incr[j]` (row-major (s+1)×n increments).
pub(crate) struct StepElement<'e> {
    pub(crate) t0: f64,
    pub(crate) h: f64,
    pub(crate) base: &'e [f64],
    pub(crate) incr: &'e [f64],
}

impl MechanicalTangent {
    /// Carries `vectors` (each (δq, δp), 2n long) through the step `el` of `lag` (mass
    /// matrix `mass`) discretised by `element`, in place (module docs); false, vectors
    /// unchanged, if its sweeps did not converge within the solver's limits.
    pub(crate) fn apply<L: Lagrangian>(
        &mut self,
        (lag, mass, element): (&L, &MassMatrix, &Element),
        el: StepElement<'_>,
        opts: &SolverOptions,
        vectors: &mut [f64],
    ) -> bool {
        let n = el.base.len();
        let keep = self.keeps_last_stage(element, (el.t0, el.h), el.base);
        self.set_stages(element, (el.t0, el.h), (el.base, el.incr), keep);
        let count = vectors.len() / (2 * n).max(1);
        self.choose_products(lag, n, count, keep);
        // Unset until the vectors are through: a failure leaves nothing to keep.
        self.last_route = None;
        self.sweeps_total = 0;
        self.identity = mass.is_identity();
        if !self.lower {
            self.saved.clear();
            self.saved.extend_from_slice(vectors);
        }
        for v in vectors.chunks_exact_mut(2 * n) {
            if !self.carry(lag, mass, opts, v) {
                vectors.copy_from_slice(&self.saved);
                return false;
            }
        }
        if !self.lower && count > 0 {
            self.sweeps_per_vector = self.sweeps_total as f64 / count as f64;
        }
        self.last_route = Some(self.route);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::column_product;

    /// Each row of the column-major product has the bits of the row's `Iterator::sum` of
    /// products (which starts from −0), for every n of the fixed sizes and beyond, including
    /// rows whose products are all −0.
    #[test]
    fn column_product_is_each_rows_sum_in_order() {
        let mut rand = crate::testing::uniform(0x51_7cc1_b727_220a);
        for n in 1..=20 {
            for zeros in [false, true] {
                let row_major: Vec<f64> = (0..n * n)
                    .map(|k| if zeros && k % n == 0 { -0.0 } else { rand() - 0.5 })
                    .collect();
                let x: Vec<f64> = (0..n)
                    .map(|b| if zeros && b > 0 { 0.0 } else { 1e3 * (rand() - 0.5) })
                    .collect();
                let want: Vec<u64> = row_major
                    .chunks_exact(n)
                    .map(|row| row.iter().zip(&x).map(|(a, b)| a * b).sum::<f64>().to_bits())
                    .collect();
                let mut jt = vec![0.0; n * n];
                for a in 0..n {
                    for b in 0..n {
                        jt[b * n + a] = row_major[a * n + b];
                    }
                }
                let mut g = vec![1.0; n];
                column_product(&jt, &x, &mut g);
                let got: Vec<u64> = g.iter().map(|v| v.to_bits()).collect();
                assert_eq!(got, want, "n = {n}, zeros = {zeros}");
            }
        }
    }
}
