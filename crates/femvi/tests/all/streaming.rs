//! Streaming diagnostics: the sliding-window trajectory and the element-by-element L² sum give
//! the very numbers of the whole recorded trajectory (bit for bit), and the time reversal of
//! `diagnostics::check`, which no longer stores the steps, still retraces uniform grids with a
//! shortened last step, lists of steps and single steps to round-off.

use femvi::diagnostics::{check, L2Sum, PiecewiseTrajectory};
use femvi::{models, Element, Integrator, Method, SolverOptions, Start, TimeGrid};

fn kepler_run(h: f64, end: f64, el: &Element) -> (Vec<f64>, PiecewiseTrajectory) {
    let lag = models::kepler(1.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.5, 0.0],
        p: vec![0.0, 1.7],
    };
    let grid = TimeGrid::uniform(0.0, h, end).unwrap();
    let mut it = Integrator::new(&lag, el, grid, start, SolverOptions::default()).unwrap();
    let all = PiecewiseTrajectory::record(&mut it, &el.basis, 2).unwrap();
    let times = (0..2000).map(|i| i as f64 * end / 1999.0).collect();
    (times, all)
}

/// A window that forgets what lies before each query evaluates like the whole trajectory, and
/// holds only a few elements.
#[test]
fn window_evaluates_like_the_whole_trajectory() {
    let el = Element::with_order(6).unwrap();
    let (times, all) = kepler_run(0.01, 7.0, &el);
    let lag = models::kepler(1.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.5, 0.0],
        p: vec![0.0, 1.7],
    };
    let grid = TimeGrid::uniform(0.0, 0.01, 7.0).unwrap();
    let mut it = Integrator::new(&lag, &el, grid, start, SolverOptions::default()).unwrap();
    let mut window = PiecewiseTrajectory::new(&el.basis, 2);
    let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
    let mut next = 0;
    let mut most = 0;
    loop {
        let more = it.step().unwrap();
        if let Some(e) = it.last_element() {
            if more {
                window.push(&e).unwrap();
            }
        }
        let covered = window.last_start().unwrap_or(f64::NEG_INFINITY);
        // Answer the queries the window now covers (all of them at the end).
        while next < times.len() && (times[next] < covered || !more) {
            window.eval(times[next], &mut a);
            all.eval(times[next], &mut b);
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "t = {}", times[next]);
            window.forget_before(times[next]);
            next += 1;
        }
        most = most.max(window.len());
        if !more {
            break;
        }
    }
    assert_eq!(next, times.len());
    assert_eq!(all.len(), 700);
    assert!(most < 20, "the window held {most} elements");
}

/// The L² sum element by element is the whole trajectory's `l2_distance`, bit for bit.
#[test]
fn l2_sum_is_the_recorded_distance() {
    let el = Element::with_order(4).unwrap();
    let (_, coarse) = kepler_run(0.05, 5.0, &el);
    let fine_el = Element::with_order(8).unwrap();
    let (_, fine) = kepler_run(0.0125, 5.0, &fine_el);
    let reference = |t: f64, out: &mut [f64]| fine.eval(t, out);
    let want = coarse.l2_distance(5, reference);
    // The same sums from the elements one by one.
    let lag = models::kepler(1.0).unwrap();
    let start = Start::Momentum {
        q: vec![0.5, 0.0],
        p: vec![0.0, 1.7],
    };
    let grid = TimeGrid::uniform(0.0, 0.05, 5.0).unwrap();
    let mut it = Integrator::new(&lag, &el, grid, start, SolverOptions::default()).unwrap();
    let mut sum = L2Sum::new(5, 2);
    while it.step().unwrap() {
        let e = it.last_element().unwrap();
        let nodes: Vec<f64> = (0..el.basis.len())
            .flat_map(|j| (0..2).map(move |c| (j, c)))
            .map(|(j, c)| e.base[c] + e.incr[j * 2 + c])
            .collect();
        sum.add(&el.basis, e.t, e.h, &nodes, reference);
    }
    assert_eq!(sum.value().to_bits(), want.to_bits());
    // A distance that measures something: order 4 against order 8, h = 0.05.
    assert!(want > 1e-9 && want < 1e-4, "{want:e}");
}

fn reversal(grid: TimeGrid, el: &Element, method: Method) -> Option<f64> {
    let lag = models::pendulum(1.0, 1.0, 1.0).unwrap();
    let start = Start::Velocity {
        q: vec![1.2],
        v: vec![0.3],
    };
    let options = SolverOptions {
        method,
        ..SolverOptions::default()
    };
    check(&lag, el, grid, start, options, None, &[])
        .unwrap()
        .time_reversal_error
}

/// The reverse run takes the forward steps backwards: with a shortened last step, with a
/// cyclic list of very different steps (also a list cut short), with a single step; explicit,
/// fixed-point and Newton.
#[test]
fn time_reversal_retraces_every_kind_of_grid() {
    let verlet = Element::galerkin(1, femvi::NodeFamily::Equispaced, femvi::QuadratureKind::Trapezoid).unwrap();
    let gauss = Element::with_order(6).unwrap();
    for (el, method) in [
        (&verlet, Method::Auto),
        (&gauss, Method::FixedPoint),
        (&gauss, Method::Newton),
    ] {
        let grids = [
            TimeGrid::uniform(0.0, 0.1, 10.05).unwrap(),
            TimeGrid::steps(0.0, vec![0.3, 0.01, 0.12], 10.0).unwrap(),
            TimeGrid::steps(0.0, vec![0.3, 0.01, 0.12], 0.31).unwrap(),
            TimeGrid::uniform(0.0, 0.25, 0.2).unwrap(),
        ];
        for grid in grids {
            let label = format!("{grid:?} {method:?}");
            let e = reversal(grid, el, method).unwrap();
            assert!(e < 1e-11, "{label}: {e:e}");
        }
    }
}
