//! Symplecticity measured: the tangent map of a step against finite differences, the
//! symplecticity defect max|MᵀJM − J| for midpoint and degrees 1–4 on Hénon–Heiles and the
//! double pendulum (and a non-symplectic map flagged), and the preserved two-form coefficient
//! ∂²L_d/∂q_k∂q_{k+1} against the paper's (2.21), (2.31) and corrected (2.51).

use crate::common::Lcg;
use femvi::diagnostics::symplecticity_defect;
use femvi::{
    models, Element, Integrator, Lagrangian, Mechanical, NodeFamily, Potential, QuadratureKind, Scalar, SolverOptions,
    Start, TimeGrid,
};

fn element(s: usize) -> Element {
    if s == 0 {
        Element::midpoint()
    } else {
        Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
    }
}

fn one_step<L: Lagrangian>(lag: &L, el: &Element, q: &[f64], p: &[f64], h: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let grid = TimeGrid::uniform(0.0, h, h).unwrap();
    let opts = SolverOptions {
        tolerance: 1e-15,
        ..Default::default()
    };
    let mut it = Integrator::new(
        lag,
        el,
        grid,
        Start::Momentum {
            q: q.to_vec(),
            p: p.to_vec(),
        },
        opts,
    )
    .unwrap();
    assert!(it.step().unwrap());
    let m = it.tangent_map().unwrap();
    (it.node().q.to_vec(), it.node().p.to_vec(), m)
}

#[test]
fn tangent_map_matches_finite_differences() {
    let lag = models::DoublePendulum {
        m1: 1.0,
        m2: 1.5,
        l1: 1.0,
        l2: 0.7,
        g: 9.81,
    };
    let (q, p, h) = ([0.7, -0.4], [0.3, 0.2], 0.05);
    for s in [0, 2, 3] {
        let el = element(s);
        let (_, _, m) = one_step(&lag, &el, &q, &p, h);
        let eps = 1e-6;
        for col in 0..4 {
            let (mut qa, mut pa, mut qb, mut pb) = (q, p, q, p);
            if col < 2 {
                qa[col] += eps;
                qb[col] -= eps;
            } else {
                pa[col - 2] += eps;
                pb[col - 2] -= eps;
            }
            let (q1a, p1a, _) = one_step(&lag, &el, &qa, &pa, h);
            let (q1b, p1b, _) = one_step(&lag, &el, &qb, &pb, h);
            for row in 0..4 {
                let fd = if row < 2 {
                    (q1a[row] - q1b[row]) / (2.0 * eps)
                } else {
                    (p1a[row - 2] - p1b[row - 2]) / (2.0 * eps)
                };
                let exact = m[row * 4 + col];
                assert!(
                    (fd - exact).abs() < 1e-7 * (1.0 + exact.abs()),
                    "s={s} M[{row}][{col}]: {exact} vs fd {fd}"
                );
            }
        }
    }
}

fn max_defect<L: Lagrangian>(lag: &L, el: &Element, start: Start, h: f64, steps: usize) -> f64 {
    let n = lag.dim();
    let grid = TimeGrid::uniform(0.0, h, h * steps as f64).unwrap();
    let opts = SolverOptions {
        tolerance: 1e-15,
        ..Default::default()
    };
    let mut it = Integrator::new(lag, el, grid, start, opts).unwrap();
    let mut worst = 0.0f64;
    while it.step().unwrap() {
        let m = it.tangent_map().unwrap();
        worst = worst.max(symplecticity_defect(&m, n));
    }
    worst
}

#[test]
fn symplecticity_defect_below_1e_12() {
    let hh = models::henon_heiles();
    let dp = models::DoublePendulum {
        m1: 1.0,
        m2: 1.0,
        l1: 1.0,
        l2: 1.0,
        g: 9.81,
    };
    for s in 0..=4 {
        let el = element(s);
        let d1 = max_defect(
            &hh,
            &el,
            Start::Momentum {
                q: vec![0.1, -0.1],
                p: vec![0.3, 0.2],
            },
            0.1,
            200,
        );
        let d2 = max_defect(
            &dp,
            &el,
            Start::Velocity {
                q: vec![1.0, 0.5],
                v: vec![0.0, 0.0],
            },
            0.02,
            200,
        );
        eprintln!("s={s}: defect Henon-Heiles {d1:.2e}, double pendulum {d2:.2e}");
        assert!(d1 <= 1e-12 && d2 <= 1e-12, "s={s}: {d1:e} {d2:e}");
    }
}

#[test]
fn a_non_symplectic_map_is_flagged() {
    // Explicit Euler for the pendulum: q' = q + h p, p' = p − h sin q; M = [[1, h], [−h cos q, 1]],
    // det M = 1 + h² cos q ≠ 1, so MᵀJM − J = (det M − 1) J.
    let (h, q) = (0.1f64, 0.3f64);
    let m = [1.0, h, -h * q.cos(), 1.0];
    let d = symplecticity_defect(&m, 1);
    assert!((d - h * h * q.cos()).abs() < 1e-15 && d > 1e-3, "{d}");
}

struct Quartic;
impl Potential for Quartic {
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D]) -> D {
        q[0].powi(4) * 0.25 + q[0] * q[0] * 0.5
    }
}
fn ddv(q: f64) -> f64 {
    3.0 * q * q + 1.0
}

/// ∂²L_d/∂q_k∂q_{k+1} (internal nodes eliminated) from the tangent map: with p_k = −D1 L_d,
/// ∂q_{k+1}/∂p_k = −1/D12.
fn d12<L: Lagrangian>(lag: &L, el: &Element, q: f64, p: f64, h: f64) -> (f64, f64, Option<f64>) {
    let grid = TimeGrid::uniform(0.0, h, h).unwrap();
    let opts = SolverOptions {
        tolerance: 1e-15,
        ..Default::default()
    };
    let mut it = Integrator::new(lag, el, grid, Start::Momentum { q: vec![q], p: vec![p] }, opts).unwrap();
    it.step().unwrap();
    let m = it.tangent_map().unwrap();
    let mid = (el.degree() == 2).then(|| {
        let e = it.last_element().unwrap();
        e.base[0] + e.incr[1]
    });
    (-1.0 / m[1], it.node().q[0], mid)
}

#[test]
fn two_form_coefficients_2_21_2_31_and_corrected_2_51() {
    let lag = Mechanical::unit_mass(Quartic);
    let mut rng = Lcg(3);
    let gl = femvi::fem::QuadratureRule::new(QuadratureKind::GaussLegendre(8)).unwrap();
    for _ in 0..20 {
        let (q, p, h) = (
            2.0 * rng.uniform() - 1.0,
            2.0 * rng.uniform() - 1.0,
            0.05 + 0.2 * rng.uniform(),
        );
        // (2.21): coefficient of dq_{k+1}∧dq_k is 1/h + h/4 V''(q̄); D12 is its negative.
        let (c, q1, _) = d12(&lag, &element(0), q, p, h);
        let paper = 1.0 / h + h / 4.0 * ddv(0.5 * (q + q1));
        assert!((c + paper).abs() < 1e-10 * paper, "(2.21): {c} vs {}", -paper);
        // (2.31): 1/h + h ∂²F/∂q_k∂q_{k+1}, F_12 = ∫₀¹ V''((1−s)q_k + s q_{k+1}) (1−s) s ds.
        // Exact integrals: V is quartic, so Gauss 3 (degree 1) and Gauss 5 (degree 2) are exact.
        let exact1 = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(3)).unwrap();
        let exact2 = Element::galerkin(2, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(5)).unwrap();
        let (c, q1, _) = d12(&lag, &exact1, q, p, h);
        let f12: f64 = gl
            .nodes
            .iter()
            .zip(&gl.weights)
            .map(|(s, w)| w * ddv((1.0 - s) * q + s * q1) * (1.0 - s) * s)
            .sum();
        let paper = 1.0 / h + h * f12;
        assert!((c + paper).abs() < 1e-10 * paper, "(2.31): {c} vs {}", -paper);
        // Corrected (2.51), oriented dq_k∧dq_{k+1}: 1/(3h) − h G_{k,k+1} − M,
        // M = (8/(3h) + h G_{m,k})(8/(3h) + h G_{m,k+1}) / (16/(3h) − h G_{m,m}),
        // G_ab = ∫₀¹ V''(q_h) f_a f_b dτ with the shape functions (2.34)–(2.37).
        let (c, q1, mid) = d12(&lag, &exact2, q, p, h);
        let qm = mid.unwrap();
        let g = |a: usize, b: usize| -> f64 {
            gl.nodes
                .iter()
                .zip(&gl.weights)
                .map(|(t, w)| {
                    let f = [(2.0 * t - 1.0) * (t - 1.0), 4.0 * t * (1.0 - t), t * (2.0 * t - 1.0)];
                    w * ddv(q * f[0] + qm * f[1] + q1 * f[2]) * f[a] * f[b]
                })
                .sum()
        };
        let mm = (8.0 / (3.0 * h) + h * g(1, 0)) * (8.0 / (3.0 * h) + h * g(1, 2)) / (16.0 / (3.0 * h) - h * g(1, 1));
        let corrected = 1.0 / (3.0 * h) - h * g(0, 2) - mm;
        assert!(
            (c - corrected).abs() < 1e-10 * corrected.abs(),
            "(2.51): {c} vs {corrected}"
        );
        // The misprinted constants (16 and 32, G_{m,k} twice) do not match.
        let printed =
            1.0 / (3.0 * h) - h * g(0, 2) - (16.0 / (3.0 * h) + h * g(1, 0)).powi(2) / (32.0 / (3.0 * h) - h * g(1, 1));
        assert!((c - printed).abs() > 1e-3 * c.abs());
    }
}
