//! Drift of the simplified Newton iteration over long fixed-step runs (issue 15 item 2): the
//! relativistic Kepler run of `benches/general.rs` (c = 10, P1's start, h = 2π/1000,
//! `Method::Newton`) at the degree given as the first argument (default 2) for as many steps
//! as the second (default 10⁶). Prints the mean iterations per step and the least-squares
//! slopes, per 1 000 steps (about a period), of the block means of the relative energy and
//! angular-momentum errors: a solver that leaves a bias in every step shows it as a slope
//! above the spread of builds that differ only in round-off.

use femvi::models::RelativisticKepler;
use femvi::{Element, Integrator, Method, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};

const BLOCK: usize = 1_000;

fn main() -> Result<(), femvi::Error> {
    let mut args = std::env::args().skip(1);
    let s: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(2);
    let steps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1_000_000);
    if steps < 2 * BLOCK {
        eprintln!("at least {} steps (two blocks of {BLOCK}) for a slope", 2 * BLOCK);
        std::process::exit(2);
    }
    let element = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s))?;
    let h = 2.0 * std::f64::consts::PI / 1000.0;
    let lag = RelativisticKepler { c: 10.0 };
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    let grid = TimeGrid::uniform(0.0, h, h * steps as f64)?;
    let opts = SolverOptions {
        method: Method::Newton,
        ..Default::default()
    };
    let mut it = Integrator::new(&lag, &element, grid, start, opts)?;
    let angular = |q: &[f64], p: &[f64]| q[0] * p[1] - q[1] * p[0];
    let e0 = it.energy()?;
    let l0 = angular(it.node().q, it.node().p);
    let (mut energy, mut momentum) = (Vec::new(), Vec::new());
    for _ in 0..steps / BLOCK {
        let (mut de, mut dl) = (0.0, 0.0);
        for _ in 0..BLOCK {
            it.advance(1)?;
            dl += (angular(it.node().q, it.node().p) - l0) / l0;
            de += (it.energy()? - e0) / e0.abs();
        }
        energy.push(de / BLOCK as f64);
        momentum.push(dl / BLOCK as f64);
    }
    println!(
        "degree {s}, {steps} steps: {:.3} iterations per step; slope per {BLOCK} steps: energy {:.3e}, angular momentum {:.3e}; last block: {:.3e}, {:.3e}",
        it.mean_iterations(),
        slope(&energy),
        slope(&momentum),
        energy.last().copied().unwrap_or(f64::NAN),
        momentum.last().copied().unwrap_or(f64::NAN),
    );
    Ok(())
}

/// Least-squares slope of y against its index.
fn slope(y: &[f64]) -> f64 {
    let m = y.len() as f64;
    let mx = (m - 1.0) / 2.0;
    let my = y.iter().sum::<f64>() / m;
    let sxy: f64 = y.iter().enumerate().map(|(i, v)| (i as f64 - mx) * (v - my)).sum();
    let sxx: f64 = (0..y.len()).map(|i| (i as f64 - mx).powi(2)).sum();
    sxy / sxx
}
