//! Set-up and step cost against the size of the system (issue 15, "O(n) set-up"): the
//! Fermi–Pasta–Ulam–Tsingou chain (α = 0.25, lowest mode, h = 0.1) at n = 10³ … 10⁶ and the
//! gravitational n-body problem (dim 3, unit masses on a jittered cubic lattice, h = 10⁻³) at
//! 100 … 10 000 bodies, degree 1 with the trapezoid rule (the explicit path), through the
//! library. Per row: the time to build the Lagrangian and the initial data (`load`),
//! `Integrator::new`, the first step, the median time per step afterwards (and per degree of
//! freedom), and the process's peak resident memory. Each size runs in a child process of its
//! own so that the peak memory is that size's.
//!
//! `cargo run --release -p femvi --example setup_scale` prints the table (Markdown);
//! `… -- fpu N [STEPS]` or `… -- nbody N` one row (STEPS: steps per timed block, by default
//! about 2·10⁷ / N; `Integrator::advance` is called once per block, so short blocks at large
//! N include a call's fixed costs, a few passes over the state).

use femvi::{models, Element, Integrator, Lagrangian, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
use std::time::Instant;

/// The process's peak resident set (VmHWM) in MiB, NaN where /proc is not there.
fn peak_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1).and_then(|k| k.parse::<f64>().ok()))
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Times Integrator::new, the first step and `steps` further steps (median over five blocks),
/// and prints the row.
fn row<L: Lagrangian>(name: &str, size: usize, load: f64, lag: &L, start: Start, h: f64, steps: usize) {
    let el = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).expect("element");
    let grid = TimeGrid::uniform(0.0, h, h * (1 + 5 * steps) as f64).expect("grid");
    let clock = Instant::now();
    let mut it = Integrator::new(lag, &el, grid, start, SolverOptions::default()).expect("integrator");
    let new = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    it.advance(1).expect("first step");
    let first = clock.elapsed().as_secs_f64();
    let blocks: Vec<f64> = (0..5)
        .map(|_| {
            let clock = Instant::now();
            it.advance(steps).expect("steps");
            clock.elapsed().as_secs_f64() / steps as f64
        })
        .collect();
    let step = median(blocks);
    let dof = lag.dim();
    println!(
        "| {name} | {size} | {load:.4} | {new:.4} | {first:.4} | {:.3e} | {:.2} | {:.0} |",
        step,
        step / dof as f64 * 1e9,
        peak_mib()
    );
}

fn fpu(n: usize, steps: Option<usize>) {
    let clock = Instant::now();
    let lag = models::fpu(n, 0.25, 0.0).expect("fpu");
    // The lowest mode's velocities, as `femvi models fpu`.
    let v: Vec<f64> = (1..=n)
        .map(|i| (std::f64::consts::PI * i as f64 / (n + 1) as f64).sin())
        .collect();
    let start = Start::Velocity { q: vec![0.0; n], v };
    let load = clock.elapsed().as_secs_f64();
    // About 2·10⁷ degrees of freedom × steps per block unless given.
    row(
        "fpu",
        n,
        load,
        &lag,
        start,
        0.1,
        steps.unwrap_or((20_000_000 / n).max(2)),
    );
}

fn nbody(bodies: usize) {
    let clock = Instant::now();
    let lag = models::n_body(1.0, vec![1.0; bodies], 3).expect("n-body");
    let side = (bodies as f64).cbrt().ceil() as usize;
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut jitter = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 0.2 - 0.1
    };
    let mut q = Vec::with_capacity(3 * bodies);
    for b in 0..bodies {
        let cell = [b % side, (b / side) % side, b / (side * side)];
        q.extend(cell.map(|c| c as f64 + jitter()));
    }
    let start = Start::Velocity {
        q,
        v: vec![0.0; 3 * bodies],
    };
    let load = clock.elapsed().as_secs_f64();
    // About 10⁸ pair interactions per block.
    row(
        "n-body",
        bodies,
        load,
        &lag,
        start,
        1e-3,
        (200_000_000 / (bodies * bodies)).max(1),
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let size = |s: Option<&String>| s.and_then(|s| s.parse::<usize>().ok()).unwrap_or(1000);
    match args.first().map(String::as_str) {
        Some("fpu") => fpu(size(args.get(1)), args.get(2).and_then(|s| s.parse().ok())),
        Some("nbody") => nbody(size(args.get(1))),
        _ => {
            println!("| system | size | load (s) | Integrator::new (s) | first step (s) | step (s) | step per dof (ns) | peak RSS (MiB) |");
            println!("|---|---|---|---|---|---|---|---|");
            let exe = std::env::current_exe().expect("own path");
            let runs = [("fpu", 1_000), ("fpu", 10_000), ("fpu", 100_000), ("fpu", 1_000_000)]
                .into_iter()
                .chain([("nbody", 100), ("nbody", 1_000), ("nbody", 10_000)]);
            for (what, n) in runs {
                let out = std::process::Command::new(&exe)
                    .args([what, &n.to_string()])
                    .output()
                    .expect("child run");
                print!("{}", String::from_utf8_lossy(&out.stdout));
                eprint!("{}", String::from_utf8_lossy(&out.stderr));
            }
        }
    }
}
