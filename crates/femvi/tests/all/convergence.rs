//! Measured convergence orders: nodal order 2s for degree s with s-point Gauss–Legendre
//! (s = 1 … 6) on the pendulum (nonlinear, 1-D; reference: a much finer degree-6 run) and on
//! Kepler (2-D; reference: Kepler's equation), with uniform and random unequal steps; and the
//! L² orders 2 and 3 of the interpolant for s = 1, 2 ((2.33), (2.56)).

use crate::common::{fit_order, kepler_exact, run_final, Errs, Lcg};
use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};

fn gauss(s: usize) -> Element {
    Element::galerkin(s, NodeFamily::Equispaced, QuadratureKind::GaussLegendre(s)).unwrap()
}

/// N uniform steps over [0, T], or a fixed random pattern of 7 unequal steps (factors in
/// [0.8, 1.2], ratios up to 1.5) with mean T/N, used cyclically. Returns the grid and the
/// largest step. (With factors in [0.6, 1.4] the error constants of degree 6 oscillate in the
/// windows above round-off: Kepler 11.49, pendulum 12.46 measured.)
fn grid(t_end: f64, n: usize, random: bool) -> (TimeGrid, f64) {
    let h = t_end / n as f64;
    if !random {
        return (TimeGrid::uniform(0.0, h, t_end).unwrap(), h);
    }
    let mut r = Lcg(11);
    let raw: Vec<f64> = (0..7).map(|_| 0.8 + 0.4 * r.uniform()).collect();
    let mean = raw.iter().sum::<f64>() / 7.0;
    let steps: Vec<f64> = raw.iter().map(|x| x / mean * h).collect();
    let hmax = steps.iter().cloned().fold(0.0, f64::max);
    (TimeGrid::steps(0.0, steps, t_end).unwrap(), hmax)
}

fn phase_error(q: &[f64], p: &[f64], qe: &[f64], pe: &[f64]) -> f64 {
    q.iter()
        .zip(qe)
        .chain(p.iter().zip(pe))
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Kepler: (eccentricity, periods, step counts) per degree, chosen (by a scan) so that the
/// errors lie between the pre-asymptotic range and the round-off floor (~1e-12 over 10 periods).
fn kepler_config(s: usize) -> (f64, f64, Vec<usize>) {
    match s {
        1 => (0.3, 1.0, vec![100, 140, 200, 300]),
        2 => (0.3, 1.0, vec![50, 60, 80, 100, 140]),
        3 => (0.1, 10.0, vec![340, 400, 500, 600, 800]),
        4 => (0.1, 10.0, vec![200, 240, 280, 340, 400]),
        5 => (0.1, 10.0, vec![100, 120, 140, 170, 200]),
        _ => (0.1, 10.0, vec![80, 90, 100, 110, 120]),
    }
}

fn kepler_orders(random: bool) {
    let lag = models::kepler(1.0).unwrap();
    for s in 1..=6 {
        let (e, periods, counts) = kepler_config(s);
        let t_end = periods * 2.0 * std::f64::consts::PI;
        let (q0, p0) = kepler_exact(e, 0.0);
        let (qe, pe) = kepler_exact(e, t_end);
        let el = gauss(s);
        let (mut hs, mut errs) = (vec![], vec![]);
        for n in counts {
            let (g, h) = grid(t_end, n, random);
            let (_, q, p) = run_final(
                &lag,
                &el,
                g,
                Start::Momentum {
                    q: q0.to_vec(),
                    p: p0.to_vec(),
                },
            );
            hs.push(h);
            errs.push(phase_error(&q, &p, &qe, &pe));
        }
        let order = fit_order(&hs, &errs);
        eprintln!("kepler s={s} random={random}: errors {} order {order:.3}", Errs(&errs));
        assert!(
            (order - 2.0 * s as f64).abs() < 0.35,
            "s={s}: order {order} (errors {})",
            Errs(&errs)
        );
    }
}

#[test]
fn nodal_order_2s_on_kepler_uniform() {
    kepler_orders(false);
}

#[test]
fn nodal_order_2s_on_kepler_random_steps() {
    kepler_orders(true);
}

/// Pendulum: (amplitude, T, step counts) per degree, from a scan as for Kepler. With random
/// steps s = 1, 2 use 1.5 times as many steps and s ≥ 3 the small-amplitude run.
fn pendulum_config(s: usize, random: bool) -> (f64, f64, Vec<usize>) {
    match (s, random) {
        (1, true) => return (2.0, 30.0, vec![300, 450, 600, 900, 1200]),
        (2, true) => return (2.0, 30.0, vec![300, 450, 600, 900]),
        (3, true) => return (0.5, 300.0, vec![600, 800, 1000, 1300, 1600]),
        (4, true) => return (0.5, 300.0, vec![500, 600, 800, 1000]),
        (5, true) | (6, true) => return (0.5, 300.0, vec![300, 350, 400, 500]),
        _ => {}
    }
    match s {
        1 => (2.0, 30.0, vec![200, 300, 400, 600, 800]),
        2 => (2.0, 30.0, vec![200, 300, 400, 600]),
        3 => (2.0, 30.0, vec![100, 130, 160, 200]),
        4 => (2.0, 30.0, vec![60, 80, 100, 130]),
        5 => (0.5, 300.0, vec![300, 350, 400, 500]),
        _ => (0.5, 300.0, vec![260, 300, 350, 400]),
    }
}

fn pendulum_orders(random: bool) {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    for s in 1..=6 {
        let (q0, t_end, counts) = pendulum_config(s, random);
        let start = Start::Velocity {
            q: vec![q0],
            v: vec![0.0],
        };
        // Reference: degree 6 with steps 20 times smaller than the finest run.
        let finest = counts[counts.len() - 1] * 20;
        let (_, qr, pr) = run_final(
            &lag,
            &gauss(6),
            TimeGrid::uniform(0.0, t_end / finest as f64, t_end).unwrap(),
            start.clone(),
        );
        let el = gauss(s);
        let (mut hs, mut errs) = (vec![], vec![]);
        for n in counts {
            let (g, h) = grid(t_end, n, random);
            let (_, q, p) = run_final(&lag, &el, g, start.clone());
            hs.push(h);
            errs.push(phase_error(&q, &p, &qr, &pr));
        }
        let order = fit_order(&hs, &errs);
        eprintln!(
            "pendulum s={s} random={random}: errors {} order {order:.3}",
            Errs(&errs)
        );
        assert!(
            (order - 2.0 * s as f64).abs() < 0.35,
            "s={s}: order {order} (errors {})",
            Errs(&errs)
        );
    }
}

#[test]
fn nodal_order_2s_on_the_pendulum_uniform() {
    pendulum_orders(false);
}

#[test]
fn nodal_order_2s_on_the_pendulum_random_steps() {
    pendulum_orders(true);
}

/// L² error of the piecewise polynomial q_h against cos t (harmonic oscillator, q0 = 1, v0 = 0).
fn l2_error(el: &Element, n: usize, random: bool) -> (f64, f64) {
    let lag = models::harmonic(1.0, 1.0).unwrap();
    let t_end = 4.0;
    let (g, h) = grid(t_end, n, random);
    let start = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    let mut it = Integrator::new(&lag, el, g, start, SolverOptions::default()).unwrap();
    let fine = femvi::fem::QuadratureRule::new(QuadratureKind::GaussLegendre(10)).unwrap();
    let mut vals = vec![0.0; el.nodes()];
    let mut sum = 0.0;
    while it.step().unwrap() {
        let e = it.last_element().unwrap();
        for (c, w) in fine.nodes.iter().zip(&fine.weights) {
            el.basis.values_in_place(*c, &mut vals);
            let qh = e.base[0] + vals.iter().zip(e.incr).map(|(l, d)| l * d).sum::<f64>();
            sum += e.h * w * (qh - (e.t + c * e.h).cos()).powi(2);
        }
    }
    (sum.sqrt(), h)
}

#[test]
fn l2_orders_of_2_33_and_2_56() {
    for (s, want) in [(1, 2.0), (2, 3.0)] {
        let el = gauss(s);
        for random in [false, true] {
            let (mut hs, mut errs) = (vec![], vec![]);
            for n in [20, 40, 80, 160] {
                let (e, h) = l2_error(&el, n, random);
                hs.push(h);
                errs.push(e);
            }
            let order = fit_order(&hs, &errs);
            eprintln!("L2 s={s} random={random}: errors {} order {order:.3}", Errs(&errs));
            assert!((order - want).abs() < 0.2, "s={s}: L2 order {order}");
        }
    }
}

#[test]
fn midpoint_has_order_2_on_kepler() {
    let lag = models::kepler(1.0).unwrap();
    let (q0, p0) = kepler_exact(0.5, 0.0);
    let (qe, _) = kepler_exact(0.5, 2.0);
    let (mut hs, mut errs) = (vec![], vec![]);
    for n in [100, 200, 400, 800] {
        let (g, h) = grid(2.0, n, false);
        let (_, q, _) = run_final(
            &lag,
            &Element::midpoint(),
            g,
            Start::Momentum {
                q: q0.to_vec(),
                p: p0.to_vec(),
            },
        );
        hs.push(h);
        errs.push(((q[0] - qe[0]).powi(2) + (q[1] - qe[1]).powi(2)).sqrt());
    }
    let order = fit_order(&hs, &errs);
    assert!((order - 2.0).abs() < 0.1, "midpoint order {order}");
}
