//! A MEGNO map of the Hénon–Heiles system at energy 1/8 on the section y = 0 (p_y > 0 from
//! the energy), over x and p_x in [−0.45, 0.45]: ⟨Y⟩ ≈ 2 on regular orbits, larger on chaotic
//! ones. Writes `x,p_x,megno` rows to standard output and, on standard error, the time with
//! 1 and with 2 threads (alternating, best of `REPEAT`) and the speed-up.
//! `cargo run --release -p femvi --example megno_map -- 200 > map.csv`

use femvi::chaos::{map, ChaosOptions, ChaosReport};
use femvi::{models, Element, Mechanical, Problem, SolveOptions, Start};
use std::time::Instant;

const ENERGY: f64 = 0.125;
const REPEAT: usize = 2;

fn problem(side: usize, i: usize) -> Problem<Mechanical<models::HenonHeilesPotential>> {
    let at = |k: usize| -0.45 + 0.9 * k as f64 / (side - 1) as f64;
    let (x, px) = (at(i % side), at(i / side));
    // p_y² = 2E − p_x² − x² (V(x, 0) = x²/2); outside the energy surface p_y is NaN and the
    // run reports a bad start.
    let py = (2.0 * ENERGY - px * px - x * x).sqrt();
    let start = Start::Momentum {
        q: vec![x, 0.0],
        p: vec![px, py],
    };
    Problem::new(models::henon_heiles(), start, 0.0, 200.0)
}

fn run(side: usize, threads: usize) -> Result<(f64, Vec<femvi::Result<ChaosReport>>), femvi::Error> {
    let clock = Instant::now();
    let element = Element::with_order(4)?;
    let reports = map(
        side * side,
        |i| problem(side, i),
        &element,
        &SolveOptions::step(0.2),
        &ChaosOptions::default(),
        threads,
    )?;
    Ok((clock.elapsed().as_secs_f64(), reports))
}

fn main() -> Result<(), femvi::Error> {
    let side: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(200)
        .max(2);
    let (mut best1, mut best2) = (f64::INFINITY, f64::INFINITY);
    let mut last = vec![];
    for _ in 0..REPEAT {
        let (t1, r1) = run(side, 1)?;
        let (t2, r2) = run(side, 2)?;
        // The runs are independent: the same numbers whatever the number of threads.
        let same = r1.iter().zip(&r2).all(|(a, b)| match (a, b) {
            (Ok(a), Ok(b)) => a.last.mean_megno.to_bits() == b.last.mean_megno.to_bits(),
            (Err(_), Err(_)) => true,
            _ => false,
        });
        assert!(same, "1 and 2 threads differ");
        (best1, best2) = (best1.min(t1), best2.min(t2));
        last = r2;
    }
    println!("x,p_x,megno");
    for (i, r) in last.iter().enumerate() {
        let at = |k: usize| -0.45 + 0.9 * k as f64 / (side - 1) as f64;
        let y = r.as_ref().map_or(f64::NAN, |r| r.last.mean_megno);
        println!("{},{},{}", at(i % side), at(i / side), y);
    }
    let ok = last.iter().filter(|r| r.is_ok()).count();
    eprintln!(
        "{side}x{side} points ({ok} on the energy surface): 1 thread {best1:.2} s, 2 threads {best2:.2} s, speed-up {:.2}",
        best1 / best2
    );
    Ok(())
}
