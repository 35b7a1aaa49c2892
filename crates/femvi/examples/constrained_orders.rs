//! The nodal order of the constrained integrators on the spherical pendulum in Cartesian
//! coordinates (|q| = 1, g = 9.81) against the same pendulum in spherical angles without
//! constraints (degree 4 at h = 0.002: converged), for degree s = 1 … 4 and each place where
//! the constraints are enforced inside the elements. Prints the errors at t = 2 and the
//! fitted orders. `cargo run --release -p femvi --example constrained_orders`

use femvi::constraints::{solve_constrained_with, Enforcement};
use femvi::{models, Element, Lagrangian, NodeFamily, Problem, QuadratureKind, Scalar, SolveOptions, Start};

/// L = ½(θ̇² + sin²θ φ̇²) + g cos θ (unit length and mass).
struct Angles {
    g: f64,
}

impl Lagrangian for Angles {
    fn dim(&self) -> usize {
        2
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn value<D: Scalar>(&self, _t: D, q: &[D], v: &[D]) -> D {
        let st = q[0].sin();
        (v[0] * v[0] + st * st * v[1] * v[1]) * 0.5 + q[0].cos() * self.g
    }
}

const G: f64 = 9.81;
const T: f64 = 2.0;
const THETA0: f64 = 1.0;
const PHIDOT0: f64 = 2.0;

fn reference() -> Result<Vec<f64>, femvi::Error> {
    let start = Start::Velocity {
        q: vec![THETA0, 0.0],
        v: vec![0.0, PHIDOT0],
    };
    let sol = femvi::solve(
        &Problem::new(Angles { g: G }, start, 0.0, T),
        &Element::with_order(8)?,
        &SolveOptions::step(0.002),
    )?;
    let q = sol
        .q_row(sol.len() - 1)
        .ok_or_else(|| femvi::Error::Observer("empty".into()))?;
    let (th, ph) = (q[0], q[1]);
    Ok(vec![th.sin() * ph.cos(), th.sin() * ph.sin(), -th.cos()])
}

fn error(element: &Element, h: f64, enforcement: Enforcement, exact: &[f64]) -> Result<f64, femvi::Error> {
    let (lag, sphere) = models::chain(3, 1, 1.0, G, 1.0)?;
    let start = Start::Velocity {
        q: vec![THETA0.sin(), 0.0, -THETA0.cos()],
        v: vec![0.0, THETA0.sin() * PHIDOT0, 0.0],
    };
    let run = solve_constrained_with(
        &Problem::new(lag, start, 0.0, T),
        &sphere,
        element,
        &SolveOptions {
            every: 0,
            ..SolveOptions::step(h)
        },
        enforcement,
    )?;
    if let Some(e) = run.solution.error {
        return Err(e);
    }
    let q = run.solution.q_row(run.solution.len() - 1).unwrap_or(&[]);
    Ok(q.iter().zip(exact).fold(0.0f64, |a, (x, y)| a.max((x - y).abs())))
}

fn main() -> Result<(), femvi::Error> {
    let exact = reference()?;
    let gauss = |s| Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s));
    let lobatto = |s| Element::galerkin(s, NodeFamily::Lobatto, QuadratureKind::GaussLobatto(s + 1));
    for (name, family) in [("gauss", 0), ("lobatto", 1)] {
        for enforcement in [
            Enforcement::Ends,
            Enforcement::Nodes,
            Enforcement::Points,
            Enforcement::Weak,
        ] {
            for s in 1..=4usize {
                let element = if family == 0 { gauss(s)? } else { lobatto(s)? };
                let hs: Vec<f64> = match s {
                    1 => vec![0.02, 0.01, 0.005, 0.0025],
                    2 => vec![0.08, 0.04, 0.02, 0.01],
                    3 => vec![0.2, 0.1, 0.05, 0.025],
                    _ => vec![0.4, 0.2, 0.1, 0.05],
                };
                let mut errs = vec![];
                for &h in &hs {
                    match error(&element, h, enforcement, &exact) {
                        Ok(e) => errs.push(e),
                        Err(e) => {
                            println!("{name} {enforcement:?} s={s} h={h}: {e}");
                            errs.push(f64::NAN);
                        }
                    }
                }
                let orders: Vec<String> = errs
                    .windows(2)
                    .map(|w| format!("{:.2}", (w[0] / w[1]).log2()))
                    .collect();
                let errs_s: Vec<String> = errs.iter().map(|e| format!("{e:.2e}")).collect();
                println!(
                    "{name:8} {:7} s={s} errors {} orders {}",
                    format!("{enforcement:?}"),
                    errs_s.join(" "),
                    orders.join(" ")
                );
            }
        }
    }
    Ok(())
}
