//! Torques on rotations (issue 37, item 3: torques as forces): the Lie-group element under the
//! discrete Lagrange–d'Alembert principle (`Integrator::with_rotations_and_force`), against
//! closed forms derived here:
//! - an isotropic body (I = i·1) under the drag τ = −c w keeps the direction of w:
//!   w(t) = w₀ e^{−ct/i} and R(t) = R₀ exp(θ(t) ŵ₀/|w₀|), θ = |w₀| (i/c)(1 − e^{−ct/i});
//! - any body under τ = −c Π: the spatial angular momentum m = R Π obeys
//!   ṁ = R(w × Π) + R(Π × w − c Π) = −c m, so m(t) = m₀ e^{−ct}.
//!
//! Nodal order 2s is fitted for s = 1, 2, 3, and the energy balance E_k − E_0 − W_k (W the
//! discrete work) closes at the element's order (for the isotropic body at degree 1, to
//! round-off).

use femvi::forces::Force;
use femvi::models::RigidBody;
use femvi::rotation::so3::{exp, mul};
use femvi::rotation::{body_state, embedded_velocity, Rotations};
use femvi::{Element, Integrator, Scalar, SolverOptions, Start, TimeGrid};

/// τ = −c (k ⊙ w) in the body frame (k = 1: drag on w; k = I: drag on Π), as the force ½ R τ̂
/// on the entries.
struct Drag {
    c: f64,
    k: [f64; 3],
}

impl Force for Drag {
    fn dim(&self) -> usize {
        9
    }
    fn force<D: Scalar>(&self, _t: D, q: &[D], v: &[D], out: &mut [D]) {
        let a = |i: usize, j: usize| q[i] * v[j] + q[3 + i] * v[3 + j] + q[6 + i] * v[6 + j];
        let w = [
            (a(2, 1) - a(1, 2)) * 0.5,
            (a(0, 2) - a(2, 0)) * 0.5,
            (a(1, 0) - a(0, 1)) * 0.5,
        ];
        let tau: [D; 3] = std::array::from_fn(|c| w[c] * (-self.c * self.k[c]));
        let z = D::from(0.0);
        let hat = [z, -tau[2], tau[1], tau[2], z, -tau[0], -tau[1], tau[0], z];
        for i in 0..3 {
            for j in 0..3 {
                out[3 * i + j] = (q[3 * i] * hat[j] + q[3 * i + 1] * hat[3 + j] + q[3 * i + 2] * hat[6 + j]) * 0.5;
            }
        }
    }
}

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

fn run<'a>(
    body: &'a RigidBody,
    drag: &'a Drag,
    element: &'a Element,
    w0: [f64; 3],
    h: f64,
    end: f64,
) -> Integrator<'a, RigidBody> {
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: embedded_velocity(&IDENTITY, &w0).to_vec(),
    };
    let grid = TimeGrid::uniform(0.0, h, end).unwrap();
    let layout = Rotations::new(9, &[0]).unwrap();
    Integrator::with_rotations_and_force(body, element, grid, start, SolverOptions::default(), layout, drag).unwrap()
}

fn fitted_order(h: &[f64], err: &[f64]) -> f64 {
    let (x, y): (Vec<f64>, Vec<f64>) = h.iter().zip(err).map(|(h, e)| (h.ln(), e.ln())).unzip();
    let (mx, my) = (x.iter().sum::<f64>() / 3.0, y.iter().sum::<f64>() / 3.0);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// The fitted orders of `error_at_end` and of the largest energy-balance error
/// max_k |E_k − E_0 − W_k| over the steps of degree s.
fn study(
    s: usize,
    steps: [f64; 3],
    error_at_end: impl Fn(&Integrator<'_, RigidBody>) -> f64,
    setup: (&RigidBody, &Drag, [f64; 3]),
) -> (f64, f64, f64) {
    let (body, drag, w0) = setup;
    let element = Element::with_order(2 * s).unwrap();
    let (mut errors, mut balances) = (vec![], vec![]);
    for h in steps {
        let mut it = run(body, drag, &element, w0, h, 2.0);
        let e0 = it.energy().unwrap();
        let mut balance: f64 = 0.0;
        while it.step().unwrap() {
            balance = balance.max((it.energy().unwrap() - e0 - it.work()).abs());
        }
        errors.push(error_at_end(&it));
        balances.push(balance);
    }
    eprintln!("s = {s}: errors {errors:?}, energy balance {balances:?}");
    let worst = balances.iter().fold(0.0f64, |m, b| m.max(*b));
    (fitted_order(&steps, &errors), fitted_order(&steps, &balances), worst)
}

const STEPS: [[f64; 3]; 3] = [[0.04, 0.02, 0.01], [0.2, 0.1, 0.05], [0.4, 0.2, 0.1]];

#[test]
fn an_isotropic_body_under_drag_follows_its_closed_form_at_order_2s() {
    let (i, c, w0): (f64, f64, [f64; 3]) = (2.0, 0.7, [0.5, 1.0, 0.3]);
    let body = RigidBody::free([i; 3]).unwrap();
    let drag = Drag { c, k: [1.0; 3] };
    let speed = (w0[0] * w0[0] + w0[1] * w0[1] + w0[2] * w0[2]).sqrt();
    let t = 2.0f64;
    let decay = (-c * t / i).exp();
    let theta = speed * (i / c) * (1.0 - decay);
    let r_exact = mul(&IDENTITY, &exp(&w0.map(|x| x / speed * theta)));
    let w_exact = w0.map(|x| x * decay);
    let error = |it: &Integrator<'_, RigidBody>| {
        let (r, pi) = body_state(it.node().q, it.node().p, 0);
        let er = r.iter().zip(&r_exact).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let ew = (0..3).fold(0.0f64, |m, k| m.max((pi[k] / i - w_exact[k]).abs()));
        er.max(ew)
    };
    for (s, steps) in (1..=3).zip(STEPS) {
        let (order, balance, worst) = study(s, steps, error, (&body, &drag, w0));
        assert!((order - 2.0 * s as f64).abs() < 0.25, "s = {s}: order {order}");
        // The balance closes at the element's order, or exactly (round-off).
        let closes = worst < 1e-13 || (balance - 2.0 * s as f64).abs() < 0.35;
        assert!(closes, "s = {s}: energy balance order {balance}, largest {worst:e}");
    }
}

#[test]
fn the_spatial_momentum_under_momentum_drag_decays_exactly_at_order_2s() {
    let (inertia, c, w0) = ([1.0, 2.0, 3.0], 0.4, [0.5, 1.0, 0.3]);
    let body = RigidBody::free(inertia).unwrap();
    let drag = Drag { c, k: inertia };
    let m0: [f64; 3] = std::array::from_fn(|k| inertia[k] * w0[k]);
    let m_exact = m0.map(|x| x * (-c * 2.0f64).exp());
    let error = |it: &Integrator<'_, RigidBody>| {
        let (r, pi) = body_state(it.node().q, it.node().p, 0);
        let m: [f64; 3] = std::array::from_fn(|a| r[3 * a] * pi[0] + r[3 * a + 1] * pi[1] + r[3 * a + 2] * pi[2]);
        (0..3).fold(0.0f64, |e, k| e.max((m[k] - m_exact[k]).abs()))
    };
    for (s, steps) in (1..=3).zip(STEPS) {
        let (order, balance, worst) = study(s, steps, error, (&body, &drag, w0));
        assert!((order - 2.0 * s as f64).abs() < 0.25, "s = {s}: order {order}");
        // The balance closes at the element's order, or exactly (round-off).
        let closes = worst < 1e-13 || (balance - 2.0 * s as f64).abs() < 0.35;
        assert!(closes, "s = {s}: energy balance order {balance}, largest {worst:e}");
    }
}

#[test]
fn forced_runs_with_rotations_refuse_tangent_vectors_and_check_the_force_size() {
    let body = RigidBody::free([1.0, 2.0, 3.0]).unwrap();
    let drag = Drag { c: 0.1, k: [1.0; 3] };
    let element = Element::with_order(2).unwrap();
    let mut it = run(&body, &drag, &element, [0.5, 1.0, 0.3], 0.1, 1.0);
    it.step().unwrap();
    let err = it.tangent_apply(&mut [1.0; 6]).unwrap_err().to_string();
    assert!(err.contains("forced Lie-group step"), "{err}");
    struct Wrong;
    impl Force for Wrong {
        fn dim(&self) -> usize {
            3
        }
        fn force<D: Scalar>(&self, _t: D, _q: &[D], _v: &[D], _out: &mut [D]) {}
    }
    let start = Start::Velocity {
        q: IDENTITY.to_vec(),
        v: vec![0.0; 9],
    };
    let grid = TimeGrid::uniform(0.0, 0.1, 1.0).unwrap();
    let layout = Rotations::new(9, &[0]).unwrap();
    let made =
        Integrator::with_rotations_and_force(&body, &element, grid, start, SolverOptions::default(), layout, &Wrong);
    assert!(made.is_err());
}
