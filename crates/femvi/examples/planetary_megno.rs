//! MEGNO of a star + two planets system (G = 1, masses 1, 1e-3, 3e-4: Jupiter and Saturn-like)
//! in `DIM` = 2 or 3 dimensions for many initial states, one per line of standard input:
//! the positions then the velocities, barycentric (`x0,y0[,z0],x1,…,vx0,vy0[,vz0],…`,
//! 4·DIM·… = 6·DIM numbers), optionally followed by an initial tangent vector in the same
//! layout (δx…, δv…; its momentum part is δp = m δv), else the default vector, and then
//! optionally by an encounter distance d. Writes `megno,fli,steps,failed,min_distance` per
//! line to standard output: `min_distance` is the smallest distance between two bodies
//! at the points where the force was evaluated (the step's stages); with d given, `failed` is
//! also 1 when it fell below d (a close encounter: REBOUND's `exit_min_distance`, which the
//! comparison applies to both codes). Degree 1 with the trapezoid rule
//! (Störmer–Verlet; `ORDER` absent or `verlet`) or the Gauss–Legendre element of order `ORDER`, step `H`, up to time `T`,
//! one thread (the CPU time is the caller's to measure: benches/peers/megno_rebound.py
//! compares it with REBOUND's MEGNO on the same states and tangent vectors).
//! `cargo run --release -p femvi --example planetary_megno -- T H [ORDER [DIM]] < states.csv`

use femvi::chaos::{indicators, ChaosOptions};
use femvi::models::GravityPotential;
use femvi::{
    models, Element, Lagrangian, Mechanical, NodeFamily, Potential, Problem, QuadratureKind, Scalar, SolveOptions,
    Start,
};
use std::cell::Cell;
use std::io::BufRead;

/// The gravity potential, watching the smallest distance between any two bodies at every
/// force evaluation; everything else is the model's own, so the run is the same bit for bit.
#[derive(Debug, Clone)]
struct Watched {
    inner: GravityPotential,
    min_distance_squared: Cell<f64>,
}

impl Potential for Watched {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn value<D: Scalar>(&self, t: D, q: &[D]) -> D {
        self.inner.value(t, q)
    }
    fn is_autonomous(&self) -> bool {
        self.inner.is_autonomous()
    }
    fn force(&self, t: f64, q: &[f64], out: &mut [f64]) {
        let d = self.inner.dim;
        // The smallest squared distance (the square root of the smallest is the smallest
        // root: sqrt is monotone and correctly rounded), its root taken once per run.
        let mut closest = self.min_distance_squared.get();
        for (i, a) in q.chunks_exact(d.max(1)).enumerate() {
            for b in q.chunks_exact(d.max(1)).skip(i + 1) {
                let r2 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
                closest = closest.min(r2);
            }
        }
        self.min_distance_squared.set(closest);
        self.inner.force(t, q, out);
    }
    fn force_jacobian(&self, t: f64, q: &[f64], out: &mut [f64]) {
        self.inner.force_jacobian(t, q, out);
    }
    fn force_derivative(&self, t: f64, q: &[f64], dq: &[f64], out: &mut [f64]) {
        self.inner.force_derivative(t, q, dq, out);
    }
    fn prepare_force_derivative(&self, t: f64, q: &[f64], cache: &mut Vec<f64>) -> bool {
        self.inner.prepare_force_derivative(t, q, cache)
    }
    fn prepared_force_derivative(&self, cache: &[f64], dq: &[f64], out: &mut [f64]) {
        self.inner.prepared_force_derivative(cache, dq, out);
    }
}

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
    let model = models::n_body(1.0, MASSES.to_vec(), dim)?;
    let lag = Mechanical::new(
        Watched {
            inner: model.potential.clone(),
            min_distance_squared: Cell::new(f64::INFINITY),
        },
        model
            .mass_matrix()
            .cloned()
            .ok_or("the n-body model has a mass matrix")?,
    )?;
    // Momentum from velocity: p = m v for the body of coordinate i.
    let momentum = |v: &[f64]| -> Vec<f64> { v.iter().enumerate().map(|(i, x)| MASSES[i / dim] * x).collect() };
    for line in std::io::stdin().lock().lines() {
        let row: Vec<f64> = line?.split(',').map(|x| x.trim().parse()).collect::<Result<_, _>>()?;
        if ![2 * n, 4 * n, 4 * n + 1].contains(&row.len()) {
            return Err(format!(
                "expected {}, {} or {} numbers per line, got {}",
                2 * n,
                4 * n,
                4 * n + 1,
                row.len()
            )
            .into());
        }
        let (row, encounter) = if row.len() == 4 * n + 1 {
            row.split_at(4 * n)
        } else {
            (&row[..], &[][..])
        };
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
        let closest = problem
            .lagrangian
            .potential
            .min_distance_squared
            .replace(f64::INFINITY)
            .sqrt();
        let close = encounter.first().is_some_and(|&d| closest < d);
        println!(
            "{},{},{},{},{}",
            r.last.mean_megno,
            r.last.fli,
            r.steps,
            u8::from(r.error.is_some() || close),
            closest
        );
    }
    Ok(())
}
