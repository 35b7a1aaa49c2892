//! Kepler orbits of eccentricity e (a = 1, period 2π) with adaptive steps (the Poincaré time
//! transformation, g = r^{3/2}) and with fixed steps: final position error against Kepler's
//! equation, energy error, steps and CPU time, for the README's guidance on choosing ds.
//!
//! `cargo run --release -p femvi --example adaptive_kepler -- E PERIODS DS ORDER [AD] [H]`
//! (AD = 1: derivatives of L_g by automatic differentiation instead of the hand-coded ones;
//! H: the fixed step to compare with, default the same number of steps as the adaptive run).
use femvi::adaptive::{solve_adaptive, AdaptiveOptions, KeplerMonitor};
use femvi::diagnostics::exact;
use femvi::{models, solve, Element, Problem, SolveOptions, Start};

fn main() -> femvi::Result<()> {
    let args: Vec<f64> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let e = args.first().copied().unwrap_or(0.9);
    let periods = args.get(1).copied().unwrap_or(10.0);
    let ds = args.get(2).copied().unwrap_or(0.05);
    let order = args.get(3).copied().unwrap_or(4.0) as usize;
    let by_ad = args.get(4).copied().unwrap_or(0.0) != 0.0;
    let q0 = [1.0 - e, 0.0];
    let p0 = [0.0, ((1.0 + e) / (1.0 - e)).sqrt()];
    let t_end = periods * 2.0 * std::f64::consts::PI;
    let start = Start::Momentum {
        q: q0.to_vec(),
        p: p0.to_vec(),
    };
    let problem = Problem::new(models::kepler(1.0).unwrap(), start, 0.0, t_end);
    let element = Element::with_order(order)?;
    let options = AdaptiveOptions {
        every: 0,
        saveat: vec![t_end],
        hand_derivatives: !by_ad,
        ..AdaptiveOptions::step(ds)
    };
    let clock = std::time::Instant::now();
    let sol = solve_adaptive(&problem, KeplerMonitor, &element, &options)?;
    let secs = clock.elapsed().as_secs_f64();
    let dist = |a: &[f64], b: [f64; 2]| match a {
        [x, y, ..] => (x - b[0]).hypot(y - b[1]),
        _ => f64::NAN, // not reached
    };
    let (q, _) = exact::kepler(1.0, 0.0, q0, p0, t_end).expect("bound orbit");
    let last = sol.t.len() - 1;
    let (q_node, _) = exact::kepler(1.0, 0.0, q0, p0, sol.t[last]).expect("bound orbit");
    let node_err = dist(&sol.q[2 * last..], q_node);
    let saved_err = dist(&sol.saved.q, q);
    let de = (sol.energy[last] - sol.e0).abs() / sol.e0.abs();
    println!(
        "adaptive e={e} periods={periods} ds={ds} order={order} ad={by_ad}: steps={} ({:.1}/period) iters/step={:.2} node_err={node_err:.3e} saveat_err={saved_err:.3e} dE/E={de:.3e} cpu={secs:.4}s us/step={:.3} error={:?}",
        sol.steps,
        sol.steps as f64 / periods,
        sol.mean_iterations,
        1e6 * secs / sol.steps as f64,
        sol.error
    );
    let h = args.get(5).copied().unwrap_or(t_end / sol.steps as f64);
    let fixed = SolveOptions {
        every: 0,
        ..SolveOptions::step(h)
    };
    let clock = std::time::Instant::now();
    let fsol = solve(&problem, &element, &fixed)?;
    let fsecs = clock.elapsed().as_secs_f64();
    let ferr = dist(&fsol.q[fsol.q.len() - 2..], q);
    let fde = (fsol.energy.last().copied().unwrap_or(f64::NAN) - sol.e0).abs() / sol.e0.abs();
    println!(
        "fixed    h={h:.4e}: steps={} iters/step={:.2} err={ferr:.3e} dE/E={fde:.3e} cpu={fsecs:.4}s us/step={:.3} error={:?}",
        fsol.steps,
        fsol.mean_iterations,
        1e6 * fsecs / fsol.steps as f64,
        fsol.error
    );
    Ok(())
}
