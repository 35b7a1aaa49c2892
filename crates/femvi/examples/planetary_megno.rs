//! MEGNO of a star + two planets system (G = 1, masses 1, 1e-3, 3e-4: Jupiter and Saturn-like)
//! in `DIM` = 2 or 3 dimensions for many initial states, one per line of standard input:
//! the positions then the velocities, barycentric (`x0,y0[,z0],x1,…,vx0,vy0[,vz0],…`,
//! 4·DIM·… = 6·DIM numbers), optionally followed by an initial tangent vector in the same
//! layout (δx…, δv…; its momentum part is δp = m δv), else the default vector. Writes
//! `megno,fli,steps,failed` per line to standard output. Degree 1 with the trapezoid rule
//! (Störmer–Verlet; `ORDER` absent or `verlet`) or the Gauss–Legendre element of order `ORDER`, step `H`, up to time `T`,
//! one thread (the CPU time is the caller's to measure: benches/peers/megno_rebound.py
//! compares it with REBOUND's MEGNO on the same states and tangent vectors).
//! `cargo run --release -p femvi --example planetary_megno -- T H [ORDER [DIM]] < states.csv`

use femvi::chaos::{indicators, ChaosOptions};
use femvi::{models, Element, NodeFamily, Problem, QuadratureKind, SolveOptions, Start};
use std::io::BufRead;

const MASSES: [f64; 3] = [1.0, 1e-3, 3e-4];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: planetary_megno T H [ORDER [DIM]] < states.csv";
    let t_end: f64 = args.next().ok_or(usage)?.parse()?;
    let h: f64 = args.next().ok_or(usage)?.parse()?;
    let element = match args.next().as_deref() {
        None | Some("verlet") => Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid)?,
        Some(order) => Element::with_order(order.parse()?)?,
    };
    let dim: usize = args.next().map_or(Ok(2), |d| d.parse())?;
    if !(dim == 2 || dim == 3) {
        return Err("DIM must be 2 or 3".into());
    }
    let n = MASSES.len() * dim;
    let lag = models::n_body(1.0, MASSES.to_vec(), dim)?;
    // Momentum from velocity: p = m v for the body of coordinate i.
    let momentum = |v: &[f64]| -> Vec<f64> { v.iter().enumerate().map(|(i, x)| MASSES[i / dim] * x).collect() };
    for line in std::io::stdin().lock().lines() {
        let row: Vec<f64> = line?.split(',').map(|x| x.trim().parse()).collect::<Result<_, _>>()?;
        if row.len() != 2 * n && row.len() != 4 * n {
            return Err(format!("expected {} or {} numbers per line, got {}", 2 * n, 4 * n, row.len()).into());
        }
        let (state, tangent) = row.split_at(2 * n);
        let (q, v) = state.split_at(n);
        let start = Start::Momentum {
            q: q.to_vec(),
            p: momentum(v),
        };
        let mut chaos = ChaosOptions::default();
        if !tangent.is_empty() {
            let (dq, dv) = tangent.split_at(n);
            chaos.initial_vector = Some(dq.iter().copied().chain(momentum(dv)).collect());
        }
        let problem = Problem::new(lag.clone(), start, 0.0, t_end);
        let r = indicators(&problem, &element, &SolveOptions::step(h), &chaos)?;
        println!(
            "{},{},{},{}",
            r.last.mean_megno,
            r.last.fli,
            r.steps,
            u8::from(r.error.is_some())
        );
    }
    Ok(())
}
