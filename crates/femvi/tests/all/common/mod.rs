//! Helpers shared by the integration tests: running a problem, exact Kepler solutions,
//! least-squares order fits and a tiny deterministic random generator.
#![allow(dead_code)]

pub mod rattle;
pub mod snapshot;
pub mod tangent_fd;

use femvi::{Element, Integrator, Lagrangian, SolverOptions, Start, TimeGrid};

/// Runs to the end; returns every node (t, q, p).
pub fn run_nodes<L: Lagrangian>(lag: &L, el: &Element, grid: TimeGrid, start: Start) -> Vec<(f64, Vec<f64>, Vec<f64>)> {
    let mut it = Integrator::new(lag, el, grid, start, SolverOptions::default()).unwrap();
    let mut out = vec![];
    loop {
        let n = it.node();
        out.push((n.t, n.q.to_vec(), n.p.to_vec()));
        if !it.step().unwrap() {
            break;
        }
    }
    out
}

/// Final node of a run.
pub fn run_final<L: Lagrangian>(lag: &L, el: &Element, grid: TimeGrid, start: Start) -> (f64, Vec<f64>, Vec<f64>) {
    let mut it = Integrator::new(lag, el, grid, start, SolverOptions::default()).unwrap();
    while it.step().unwrap() {}
    let n = it.node();
    (n.t, n.q.to_vec(), n.p.to_vec())
}

/// Least-squares order fits: the library's (unit-tested against an exact power law).
#[allow(unused_imports)]
pub use femvi::diagnostics::fit_order;

/// Exact Kepler state (μ = 1) at time t from q0 = (a(1−e), 0), p0 = (0, √((1+e)/(a(1−e)))),
/// by Newton's method on Kepler's equation E − e sin E = M.
pub fn kepler_exact(e: f64, t: f64) -> ([f64; 2], [f64; 2]) {
    let a = 1.0; // period 2π
    let m = t.rem_euclid(2.0 * std::f64::consts::PI);
    let mut big_e = if e < 0.8 { m } else { std::f64::consts::PI };
    for _ in 0..100 {
        let d = (big_e - e * big_e.sin() - m) / (1.0 - e * big_e.cos());
        big_e -= d;
        if d.abs() < 1e-16 {
            break;
        }
    }
    let (s, c) = big_e.sin_cos();
    let b = a * (1.0 - e * e).sqrt();
    let edot = 1.0 / (a.powf(1.5) * (1.0 - e * c));
    ([a * (c - e), b * s], [-a * s * edot, b * c * edot])
}

/// Deterministic numbers in [0, 1) (a 64-bit LCG), so tests with random steps are reproducible.
pub struct Lcg(pub u64);
impl Lcg {
    pub fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Formats errors compactly for test messages.
pub struct Errs<'a>(pub &'a [f64]);
impl std::fmt::Display for Errs<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for e in self.0 {
            write!(f, "{e:.2e} ")?;
        }
        Ok(())
    }
}

/// Observed order: the least-squares slope of log|err| against log h, with h ∝ 1/n for
/// meshes of n elements.
pub fn fitted_order(n: &[usize], err: &[f64]) -> f64 {
    let pts: Vec<(f64, f64)> = n
        .iter()
        .zip(err)
        .map(|(&n, &e)| (-(n as f64).ln(), e.abs().ln()))
        .collect();
    let k = pts.len() as f64;
    let (mx, my) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x / k, b + y / k));
    let sxy: f64 = pts.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = pts.iter().map(|(x, _)| (x - mx) * (x - mx)).sum();
    sxy / sxx
}
