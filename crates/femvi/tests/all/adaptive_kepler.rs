//! Measurements of adaptive steps on eccentric Kepler orbits (issue 21): the order in the
//! fictitious step Δs (fit over several Δs, degrees 1 to 4), the energy error over 1 000
//! periods without drift (first against last tenth), the phase error against Kepler's
//! equation, and adaptive against fixed steps of the same number of steps.

use crate::common::{fit_order, kepler_exact, Errs};
use femvi::adaptive::{solve_adaptive, AdaptiveOptions, AdaptiveSolution, KeplerMonitor};
use femvi::{models, solve, Element, Problem, SolveOptions, Start};
use std::f64::consts::PI;

fn problem(e: f64, periods: f64) -> Problem<femvi::Mechanical<models::KeplerPotential>> {
    let start = Start::Momentum {
        q: vec![1.0 - e, 0.0],
        p: vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()],
    };
    Problem::new(models::kepler(1.0).unwrap(), start, 0.0, periods * 2.0 * PI)
}

fn run(e: f64, periods: f64, order: usize, ds: f64, every: usize) -> AdaptiveSolution {
    let options = AdaptiveOptions {
        every,
        ..AdaptiveOptions::step(ds)
    };
    let sol = solve_adaptive(
        &problem(e, periods),
        KeplerMonitor,
        &Element::with_order(order).unwrap(),
        &options,
    )
    .unwrap();
    assert!(sol.error.is_none(), "{:?}", sol.error);
    sol
}

/// Position error of the last node against the closed form at its physical time.
fn final_error(e: f64, sol: &AdaptiveSolution) -> f64 {
    let i = sol.t.len() - 1;
    let (q, _) = kepler_exact(e, sol.t[i]);
    (sol.q[2 * i] - q[0]).hypot(sol.q[2 * i + 1] - q[1])
}

#[test]
fn order_2s_in_the_fictitious_step() {
    let e = 0.9;
    // Steps per degree chosen so that errors stay well above round-off.
    let cases: [(usize, [f64; 3]); 4] = [
        (2, [0.02, 0.01, 0.005]),
        (4, [0.1, 0.05, 0.025]),
        (6, [0.2, 0.1, 0.05]),
        (8, [0.4, 0.2, 0.1]),
    ];
    for (order, steps) in cases {
        let errors: Vec<f64> = steps
            .iter()
            .map(|&ds| final_error(e, &run(e, 1.0, order, ds, 0)))
            .collect();
        let fitted = fit_order(&steps, &errors);
        println!(
            "Kepler e = 0.9, one period, order {order}: errors {} fitted order {fitted:.2}",
            Errs(&errors)
        );
        assert!((fitted - order as f64).abs() < 0.5, "order {order}: fitted {fitted}");
    }
}

/// Largest |H − E₀|/|E₀| in each tenth of the run.
fn tenths(sol: &AdaptiveSolution) -> Vec<f64> {
    let m = sol.energy.len();
    (0..10)
        .map(|k| {
            sol.energy[k * m / 10..(k + 1) * m / 10]
                .iter()
                .fold(0.0f64, |w, h| w.max(((h - sol.e0) / sol.e0).abs()))
        })
        .collect()
}

#[test]
fn energy_error_bounded_without_drift_over_1000_periods() {
    for (e, ds) in [(0.9, 0.1), (0.99, 0.1)] {
        let sol = run(e, 1000.0, 4, ds, 1);
        let per_tenth = tenths(&sol);
        let x: Vec<f64> = (0..10).map(|k| k as f64).collect();
        let slope = femvi::diagnostics::linear_slope(&x, &per_tenth) / per_tenth[0];
        let phase = final_error(e, &sol);
        println!(
            "Kepler e = {e}, 1000 periods, order 4, ds = {ds}: {} steps; max relative energy error per tenth {}; slope {slope:.2e} of the first tenth per tenth; final position error {phase:.2e}",
            sol.steps,
            Errs(&per_tenth)
        );
        // No drift: the last tenth is no worse than the first (a linear drift would make it
        // ten times worse), and the fitted slope is small against the level.
        assert!(per_tenth[9] < 1.5 * per_tenth[0], "{per_tenth:?}");
        assert!(slope.abs() < 0.02, "{slope}");
    }
}

#[test]
fn adaptive_steps_beat_fixed_steps_of_the_same_number() {
    for e in [0.9, 0.99] {
        let periods = 10.0;
        let sol = run(e, periods, 4, 0.05, 0);
        let adaptive = final_error(e, &sol);
        // Fixed steps: as many steps over the same span, the same element (order 4).
        let p = problem(e, periods);
        let h = p.t_end / sol.steps as f64;
        let fixed = solve(
            &p,
            &Element::with_order(4).unwrap(),
            &SolveOptions {
                every: 0,
                ..SolveOptions::step(h)
            },
        )
        .unwrap();
        let i = fixed.t.len() - 1;
        let (q, _) = kepler_exact(e, fixed.t[i]);
        let fixed_error = (fixed.q[2 * i] - q[0]).hypot(fixed.q[2 * i + 1] - q[1]);
        println!(
            "Kepler e = {e}, {periods} periods, order 4, {} steps: final position error adaptive {adaptive:.2e}, fixed {fixed_error:.2e}, ratio {:.1e}",
            sol.steps,
            adaptive / fixed_error
        );
        assert!(adaptive < 1e-4 * fixed_error, "{adaptive:e} vs {fixed_error:e}");
    }
}

#[test]
fn two_bodies_with_the_n_body_monitor_follow_kepler() {
    // Two bodies of mass ½ (G = 1): their separation is a Kepler orbit with μ = 1, and the
    // n-body monitor is that orbit's r^{3/2}. Centre of mass at rest at the origin.
    let e: f64 = 0.9;
    let bodies = models::n_body(1.0, vec![0.5, 0.5], 2).unwrap();
    let (r0, w0) = (1.0 - e, ((1.0 + e) / (1.0 - e)).sqrt());
    let start = Start::Velocity {
        q: vec![-0.5 * r0, 0.0, 0.5 * r0, 0.0],
        v: vec![0.0, -0.5 * w0, 0.0, 0.5 * w0],
    };
    let problem = Problem::new(bodies, start, 0.0, 4.0 * PI);
    let options = AdaptiveOptions::step(0.05);
    let monitor = femvi::adaptive::NBodyMonitor::new(2, 2);
    let sol = solve_adaptive(&problem, monitor, &Element::with_order(6).unwrap(), &options).unwrap();
    assert!(sol.error.is_none(), "{:?}", sol.error);
    let mut worst = 0.0f64;
    for (i, &t) in sol.t.iter().enumerate() {
        let q = &sol.q[4 * i..4 * i + 4];
        let (exact, _) = kepler_exact(e, t);
        worst = worst.max((q[2] - q[0] - exact[0]).hypot(q[3] - q[1] - exact[1]));
    }
    println!("two bodies, e = 0.9, two orbits, order 6, ds = 0.05, n-body monitor: {} steps, max separation error {worst:.2e}", sol.steps);
    // The Kepler run of the same order and ds has the same steps (same g along the orbit).
    let kepler = run(e, 2.0, 6, 0.05, 0);
    assert_eq!(sol.steps, kepler.steps);
    assert!(worst < 1e-7, "{worst:e}");
}
