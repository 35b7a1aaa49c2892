//! The solve API: dense output orders against the closed form, `saveat` against the dense
//! output (bit for bit, and the nodes at node times), events against an independent
//! computation (a Hénon–Heiles Poincaré section located by Hénon's trick on a fine RK4 run),
//! `every`, `max_steps`, stopping events, and the prefix kept after a failure.

mod energy_nodes;
use crate::common::{fit_order, Errs};
use femvi::solution::{Direction, Event};
use femvi::{models, solve, Element, Problem, SolveOptions, Start, StepFailure};

fn harmonic_problem(t_end: f64) -> Problem<femvi::Mechanical<models::HarmonicPotential>> {
    let start = Start::Velocity {
        q: vec![1.0],
        v: vec![0.0],
    };
    Problem::new(models::harmonic(1.0, 1.0).unwrap(), start, 0.0, t_end)
}

#[test]
fn dense_output_has_order_s_plus_1_in_q_and_s_in_v() {
    for s in 1..=4usize {
        let element = Element::with_order(2 * s).unwrap();
        let (mut hs, mut eq, mut ev) = (vec![], vec![], vec![]);
        for h in [0.2, 0.1, 0.05, 0.025] {
            let options = SolveOptions {
                dense: true,
                ..SolveOptions::step(h)
            };
            let sol = solve(&harmonic_problem(2.0), &element, &options).unwrap();
            let dense = sol.dense.unwrap();
            let (mut q, mut v) = ([0.0], [0.0]);
            let (mut wq, mut wv) = (0.0f64, 0.0f64);
            let elements = (2.0 / h).round() as usize;
            for k in 0..elements {
                for j in 1..=7 {
                    let t = h * (k as f64 + j as f64 / 8.0);
                    dense.state_at(t, &mut q, &mut v).unwrap();
                    wq = wq.max((q[0] - t.cos()).abs());
                    wv = wv.max((v[0] + t.sin()).abs());
                }
            }
            hs.push(h);
            eq.push(wq);
            ev.push(wv);
        }
        let (oq, ov) = (fit_order(&hs, &eq), fit_order(&hs, &ev));
        eprintln!(
            "dense s={s}: q errors {} order {oq:.3}; v errors {} order {ov:.3}",
            Errs(&eq),
            Errs(&ev)
        );
        assert!((oq - (s as f64 + 1.0)).abs() < 0.3, "s={s}: q order {oq}");
        assert!((ov - s as f64).abs() < 0.3, "s={s}: v order {ov}");
    }
}

#[test]
fn saveat_equals_the_dense_output_and_the_nodes_at_node_times() {
    let element = Element::with_order(6).unwrap();
    let h = 0.1;
    // Node times (k h computed as the grid computes them) and times between nodes.
    let node_times: Vec<f64> = (0..=30).step_by(3).map(|k| k as f64 * h).collect();
    let mut saveat: Vec<f64> = node_times.clone();
    saveat.extend((0..30).map(|k| (k as f64 + 0.37) * h));
    saveat.sort_by(f64::total_cmp);
    let options = SolveOptions {
        dense: true,
        saveat: saveat.clone(),
        ..SolveOptions::step(h)
    };
    let problem = harmonic_problem(3.0);
    let sol = solve(&problem, &element, &options).unwrap();
    assert_eq!(sol.saved.t, saveat);
    let dense = sol.dense.clone().unwrap();
    let (mut q, mut v, mut p) = ([0.0], [0.0], [0.0]);
    let mut at_nodes = 0;
    for (i, &t) in saveat.iter().enumerate() {
        dense.state_at(t, &mut q, &mut v).unwrap();
        dense.p_at(&problem.lagrangian, t, &mut p).unwrap();
        assert_eq!(q[0].to_bits(), sol.saved.q[i].to_bits(), "q at {t}");
        assert_eq!(v[0].to_bits(), sol.saved.v[i].to_bits(), "v at {t}");
        assert_eq!(p[0].to_bits(), sol.saved.p[i].to_bits(), "p at {t}");
        if let Some(j) = sol.t.iter().position(|&tk| tk == t) {
            at_nodes += 1;
            assert_eq!(sol.q[j].to_bits(), sol.saved.q[i].to_bits(), "node q at {t}");
            assert_eq!(sol.p[j].to_bits(), sol.saved.p[i].to_bits(), "node p at {t}");
            assert_eq!(sol.v[j].to_bits(), sol.saved.v[i].to_bits(), "node v at {t}");
        }
    }
    assert!(at_nodes >= 10, "{at_nodes} saveat times fell on nodes");
}

/// Hénon–Heiles: ż = f(z) for z = (x, y, px, py).
fn hh(z: [f64; 4]) -> [f64; 4] {
    let [x, y, px, py] = z;
    [px, py, -x - 2.0 * x * y, -y - x * x + y * y]
}

fn rk4(z: [f64; 4], h: f64, f: impl Fn([f64; 4]) -> [f64; 4]) -> [f64; 4] {
    let add = |a: [f64; 4], b: [f64; 4], c: f64| std::array::from_fn(|i| a[i] + c * b[i]);
    let k1 = f(z);
    let k2 = f(add(z, k1, 0.5 * h));
    let k3 = f(add(z, k2, 0.5 * h));
    let k4 = f(add(z, k3, h));
    std::array::from_fn(|i| z[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

/// The section y = 0, p_y > 0 by RK4 with step h and Hénon's trick at each crossing (one RK4
/// step in y as the independent variable, from y_k to 0): (t, x, p_x) per crossing.
fn henon_section(z0: [f64; 4], t_end: f64, h: f64) -> Vec<[f64; 3]> {
    let mut out = vec![];
    let mut z = z0;
    // t is carried as a fifth variable in Hénon's step: dt/dy = 1/ẏ.
    let in_y = |w: [f64; 5]| -> [f64; 5] {
        let d = hh([w[0], w[1], w[2], w[3]]);
        let py = w[3];
        [d[0] / py, 1.0, d[2] / py, d[3] / py, 1.0 / py]
    };
    let steps = (t_end / h).round() as usize;
    for k in 0..steps {
        // The time as k h, not a running sum (whose rounding drifts by ~1e-10 over 4e5 steps).
        let t = k as f64 * h;
        let next = rk4(z, h, hh);
        if z[1] < 0.0 && next[1] >= 0.0 {
            let w = [z[0], z[1], z[2], z[3], t];
            let dy = -z[1];
            let add = |a: [f64; 5], b: [f64; 5], c: f64| -> [f64; 5] { std::array::from_fn(|i| a[i] + c * b[i]) };
            let k1 = in_y(w);
            let k2 = in_y(add(w, k1, 0.5 * dy));
            let k3 = in_y(add(w, k2, 0.5 * dy));
            let k4 = in_y(add(w, k3, dy));
            let c: [f64; 5] = std::array::from_fn(|i| w[i] + dy / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
            out.push([c[4], c[0], c[2]]);
        }
        z = next;
    }
    out
}

#[test]
fn poincare_section_of_henon_heiles_agrees_with_henons_trick() {
    // E = 1/8 on a regular orbit: x = 0.1, y = 0, p_x = 0, p_y from the energy.
    let (x0, px0) = (0.1f64, 0.0f64);
    let py0 = (2.0 * 0.125 - px0 * px0 - x0 * x0).sqrt();
    let t_end = 100.0;
    let reference = henon_section([x0, 0.0, px0, py0], t_end, 2.5e-4);
    let start = Start::Momentum {
        q: vec![x0, 0.0],
        p: vec![px0, py0],
    };
    let problem = Problem::new(models::henon_heiles(), start, 0.0, t_end);
    let section = Event::new("y = 0", |_t, q, _v| q[1]).direction(Direction::Rising);
    let options = SolveOptions {
        every: 0,
        events: vec![section],
        ..SolveOptions::step(0.02)
    };
    let sol = solve(&problem, &Element::with_order(16).unwrap(), &options).unwrap();
    assert!(sol.error.is_none());
    // The start lies on the section with y = 0 exactly: Hénon's loop starts at y = 0 and does
    // not count it (y < 0 is needed before), femvi's does not either (g(t0) = 0).
    assert_eq!(sol.events.len(), reference.len(), "crossings");
    assert!(reference.len() >= 10, "{} crossings", reference.len());
    let mut worst = 0.0f64;
    for (e, r) in sol.events.iter().zip(&reference) {
        assert!(e.v[1] > 0.0, "rising");
        worst = worst
            .max((e.t - r[0]).abs())
            .max((e.q[0] - r[1]).abs())
            .max((e.p[0] - r[2]).abs());
    }
    eprintln!("section: {} crossings, worst difference {worst:.2e}", reference.len());
    if std::env::var_os("FEMVI_SECTION_DEBUG").is_some() {
        let finer = henon_section([x0, 0.0, px0, py0], t_end, 1.25e-4);
        for ((e, r), f) in sol.events.iter().zip(&reference).zip(&finer) {
            eprintln!(
                "t {:.3e} {:.3e}  x {:.3e} {:.3e}  px {:.3e} {:.3e}",
                e.t - r[0],
                f[0] - r[0],
                e.q[0] - r[1],
                f[1] - r[1],
                e.p[0] - r[2],
                f[2] - r[2]
            );
        }
    }
    assert!(worst <= 1e-10, "worst difference {worst:e}");
}

#[test]
fn every_max_steps_and_stopping_events() {
    let element = Element::with_order(4).unwrap();
    let every = SolveOptions {
        every: 7,
        ..SolveOptions::step(0.1)
    };
    let sol = solve(&harmonic_problem(3.0), &element, &every).unwrap();
    // Nodes 0, 7, 14, 21, 28 and the last (30).
    assert_eq!(sol.step, vec![0, 7, 14, 21, 28, 30]);
    assert_eq!(sol.q.len(), 6);
    let limited = SolveOptions {
        max_steps: Some(12),
        ..SolveOptions::step(0.1)
    };
    let sol = solve(&harmonic_problem(3.0), &element, &limited).unwrap();
    assert!(sol.stopped && sol.error.is_none());
    assert_eq!((sol.steps, *sol.step.last().unwrap()), (12, 12));
    // x = cos t falls through zero at π/2: stop there.
    let stop = SolveOptions {
        events: vec![Event::new("x = 0", |_t, q, _v| q[0]).stop(true)],
        ..SolveOptions::step(0.1)
    };
    // Degree 4: the interpolant's error is below h^5/5! max|x^(5)| = 8e-8.
    let sol = solve(&harmonic_problem(3.0), &Element::with_order(8).unwrap(), &stop).unwrap();
    assert!(sol.stopped);
    assert_eq!(sol.events.len(), 1);
    assert!((sol.events[0].t - std::f64::consts::FRAC_PI_2).abs() < 1e-6);
    assert!(*sol.t.last().unwrap() < 1.7 && *sol.t.last().unwrap() >= sol.events[0].t);
}

#[test]
fn a_failed_run_keeps_what_it_computed() {
    // Verlet is unstable for the harmonic oscillator at h > 2: |q| grows until q² overflows
    // (the energy is infinite while q is still finite), then q itself. With the energy
    // tracked at every node the run ends at the first infinite energy; the solution holds the
    // nodes before it, all finite, as `femvi run` writes them.
    let element = Element::galerkin(1, femvi::NodeFamily::Equispaced, femvi::QuadratureKind::Trapezoid).unwrap();
    let sol = solve(&harmonic_problem(1e4), &element, &SolveOptions::step(2.5)).unwrap();
    let Some(femvi::Error::NonFiniteEnergy { step, .. }) = sol.error else {
        panic!("expected a non-finite energy, got {:?}", sol.error)
    };
    assert_eq!(step, sol.steps);
    // Every node before it is kept (every = 1), and the infinite energy is in neither the
    // arrays nor the report.
    assert!(step > 10 && sol.len() == step && *sol.step.last().unwrap() == step - 1);
    assert!(sol.q.iter().chain(&sol.p).chain(&sol.energy).all(|x| x.is_finite()));
    let report = sol.energy_report.as_ref().unwrap();
    let e0 = sol.energy[0];
    let largest = sol.energy.iter().fold(0.0f64, |m, e| m.max((e - e0).abs())) / e0.abs();
    assert_eq!(report.max_rel_error, largest);
    // Without energy tracking and only node 0 kept before the end, no energy is computed
    // on the way: the step that overflows q is the error, and the nodes kept are finite.
    let sparse = SolveOptions {
        every: 100_000,
        track_energy: false,
        ..SolveOptions::step(2.5)
    };
    let sol = solve(&harmonic_problem(1e4), &element, &sparse).unwrap();
    let Some(femvi::Error::Step(e)) = &sol.error else {
        panic!("expected a step error, got {:?}", sol.error)
    };
    assert_eq!(e.failure, StepFailure::NonFinite);
    assert!(e.step > step, "{} {step}", e.step);
    assert!(sol.q.iter().chain(&sol.p).chain(&sol.energy).all(|x| x.is_finite()));
}

#[test]
fn an_owned_integrator_runs_on_another_thread_with_the_same_numbers() {
    let make_start = || Start::Velocity {
        q: vec![0.4, 0.0],
        v: vec![0.0, 2.0],
    };
    let grid = || femvi::TimeGrid::uniform(0.0, 0.01, 10.0).unwrap();
    let (kep, el) = (models::kepler(1.0).unwrap(), Element::with_order(6).unwrap());
    let mut borrowed = femvi::Integrator::new(&kep, &el, grid(), make_start(), Default::default()).unwrap();
    while borrowed.step().unwrap() {}
    let mut owned = femvi::Integrator::owned(
        models::kepler(1.0).unwrap(),
        Element::with_order(6).unwrap(),
        grid(),
        make_start(),
        Default::default(),
    )
    .unwrap();
    let (q, p) = std::thread::spawn(move || {
        while owned.step().unwrap() {}
        (owned.node().q.to_vec(), owned.node().p.to_vec())
    })
    .join()
    .unwrap();
    assert_eq!(q, borrowed.node().q);
    assert_eq!(p, borrowed.node().p);
}

/// The energy report sees every node, whatever is kept: against H = |p|²/2 − 1/|q| computed
/// here from the nodes (Kepler, e = 0.5), and the same report when only every 7th node is kept.
#[test]
fn the_energy_report_covers_every_node() {
    let element = Element::with_order(2).unwrap();
    let start = Start::Momentum {
        q: vec![0.5, 0.0],
        p: vec![0.0, 3f64.sqrt()],
    };
    let problem = Problem::new(models::kepler(1.0).unwrap(), start, 0.0, 30.0);
    let all = solve(&problem, &element, &SolveOptions::step(0.05)).unwrap();
    let h = |q: &[f64], p: &[f64]| 0.5 * (p[0] * p[0] + p[1] * p[1]) - 1.0 / q[0].hypot(q[1]);
    let h0 = h(&[0.5, 0.0], &[0.0, 3f64.sqrt()]);
    let by_hand = all
        .q
        .chunks(2)
        .zip(all.p.chunks(2))
        .map(|(q, p)| ((h(q, p) - h0) / h0).abs())
        .fold(0.0f64, f64::max);
    let report = all.energy_report.unwrap();
    eprintln!(
        "Kepler h = 0.05: max rel energy error {:.3e} (by hand {by_hand:.3e})",
        report.max_rel_error
    );
    assert!(report.max_rel_error > 1e-4, "h = 0.05 has a visible energy error");
    assert!((report.max_rel_error - by_hand).abs() <= 1e-12 * by_hand);
    assert_eq!(report.max_rel_balance, None);
    let sparse = SolveOptions {
        every: 7,
        ..SolveOptions::step(0.05)
    };
    let kept = solve(&problem, &element, &sparse).unwrap();
    assert_eq!(kept.energy_report, Some(report));
    let untracked = SolveOptions {
        track_energy: false,
        ..sparse
    };
    let plain = solve(&problem, &element, &untracked).unwrap();
    assert_eq!(plain.energy_report, None);
    assert_eq!(plain.energy, kept.energy);
}
