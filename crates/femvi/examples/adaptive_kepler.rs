//! Kepler orbits of eccentricity e with adaptive steps (the Poincaré time transformation,
//! g = r^{3/2}) against fixed steps: final position error after a number of periods, energy
//! error, force evaluations. `cargo run --release -p femvi --example adaptive_kepler -- E PERIODS DS ORDER`
use femvi::adaptive::{solve_adaptive, AdaptiveOptions, KeplerMonitor};
use femvi::diagnostics::exact;
use femvi::{models, solve, Element, Problem, SolveOptions, Start};

fn main() -> femvi::Result<()> {
    let args: Vec<f64> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let e = args.first().copied().unwrap_or(0.9);
    let periods = args.get(1).copied().unwrap_or(10.0);
    let ds = args.get(2).copied().unwrap_or(0.05);
    let order = args.get(3).copied().unwrap_or(4.0) as usize;
    let q0 = [1.0 - e, 0.0];
    let p0 = [0.0, ((1.0 + e) / (1.0 - e)).sqrt()];
    let t_end = periods * 2.0 * std::f64::consts::PI;
    let start = Start::Momentum {
        q: q0.to_vec(),
        p: p0.to_vec(),
    };
    let problem = Problem::new(models::kepler(1.0), start, 0.0, t_end);
    let by_ad = args.get(4).copied().unwrap_or(0.0) != 0.0;
    let options = AdaptiveOptions {
        every: 0,
        saveat: vec![t_end],
        hand_derivatives: !by_ad,
        ..AdaptiveOptions::step(ds)
    };
    let clock = std::time::Instant::now();
    let sol = solve_adaptive(&problem, KeplerMonitor, &Element::with_order(order)?, &options)?;
    let secs = clock.elapsed().as_secs_f64();
    let (q, _) = exact::kepler(1.0, 0.0, q0, p0, t_end).expect("bound orbit");
    let err = ((sol.saved.q[0] - q[0]).powi(2) + (sol.saved.q[1] - q[1]).powi(2)).sqrt();
    let de = (sol.energy.last().unwrap() - sol.e0).abs() / sol.e0.abs();
    println!(
        "e={e} periods={periods} ds={ds} order={order}: steps={} iters/step={:.2} err={err:.3e} dE/E={de:.3e} time={secs:.3}s error={:?}",
        sol.steps, sol.mean_iterations, sol.error
    );
    // Fixed steps, as many as the adaptive run took.
    let h = t_end / sol.steps as f64;
    let fixed = SolveOptions {
        every: 0,
        saveat: vec![t_end],
        ..SolveOptions::step(h)
    };
    let clock = std::time::Instant::now();
    let fsol = solve(&problem, &Element::with_order(order)?, &fixed)?;
    let fsecs = clock.elapsed().as_secs_f64();
    let ferr = ((fsol.saved.q[0] - q[0]).powi(2) + (fsol.saved.q[1] - q[1]).powi(2)).sqrt();
    let fde = (fsol.energy.last().unwrap() - sol.e0).abs() / sol.e0.abs();
    println!(
        "  fixed h={h:.4e}: steps={} iters/step={:.2} err={ferr:.3e} dE/E={fde:.3e} time={fsecs:.3}s error={:?}",
        fsol.steps, fsol.mean_iterations, fsol.error
    );
    Ok(())
}
