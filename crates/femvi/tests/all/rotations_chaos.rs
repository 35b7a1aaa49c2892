//! Tangent vectors and chaos indicators of runs with rotations (issue 37, item 3): the
//! Lie-group step's tangent map in the canonical chart coordinates (ψ, p_ψ) of T*SO(3)
//! (`rotation/tangent.rs`), carried by `Integrator::tangent_apply` and the chaos loop,
//! against central differences of whole runs started from perturbed charts (an independent
//! computation: only the run's nodes are used), and the indicators of an integrable body
//! (the free body: ⟨Y⟩ → 2, the spectrum near 0 and summing to 0) and of a chaotic one.

use femvi::chaos::{indicators_on, ChaosOptions};
use femvi::models::RigidBody;
use femvi::rotation::so3::{dexp, dexp_inv, exp, hat, mul, mul_tn, vee};
use femvi::rotation::{body_state, embedded_velocity, Rotations};
use femvi::{Element, Integrator, SolverOptions, Start, TimeGrid};

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

/// The asymmetric heavy top of these tests (centre of mass off every principal axis).
fn top() -> RigidBody {
    RigidBody::heavy_top([1.0, 2.0, 3.0], 1.0, 9.81, [0.3, 0.2, 0.5]).unwrap()
}

fn integrator<'a>(
    body: &'a RigidBody,
    element: &'a Element,
    start: Start,
    h: f64,
    end: f64,
) -> Integrator<'a, RigidBody> {
    let grid = TimeGrid::uniform(0.0, h, end).unwrap();
    let layout = Rotations::new(9, &[0]).unwrap();
    Integrator::with_rotations(body, element, grid, start, SolverOptions::default(), layout).unwrap()
}

/// The start at chart coordinates (ψ, p_ψ) about (R0, Π0): R = R0 exp(ψ̂) and body momentum
/// μ = dexp_ψ⁻¹ p_ψ, as (q, p) with P = ½ R μ̂.
fn chart_start(r0: &[f64; 9], psi: [f64; 3], p_psi: [f64; 3]) -> Start {
    let r = mul(r0, &exp(&psi));
    let mu = dexp_inv(&psi, &p_psi);
    let p = mul(&r, &hat(&mu)).map(|x| 0.5 * x);
    Start::Momentum {
        q: r.to_vec(),
        p: p.to_vec(),
    }
}

/// The logarithm of a rotation near the identity.
fn log(a: &[f64; 9]) -> [f64; 3] {
    let c = ((a[0] + a[4] + a[8] - 1.0) / 2.0).clamp(-1.0, 1.0);
    let theta = c.acos();
    let s = vee(&std::array::from_fn(|k| 0.5 * (a[k] - a[(k % 3) * 3 + k / 3])));
    let f = if theta < 1e-8 { 1.0 } else { theta / theta.sin() };
    s.map(|x| f * x)
}

/// The end of the run from `start`, in the chart about (R_ref, ·): (ψ, p_ψ) with
/// ψ = log(R_refᵀ R), p_ψ = dexp_ψ Π.
fn end_in_chart(body: &RigidBody, element: &Element, start: Start, r_ref: &[f64; 9], (h, end): (f64, f64)) -> [f64; 6] {
    let mut it = integrator(body, element, start, h, end);
    while it.step().unwrap() {}
    let node = it.node();
    let (r, pi) = body_state(node.q, node.p, 0);
    let psi = log(&mul_tn(r_ref, &r));
    let p = dexp(&psi, &pi);
    [psi[0], psi[1], psi[2], p[0], p[1], p[2]]
}

/// The product of the steps' tangent maps (6 × 6, column j the image of unit vector j)
/// against central differences of whole runs, for the top at degree `degree`.
fn tangent_against_differences(degree: usize) -> f64 {
    let body = top();
    let element = Element::with_order(2 * degree).unwrap();
    let (h, end) = (0.05, 1.0);
    let w0 = [0.5, 1.0, 0.3];
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: embedded_velocity(&IDENTITY, &w0).to_vec(),
    };
    let mut it = integrator(&body, &element, start, h, end);
    assert_eq!(it.tangent_dim(), 6);
    let mut w: Vec<f64> = (0..36).map(|i| if i % 7 == 0 { 1.0 } else { 0.0 }).collect();
    let (_, pi0) = body_state(it.node().q, it.node().p, 0);
    while it.step().unwrap() {
        it.tangent_apply(&mut w).unwrap();
    }
    let (r_end, _) = body_state(it.node().q, it.node().p, 0);
    let eps = 1e-6;
    let mut worst: f64 = 0.0;
    for col in 0..6 {
        let at = |sign: f64| {
            let mut u = [0.0; 6];
            u[col] = sign * eps;
            let psi = [u[0], u[1], u[2]];
            let p = [pi0[0] + u[3], pi0[1] + u[4], pi0[2] + u[5]];
            end_in_chart(&body, &element, chart_start(&IDENTITY, psi, p), &r_end, (h, end))
        };
        let (plus, minus) = (at(1.0), at(-1.0));
        for row in 0..6 {
            let fd = (plus[row] - minus[row]) / (2.0 * eps);
            let scale = w[col * 6..col * 6 + 6].iter().fold(1.0f64, |m, x| m.max(x.abs()));
            worst = worst.max((w[col * 6 + row] - fd).abs() / scale);
        }
    }
    worst
}

#[test]
fn tangent_vectors_on_t_star_so3_follow_whole_runs() {
    // Degree 1 (the rigid body's fixed point) and degree 2 (Newton in the algebra), 20 steps.
    for degree in [1, 2] {
        let e = tangent_against_differences(degree);
        eprintln!("degree {degree}: tangent map against differences {e:e}");
        assert!(e < 1e-6, "degree {degree}: tangent map against differences {e:e}");
    }
}

#[test]
fn the_free_body_is_regular_and_its_spectrum_pairs() {
    let body = RigidBody::free([1.0, 2.0, 3.0]).unwrap();
    let element = Element::with_order(2).unwrap();
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: embedded_velocity(&IDENTITY, &[0.5, 1.0, 0.3]).to_vec(),
    };
    let mut it = integrator(&body, &element, start, 0.05, 500.0);
    let chaos = ChaosOptions {
        spectrum: true,
        ..ChaosOptions::default()
    };
    let r = indicators_on(&mut it, &chaos).unwrap();
    assert!(r.error.is_none(), "{:?}", r.error);
    let s = r.spectrum.unwrap();
    assert_eq!(s.len(), 6);
    // Symplectic steps: the exponents sum to zero up to round-off; integrable: all small.
    assert!(s.iter().sum::<f64>().abs() < 1e-10, "spectrum {s:?}");
    assert!(s.iter().all(|l| l.abs() < 0.03), "spectrum {s:?}");
    assert!((r.last.mean_megno - 2.0).abs() < 0.3, "<Y> = {}", r.last.mean_megno);
}

#[test]
fn an_asymmetric_heavy_top_is_chaotic_at_both_degrees() {
    let body = top();
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: embedded_velocity(&IDENTITY, &[0.5, 1.0, 0.3]).to_vec(),
    };
    let mut largest = vec![];
    for degree in [1, 2] {
        let element = Element::with_order(2 * degree).unwrap();
        let mut it = integrator(&body, &element, start.clone(), 0.01, 400.0);
        let r = indicators_on(&mut it, &ChaosOptions::default()).unwrap();
        assert!(r.error.is_none(), "{:?}", r.error);
        eprintln!(
            "degree {degree}: <Y> = {}, lambda = {}",
            r.last.mean_megno, r.last.lyapunov
        );
        assert!(r.last.mean_megno > 10.0, "<Y> = {}", r.last.mean_megno);
        largest.push(r.last.lyapunov);
    }
    assert!(largest.iter().all(|l| *l > 0.05), "exponents {largest:?}");
}

#[test]
fn tangent_vectors_of_the_wrong_length_are_refused() {
    let body = top();
    let element = Element::with_order(2).unwrap();
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: embedded_velocity(&IDENTITY, &[0.5, 1.0, 0.3]).to_vec(),
    };
    let mut it = integrator(&body, &element, start, 0.05, 1.0);
    // Before any step: no map yet.
    assert!(it.tangent_apply(&mut [1.0; 6]).is_err());
    it.step().unwrap();
    // Vectors of T*SO(3) have 6 components: lengths that are not a multiple are refused.
    assert!(it.tangent_apply(&mut [1.0; 4]).is_err());
    assert!(it.tangent_apply(&mut [1.0; 9]).is_err());
    let mut v = [1.0; 6];
    it.tangent_apply(&mut v).unwrap();
    assert!(v.iter().all(|x| x.is_finite()));
}
