//! The routes of `Integrator::tangent_apply` against the dense map (`Integrator::tangent_map`,
//! implicit differentiation of the element equations with the element Hessian): the
//! mechanical tangent (the variational equations in the fixed-point step's structure, on the
//! force's directional derivative, or for small n on the stage Jacobians) on several
//! systems, degrees and quadratures, whichever solver took the steps; and its
//! symplecticity, a property neither route assumes.

use femvi::expr::ExprLagrangian;
use femvi::{
    models, Element, Integrator, Lagrangian, Method, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid,
};

/// Steps `lag` 30 times with `element` and `method`; at every step compares one mixed vector
/// carried alone (few products: the force's directional derivative unless n is tiny) and the
/// 2n unit vectors plus the mixed one carried together (the stage Jacobians for n ≤ 16) with
/// the dense map, and returns the largest relative difference.
fn worst<L: Lagrangian>(lag: &L, element: &Element, method: Method, start: Start, h: f64) -> f64 {
    let n = lag.dim();
    let d = 2 * n;
    let opts = SolverOptions {
        method,
        ..SolverOptions::default()
    };
    let grid = TimeGrid::uniform(0.0, h, 30.0 * h).unwrap();
    let mut it = Integrator::new(lag, element, grid, start, opts).unwrap();
    let mut worst: f64 = 0.0;
    while it.step().unwrap() {
        let mixed: Vec<f64> = (0..d).map(|i| 0.3 - 0.11 * i as f64).collect();
        let mut alone = mixed.clone();
        it.tangent_apply(&mut alone).unwrap();
        let mut v: Vec<f64> = (0..d * d).map(|i| if i % d == i / d { 1.0 } else { 0.0 }).collect();
        v.extend(&mixed);
        it.tangent_apply(&mut v).unwrap();
        v.extend(alone);
        let m = it.tangent_map().unwrap();
        let scale = m.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for (k, col) in v.chunks_exact(d).enumerate() {
            for (i, x) in col.iter().enumerate() {
                let want: f64 = if k < d {
                    m[i * d + k]
                } else {
                    (0..d).map(|j| m[i * d + j] * (0.3 - 0.11 * j as f64)).sum()
                };
                worst = worst.max((x - want).abs() / scale);
            }
        }
    }
    worst
}

fn trapezoid() -> Element {
    Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap()
}

fn elements() -> Vec<(&'static str, Element)> {
    vec![
        ("trapezoid", trapezoid()),
        ("gauss order 4", Element::with_order(4).unwrap()),
        ("gauss order 8", Element::with_order(8).unwrap()),
        (
            "degree 3 Lobatto",
            Element::galerkin(3, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(4)).unwrap(),
        ),
    ]
}

#[test]
fn the_mechanical_tangent_is_the_dense_map() {
    let kepler = models::kepler(1.0).unwrap();
    let kepler_start = || Start::Momentum {
        q: vec![0.5, 0.0],
        p: vec![0.0, 3f64.sqrt()],
    };
    let hh = models::henon_heiles();
    let hh_start = || Start::Momentum {
        q: vec![0.0, -0.1],
        p: vec![0.55, 0.1],
    };
    // Unequal masses: M is not the identity.
    let planets = models::n_body(1.0, vec![1.0, 1e-3, 3e-4], 3).unwrap();
    let masses = [1.0, 1e-3, 3e-4];
    let vel = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -0.79, 0.0, 0.01];
    let planets_start = || Start::Momentum {
        q: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.6, 0.01],
        p: (0..9).map(|i| masses[i / 3] * vel[i]).collect(),
    };
    // n = 8 forms the stage Jacobians, n = 20 (above JACOBIAN_MAX_DIM = 16) takes the
    // force's directional derivative at every product.
    let fpu = models::fpu(8, 0.25, 0.5).unwrap();
    let fpu_start = |n: usize| Start::Momentum {
        q: (0..n).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect(),
        p: vec![0.0; n],
    };
    let fpu20 = models::fpu(20, 0.25, 0.5).unwrap();
    for (name, el) in elements() {
        let methods: &[Method] = if el.degree() == 1 {
            &[Method::Auto, Method::FixedPoint, Method::Newton]
        } else {
            &[Method::Auto, Method::Newton]
        };
        for &method in methods {
            let cases = [
                ("kepler", worst(&kepler, &el, method, kepler_start(), 0.05)),
                ("henon-heiles", worst(&hh, &el, method, hh_start(), 0.1)),
                (
                    "star + two planets",
                    worst(&planets, &el, method, planets_start(), 0.03),
                ),
                ("fpu", worst(&fpu, &el, method, fpu_start(8), 0.1)),
                ("fpu n = 20", worst(&fpu20, &el, method, fpu_start(20), 0.1)),
            ];
            for (system, e) in cases {
                assert!(e < 1e-12, "{system}, {name}, {method:?}: {e:e}");
            }
        }
    }
}

/// The trapezoid's first stage is its last step's last (first same as last) only when that
/// step was carried: vectors carried on some steps and not others (the stage kept would then
/// be two steps old, O(h) away) still follow the dense map of each step carried.
#[test]
fn a_step_after_one_not_carried_does_not_keep_its_first_stage() {
    let lag = models::n_body(1.0, vec![1.0, 1e-3, 3e-4], 2).unwrap();
    let start = Start::Momentum {
        q: vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.6],
        p: vec![0.0, 0.0, 0.0, 1e-3, -0.79 * 3e-4, 0.0],
    };
    let d = 2 * lag.dim();
    let grid = TimeGrid::uniform(0.0, 0.03, 3.0).unwrap();
    let element = trapezoid();
    let mut it = Integrator::new(&lag, &element, grid, start, SolverOptions::default()).unwrap();
    {
        let mut k = 0;
        while it.step().unwrap() {
            k += 1;
            if k % 3 == 0 {
                continue;
            }
            // One vector (the force's products) and 2n + 1 (prepared products).
            for count in [1, d + 1] {
                let mut v: Vec<f64> = (0..count * d).map(|i| 0.3 - 0.07 * (i % 11) as f64).collect();
                let want = v.clone();
                it.tangent_apply(&mut v).unwrap();
                let m = it.tangent_map().unwrap();
                let scale = m.iter().fold(0.0f64, |a, x| a.max(x.abs()));
                for (col, w) in v.chunks_exact(d).zip(want.chunks_exact(d)) {
                    for (i, x) in col.iter().enumerate() {
                        let y: f64 = (0..d).map(|j| m[i * d + j] * w[j]).sum();
                        assert!(
                            (x - y).abs() <= 1e-12 * scale,
                            "step {k}, {count} vectors: {x} against {y}"
                        );
                    }
                }
            }
        }
    }
}

/// A compiled expression's force derivative (symbolic) gives the same maps, with a
/// configuration-dependent coupling and a mass matrix that is not diagonal.
#[test]
fn the_mechanical_tangent_of_an_expression_is_the_dense_map() {
    let names = ["x".to_string(), "y".to_string()];
    let lag = ExprLagrangian::new(
        "x_dot^2 + 0.5*x_dot*y_dot + y_dot^2 - 0.5*x^2 - 0.5*y^2 - x^2*y + y^3/3 - 0.1*cos(x*y)",
        &names,
        &[],
    )
    .unwrap();
    assert!(lag.mass_matrix().is_some());
    for (name, el) in elements() {
        let start = Start::Momentum {
            q: vec![0.1, -0.2],
            p: vec![0.3, 0.1],
        };
        let e = worst(&lag, &el, Method::Auto, start, 0.1);
        assert!(e < 1e-12, "{name}: {e:e}");
    }
}

/// Symplecticity of the carried map, MᵀΩM = Ω, to rounding: a property of the exact map that
/// the fixed-point route does not build in.
#[test]
fn the_mechanical_tangent_is_symplectic() {
    let lag = models::n_body(1.0, vec![1.0, 1e-3, 3e-4], 2).unwrap();
    let masses = [1.0, 1e-3, 3e-4];
    let vel = [0.0, 0.0, 0.0, 1.0, -0.79, 0.0];
    let start = Start::Momentum {
        q: vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.6],
        p: (0..6).map(|i| masses[i / 2] * vel[i]).collect(),
    };
    let (n, d) = (6, 12);
    for (name, el) in elements() {
        let grid = TimeGrid::uniform(0.0, 0.02, 1.0).unwrap();
        let mut it = Integrator::new(&lag, &el, grid, start.clone(), SolverOptions::default()).unwrap();
        // The product of 50 steps' maps, column by column.
        let mut w: Vec<f64> = (0..d * d).map(|i| if i % d == i / d { 1.0 } else { 0.0 }).collect();
        while it.step().unwrap() {
            it.tangent_apply(&mut w).unwrap();
        }
        // Ω(a, b) = a_qᵀ b_p − a_pᵀ b_q for columns a, b.
        let omega = |a: &[f64], b: &[f64]| (0..n).map(|i| a[i] * b[n + i] - a[n + i] * b[i]).sum::<f64>();
        let mut defect: f64 = 0.0;
        let scale = w.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for i in 0..d {
            for j in 0..d {
                let want = if j == i + n {
                    1.0
                } else if i == j + n {
                    -1.0
                } else {
                    0.0
                };
                let got = omega(&w[i * d..(i + 1) * d], &w[j * d..(j + 1) * d]);
                defect = defect.max((got - want).abs());
            }
        }
        assert!(defect < 1e-12 * scale * scale, "{name}: {defect:e} (scale {scale:e})");
    }
}

/// Refusals: vectors of the wrong length, and no step taken yet.
#[test]
fn tangent_apply_refuses_what_it_cannot_carry() {
    let lag = models::kepler(1.0).unwrap();
    let el = trapezoid();
    let grid = TimeGrid::uniform(0.0, 0.1, 1.0).unwrap();
    let start = Start::Momentum {
        q: vec![1.0, 0.0],
        p: vec![0.0, 1.0],
    };
    let mut it = Integrator::new(&lag, &el, grid, start, SolverOptions::default()).unwrap();
    let mut v = vec![1.0, 0.0, 0.0, 0.0];
    assert!(it.tangent_apply(&mut v).is_err(), "before the first step");
    it.step().unwrap();
    let mut short = vec![1.0, 0.0, 0.0];
    assert!(matches!(
        it.tangent_apply(&mut short),
        Err(femvi::Error::Dimension { .. })
    ));
    assert_eq!(short, [1.0, 0.0, 0.0]);
    assert!(it.tangent_apply(&mut v).is_ok());
    assert!(it.tangent_apply(&mut []).is_ok());
}
