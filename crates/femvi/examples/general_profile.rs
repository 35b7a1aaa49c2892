//! Profiling aid for the general path (issue 15 item 2): the relativistic Kepler run of
//! `benches/general.rs` (2 000 steps, Method::Newton) at the degree given as the first
//! argument (default 2), repeated as many times as the second (default 1); with a third
//! argument `kepler`, the Kepler model's fixed-point step instead (the yardstick). For
//! callgrind or `perf stat`; with `FEMVI_ITERATIONS` set, each run also prints its mean
//! iterations per step to stderr.

use femvi::models::RelativisticKepler;
use femvi::{Element, Integrator, Lagrangian, Method, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};

fn main() {
    let mut args = std::env::args().skip(1);
    let s: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(2);
    let reps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let el = Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap();
    let h = 2.0 * std::f64::consts::PI / 1000.0;
    let kepler = args.next().is_some_and(|a| a == "kepler");
    for _ in 0..reps {
        if kepler {
            let x = run(&femvi::models::kepler(1.0).unwrap(), &el, h, Method::Auto);
            println!("{x:?}");
        } else {
            println!("{:?}", run(&RelativisticKepler { c: 10.0 }, &el, h, Method::Newton));
        }
    }
}

/// 2 000 steps of h from (q, p) = ((0.4, 0), (0, 2)); the final q.
fn run<L: Lagrangian>(lag: &L, el: &Element, h: f64, method: Method) -> Vec<f64> {
    {
        let start = Start::Momentum {
            q: vec![0.4, 0.0],
            p: vec![0.0, 2.0],
        };
        let grid = TimeGrid::uniform(0.0, h, h * 2000.0).unwrap();
        let opts = SolverOptions {
            method,
            ..Default::default()
        };
        let mut it = Integrator::new(lag, el, grid, start, opts).unwrap();
        while it.advance(usize::MAX).unwrap() > 0 {}
        if std::env::var_os("FEMVI_ITERATIONS").is_some() {
            eprintln!("mean iterations per step {}", it.mean_iterations());
        }
        it.node().q.to_vec()
    }
}
