//! Drift of energy and angular momentum of adaptive Kepler runs (issue 21): e = 0.9 from
//! pericentre, degree-4 Gauss–Legendre element (order 8), the Kepler monitor g = |q|^{3/2},
//! every node. Prints the mean signed relative error of H and of L = x p_y − y p_x per tenth
//! of the run and the slope per period of a line fitted to the ten means (least squares
//! against the tenths' midpoints), and the largest |ΔH/H| per tenth with its slope.
//!
//! `cargo run --release -p femvi --example adaptive_drift -- DS PERIODS [TOL] [E] [full]`
//! (`full`: `Method::FullNewton` instead of the default simplified Newton)
use femvi::adaptive::{KeplerMonitor, TimeTransformed};
use femvi::{models, Element, Integrator, SolverOptions, Start, TimeGrid};

/// Least-squares slope of `y` against the midpoints of ten equal parts of `periods`.
fn slope(y: &[f64], periods: f64) -> f64 {
    let x: Vec<f64> = (0..y.len())
        .map(|k| (k as f64 + 0.5) / y.len() as f64 * periods)
        .collect();
    let (mx, my) = (
        x.iter().sum::<f64>() / x.len() as f64,
        y.iter().sum::<f64>() / y.len() as f64,
    );
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// S(e) = ∫₀^{2π} (1 − e cos E)^{−1/2} dE: one orbit in fictitious time (a = μ = 1),
/// by the trapezoid rule (spectrally accurate for a periodic integrand).
fn orbit_in_s(e: f64) -> f64 {
    let m = 20_000;
    let h = 2.0 * std::f64::consts::PI / m as f64;
    (0..m).map(|k| (1.0 - e * (k as f64 * h).cos()).powf(-0.5)).sum::<f64>() * h
}

fn main() -> femvi::Result<()> {
    let args: Vec<f64> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let ds = args.first().copied().unwrap_or(0.3);
    let periods = args.get(1).copied().unwrap_or(1e4);
    let tol = args.get(2).copied().unwrap_or(1e-14);
    let e = args.get(3).copied().unwrap_or(0.9);
    let q0 = vec![1.0 - e, 0.0];
    let p0 = vec![0.0, ((1.0 + e) / (1.0 - e)).sqrt()];
    let energy = |q: &[f64], p: &[f64]| 0.5 * (p[0] * p[0] + p[1] * p[1]) - 1.0 / q[0].hypot(q[1]);
    let ang = |q: &[f64], p: &[f64]| q[0] * p[1] - q[1] * p[0];
    let (e0, l0) = (energy(&q0, &p0), ang(&q0, &p0));
    let lg = TimeTransformed::new(models::kepler(1.0)?, KeplerMonitor, e0)?;
    let element = Element::with_order(8)?;
    let steps = (periods * orbit_in_s(e) / ds).ceil() as usize;
    let grid = TimeGrid::uniform(0.0, ds, ds * steps as f64)?;
    let opts = SolverOptions {
        tolerance: tol,
        method: if std::env::args().any(|a| a == "full") {
            femvi::Method::FullNewton
        } else {
            femvi::Method::Auto
        },
        ..SolverOptions::default()
    };
    let start = Start::Momentum { q: q0, p: p0 };
    let mut it = Integrator::new(&lg, &element, grid, start, opts)?;
    let (mut me, mut ml, mut mx) = ([0.0; 10], [0.0; 10], [0.0f64; 10]);
    let mut count = [0usize; 10];
    let clock = std::time::Instant::now();
    let mut k = 0;
    it.advance_observed(steps, |node| {
        let tenth = (k * 10 / steps).min(9);
        let de = (energy(node.q, node.p) - e0) / e0.abs();
        me[tenth] += de;
        mx[tenth] = mx[tenth].max(de.abs());
        ml[tenth] += (ang(node.q, node.p) - l0) / l0;
        count[tenth] += 1;
        k += 1;
        true
    })?;
    for j in 0..10 {
        me[j] /= count[j] as f64;
        ml[j] /= count[j] as f64;
    }
    let fmt = |v: &[f64]| v.iter().map(|x| format!("{x:.2e}")).collect::<Vec<_>>().join(" ");
    println!(
        "ds={ds} periods={periods} tol={tol} e={e}: steps={k} iters/step={:.2} cpu={:.1}s",
        it.mean_iterations(),
        clock.elapsed().as_secs_f64()
    );
    println!("E mean/tenth: {}  slope/period {:.2e}", fmt(&me), slope(&me, periods));
    println!("L mean/tenth: {}  slope/period {:.2e}", fmt(&ml), slope(&ml, periods));
    println!("|dE| max/tenth: {}  slope/period {:.2e}", fmt(&mx), slope(&mx, periods));
    Ok(())
}
