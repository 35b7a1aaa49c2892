//! Rotations as configuration variables (issue 37): the Lie-group Galerkin element of
//! `femvi::rotation` on the free rigid body and the heavy top, against an independent
//! reference (`rigid_reference.json`: Euler's equations with Ṙ = R ŵ by a Taylor-series method
//! in 50-digit arithmetic, `benches/peers/rigid_reference.py`), and its invariants.

use femvi::models::RigidBody;
use femvi::rotation::so3::orthogonality_defect;
use femvi::rotation::{body_state, embedded_velocity, Rotations};
use femvi::{Element, Error, Integrator, Method, SolverOptions, Start, TimeGrid};
use serde_json::Value;

const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

fn reference() -> Value {
    serde_json::from_str(include_str!("rigid_reference.json")).unwrap()
}

fn numbers<const N: usize>(v: &Value) -> [f64; N] {
    let a = v.as_array().unwrap();
    std::array::from_fn(|i| a[i].as_f64().unwrap())
}

/// A reference state (t, R, w).
type State = (f64, [f64; 9], [f64; 3]);

/// The reference case `name`: the body, R0, w0 and the states.
fn case(name: &str) -> (RigidBody, [f64; 9], [f64; 3], Vec<State>) {
    let all = reference();
    let c = &all[name];
    let inertia: [f64; 3] = numbers(&c["inertia"]);
    let body = match name {
        "heavy_top" => RigidBody::heavy_top(
            inertia,
            c["m"].as_f64().unwrap(),
            c["g"].as_f64().unwrap(),
            numbers(&c["chi"]),
        )
        .unwrap(),
        _ => RigidBody::free(inertia).unwrap(),
    };
    let states = c["states"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["t"].as_f64().unwrap(), numbers(&s["R"]), numbers(&s["w"])))
        .collect();
    (body, numbers(&c["R0"]), numbers(&c["w0"]), states)
}

fn start(r0: &[f64; 9], w0: &[f64; 3]) -> Start {
    Start::Velocity {
        q: r0.to_vec(),
        v: embedded_velocity(r0, w0).to_vec(),
    }
}

fn run<'a>(
    body: &'a RigidBody,
    element: &'a Element,
    r0: &[f64; 9],
    w0: &[f64; 3],
    h: f64,
    end: f64,
) -> Integrator<'a, RigidBody> {
    let grid = TimeGrid::uniform(0.0, h, end).unwrap();
    let layout = Rotations::new(9, &[0]).unwrap();
    Integrator::with_rotations(body, element, grid, start(r0, w0), SolverOptions::default(), layout).unwrap()
}

/// (R, w, Π) at the current node.
fn body_at(it: &Integrator<'_, RigidBody>) -> ([f64; 9], [f64; 3], [f64; 3]) {
    let node = it.node();
    let (r, pi) = body_state(node.q, node.p, 0);
    let i = it.lagrangian().inertia();
    (r, [pi[0] / i[0], pi[1] / i[1], pi[2] / i[2]], pi)
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| f64::max(m, (x - y).abs()))
}

fn norm(x: &[f64; 3]) -> f64 {
    (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// The least-squares slope of log(err) against log(h).
fn fitted_order(h: &[f64], err: &[f64]) -> f64 {
    let (x, y): (Vec<f64>, Vec<f64>) = h.iter().zip(err).map(|(h, e)| (h.ln(), e.ln())).unzip();
    let (mx, my) = (
        x.iter().sum::<f64>() / x.len() as f64,
        y.iter().sum::<f64>() / y.len() as f64,
    );
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Nodal order 2s in R and in w for s = 1 … 4, from the errors at t = 2 over three steps each.
fn check_orders(name: &str, steps: [[f64; 3]; 4]) {
    let (body, r0, w0, states) = case(name);
    let (_, r_ref, w_ref) = states.iter().find(|s| s.0 == 2.0).copied().unwrap();
    for (s, hs) in (1..=4).zip(steps) {
        let element = Element::with_order(2 * s).unwrap();
        let (mut er, mut ew) = (vec![], vec![]);
        for h in hs {
            let mut it = run(&body, &element, &r0, &w0, h, 2.0);
            while it.step().unwrap() {}
            let (r, w, _) = body_at(&it);
            assert!((it.node().t - 2.0).abs() < 1e-12);
            er.push(max_diff(&r, &r_ref));
            ew.push(max_diff(&w, &w_ref));
        }
        let (pr, pw) = (fitted_order(&hs, &er), fitted_order(&hs, &ew));
        assert!(
            (pr - 2.0 * s as f64).abs() < 0.25 && (pw - 2.0 * s as f64).abs() < 0.25,
            "{name}, degree {s}: orders {pr:.3} (R) {pw:.3} (w) from errors {er:?} {ew:?}"
        );
        assert!(
            er[2] > 1e-14,
            "{name}, degree {s}: the errors must stay above round-off: {er:?}"
        );
    }
}

#[test]
fn free_body_has_nodal_order_2s_against_the_reference() {
    check_orders(
        "free_body",
        [
            [0.1, 0.05, 0.025],
            [0.1, 0.05, 0.025],
            [0.4, 0.2, 0.1],
            [1.0, 0.5, 0.25],
        ],
    );
}

#[test]
fn heavy_top_has_nodal_order_2s_against_the_reference() {
    check_orders(
        "heavy_top",
        [
            [0.02, 0.01, 0.005],
            [0.04, 0.02, 0.01],
            [0.1, 0.05, 0.025],
            [0.2, 0.1, 0.05],
        ],
    );
}

#[test]
fn free_body_keeps_r_on_so3_and_its_momenta_to_round_off() {
    // 2·10⁴ steps of h = 0.01 (t = 200) at degrees 1 and 2: RᵀR = 1 to round-off without
    // growth, the spatial angular momentum R Π (the free body's Noether momentum, conserved
    // exactly by the discrete flow) and |Π| to accumulated round-off; the energy error
    // bounded and no larger in the second half than in the first.
    let (body, r0, w0, _) = case("free_body");
    for s in 1..=2 {
        let element = Element::with_order(2 * s).unwrap();
        let mut it = run(&body, &element, &r0, &w0, 0.01, 200.0);
        let (_, _, pi0) = body_at(&it);
        let spatial = |r: &[f64; 9], pi: &[f64; 3]| {
            [0, 1, 2].map(|i| r[3 * i] * pi[0] + r[3 * i + 1] * pi[1] + r[3 * i + 2] * pi[2])
        };
        let m0 = spatial(&r0, &pi0);
        let e0 = it.energy().unwrap();
        let (mut orth, mut dm, mut dpi) = (0.0f64, 0.0f64, 0.0f64);
        let mut de = [0.0f64; 2];
        let mut k = 0;
        while it.step().unwrap() {
            k += 1;
            let (r, _, pi) = body_at(&it);
            orth = orth.max(orthogonality_defect(&r));
            dm = dm.max(max_diff(&spatial(&r, &pi), &m0));
            dpi = dpi.max((norm(&pi) / norm(&pi0) - 1.0).abs());
            if k % 10 == 0 {
                let half = usize::from(k > 10_000);
                de[half] = de[half].max((it.energy().unwrap() / e0 - 1.0).abs());
            }
        }
        assert_eq!(k, 20_000);
        assert!(orth < 2e-15, "degree {s}: max |RᵀR − 1| = {orth:e}");
        // Round-off of a few ulps per step, as a random walk: 4 ε √k |Π|; a method that did
        // not conserve them would move them by its local error, about h^(2s+1) per step.
        let walk = 4.0 * f64::EPSILON * (k as f64).sqrt();
        assert!(
            dm < walk * norm(&pi0) && dpi < walk,
            "degree {s}: R Π moved {dm:e}, |Π| {dpi:e} (bound {walk:e})"
        );
        // Energy: the error of an order-2s method, bounded, not drifting.
        assert!(
            de[0] > 0.0 && de[1] < 1.5 * de[0] && de[1] < [1e-4, 1e-9][s - 1],
            "degree {s}: {de:?}"
        );
    }
}

#[test]
fn heavy_top_conserves_its_vertical_angular_momentum() {
    // Gravity along −z is invariant under rotations about the vertical: e₃·(R Π) is the
    // Noether momentum, conserved by the discrete flow to round-off.
    let (body, r0, w0, _) = case("heavy_top");
    let element = Element::with_order(4).unwrap();
    let mut it = run(&body, &element, &r0, &w0, 0.01, 20.0);
    let vertical = |it: &Integrator<'_, RigidBody>| {
        let (r, _, pi) = body_at(it);
        r[6] * pi[0] + r[7] * pi[1] + r[8] * pi[2]
    };
    let v0 = vertical(&it);
    let reference = reference()["heavy_top"]["vertical_Pi_t0"].as_f64().unwrap();
    assert!((v0 - reference).abs() < 1e-14, "{v0} against {reference}");
    let mut worst = 0.0f64;
    while it.step().unwrap() {
        worst = worst.max((vertical(&it) - v0).abs());
    }
    assert!(worst < 1e-13, "e₃·RΠ moved {worst:e}");
}

#[test]
fn a_resumed_run_is_the_uninterrupted_run_bit_for_bit() {
    let (body, r0, w0, _) = case("heavy_top");
    let element = Element::with_order(4).unwrap();
    let mut whole = run(&body, &element, &r0, &w0, 0.01, 1.0);
    let mut first = run(&body, &element, &r0, &w0, 0.01, 1.0);
    for _ in 0..37 {
        first.step().unwrap();
    }
    let saved = first.checkpoint("top");
    let mut resumed = run(&body, &element, &r0, &w0, 0.01, 1.0);
    resumed.restore(&saved, "top").unwrap();
    while whole.step().unwrap() {}
    while resumed.step().unwrap() {}
    let (a, b) = (whole.node(), resumed.node());
    assert_eq!((a.k, a.q, a.p), (b.k, b.q, b.p));
}

#[test]
fn rotations_and_ordinary_coordinates_step_side_by_side() {
    // A free body beside an uncoupled harmonic oscillator x (coordinate 9): the body's path
    // is the one it has alone, and x(t) = cos t to the element's accuracy.
    struct BodyAndSpring(RigidBody);
    impl femvi::Lagrangian for BodyAndSpring {
        fn dim(&self) -> usize {
            10
        }
        fn value<D: femvi::Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
            self.0.value(t, &q[..9], &v[..9]) + (v[9] * v[9] - q[9] * q[9]) * 0.5
        }
    }
    let (body, r0, w0, _) = case("free_body");
    let both = BodyAndSpring(body.clone());
    let element = Element::with_order(4).unwrap();
    let (mut q, mut v) = (r0.to_vec(), embedded_velocity(&r0, &w0).to_vec());
    q.push(1.0);
    v.push(0.0);
    let grid = TimeGrid::uniform(0.0, 0.05, 3.0).unwrap();
    let layout = Rotations::new(10, &[0]).unwrap();
    let mut it = Integrator::with_rotations(
        &both,
        &element,
        grid,
        Start::Velocity { q, v },
        SolverOptions::default(),
        layout,
    )
    .unwrap();
    let mut alone = run(&body, &element, &r0, &w0, 0.05, 3.0);
    while it.step().unwrap() {
        alone.step().unwrap();
        let (a, b) = (it.node(), alone.node());
        assert!(max_diff(&a.q[..9], b.q) < 1e-14 && max_diff(&a.p[..9], b.p) < 1e-14);
        assert!((a.q[9] - a.t.cos()).abs() < 1e-6, "x({}) = {}", a.t, a.q[9]);
    }
}

#[test]
fn bad_starts_and_options_are_typed_errors() {
    let body = RigidBody::free([1.0, 2.0, 3.0]).unwrap();
    let element = Element::with_order(2).unwrap();
    let grid = || TimeGrid::uniform(0.0, 0.1, 1.0).unwrap();
    let layout = || Rotations::new(9, &[0]).unwrap();
    let opts = SolverOptions::default();
    let mut skew = IDENTITY;
    skew[1] = 1e-6;
    let not_orthogonal = Integrator::with_rotations(&body, &element, grid(), start(&skew, &[0.0; 3]), opts, layout());
    assert!(matches!(not_orthogonal, Err(Error::Invalid { ref reason, .. }) if reason.contains("not a rotation")));
    let positions = Start::Positions {
        q0: IDENTITY.to_vec(),
        q1: IDENTITY.to_vec(),
    };
    assert!(Integrator::with_rotations(&body, &element, grid(), positions, opts, layout()).is_err());
    let explicit = SolverOptions {
        method: Method::Explicit,
        ..opts
    };
    assert!(
        Integrator::with_rotations(&body, &element, grid(), start(&IDENTITY, &[0.0; 3]), explicit, layout()).is_err()
    );
    let short = Start::Velocity {
        q: vec![1.0; 8],
        v: vec![0.0; 8],
    };
    assert!(matches!(
        Integrator::with_rotations(&body, &element, grid(), short, opts, layout()),
        Err(Error::Dimension { .. })
    ));
    let nan = start(&IDENTITY, &[f64::NAN, 0.0, 0.0]);
    assert!(Integrator::with_rotations(&body, &element, grid(), nan, opts, layout()).is_err());
    assert!(
        Rotations::new(9, &[1]).is_err() && Rotations::new(18, &[0, 4]).is_err() && Rotations::new(9, &[]).is_err()
    );
    assert!(
        RigidBody::free([1.0, 0.0, 2.0]).is_err() && RigidBody::heavy_top([1.0; 3], f64::NAN, 1.0, [0.0; 3]).is_err()
    );
}

/// The body without its declared structure: the Lie-group element's Newton path.
struct Plain(RigidBody);

impl femvi::Lagrangian for Plain {
    fn dim(&self) -> usize {
        9
    }
    fn value<D: femvi::Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
        self.0.value(t, q, v)
    }
}

#[test]
fn the_rigid_body_fixed_point_solves_the_newton_step_equations() {
    // Degree 1 (Gauss midpoint, and the trapezoid rule with the potential at both ends):
    // the fixed point of `rotation/body.rs` against Newton with automatic derivatives on the
    // same action, node by node over 300 steps.
    for name in ["free_body", "heavy_top"] {
        let (body, r0, w0, _) = case(name);
        let plain = Plain(body.clone());
        for element in [
            Element::with_order(2).unwrap(),
            Element::galerkin(1, femvi::NodeFamily::Equispaced, femvi::QuadratureKind::Trapezoid).unwrap(),
        ] {
            let grid = || TimeGrid::uniform(0.0, 0.01, 3.0).unwrap();
            let layout = || Rotations::new(9, &[0]).unwrap();
            let opts = SolverOptions::default();
            let mut fast =
                Integrator::with_rotations(&body, &element, grid(), start(&r0, &w0), opts, layout()).unwrap();
            let mut newton =
                Integrator::with_rotations(&plain, &element, grid(), start(&r0, &w0), opts, layout()).unwrap();
            let mut worst = 0.0f64;
            while fast.step().unwrap() {
                assert!(newton.step().unwrap());
                let (a, b) = (fast.node(), newton.node());
                worst = worst.max(max_diff(a.q, b.q)).max(max_diff(a.p, b.p));
            }
            assert!(worst < 1e-13, "{name}: {worst:e}");
            // The fixed point's sweeps against Newton's iterations.
            assert!(fast.mean_iterations() > newton.mean_iterations());
        }
    }
}

#[test]
fn steps_are_symplectic_on_t_star_so3() {
    // max |JᵀΩJ − Ω| of every step's Jacobian in canonical coordinates (R = R_k exp(ψ̂),
    // p_ψ = dexp_ψ μ): the heavy top at degrees 1 to 3 (the fixed point at degree 1), and a
    // body beside an ordinary coordinate coupled to it.
    let (top, r0, w0, _) = case("heavy_top");
    for s in 1..=3 {
        let element = Element::with_order(2 * s).unwrap();
        let grid = TimeGrid::uniform(0.0, 0.05, 2.0).unwrap();
        let layout = Rotations::new(9, &[0]).unwrap();
        let opts = SolverOptions::default();
        let mut it = Integrator::with_rotations_measured(&top, &element, grid, start(&r0, &w0), opts, layout).unwrap();
        while it.step().unwrap() {}
        let d = it.symplecticity_defect().unwrap();
        assert!(d < 1e-12, "heavy top, degree {s}: {d:e}");
    }
    struct Coupled(RigidBody);
    impl femvi::Lagrangian for Coupled {
        fn dim(&self) -> usize {
            10
        }
        fn value<D: femvi::Scalar>(&self, t: D, q: &[D], v: &[D]) -> D {
            // A slider x pulled by the height of the body's third axis.
            self.0.value(t, &q[..9], &v[..9]) + v[9] * v[9] * 0.5 - q[9] * q[9] * 0.5 - q[9] * q[8] * 0.3
        }
    }
    let both = Coupled(top.clone());
    let element = Element::with_order(4).unwrap();
    let (mut q, mut v) = (r0.to_vec(), embedded_velocity(&r0, &w0).to_vec());
    q.push(0.5);
    v.push(0.1);
    let grid = TimeGrid::uniform(0.0, 0.05, 2.0).unwrap();
    let layout = Rotations::new(10, &[0]).unwrap();
    let opts = SolverOptions::default();
    let mut it =
        Integrator::with_rotations_measured(&both, &element, grid, Start::Velocity { q, v }, opts, layout).unwrap();
    while it.step().unwrap() {}
    let d = it.symplecticity_defect().unwrap();
    assert!(d < 1e-12, "coupled: {d:e}");
}
