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

/// The basis tables of an element for one step size h (recomputed when h changes). Rows are
/// s wide (the columns j = 1 … s), with the columns j = 0 of the gradient's tables apart, so
/// that [`residual_fixed`] takes them as fixed-size arrays without a division.
#[derive(Debug, Clone)]
pub(crate) struct ResidualTables {
    /// The bits of the h the tables are for (NaN's: none yet).
    h_bits: u64,
    /// ℓ_j(c_i), row i, j = 1 … s.
    a: Vec<f64>,
    /// ℓ_j'(c_i)/h, row i, j = 1 … s.
    dh: Vec<f64>,
    /// h ℓ_0(c_i) and ℓ_0'(c_i), one per point i.
    ha0: Vec<f64>,
    d0: Vec<f64>,
    /// h ℓ_j(c_i), row i, j = 1 … s.
    ha: Vec<f64>,
    /// ℓ_j'(c_i), row i, j = 1 … s.
    d: Vec<f64>,
}

impl ResidualTables {
    /// Empty tables (filled at the first evaluation).
    pub(crate) fn new() -> Self {
        Self {
            h_bits: f64::NAN.to_bits(),
            a: Vec::new(),
            dh: Vec::new(),
            ha0: Vec::new(),
            d0: Vec::new(),
            ha: Vec::new(),
            d: Vec::new(),
        }
    }

    fn update(&mut self, element: &Element, h: f64) {
        if self.h_bits == h.to_bits() && !self.ha0.is_empty() {
            return;
        }
        let (s, r) = (element.degree(), element.points());
        self.h_bits = h.to_bits();
        for t in [
            &mut self.a,
            &mut self.dh,
            &mut self.ha0,
            &mut self.d0,
            &mut self.ha,
            &mut self.d,
        ] {
            t.clear();
        }
        for i in 0..r {
            for j in 0..=s {
                let (aj, dj) = (element.phi(i, j), element.dphi(i, j));
                if j > 0 {
                    self.a.push(aj);
                    self.dh.push(dj / h);
                    self.ha.push(h * aj);
                    self.d.push(dj);
                } else {
                    self.ha0.push(h * aj);
                    self.d0.push(dj);
                }
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
/// For n ≤ 4 and degrees s ≤ 4 the loops run over fixed-size arrays ([`residual_fixed`];
/// same operations, same bits): with n and s run-time lengths, the iterator and bounds
/// overhead of these short loops cost more than the Lagrangian's derivatives (callgrind,
/// relativistic Kepler).
#[allow(clippy::too_many_arguments)]
#[inline]
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
    macro_rules! fixed {
        ($($n:literal, $s:literal);*) => {
            match (q.len(), element.degree()) {
                $(($n, $s) => residual_fixed::<$n, $s, L>(args, work, grad, (t0, h), (q, p), x, r),)*
                _ => false,
            }
        };
    }
    let done = fixed!(1, 1; 1, 2; 1, 3; 1, 4; 2, 1; 2, 2; 2, 3; 2, 4; 3, 1; 3, 2; 3, 3; 3, 4; 4, 1; 4, 2; 4, 3; 4, 4);
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
        && tables.dh.len() == pts * s
        && tables.ha.len() == pts * s
        && tables.d.len() == pts * s
        && tables.ha0.len() == pts
        && tables.d0.len() == pts
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

/// [`simplified_residual`] for n = N and degree s = S (false, nothing done, if a buffer does
/// not fit). Every row of the tables, every X^j and every row of `grad` is a fixed-size array
/// and the rows are summed in registers, so the loops carry no bounds checks: with s a run-time
/// length a residual at degree 4 took ~1 650 instructions besides the Lagrangian's (callgrind,
/// relativistic Kepler), and this version takes 0.95× (degree 2) and 0.91× (degree 4) the
/// time of a step (7 alternating rounds). Each sum takes its terms in the same order as
/// [`residual_any`]'s, so the bits are the same (`tests` below).
#[allow(clippy::too_many_arguments)]
#[inline]
fn residual_fixed<const N: usize, const S: usize, L: Lagrangian>(
    (lag, element, tables): (&L, &Element, &ResidualTables),
    work: &mut ElementWork,
    grad: &mut [f64],
    (t0, h): (f64, f64),
    (q, p): (&[f64], &[f64]),
    x: &[f64],
    r: &mut [f64],
) -> bool {
    let pts = element.points();
    let (Ok(q), Ok(p)) = (<&[f64; N]>::try_from(q), <&[f64; N]>::try_from(p)) else {
        return false;
    };
    if element.degree() != S || !fits(element, tables, work, N, [x.len(), r.len(), N, grad.len()]) {
        return false;
    }
    let (xs, _) = x.as_chunks::<N>();
    let Ok(xs) = <&[[f64; N]; S]>::try_from(xs) else {
        return false;
    };
    // Rows ∂L_d/∂Q^j, j < S, and the last one, summed from +0.0 as `residual_any`'s zeroed
    // buffer is.
    let (mut rows, mut last) = ([[0.0; N]; S], [0.0; N]);
    // Σ_i b_i ∂L/∂q(c_i), summed in the order of `finish` (an f64 sum starts at −0.0).
    let mut lq_sum = [-0.0; N];
    // Rows as arrays of S (`as_chunks`: no division by a run-time width, which as
    // `chunks_exact` cost a tenth of a degree-2 step).
    let [a, dh, ha, d] = [&tables.a, &tables.dh, &tables.ha, &tables.d].map(|t| t.as_chunks::<S>().0);
    let a_rows = a.iter().zip(dh);
    let g_rows = tables.ha0.iter().zip(&tables.d0).zip(ha.iter().zip(d));
    let rule = element.rule.nodes.iter().zip(&element.rule.weights);
    let out = work.tc.iter_mut().zip(work.pts.iter_mut());
    for ((((a, dh), ((ha0, d0), (ha, d))), (&node, &b)), (tc, pd)) in a_rows.zip(g_rows).zip(rule).zip(out).take(pts) {
        let t = t0 + node * h;
        *tc = t;
        let (mut qi, mut vi) = (*q, [0.0; N]);
        for ((aj, dj), xj) in a.iter().zip(dh).zip(xs) {
            for c in 0..N {
                qi[c] += aj * xj[c];
                vi[c] += dj * xj[c];
            }
        }
        lag.first_derivatives(t, &qi, &vi, false, pd);
        let (Ok(lq), Ok(lv)) = (<&[f64; N]>::try_from(pd.l_q()), <&[f64; N]>::try_from(pd.l_v())) else {
            r.iter_mut().chain(grad.iter_mut()).for_each(|v| *v = f64::NAN);
            return true;
        };
        for c in 0..N {
            lq_sum[c] += b * lq[c];
        }
        // Row j of the gradient takes h ℓ_j(c_i) and ℓ_j'(c_i): row 0 from `ha0`, `d0`, rows
        // 1 … S−1 and the last (j = S) from the rows of `ha`, `d` (columns j = 1 … S).
        let (haj, dj) = (*ha0, *d0);
        for c in 0..N {
            rows[0][c] += b * (haj * lq[c] + dj * lv[c]);
        }
        for j in 1..S {
            let (haj, dj) = (ha[j - 1], d[j - 1]);
            for c in 0..N {
                rows[j][c] += b * (haj * lq[c] + dj * lv[c]);
            }
        }
        let (haj, dj) = (ha[S - 1], d[S - 1]);
        for c in 0..N {
            last[c] += b * (haj * lq[c] + dj * lv[c]);
        }
    }
    let (gs, _) = grad.as_chunks_mut::<N>();
    for (g, row) in gs.iter_mut().zip(rows.iter().chain([&last])) {
        *g = *row;
    }
    let (rs, _) = r.as_chunks_mut::<N>();
    for (rj, row) in rs.iter_mut().zip(&rows) {
        *rj = *row;
    }
    if let Some(r0) = rs.first_mut() {
        for c in 0..N {
            let mut sum = -0.0;
            for row in rows.iter().skip(1) {
                sum += row[c];
            }
            sum += last[c];
            r0[c] = p[c] + (h * lq_sum[c] - sum);
        }
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
        let (ha, d) = (&tables.ha[i * s..(i + 1) * s], &tables.d[i * s..(i + 1) * s]);
        let ha = std::iter::once(&tables.ha0[i]).chain(ha);
        let d = std::iter::once(&tables.d0[i]).chain(d);
        for ((gj, &haj), &dj) in grad.chunks_exact_mut(n).zip(ha).zip(d) {
            for ((g, lq), lv) in gj.iter_mut().zip(lq).zip(lv) {
                *g += b * (haj * lq + dj * lv);
            }
        }
    }
    finish(element, work, grad, h, p, r);
}

#[cfg(test)]
mod tests {
    //! The fixed-size residual against the any-size one, bit for bit: the module's claim
    //! that both sum the same terms in the same order.
    use super::*;
    use crate::lagrangian::Scalar;
    use crate::{NodeFamily, QuadratureKind};

    /// A velocity-dependent Lagrangian in any dimension (couples q and v in every term).
    struct Coupled(usize);

    impl Lagrangian for Coupled {
        fn dim(&self) -> usize {
            self.0
        }
        fn value<D: Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
            let (mut kin, mut pot, mut mix) = (D::from(0.0), D::from(0.0), D::from(0.0));
            for (i, (&qi, &vi)) in q.iter().zip(v).enumerate() {
                let w = 1.0 + 0.1 * i as f64;
                kin += vi * vi * (qi * 0.3).cos() * w;
                pot += (qi * qi + 1.0).sqrt() * w;
                mix += vi * q[(i + 1) % q.len()] * (t * 0.2).sin();
            }
            kin * 0.5 - pot + mix
        }
    }

    /// Both residuals (and the gradient rows) at a pseudo-random point, as bits.
    fn both(n: usize, s: usize, seed: u64) -> [Vec<u64>; 2] {
        let element = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s + 1)).unwrap();
        let lag = Coupled(n);
        let mut state = seed;
        let mut rand = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let q: Vec<f64> = (0..n).map(|_| rand()).collect();
        let p: Vec<f64> = (0..n).map(|_| rand()).collect();
        let x: Vec<f64> = (0..s * n).map(|_| 0.1 * rand()).collect();
        let (t0, h) = (0.3 + rand(), 0.05 + 0.01 * rand());
        let mut tables = ResidualTables::new();
        tables.update(&element, h);
        let run = |fixed: bool| {
            let mut work = ElementWork::new(&element, n);
            let (mut grad, mut r) = (vec![0.0; (s + 1) * n], vec![0.0; s * n]);
            let args = (&lag, &element, &tables);
            if fixed {
                macro_rules! fixed {
                    ($($n:literal, $s:literal);*) => {
                        match (n, s) {
                            $(($n, $s) => residual_fixed::<$n, $s, Coupled>(args, &mut work, &mut grad, (t0, h), (&q, &p), &x, &mut r),)*
                            _ => false,
                        }
                    };
                }
                assert!(fixed!(1, 1; 1, 3; 2, 2; 2, 4; 3, 1; 3, 3; 4, 2; 4, 4), "n {n}, s {s}");
            } else {
                residual_any(args, &mut work, &mut grad, (t0, h), (&q, &p), &x, &mut r);
            }
            r.iter().chain(&grad).map(|v| v.to_bits()).collect::<Vec<_>>()
        };
        [run(true), run(false)]
    }

    #[test]
    fn fixed_size_residual_equals_the_any_size_one_bit_for_bit() {
        for (n, s) in [(1, 1), (1, 3), (2, 2), (2, 4), (3, 1), (3, 3), (4, 2), (4, 4)] {
            for seed in 0..20 {
                let [fixed, any] = both(n, s, seed);
                assert!(fixed.iter().all(|&b| f64::from_bits(b).is_finite()), "n {n}, s {s}");
                assert_eq!(fixed, any, "n {n}, s {s}, seed {seed}");
            }
        }
    }
}
