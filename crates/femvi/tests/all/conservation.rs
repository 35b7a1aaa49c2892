//! Long-run conservation: the angular momentum of a central-force problem (Noether's theorem
//! for the rotation-invariant discrete Lagrangian) over 10⁵ steps, and the pendulum's energy
//! error bounded without drift over 10⁶ steps.

use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};

#[test]
fn kepler_angular_momentum_over_1e5_steps() {
    let lag = models::kepler(1.0).unwrap();
    for (s, h) in [(1usize, 0.002), (2, 0.01), (3, 0.02)] {
        let el = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
        let steps = 100_000;
        let grid = TimeGrid::uniform(0.0, h, h * steps as f64).unwrap();
        let start = Start::Momentum {
            q: vec![0.4, 0.0],
            p: vec![0.0, 2.0],
        };
        let mut it = Integrator::new(&lag, &el, grid, start, SolverOptions::default()).unwrap();
        let l0 = 0.4 * 2.0;
        let mut worst = 0.0f64;
        let mut count = 0;
        while it.step().unwrap() {
            let n = it.node();
            let l = n.q[0] * n.p[1] - n.q[1] * n.p[0];
            worst = worst.max(((l - l0) / l0).abs());
            count += 1;
        }
        assert_eq!(count, steps);
        eprintln!("s={s}: max relative angular momentum error {worst:.2e} over {steps} steps");
        assert!(worst <= 1e-13, "s={s}: {worst:e}");
    }
}

#[test]
fn pendulum_energy_bounded_without_drift_over_1e6_steps() {
    // Störmer–Verlet (degree 1, trapezoid), h = 0.05, 10⁶ steps (t = 5·10⁴, ~8000 periods).
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let el = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let (h, steps) = (0.05, 1_000_000usize);
    let grid = TimeGrid::uniform(0.0, h, h * steps as f64).unwrap();
    let mut it = Integrator::new(
        &lag,
        &el,
        grid,
        Start::Momentum {
            q: vec![0.0],
            p: vec![1.5],
        },
        SolverOptions::default(),
    )
    .unwrap();
    let energy = |q: f64, p: f64| 0.5 * p * p - q.cos();
    let e0 = energy(0.0, 1.5);
    // Max |ΔE| per tenth of the run: no drift means the last tenth is no worse than the first.
    let mut tenth = vec![0.0f64; 10];
    let mut k = 0;
    while it.step().unwrap() {
        let n = it.node();
        let de = (energy(n.q[0], n.p[0]) - e0).abs();
        let i = (k * 10 / steps).min(9);
        tenth[i] = tenth[i].max(de);
        k += 1;
    }
    eprintln!("max |dE| per tenth of the run: {tenth:?}");
    let first = tenth[0];
    // Verlet's energy error is O(h²) ≈ h²/8·|V''|·p² ~ 1e-3 here; the bound must hold everywhere.
    assert!(tenth.iter().all(|&m| m < 5e-3), "{tenth:?}");
    // No drift: every tenth within 1 % of the first (a drift of even 1e-9 per unit time
    // would show as 5e-5 by the end).
    assert!(tenth.iter().all(|&m| (m - first).abs() <= 0.01 * first), "{tenth:?}");
}
