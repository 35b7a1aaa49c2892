//! The tangent benchmark's ratios (`benches/tangent.rs`) measured alternately in one process,
//! so that the machine's drift falls on both sides: for each system and degree, rounds of a
//! plain run, the run with one tangent vector and with 1 + 2n (the spectrum, re-orthonormalised
//! every 10 steps), 1000 steps each; prints the median over the rounds of each round's ratio
//! to its plain run. `tangent_ratios [ROUNDS] [SYSTEM]` (SYSTEM: kepler, henon-heiles,
//! planets, fpu; all by default).

use femvi::chaos::{indicators, ChaosOptions};
use femvi::{Element, Lagrangian, NodeFamily, Problem, QuadratureKind, SolveOptions};
use std::hint::black_box;
use std::time::Instant;

/// Seconds per run of `f`, repeated until at least 20 ms have passed.
fn time(f: &mut dyn FnMut()) -> f64 {
    let (start, mut reps) = (Instant::now(), 0u32);
    while reps == 0 || start.elapsed().as_secs_f64() < 0.02 {
        f();
        reps += 1;
    }
    start.elapsed().as_secs_f64() / f64::from(reps)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn system<L: Lagrangian>(name: &str, problem: &Problem<L>, h: f64, rounds: usize) {
    let elements = [
        (
            1,
            Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).expect("trapezoid"),
        ),
        (2, Element::with_order(4).expect("order 4")),
    ];
    for (degree, element) in elements {
        let options = SolveOptions {
            every: 0,
            ..SolveOptions::step(h)
        };
        let chaos = |spectrum| ChaosOptions {
            spectrum,
            renormalize_every: 10,
            ..ChaosOptions::default()
        };
        let (one, all) = (chaos(false), chaos(true));
        let (mut plain, mut r1, mut r2) = (vec![], vec![], vec![]);
        for _ in 0..rounds {
            let p = time(&mut || {
                black_box(femvi::solve(problem, &element, &options).expect("plain run").steps);
            });
            let t1 = time(&mut || {
                black_box(indicators(problem, &element, &options, &one).expect("one vector").steps);
            });
            let t2 = time(&mut || {
                black_box(
                    indicators(problem, &element, &options, &all)
                        .expect("1 + 2n vectors")
                        .steps,
                );
            });
            plain.push(p);
            r1.push(t1 / p);
            r2.push(t2 / p);
        }
        println!(
            "{name}, degree {degree}: plain {:.0} ns/step, one vector {:.2}x, 1 + 2n vectors {:.2}x",
            median(plain) * 1e6,
            median(r1),
            median(r2)
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: tangent_ratios [ROUNDS >= 1] [all|kepler|henon-heiles|planets|fpu]";
    let rounds = match args.get(1).map(|r| r.parse::<usize>()) {
        None => 11,
        Some(Ok(r)) if r >= 1 => r,
        Some(_) => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    };
    let only = args.get(2).map_or("all", String::as_str);
    if !["all", "kepler", "henon-heiles", "planets", "fpu"].contains(&only) {
        eprintln!("{usage}");
        std::process::exit(2);
    }
    macro_rules! measure {
        ($($key:literal, $label:literal, $problem:path;)*) => {
            $(if only == "all" || only == $key {
                let (p, h) = $problem();
                system($label, &p, h, rounds);
            })*
        };
    }
    measure! {
        "kepler", "Kepler", femvi_bench::tangent_kepler;
        "henon-heiles", "Hénon–Heiles", femvi_bench::tangent_henon_heiles;
        "planets", "star + two planets", femvi_bench::tangent_planets;
        "fpu", "FPU n = 64", femvi_bench::tangent_fpu;
    }
}
