//! The residual of the simplified Newton iteration (`newton_step.rs`, issue 15 item 2): the
//! step equations R_j = ∂L_d/∂Q^j (0 < j < s) and R_0 = p_k + Δp − Σ_{j≥1} ∂L_d/∂Q^j of
//! (2.40)–(2.42), evaluated from the unknowns X^1 … X^s with the element's basis tables
//! copied once per step size into [`ResidualTables`]: the points
//! q(c_i) = q_k + Σ_j ℓ_j(c_i) X^j, v(c_i) = Σ_j ℓ_j'(c_i)/h X^j and the rows
//! b_i (h ℓ_j(c_i) ∂L/∂q + ℓ_j'(c_i) ∂L/∂v) are formed with the same operations, in the same
//! order, as [`Element::points_in_place`] and [`Element::hessian_in_place`] (same bits), but
//! without their per-call divisions by h, products h ℓ_j and node-0 terms (X^0 = 0), which
//! were a third of a relativistic Kepler step (callgrind).
//!
//! [`Element::points_in_place`]: crate::discrete::Element::points_in_place
//! [`Element::hessian_in_place`]: crate::discrete::Element::hessian_in_place

use crate::discrete::{Element, ElementWork};
use crate::lagrangian::Lagrangian;

/// The basis tables of an element for one step size h (recomputed when h changes).
#[derive(Debug, Clone)]
pub(crate) struct ResidualTables {
    /// The bits of the h the tables are for (NaN's: none yet).
    h_bits: u64,
    /// ℓ_j(c_i), row i, j = 1 … s.
    a: Vec<f64>,
    /// ℓ_j'(c_i)/h, row i, j = 1 … s.
    dh: Vec<f64>,
    /// h ℓ_j(c_i), row i, j = 0 … s.
    ha: Vec<f64>,
    /// ℓ_j'(c_i), row i, j = 0 … s.
    d: Vec<f64>,
}

impl ResidualTables {
    /// Empty tables (filled at the first evaluation).
    pub(crate) fn new() -> Self {
        Self {
            h_bits: f64::NAN.to_bits(),
            a: Vec::new(),
            dh: Vec::new(),
            ha: Vec::new(),
            d: Vec::new(),
        }
    }

    fn update(&mut self, element: &Element, h: f64) {
        if self.h_bits == h.to_bits() && !self.a.is_empty() {
            return;
        }
        let (s, r) = (element.degree(), element.points());
        self.h_bits = h.to_bits();
        self.a.clear();
        self.dh.clear();
        self.ha.clear();
        self.d.clear();
        for i in 0..r {
            for j in 0..=s {
                let (aj, dj) = (element.phi(i, j), element.dphi(i, j));
                if j > 0 {
                    self.a.push(aj);
                    self.dh.push(dj / h);
                }
                self.ha.push(h * aj);
                self.d.push(dj);
            }
        }
    }
}

/// The residual R(X) into `r` (dim = s·n entries) for the step from (t0, q, p) with step h;
/// the point derivatives are left in `work.pts` (∂L/∂q there gives Δp). `grad` holds the
/// (s + 1)·n rows ∂L_d/∂Q^j. Sizes are the caller's (`buffers`); ones that do not fit give a
/// NaN residual.
///
/// The rows are assembled as b_i (h ℓ_j(c_i) ∂L/∂q + ℓ_j'(c_i) ∂L/∂v), the arithmetic of the
/// gradient inside [`Element::hessian_in_place`] (whose rows full Newton drives to zero), not
/// as a ∂L/∂q + d ∂L/∂v with the products a = b_i h ℓ_j and d = b_i ℓ_j' of
/// [`Element::gradient_in_place`]: those rounded products bias every step of a run of equal
/// steps the same way, and an iteration that drove those rows to zero drifted the angular
/// momentum of `tests/adaptive_drift.rs` by 2e-13 over 2 000 periods (−6e-15 with these rows).
///
/// [`Element::hessian_in_place`]: crate::discrete::Element::hessian_in_place
/// [`Element::gradient_in_place`]: crate::discrete::Element::gradient_in_place
///
/// For n ≤ 4 the loops run over fixed-size arrays ([`residual_fixed`]; same operations,
/// same bits): with n a run-time length, the iterator and bounds overhead of these short
/// loops cost more than the Lagrangian's derivatives (callgrind, relativistic Kepler).
#[allow(clippy::too_many_arguments)]
pub(crate) fn simplified_residual<L: Lagrangian>(
    lag: &L,
    element: &Element,
    tables: &mut ResidualTables,
    work: &mut ElementWork,
    grad: &mut [f64],
    (t0, h): (f64, f64),
    (q, p): (&[f64], &[f64]),
    x: &[f64],
    r: &mut [f64],
) {
    tables.update(element, h);
    let args = (lag, element, &*tables);
    let done = match q.len() {
        1 => residual_fixed::<1, L>(args, work, grad, (t0, h), (q, p), x, r),
        2 => residual_fixed::<2, L>(args, work, grad, (t0, h), (q, p), x, r),
        3 => residual_fixed::<3, L>(args, work, grad, (t0, h), (q, p), x, r),
        4 => residual_fixed::<4, L>(args, work, grad, (t0, h), (q, p), x, r),
        _ => false,
    };
    if !done {
        residual_any(args, work, grad, (t0, h), (q, p), x, r);
    }
}

/// Whether the buffers fit dimension n (and the tables the element).
fn fits(element: &Element, tables: &ResidualTables, work: &ElementWork, n: usize, lens: [usize; 4]) -> bool {
    let (s, pts) = (element.degree(), element.points());
    let [x, r, p, grad] = lens;
    x == s * n
        && r == s * n
        && p == n
        && grad == (s + 1) * n
        && work.tc.len() >= pts
        && work.qc.len() >= pts * n
        && work.vc.len() >= pts * n
        && work.pts.len() >= pts
        && tables.a.len() == pts * s
        && tables.ha.len() == pts * (s + 1)
        && element.rule.weights.len() >= pts
        && element.rule.nodes.len() >= pts
}

/// R_0 = p_k + Δp − Σ_{j≥1} ∂L_d/∂Q^j and the rows R_j = ∂L_d/∂Q^j (0 < j < s) from the rows
/// in `grad` and ∂L/∂q at the points (lengths checked by the caller).
fn finish(element: &Element, work: &ElementWork, grad: &[f64], h: f64, p: &[f64], r: &mut [f64]) {
    let (n, s, pts) = (p.len(), element.degree(), element.points());
    r.copy_from_slice(&grad[..s * n]);
    // Issue 21: R_0 = p_k + Δp − Σ_{j≥1} ∂L_d/∂Q^j, not p_k + row 0 (see
    // `newton_step::residual_from_rows`).
    for (c, (rc, pc)) in r.iter_mut().zip(p).enumerate() {
        let dp = h
            * (0..pts)
                .map(|i| element.rule.weights[i] * work.pts[i].l_q().get(c).copied().unwrap_or(f64::NAN))
                .sum::<f64>();
        let rows: f64 = (1..=s).map(|j| grad[j * n + c]).sum();
        *rc = pc + (dp - rows);
    }
}

/// [`simplified_residual`] for n = N (false, nothing done, if a buffer does not fit).
#[allow(clippy::too_many_arguments)]
fn residual_fixed<const N: usize, L: Lagrangian>(
    (lag, element, tables): (&L, &Element, &ResidualTables),
    work: &mut ElementWork,
    grad: &mut [f64],
    (t0, h): (f64, f64),
    (q, p): (&[f64], &[f64]),
    x: &[f64],
    r: &mut [f64],
) -> bool {
    let (s, pts) = (element.degree(), element.points());
    let Ok(q) = <&[f64; N]>::try_from(q) else {
        return false;
    };
    if !fits(element, tables, work, N, [x.len(), r.len(), p.len(), grad.len()]) {
        return false;
    }
    grad.iter_mut().for_each(|g| *g = 0.0);
    // Σ_i b_i ∂L/∂q(c_i), summed in the order of `finish` (an f64 sum starts at −0.0).
    let mut lq_sum = [-0.0; N];
    for i in 0..pts {
        let t = t0 + element.rule.nodes[i] * h;
        work.tc[i] = t;
        let (mut qi, mut vi) = (*q, [0.0; N]);
        for j in 0..s {
            let (aj, dj) = (tables.a[i * s + j], tables.dh[i * s + j]);
            let xj = &x[j * N..(j + 1) * N];
            for c in 0..N {
                qi[c] += aj * xj[c];
                vi[c] += dj * xj[c];
            }
        }
        let pd = &mut work.pts[i];
        lag.first_derivatives(t, &qi, &vi, false, pd);
        let (Ok(lq), Ok(lv)) = (<&[f64; N]>::try_from(pd.l_q()), <&[f64; N]>::try_from(pd.l_v())) else {
            r.iter_mut().for_each(|v| *v = f64::NAN);
            return true;
        };
        let b = element.rule.weights[i];
        for c in 0..N {
            lq_sum[c] += b * lq[c];
        }
        for j in 0..=s {
            let (haj, dj) = (tables.ha[i * (s + 1) + j], tables.d[i * (s + 1) + j]);
            let g = &mut grad[j * N..(j + 1) * N];
            for c in 0..N {
                g[c] += b * (haj * lq[c] + dj * lv[c]);
            }
        }
    }
    r.copy_from_slice(&grad[..s * N]);
    for c in 0..N {
        let mut rows = -0.0;
        for j in 1..=s {
            rows += grad[j * N + c];
        }
        r[c] = p[c] + (h * lq_sum[c] - rows);
    }
    true
}

/// [`simplified_residual`] for any n.
#[allow(clippy::too_many_arguments)]
fn residual_any<L: Lagrangian>(
    (lag, element, tables): (&L, &Element, &ResidualTables),
    work: &mut ElementWork,
    grad: &mut [f64],
    (t0, h): (f64, f64),
    (q, p): (&[f64], &[f64]),
    x: &[f64],
    r: &mut [f64],
) {
    let (n, s, pts) = (q.len(), element.degree(), element.points());
    if n == 0 || !fits(element, tables, work, n, [x.len(), r.len(), p.len(), grad.len()]) {
        r.iter_mut().for_each(|v| *v = f64::NAN);
        return;
    }
    grad.iter_mut().for_each(|g| *g = 0.0);
    for i in 0..pts {
        work.tc[i] = t0 + element.rule.nodes[i] * h;
        let qi = &mut work.qc[i * n..(i + 1) * n];
        let vi = &mut work.vc[i * n..(i + 1) * n];
        qi.copy_from_slice(q);
        vi.iter_mut().for_each(|v| *v = 0.0);
        let (a, dh) = (&tables.a[i * s..(i + 1) * s], &tables.dh[i * s..(i + 1) * s]);
        for ((xj, &aj), &dj) in x.chunks_exact(n).zip(a).zip(dh) {
            for ((qc, vc), &xc) in qi.iter_mut().zip(vi.iter_mut()).zip(xj) {
                *qc += aj * xc;
                *vc += dj * xc;
            }
        }
        let pd = &mut work.pts[i];
        lag.first_derivatives(work.tc[i], qi, vi, false, pd);
        let (lq, lv) = (pd.l_q(), pd.l_v());
        if lq.len() != n || lv.len() != n {
            r.iter_mut().for_each(|v| *v = f64::NAN);
            return;
        }
        let b = element.rule.weights[i];
        let (ha, d) = (
            &tables.ha[i * (s + 1)..(i + 1) * (s + 1)],
            &tables.d[i * (s + 1)..(i + 1) * (s + 1)],
        );
        for ((gj, &haj), &dj) in grad.chunks_exact_mut(n).zip(ha).zip(d) {
            for ((g, lq), lv) in gj.iter_mut().zip(lq).zip(lv) {
                *g += b * (haj * lq + dj * lv);
            }
        }
    }
    finish(element, work, grad, h, p, r);
}
