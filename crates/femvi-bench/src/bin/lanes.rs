//! A fixed amount of ensemble work for timing whole processes against each other
//! (`farm-bench --vs`): `lanes MODEL MEMBERS STEPS [WIDTH] [DEGREE]` runs MEMBERS members of
//! `kepler` or `henon-heiles` for STEPS steps of 0.01 on one thread in SIMD lanes (WIDTH:
//! best, avx512, avx2, portable; or `one` for one member at a time) and prints a checksum of
//! the final states. DEGREE 1 (the default) is Störmer–Verlet; 2 and 3 are the Gauss–Legendre
//! elements of that degree, solved by the fixed-point iteration.

use femvi::ensemble::{EnsembleLanes, Width};
use femvi::solution::EnergyTracker;
use femvi::{models, Element, Integrator, Lagrangian, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: lanes kepler|henon-heiles MEMBERS STEPS [best|avx512|avx2|portable|one] [DEGREE]";
    let (Some(model), Some(members), Some(steps)) = (args.get(1), args.get(2), args.get(3)) else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let (Ok(members), Ok(steps)) = (members.parse::<usize>(), steps.parse::<usize>()) else {
        eprintln!("{usage}");
        std::process::exit(2);
    };
    let width = args.get(4).map_or("best", String::as_str);
    let element = match args.get(5).map_or("1", String::as_str) {
        "1" => Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid),
        d => match d.parse::<usize>() {
            Ok(s @ 2..=3) => Element::with_order(2 * s),
            _ => {
                eprintln!("{usage}");
                std::process::exit(2);
            }
        },
    }
    .expect("element");
    let sum = match model.as_str() {
        "kepler" => run(
            &models::kepler(1.0).expect("kepler"),
            &element,
            true,
            (members, steps),
            width,
        ),
        _ => run(&models::henon_heiles(), &element, false, (members, steps), width),
    };
    println!("{sum:e}");
}

fn run<L: Lagrangian + Sync>(
    lag: &L,
    el: &Element,
    kepler: bool,
    (members, steps): (usize, usize),
    width: &str,
) -> f64 {
    let starts = femvi_bench::ensemble_starts(kepler, members);
    let grid = TimeGrid::uniform(0.0, 0.01, 0.01 * steps as f64).expect("grid");
    let template = Integrator::new(lag, el, grid.clone(), starts[0].clone(), SolverOptions::default()).expect("run");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    let width = match width {
        "one" => return one_by_one(lag, el, &grid, &starts),
        "avx512" => Width::Avx512,
        "avx2" => Width::Avx2,
        "portable" => Width::Portable,
        _ => Width::Best,
    };
    let lanes = EnsembleLanes::of(&template).expect("in lanes").width(width);
    let ends = pool.install(|| lanes.run(&starts, &|_| {}));
    ends.iter().flatten().map(|e| e.q[0] + e.energy_error).sum()
}

fn one_by_one<L: Lagrangian>(lag: &L, el: &Element, grid: &TimeGrid, starts: &[Start]) -> f64 {
    let (mut sum, mut sweeps) = (0.0, 0.0);
    for s in starts {
        let mut it = Integrator::new(lag, el, grid.clone(), s.clone(), SolverOptions::default()).expect("run");
        let mut tracker = EnergyTracker::new(lag.dim(), s, true);
        let node = it.node();
        let _ = tracker.node(lag, node.t, node.q, node.p);
        while let Ok(true) = it.step() {
            let node = it.node();
            let _ = tracker.node(lag, node.t, node.q, node.p);
        }
        sum += it.node().q[0] + tracker.report().max_rel_error;
        sweeps += it.mean_iterations();
    }
    if std::env::var_os("LANES_SWEEPS").is_some() {
        eprintln!("mean sweeps per step: {:.3}", sweeps / starts.len() as f64);
    }
    sum
}
