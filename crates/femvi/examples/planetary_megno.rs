//! MEGNO of a planar star + two planets system (G = 1, masses 1, 1e-3, 3e-4: Jupiter and
//! Saturn-like) for many initial states, one per line of standard input:
//! `x0,y0,x1,y1,x2,y2,vx0,vy0,vx1,vy1,vx2,vy2` (barycentric). Writes `megno,fli,steps,failed`
//! per line to standard output. Degree 1 with the trapezoid rule (Störmer–Verlet), step `H`, up to
//! time `T`, one thread (the CPU time is the caller's to measure: benches/peers/megno_rebound.py
//! compares it with REBOUND's MEGNO on the same states).
//! `cargo run --release -p femvi --example planetary_megno -- T H [ORDER] < states.csv`

use femvi::chaos::{indicators, ChaosOptions};
use femvi::{models, Element, NodeFamily, Problem, QuadratureKind, SolveOptions, Start};
use std::io::BufRead;

const MASSES: [f64; 3] = [1.0, 1e-3, 3e-4];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: planetary_megno T H [ORDER] < states.csv";
    let t_end: f64 = args.next().ok_or(usage)?.parse()?;
    let h: f64 = args.next().ok_or(usage)?.parse()?;
    // An optional third argument: the element's order (Gauss–Legendre, order 2s) instead.
    let element = match args.next() {
        None => Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid)?,
        Some(order) => Element::with_order(order.parse()?)?,
    };
    let lag = models::n_body(1.0, MASSES.to_vec(), 2)?;
    for line in std::io::stdin().lock().lines() {
        let row: Vec<f64> = line?.split(',').map(|x| x.trim().parse()).collect::<Result<_, _>>()?;
        if row.len() != 12 {
            return Err(format!("expected 12 numbers per line, got {}", row.len()).into());
        }
        let q = row[..6].to_vec();
        // p = m v, body by body.
        let p: Vec<f64> = row[6..].iter().enumerate().map(|(i, v)| MASSES[i / 2] * v).collect();
        let problem = Problem::new(lag.clone(), Start::Momentum { q, p }, 0.0, t_end);
        let r = indicators(&problem, &element, &SolveOptions::step(h), &ChaosOptions::default())?;
        // A run stopped by a failed step (a close encounter) reports what it had: its MEGNO
        // is then flagged by the last column.
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
