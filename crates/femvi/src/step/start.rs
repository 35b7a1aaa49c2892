//! Starting values of the fixed-point iteration (step/fixed_point.rs) from the last step:
//! the stage forces w = M⁻¹f of the accepted step, the forces at the nodes q_k and q_{k−1},
//! and one force at a predicted point inside the new step, interpolated in time to the new
//! stage times.
//!
//! Extrapolating only the last step's r stage forces to the new stages (a polynomial of degree
//! r − 1 evaluated up to two steps away from its data) left a starting error of 2e-4 … 1e-3 on
//! the pendulum at h = 0.5 with degree 6, and every fixed-point sweep costs r force
//! evaluations. One or two extra evaluations per step make it an interpolation instead: the
//! force at t_k (the shared node, exact data; for rules with end points it is the last stage
//! force already), the force at t_{k−1} kept from the last step's start, and the force at
//! t_k + θh at the position predicted from the other data with the element's own polynomial,
//! Y(θ) = h a(θ) u + h² Σ_i B(θ)_i w_i (DESIGN.md §2). The starting error there drops to
//! 1e-7 … 2e-6 and the sweeps per step from 5.21 to 4.36 (P3, degree 6, h = 0.5; where θ lies in
//! 0.3 … 1 made no difference beyond noise). The idea is that of the "starting approximations
//! with additional function evaluations" of Hairer–Lubich–Wanner, Geometric Numerical
//! Integration, §VIII.6.1, built here from Lagrange interpolation on whatever rule the element
//! uses.
//!
//! All tables are products of Lagrange bases with the h-scaled element tables, kept until the
//! step, the step ratio or the set of data changes (so a uniform grid computes them once).

use super::fixed_point::{affine, FixedPointTables};
use crate::discrete::Element;

/// Where the predicted force is taken, as a fraction of the new step (0.3 … 1 measured alike).
const PREDICTOR_THETA: f64 = 0.6;

/// Cached tables and the force data of the starting procedure.
#[derive(Debug, Clone)]
pub(crate) struct StageStart {
    r: usize,
    n: usize,
    /// The rule has a point at c = 1 or c = 0: the last step's stage forces already include the
    /// force at t_k or t_{k−1}, and the node forces are left out (a repeated time would make
    /// the interpolation singular).
    end_point: bool,
    /// Tables for the three ways of starting — the stage forces alone; with the node force at
    /// t_k and the predicted force; with the node forces at t_k and t_{k−1} and the predicted
    /// force — each kept for the last `CACHED` pairs of step and step ratio, so that
    /// alternating between the ways (as the choice per step may) or cycling through a list of
    /// steps recomputes nothing.
    sets: [Vec<Tables>; 3],
    /// The entry of each set to be replaced next.
    next: [usize; 3],
    /// Barycentric weights scratch.
    bary: Vec<f64>,
    /// The step (node index) at which `data[r]` (the force at the node) was taken.
    node_force_k: Option<usize>,
    /// Times of the data in units of the new step relative to t_k: (c_j − 1) h_{k−1}/h, 0,
    /// −h_{k−1}/h, θ.
    nodes: Vec<f64>,
    /// Lagrange basis row scratch.
    row: Vec<f64>,
    basis: Vec<f64>,
    /// Forces at the data points, up to (r + 3) × n; the first r × n are the last step's stage
    /// forces (written by the integrator when it accepts a step).
    pub(super) data: Vec<f64>,
    /// Predicted displacement at θ.
    y_theta: Vec<f64>,
}

/// The tables of one way of starting, for the step `h_bits` after a step ratio `key_bits`.
#[derive(Debug, Clone)]
struct Tables {
    key_bits: u64,
    h_bits: u64,
    /// h a(θ) and h² B(θ) E₁ (length m1): the predicted position from the first m1 data.
    pred_a: f64,
    pred: Vec<f64>,
    /// h² B E₂ (column-major r × w, w = m1 + 1 with the predictor, m1 without): the stages
    /// from all data.
    mat: Vec<f64>,
}

/// Table entries kept per way of starting: a cycle of up to this many distinct steps (a
/// `[time] steps` list) finds its tables. (A grid whose steps never repeat rebuilds them every
/// step: measured on P3, degree 8, 0.65 µs per step on the uniform grid against 2.35 µs with 997
/// distinct steps, together with the integrator's step tables.)
const CACHED: usize = 4;

impl StageStart {
    /// The forces at the data points and where the node force was taken (checkpoints).
    pub(super) fn save(&self, w: &mut super::checkpoint::Words) {
        w.fs(&self.data);
        match self.node_force_k {
            None => w.b(false),
            Some(k) => {
                w.b(true);
                w.u(k);
            }
        }
    }

    pub(super) fn load(&mut self, r: &mut super::checkpoint::Reader<'_>) -> crate::error::Result<()> {
        r.fs(&mut self.data)?;
        self.node_force_k = if r.b()? { Some(r.u()?) } else { None };
        Ok(())
    }

    /// Workspace for `element` in dimension n.
    pub(crate) fn new(element: &Element, n: usize) -> Self {
        let r = element.points();
        // Rules with a point at c = 1 also have one at c = 0 (all of them are symmetric).
        let end_point = element.rule.nodes.contains(&1.0) || element.rule.nodes.contains(&0.0);
        let most = r + 3;
        Self {
            r,
            n,
            end_point,
            sets: std::array::from_fn(|_| {
                (0..CACHED)
                    .map(|_| Tables {
                        key_bits: f64::NAN.to_bits(),
                        h_bits: f64::NAN.to_bits(),
                        pred_a: 0.0,
                        pred: vec![0.0; most],
                        mat: vec![0.0; r * most],
                    })
                    .collect()
            }),
            next: [0; 3],
            bary: vec![0.0; most],
            node_force_k: None,
            nodes: vec![0.0; most],
            row: vec![0.0; most],
            basis: vec![0.0; element.degree() + 1],
            data: vec![0.0; most * n],
            y_theta: vec![0.0; n],
        }
    }

    /// The tables for step h after a step `last_h` with m1 data points before the predictor
    /// (`predict`) or without one, recomputed if the step or the ratio changed.
    fn tables(
        &mut self,
        element: &Element,
        tab: &FixedPointTables,
        h: f64,
        last_h: f64,
        m1: usize,
        predict: bool,
    ) -> (usize, usize) {
        let r = self.r;
        // With the predictor, m1 is r (rules with end points) or r + 1 for one element, r + 2
        // for the other: three sets suffice.
        let set = match (predict, m1 > r + 1) {
            (false, _) => 0,
            (true, false) => 1,
            (true, true) => 2,
        };
        let key = last_h / h;
        let found = self.sets[set]
            .iter()
            .position(|t| key.to_bits() == t.key_bits && h.to_bits() == t.h_bits);
        if let Some(e) = found {
            return (set, e);
        }
        let e = self.next[set];
        self.next[set] = (e + 1) % CACHED;
        let t = &mut self.sets[set][e];
        t.key_bits = key.to_bits();
        t.h_bits = h.to_bits();
        let s = element.degree();
        let c = &element.rule.nodes;
        for j in 0..r {
            self.nodes[j] = (c[j] - 1.0) * key;
        }
        if m1 > r {
            self.nodes[r] = 0.0;
        }
        if m1 > r + 1 {
            self.nodes[r + 1] = -key;
        }
        let w = m1 + usize::from(predict);
        if predict {
            self.nodes[m1] = PREDICTOR_THETA;
            // a(θ), B(θ): the element polynomial at θ, Σ_m φ_m(θ) (α_m, β_m·).
            element.basis.values_in_place(PREDICTOR_THETA, &mut self.basis);
            let a_theta: f64 = (1..=s).map(|m| self.basis[m] * tab.alpha[m - 1]).sum();
            t.pred_a = h * a_theta;
            // pred_j = h² Σ_i B(θ)_i E₁(c_i)_j.
            t.pred[..m1].iter_mut().for_each(|p| *p = 0.0);
            barycentric_weights(&self.nodes[..m1], &mut self.bary[..m1]);
            for i in 0..r {
                let b_theta: f64 = (1..=s).map(|m| self.basis[m] * tab.beta[(m - 1) * r + i]).sum();
                lagrange_row(&self.nodes[..m1], &self.bary[..m1], c[i], &mut self.row[..m1]);
                for j in 0..m1 {
                    t.pred[j] += h * h * b_theta * self.row[j];
                }
            }
        }
        // mat_lj = h² Σ_i B_li E₂(c_i)_j.
        t.mat[..r * w].iter_mut().for_each(|x| *x = 0.0);
        barycentric_weights(&self.nodes[..w], &mut self.bary[..w]);
        for i in 0..r {
            lagrange_row(&self.nodes[..w], &self.bary[..w], c[i], &mut self.row[..w]);
            for l in 0..r {
                let b = h * h * tab.b[l * r + i];
                for j in 0..w {
                    t.mat[j * r + l] += b * self.row[j];
                }
            }
        }
        (set, e)
    }

    /// The table of the start from the last step's stage forces alone (what [`Self::start`]
    /// does without `rich`, whether or not the rule has end points): y_l = h a_l u + Σ_j mat_jl w_j,
    /// `mat` column-major r × r (entry (l, j) at j r + l), for the step h after a step
    /// `last_h`. The ensemble lanes start their stages with it (`ensemble/fixed_point/`).
    pub(crate) fn plain_table(&mut self, element: &Element, tab: &FixedPointTables, h: f64, last_h: f64) -> &[f64] {
        let r = self.r;
        let (set, e) = self.tables(element, tab, h, last_h, r, false);
        &self.sets[set][e].mat[..r * r]
    }

    /// Starting stage values y (r × n) for the step h from node k with u = M⁻¹p_k, after a
    /// step `last_h` whose stage forces are in `data[..r n]`. `rich`: with the node forces and
    /// the predicted force (one or two evaluations); otherwise the stage forces alone,
    /// extrapolated (none). `eval(θ, y, w)` sets w = M⁻¹f(t_k + θh, q_k + y).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn start(
        &mut self,
        element: &Element,
        tab: &FixedPointTables,
        k: usize,
        h: f64,
        last_h: f64,
        rich: bool,
        ha: &[f64],
        u: &[f64],
        y: &mut [f64],
        mut eval: impl FnMut(f64, &[f64], &mut [f64]),
    ) {
        let (r, n) = (self.r, self.n);
        let m1 = if self.end_point || !rich {
            r
        } else {
            // The node force of the last start is the force at t_{k−1} now, if it was taken
            // there (the last step may have started otherwise).
            let prev = k > 0 && self.node_force_k == Some(k - 1);
            if prev {
                self.data.copy_within(r * n..(r + 1) * n, (r + 1) * n);
            }
            self.y_theta.iter_mut().for_each(|x| *x = 0.0);
            eval(0.0, &self.y_theta, &mut self.data[r * n..(r + 1) * n]);
            self.node_force_k = Some(k);
            if prev {
                r + 2
            } else {
                r + 1
            }
        };
        let (set, e) = self.tables(element, tab, h, last_h, m1, rich);
        let t = &self.sets[set][e];
        if rich {
            for c in 0..n {
                let mut acc = t.pred_a * u[c];
                for j in 0..m1 {
                    acc += t.pred[j] * self.data[j * n + c];
                }
                self.y_theta[c] = acc;
            }
            eval(PREDICTOR_THETA, &self.y_theta, &mut self.data[m1 * n..(m1 + 1) * n]);
        }
        let w = m1 + usize::from(rich);
        affine(r, n, ha, u, &t.mat, w, &self.data, y, false);
    }
}

/// Barycentric weights 1/Π_{k≠j}(τ_j − τ_k) of `nodes`.
fn barycentric_weights(nodes: &[f64], out: &mut [f64]) {
    for (j, o) in out.iter_mut().enumerate() {
        *o = 1.0
            / (0..nodes.len())
                .filter(|&k| k != j)
                .map(|k| nodes[j] - nodes[k])
                .product::<f64>();
    }
}

/// The Lagrange basis on `nodes` (with barycentric weights `bary`) at x; a node hit exactly
/// gives its unit row.
fn lagrange_row(nodes: &[f64], bary: &[f64], x: f64, out: &mut [f64]) {
    if let Some(j) = nodes.iter().position(|&t| t == x) {
        out.iter_mut().enumerate().for_each(|(k, e)| *e = f64::from(k == j));
        return;
    }
    let mut sum = 0.0;
    for ((o, &t), &w) in out.iter_mut().zip(nodes).zip(bary) {
        *o = w / (x - t);
        sum += *o;
    }
    out.iter_mut().for_each(|e| *e /= sum);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::{NodeFamily, QuadratureKind};

    /// With a force that is a polynomial in t alone, the converged stages are
    /// Y_l = h a_l u + h² Σ_i B_li g(t_k + c_i h) exactly, and the start interpolates r + 3
    /// values of g (r + 2 before the force at the previous node is known): it must reproduce
    /// Y for polynomials up to degree r + 2 (r + 1) to rounding, and miss beyond (measured:
    /// 8e-10 relative for degree r + 4).
    #[test]
    fn start_is_exact_for_forces_polynomial_in_time() {
        let r = 6;
        let el = Element::galerkin(r, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(r)).unwrap();
        let tab = FixedPointTables::new(&el).unwrap();
        let g = |deg: i32, t: f64| (0..=deg).map(|k| (0.5 * t).powi(k)).sum::<f64>();
        // Steps of a varying grid: h_{k−1} = 0.3, h_k = 0.25 (ratio 1.2), then 0.25 again.
        let (t_prev, h_prev) = (1.0, 0.3);
        let run = |deg: i32, with_previous_node: bool| {
            let mut st = StageStart::new(&el, 1);
            let c = &el.rule.nodes;
            let (mut t_k, mut h_last, mut h) = (t_prev + h_prev, h_prev, 0.25);
            let mut k = 5;
            if with_previous_node {
                // One start before, at t_{k−1}, leaves the force at that node behind.
                let t0 = t_prev - 0.2;
                for j in 0..r {
                    st.data[j] = g(deg, t0 + c[j] * 0.2);
                }
                let ha: Vec<f64> = tab.a.iter().map(|a| 0.3 * a).collect();
                let mut y = vec![0.0; r];
                st.start(&el, &tab, k - 1, 0.3, 0.2, true, &ha, &[0.0], &mut y, |th, _, w| {
                    w[0] = g(deg, t_prev + th * 0.3)
                });
            } else {
                (t_k, h_last, h) = (t_prev + h_prev, h_prev, 0.25);
                k = 0;
            }
            for j in 0..r {
                st.data[j] = g(deg, t_prev + c[j] * h_last);
            }
            let u = 0.7;
            let ha: Vec<f64> = tab.a.iter().map(|a| h * a).collect();
            let mut y = vec![0.0; r];
            st.start(&el, &tab, k, h, h_last, true, &ha, &[u], &mut y, |th, _, w| {
                w[0] = g(deg, t_k + th * h)
            });
            (0..r)
                .map(|l| {
                    let exact = h * tab.a[l] * u
                        + h * h * (0..r).map(|i| tab.b[l * r + i] * g(deg, t_k + c[i] * h)).sum::<f64>();
                    ((y[l] - exact) / exact.abs().max(1e-300)).abs()
                })
                .fold(0.0, f64::max)
        };
        let r = r as i32;
        for (with_prev, exact_degree) in [(true, r + 2), (false, r + 1)] {
            let hit = run(exact_degree, with_prev);
            let miss = run(exact_degree + 2, with_prev);
            assert!(
                hit < 1e-13,
                "previous node {with_prev}: degree {exact_degree} missed by {hit:e}"
            );
            // At least a hundred times the rounding bound above: the degree is what decides.
            assert!(
                miss > 1e-11,
                "previous node {with_prev}: degree {} hit ({miss:e})",
                exact_degree + 2
            );
        }
    }
}
