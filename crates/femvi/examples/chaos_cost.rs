//! Two measurements of the chaos indicators (issue: variational equations), on the Hénon–Heiles
//! orbit at E = 1/6 from (0, −0.1), p_y = 0 (chaotic), element of order 4, h = 0.1:
//!
//! 1. `cost`: the time per step of `chaos::indicators` (the step's tangent map, all 2n = 4
//!    tangent directions, MEGNO/FLI on one vector; and with the spectrum, its 2n vectors
//!    re-orthonormalised every 10 steps) against a plain `solve` of the same run, alternating,
//!    medians of `REPS`.
//! 2. `pairs`: the Lyapunov spectrum's ± pair sums λ_i + λ_{2n+1−i} after T = 10⁴ … 4·10⁵,
//!    to see how they tend to 0 with T.
//!
//! `cargo run --release -p femvi --example chaos_cost -- cost|pairs`

use femvi::chaos::{indicators, ChaosOptions};
use femvi::{models, Element, Mechanical, Problem, SolveOptions, Start};
use std::time::Instant;

const REPS: usize = 5;

fn orbit(t_end: f64) -> Problem<Mechanical<models::HenonHeilesPotential>> {
    let (y0, energy): (f64, f64) = (-0.1, 1.0 / 6.0);
    let v = 0.5 * y0 * y0 - y0.powi(3) / 3.0;
    let start = Start::Momentum {
        q: vec![0.0, y0],
        p: vec![(2.0 * (energy - v)).sqrt(), 0.0],
    };
    Problem::new(models::henon_heiles(), start, 0.0, t_end)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), femvi::Error> {
    let what = std::env::args().nth(1).unwrap_or_else(|| "cost".into());
    let element = Element::with_order(4)?;
    let options = SolveOptions {
        every: 0,
        ..SolveOptions::step(0.1)
    };
    let spectrum = ChaosOptions {
        spectrum: true,
        renormalize_every: 10,
        ..ChaosOptions::default()
    };
    if what == "pairs" {
        for (t, transient) in [
            (1e4, 0.0),
            (3e4, 0.0),
            (1e5, 0.0),
            (4e5, 0.0),
            (1e4, 1e3),
            (3e4, 3e3),
            (1e5, 1e4),
        ] {
            let chaos = ChaosOptions {
                spectrum_transient: transient,
                ..spectrum.clone()
            };
            print!("transient {transient:.0e}, ");
            let r = indicators(&orbit(t), &element, &options, &chaos)?;
            let s = r.spectrum.unwrap_or_default();
            if s.len() == 4 {
                println!(
                    "T = {t:.0e}: spectrum {:.6e} {:.6e} {:.6e} {:.6e}; pair sums {:.2e} {:.2e}; total {:.1e}",
                    s[0],
                    s[1],
                    s[2],
                    s[3],
                    s[0] + s[3],
                    s[1] + s[2],
                    s.iter().sum::<f64>()
                );
            }
        }
        return Ok(());
    }
    let problem = orbit(1e4);
    let (mut plain, mut megno, mut full) = (vec![], vec![], vec![]);
    for _ in 0..REPS {
        let c = Instant::now();
        let sol = femvi::solve(&problem, &element, &options)?;
        plain.push(c.elapsed().as_secs_f64() / sol.steps as f64);
        let c = Instant::now();
        let r = indicators(&problem, &element, &options, &ChaosOptions::default())?;
        megno.push(c.elapsed().as_secs_f64() / r.steps as f64);
        let c = Instant::now();
        let r = indicators(&problem, &element, &options, &spectrum)?;
        full.push(c.elapsed().as_secs_f64() / r.steps as f64);
    }
    let (p, m, f) = (median(plain), median(megno), median(full));
    println!(
        "per step: plain {:.2} us, MEGNO/FLI (1 vector) {:.2} us ({:.1}x), spectrum (2n = 4 vectors) {:.2} us ({:.1}x)",
        1e6 * p,
        1e6 * m,
        m / p,
        1e6 * f,
        f / p
    );
    Ok(())
}
