//! Issue 34, defect 1: the inverse Legendre transform on regular Lagrangians with
//! configuration-dependent masses never reports a degeneracy, and truly degenerate ones are
//! still refused with their condition number.
//!
//! The regularity of each system is derived, not assumed: the double pendulum's mass matrix has
//! det M = m2 l1² l2² (m1 + m2 sin²(θ1 − θ2)) > 0 for positive masses and rods; the elastic
//! pendulum's is diag(m, m r²), regular while r > 0 (checked along the run).

use femvi::{solve, Element, Error, Lagrangian, NodeFamily, Problem, QuadratureKind, Scalar, SolveOptions, Start};

/// Deterministic draws in [lo, hi).
struct Draws(u64);
impl Draws {
    fn next(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn element(degree: usize) -> Element {
    Element::galerkin(degree, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(degree)).expect("element")
}

/// Whether an error is one of the inverse Legendre transform's.
fn legendre_error(e: &Error) -> bool {
    matches!(
        e,
        Error::DegenerateLagrangian { .. } | Error::LegendreNotConverged { .. }
    ) || e.to_string().contains("degenerate")
        || e.to_string().contains("Legendre")
}

/// An elastic pendulum in polar coordinates (r, θ): L = ½m(ṙ² + r²θ̇²) + m g r cos θ − ½k(r − r0)².
struct Elastic {
    m: f64,
    g: f64,
    k: f64,
    r0: f64,
}
impl Lagrangian for Elastic {
    fn dim(&self) -> usize {
        2
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let (r, th) = (q[0], q[1]);
        (v[0] * v[0] + r * r * v[1] * v[1]) * (0.5 * self.m) + r * th.cos() * (self.m * self.g)
            - (r - self.r0) * (r - self.r0) * (0.5 * self.k)
    }
}

#[test]
fn random_double_pendulums_are_never_reported_degenerate() {
    let mut rng = Draws(34);
    let (mut runs, mut steps) = (0usize, 0usize);
    for system in 0..40 {
        let (m1, m2) = (rng.next(0.2, 5.0), rng.next(0.2, 5.0));
        let (l1, l2) = (rng.next(0.2, 3.0), rng.next(0.2, 3.0));
        let g = rng.next(0.0, 20.0);
        let q = vec![rng.next(-3.0, 3.0), rng.next(-3.0, 3.0)];
        let v = vec![rng.next(-2.0, 2.0), rng.next(-2.0, 2.0)];
        let lag = femvi::models::DoublePendulum::new(m1, m2, l1, l2, g).expect("positive parameters");
        // A step small against the fastest time scales (rods, gravity, spin).
        let h = 0.005 * l1.min(l2).sqrt() / (1.0 + g.sqrt() + v[0].abs() + v[1].abs());
        let problem = Problem::new(lag, Start::Velocity { q, v }, 0.0, 2000.0 * h);
        for degree in 1..=4 {
            let sol = solve(&problem, &element(degree), &SolveOptions::step(h)).expect("valid problem");
            if let Some(e) = &sol.error {
                assert!(
                    !legendre_error(e),
                    "system {system} (m {m1} {m2}, l {l1} {l2}, g {g}), degree {degree}: {e}"
                );
            }
            // Every kept node has a finite energy, which needs the inverse Legendre transform.
            assert!(sol.energy.iter().all(|e| e.is_finite()));
            runs += 1;
            steps += sol.steps;
        }
    }
    assert_eq!(runs, 160);
    eprintln!("{runs} runs, {steps} steps, no spurious degeneracy");
    assert!(steps >= 150 * 2000, "most runs reached their end: {steps} steps");
}

/// The system (g = 9.81, l2 = 0.8, unit masses and l1, from (0.5, 0.3) at rest,
/// degree 2, h = 0.01), to t = 200: it stopped at t = 10.44 before.
#[test]
fn the_reported_double_pendulum_runs_through() {
    let lag = femvi::models::DoublePendulum::new(1.0, 1.0, 1.0, 0.8, 9.81).expect("parameters");
    let start = Start::Velocity {
        q: vec![0.5, 0.3],
        v: vec![0.0, 0.0],
    };
    let problem = Problem::new(lag, start, 0.0, 200.0);
    let sol = solve(&problem, &element(2), &SolveOptions::step(0.01)).expect("valid problem");
    assert!(sol.error.is_none(), "{:?}", sol.error);
    assert_eq!(sol.steps, 20_000);
    let e0 = sol.energy[0];
    let drift = sol.energy.iter().fold(0.0f64, |m, e| m.max((e - e0).abs())) / e0.abs();
    assert!(drift < 1e-4, "energy error {drift}");
}

#[test]
fn random_elastic_pendulums_are_never_reported_degenerate() {
    let mut rng = Draws(340);
    for system in 0..20 {
        let lag = Elastic {
            m: rng.next(0.5, 3.0),
            g: rng.next(1.0, 15.0),
            k: rng.next(50.0, 200.0),
            r0: rng.next(0.5, 2.0),
        };
        let q = vec![lag.r0 * rng.next(0.9, 1.1), rng.next(-2.0, 2.0)];
        let v = vec![rng.next(-0.5, 0.5), rng.next(-1.0, 1.0)];
        let h = 0.002;
        let problem = Problem::new(lag, Start::Velocity { q, v }, 0.0, 4.0);
        for degree in 1..=4 {
            let sol = solve(&problem, &element(degree), &SolveOptions::step(h)).expect("valid problem");
            if let Some(e) = &sol.error {
                panic!("system {system}, degree {degree}: {e}");
            }
            // Regular along the run: r stays away from 0.
            assert!(sol.q.chunks(2).all(|q| q[0] > 0.1), "system {system}");
        }
    }
}

/// L = ½(ẋ + ẏ)² − ½(x² + y²): ∂²L/∂v² = [[1, 1], [1, 1]] is singular everywhere.
struct Singular;
impl Lagrangian for Singular {
    fn dim(&self) -> usize {
        2
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        (v[0] + v[1]) * (v[0] + v[1]) * 0.5 - (q[0] * q[0] + q[1] * q[1]) * 0.5
    }
}

/// L = ẋ⁴/12 − x²/2: ∂²L/∂v² = ẋ² vanishes at ẋ = 0.
struct Quartic;
impl Lagrangian for Quartic {
    fn dim(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        v[0] * v[0] * v[0] * v[0] * (1.0 / 12.0) - q[0] * q[0] * 0.5
    }
}

/// L = ẋẏ − ½(x² + y²): ∂²L/∂v² = [[0, 1], [1, 0]], indefinite but regular (det = −1).
struct Indefinite;
impl Lagrangian for Indefinite {
    fn dim(&self) -> usize {
        2
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        v[0] * v[1] - (q[0] * q[0] + q[1] * q[1]) * 0.5
    }
}

/// The error a run ends with, whether it comes at the start or from the run.
fn run_error<L: Lagrangian>(lag: L, start: Start) -> Option<Error> {
    let problem = Problem::new(lag, start, 0.0, 1.0);
    match solve(&problem, &element(2), &SolveOptions::step(0.01)) {
        Err(e) => Some(e),
        Ok(sol) => sol.error,
    }
}

#[test]
fn degenerate_lagrangians_are_still_refused_with_their_condition() {
    let start = Start::Velocity {
        q: vec![0.1, 0.2],
        v: vec![0.3, -0.1],
    };
    match run_error(Singular, start) {
        Some(Error::DegenerateLagrangian { condition, .. }) => assert!(condition > 1e12, "{condition}"),
        other => panic!("singular Hessian not refused: {other:?}"),
    }
    let at_rest = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    match run_error(Quartic, at_rest) {
        Some(e @ Error::DegenerateLagrangian { condition, .. }) => {
            assert!(condition > 1e12, "{condition}");
            assert!(e.to_string().contains("condition number"), "{e}");
        }
        other => panic!("vanishing Hessian not refused: {other:?}"),
    }
    let start = Start::Velocity {
        q: vec![0.1, 0.2],
        v: vec![0.3, -0.1],
    };
    assert!(
        run_error(Indefinite, start).is_none(),
        "a regular indefinite Hessian refused"
    );
}
