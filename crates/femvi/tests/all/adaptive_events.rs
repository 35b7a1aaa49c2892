//! Events in adaptive runs (issue 21, item 2): pericentre and apocentre passages of an
//! eccentric Kepler orbit located on the dense output in fictitious time, against the closed
//! form (period 2π for a = 1: pericentre at t = 2πk, apocentre at t = π(2k − 1)); a stopping
//! event; events past the physical end time left out.

use femvi::adaptive::{solve_adaptive, AdaptiveOptions, AdaptiveSolution, KeplerMonitor};
use femvi::solution::{Direction, Event};
use femvi::{models, Element, Problem, Start};
use std::f64::consts::PI;

const E: f64 = 0.9;

fn run(order: usize, ds: f64, t_end: f64, stop_at_apocentre: bool) -> AdaptiveSolution {
    let start = Start::Momentum {
        q: vec![1.0 - E, 0.0],
        p: vec![0.0, ((1.0 + E) / (1.0 - E)).sqrt()],
    };
    let problem = Problem::new(models::kepler(1.0).unwrap(), start, 0.0, t_end);
    let options = AdaptiveOptions {
        every: 0,
        events: vec![
            Event::new("pericentre", |_, q, _| q[1]).direction(Direction::Rising),
            Event::new("apocentre", |_, q, _| q[1])
                .direction(Direction::Falling)
                .stop(stop_at_apocentre),
        ],
        ..AdaptiveOptions::step(ds)
    };
    let sol = solve_adaptive(&problem, KeplerMonitor, &Element::with_order(order).unwrap(), &options).unwrap();
    assert!(sol.error.is_none(), "{:?}", sol.error);
    sol
}

/// The largest error of the event times and positions against the closed form.
fn event_errors(sol: &AdaptiveSolution) -> (f64, f64) {
    let (mut dt, mut dq) = (0.0f64, 0.0f64);
    let mut count = [0usize; 2];
    for ev in &sol.events {
        count[ev.event] += 1;
        let k = count[ev.event] as f64;
        let (t, x) = if ev.event == 0 {
            (2.0 * PI * k, 1.0 - E)
        } else {
            (PI * (2.0 * k - 1.0), -(1.0 + E))
        };
        dt = dt.max((ev.t - t).abs());
        dq = dq.max((ev.q[0] - x).abs()).max(ev.q[1].abs());
    }
    (dt, dq)
}

#[test]
fn pericentre_and_apocentre_passages_match_the_closed_form() {
    // 5.5 half-periods... 2.75 periods: pericentres at 2π, 4π, apocentres at π, 3π, 5π; the
    // last step overshoots t_end = 5.5π but its events are outside the span.
    let sol = run(8, 0.05, 5.5 * PI, false);
    let kinds: Vec<usize> = sol.events.iter().map(|e| e.event).collect();
    assert_eq!(kinds, vec![1, 0, 1, 0, 1]);
    assert!(sol.events.iter().all(|e| e.t <= 5.5 * PI));
    let (dt, dq) = event_errors(&sol);
    println!("order 8, ds 0.05: event times {dt:.2e}, positions {dq:.2e}");
    assert!(dt <= 1e-8 && dq <= 1e-8, "{dt:e} {dq:e}");
    // The momentum there is the physical one: at apocentre p = (0, −√((1 − e)/(1 + e))).
    let apo = &sol.events[0];
    assert!((apo.p[1] + ((1.0 - E) / (1.0 + E)).sqrt()).abs() <= 1e-7 && apo.p[0].abs() <= 1e-7);
    assert!((apo.v[1] - apo.p[1]).abs() <= 1e-7, "v = p for unit mass");
}

#[test]
fn event_errors_shrink_with_the_fictitious_step() {
    // Degree 2 (order 4): the event time error falls at least like ds^3 (q_h is of order
    // s + 1 = 3 between nodes; the nodes themselves are of order 4).
    let errs: Vec<f64> = [0.1, 0.05, 0.025]
        .iter()
        .map(|&ds| event_errors(&run(4, ds, 4.5 * PI, false)).0)
        .collect();
    println!("order 4, event time errors for ds = 0.1, 0.05, 0.025: {errs:?}");
    for w in errs.windows(2) {
        assert!(w[1] <= w[0] / 6.0, "{errs:?}");
    }
}

#[test]
fn a_stopping_event_ends_the_run_at_its_step() {
    let sol = run(6, 0.05, 10.0 * PI, true);
    assert!(sol.stopped);
    assert_eq!(sol.events.len(), 1);
    let ev = &sol.events[0];
    assert!((ev.t - PI).abs() <= 1e-7, "{}", ev.t);
    // The run ends at the end of the step that holds the event: its last node is past t = π,
    // by less than one physical step there (g = r^{3/2} ≈ 2.6 at apocentre, ds = 0.05).
    let last = *sol.t.last().unwrap();
    assert!(last >= ev.t && last - ev.t <= 0.05 * 1.9f64.powf(1.5) * 1.01, "{last}");
}
