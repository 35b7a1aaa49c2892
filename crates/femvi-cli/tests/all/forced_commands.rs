//! `femvi convergence` and `femvi ensemble` of a problem with `[forces]` (issue 33): both drive
//! the forced integrator (`Integrator::with_force`) as `femvi run` does. The damped oscillator
//! x'' + c x' + k x = 0 (examples/forces/damped-oscillator.toml: k = 1, c = 0.3, degree 2 with
//! 2-point Gauss, order 4) has the closed form x = x0 e^{-ct/2} (cos wt + c/(2w) sin wt),
//! w² = k − c²/4, from (x0, 0).

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn damped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/forces/damped-oscillator.toml")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

/// `femvi ARGS… FILE --out OUT`, finished.
fn femvi_on(args: &[&str], file: &Path, out: &Path) -> std::process::Output {
    femvi().args(args).arg(file).arg("--out").arg(out).output().unwrap()
}

/// summary.json of `femvi run FILE --quiet --set S…` into `out`.
fn single_run(file: &Path, set: &[String], out: &Path) -> serde_json::Value {
    let mut cmd = femvi();
    cmd.arg("run").arg(file).arg("--quiet").arg("--out").arg(out);
    for s in set {
        cmd.arg("--set").arg(s);
    }
    cmd.assert().success();
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
}

/// The `--set` overrides of a start: the end time, q and the second half (`v` or `p`).
fn start_set(end: &str, start: &[f64], second: &str) -> Vec<String> {
    let n = start.len() / 2;
    vec![
        format!("time.end={end}"),
        format!("initial.q=[{}]", row_of(&start[..n])),
        format!("initial.{second}=[{}]", row_of(&start[n..])),
    ]
}

/// The closed form (x, ẋ) from (x0, 0) at t.
fn exact(x0: f64, t: f64) -> (f64, f64) {
    let (k, c) = (1.0f64, 0.3f64);
    let w = (k - c * c / 4.0).sqrt();
    let e = (-c * t / 2.0).exp();
    let x = x0 * e * ((w * t).cos() + c / (2.0 * w) * (w * t).sin());
    // ẋ = −x0 e^{-ct/2} (w + c²/(4w)) sin wt = −x0 k/w e^{-ct/2} sin wt.
    let v = -x0 * k / w * e * (w * t).sin();
    (x, v)
}

#[test]
fn convergence_of_a_forced_run_has_the_order_of_the_element() {
    let dir = tempfile::tempdir().unwrap();
    let out = femvi_on(
        &[
            "convergence",
            "--set",
            "time.end=10",
            "--steps",
            "0.4,0.2,0.1,0.05",
            "--json",
        ],
        &damped(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let order = study["order"].as_f64().unwrap();
    assert!((3.8..=4.3).contains(&order), "order {order}");
    // The reference is a forced run too: the unforced closed form is not offered.
    assert!(study["reference"].as_str().unwrap().starts_with("galerkin degree 4"));
    let refused = femvi_on(
        &[
            "convergence",
            "--set",
            "time.end=10",
            "--steps",
            "0.2,0.1",
            "--reference",
            "exact",
        ],
        &damped(),
        dir.path(),
    );
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("no closed form"));
}

#[test]
fn ensemble_members_of_a_forced_problem_are_single_runs_and_meet_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let states = dir.path().join("states.csv");
    std::fs::write(&states, "x,v_x\n1.0,0.0\n0.5,0.0\n").unwrap();
    let out = dir.path().join("ensemble");
    let states = states.to_string_lossy();
    let ran = femvi_on(
        &[
            "ensemble",
            "--set",
            "time.end=10",
            "--quiet",
            "--velocity",
            "--states",
            &states,
        ],
        &damped(),
        &out,
    );
    assert!(ran.status.success(), "{}", String::from_utf8_lossy(&ran.stderr));
    let mut r = csv::Reader::from_path(out.join("ensemble.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(
        header,
        ["member", "final_t", "x", "p_x", "energy_error", "steps", "error"]
    );
    let rows: Vec<Vec<String>> = r
        .records()
        .map(|x| x.unwrap().iter().map(String::from).collect())
        .collect();
    let num = |row: &[String], i: usize| row[i].parse::<f64>().unwrap();
    for (row, x0) in rows.iter().zip([1.0, 0.5]) {
        assert_eq!(num(row, 1), 10.0);
        let (x, v) = exact(x0, 10.0);
        // p = ẋ for L = ½ẋ² − ½kx².
        assert!((num(row, 2) - x).abs() <= 1e-6 * x0, "{row:?}");
        assert!((num(row, 3) - v).abs() <= 1e-6 * x0, "{row:?}");
        // The energy balance H − H0 = W, not the energy (which decays by ~95 %).
        assert!(num(row, 4) < 1e-6, "{row:?}");
    }
    // Member 0 is the file's own start: `femvi run`'s final node and balance, bit for bit.
    let s = single_run(&damped(), &["time.end=10".into()], &dir.path().join("single"));
    assert_eq!(num(&rows[0], 2).to_bits(), s["final_q"][0].as_f64().unwrap().to_bits());
    assert_eq!(num(&rows[0], 3).to_bits(), s["final_p"][0].as_f64().unwrap().to_bits());
    let balance = s["max_rel_energy_balance_error"].as_f64().unwrap();
    assert_eq!(num(&rows[0], 4).to_bits(), balance.to_bits());
}

fn sphere() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/constrained/spherical-pendulum.toml")
}

#[test]
fn convergence_of_a_constrained_run_has_the_order_of_the_element() {
    // The spherical pendulum at degree 2 (order 4 on the manifold, docs/src/constraints.md);
    // the reference is the constrained run at degree 4 and a quarter of the finest step.
    let dir = tempfile::tempdir().unwrap();
    let out = femvi_on(
        &[
            "convergence",
            "--set",
            "time.end=2",
            "--steps",
            "0.08,0.04,0.02,0.01",
            "--json",
        ],
        &sphere(),
        dir.path(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let order = study["order"].as_f64().unwrap();
    assert!((3.8..=4.3).contains(&order), "order {order}");
    // --l2 sums the runs' constrained element polynomials against the reference's (issue 33:
    // the constrained run is the one integrator): the L² error of degree-s elements falls like
    // h^(s+1), order 3 here, while the nodes keep order 4.
    let l2 = femvi_on(
        &[
            "convergence",
            "--set",
            "time.end=2",
            "--steps",
            "0.08,0.04,0.02,0.01",
            "--l2",
            "--json",
        ],
        &sphere(),
        dir.path(),
    );
    assert!(l2.status.success(), "{}", String::from_utf8_lossy(&l2.stderr));
    let study: serde_json::Value = serde_json::from_slice(&l2.stdout).unwrap();
    let (nodal, l2_order) = (study["order"].as_f64().unwrap(), study["l2_order"].as_f64().unwrap());
    assert!(
        (3.8..=4.3).contains(&nodal) && (2.8..=3.3).contains(&l2_order),
        "{nodal} {l2_order}"
    );
}

#[test]
fn ensemble_members_of_a_constrained_problem_are_single_runs_on_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let states = dir.path().join("states.csv");
    // The file's start, and a start at 60° from the vertical moving along y.
    let (s, c) = (60f64.to_radians().sin(), 60f64.to_radians().cos());
    let second = [s, 0.0, -c, 0.0, 2.0, 0.0];
    let row = |r: &[f64]| r.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(",");
    let first = [
        0.8414709848078965,
        0.0,
        -0.5403023058681398,
        0.0,
        1.682941969615793,
        0.0,
    ];
    std::fs::write(&states, format!("{}\n{}\n", row(&first), row(&second))).unwrap();
    let out = dir.path().join("ensemble");
    let states = states.to_string_lossy();
    let ran = femvi_on(
        &[
            "ensemble",
            "--set",
            "time.end=2",
            "--quiet",
            "--velocity",
            "--states",
            &states,
        ],
        &sphere(),
        &out,
    );
    assert!(ran.status.success(), "{}", String::from_utf8_lossy(&ran.stderr));
    let mut r = csv::Reader::from_path(out.join("ensemble.csv")).unwrap();
    let rows: Vec<Vec<f64>> = r
        .records()
        .map(|x| x.unwrap().iter().take(10).map(|v| v.parse().unwrap()).collect())
        .collect();
    for (i, (row, start)) in rows.iter().zip([first, second]).enumerate() {
        assert_eq!(row[1], 2.0);
        let q = &row[2..5];
        assert!(
            (q.iter().map(|x| x * x).sum::<f64>().sqrt() - 1.0).abs() < 1e-13,
            "{row:?}"
        );
        // The single run from the same start: its final node and energy error, bit for bit.
        let s = single_run(
            &sphere(),
            &start_set("2", &start, "v"),
            &dir.path().join(format!("single{i}")),
        );
        for c in 0..3 {
            assert_eq!(row[2 + c].to_bits(), s["final_q"][c].as_f64().unwrap().to_bits());
            assert_eq!(row[5 + c].to_bits(), s["final_p"][c].as_f64().unwrap().to_bits());
        }
        assert_eq!(row[8].to_bits(), s["max_rel_energy_error"].as_f64().unwrap().to_bits());
    }
}

fn row_of(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(",")
}

#[test]
fn ensemble_members_of_an_adaptive_problem_are_single_runs_on_the_kepler_orbit() {
    // kepler-eccentric.toml (μ = 1, e = 0.9 from pericentre, adaptive steps in s with the
    // Kepler monitor) over two periods; a second member on the circular orbit r = 1.
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/kepler-eccentric.toml");
    let end = 4.0 * std::f64::consts::PI;
    let dir = tempfile::tempdir().unwrap();
    let states = dir.path().join("states.csv");
    let starts = [[0.01, 0.0, 0.0, 14.106735979665885], [1.0, 0.0, 0.0, 1.0]];
    std::fs::write(&states, format!("{}\n{}\n", row_of(&starts[0]), row_of(&starts[1]))).unwrap();
    let out = dir.path().join("ensemble");
    let set_end = format!("time.end={end:?}");
    let states = states.to_string_lossy();
    let ran = femvi_on(
        &["ensemble", "--set", &set_end, "--quiet", "--states", &states],
        &file,
        &out,
    );
    assert!(ran.status.success(), "{}", String::from_utf8_lossy(&ran.stderr));
    let mut r = csv::Reader::from_path(out.join("ensemble.csv")).unwrap();
    let rows: Vec<Vec<f64>> = r
        .records()
        .map(|x| x.unwrap().iter().take(8).map(|v| v.parse().unwrap()).collect())
        .collect();
    for (i, (row, start)) in rows.iter().zip(starts).enumerate() {
        // The closed form (Kepler's equation) at the member's final time.
        let (q, p) =
            femvi::diagnostics::exact::kepler(1.0, 0.0, [start[0], start[1]], [start[2], start[3]], row[1]).unwrap();
        let err = (row[2] - q[0]).hypot(row[3] - q[1]);
        assert!(
            err < 1e-6,
            "member {i}: {err:e} from the closed form; {row:?} vs {q:?} {p:?}"
        );
        // Adaptive runs end on the first node at or past the end time.
        assert!(row[1] >= end && row[1] < end + 0.1, "{row:?}");
        // The single run from the same start: its final node and energy error, bit for bit.
        let s = single_run(
            &file,
            &start_set(&format!("{end:?}"), &start, "p"),
            &dir.path().join(format!("single{i}")),
        );
        for c in 0..2 {
            assert_eq!(
                row[2 + c].to_bits(),
                s["final_q"][c].as_f64().unwrap().to_bits(),
                "member {i}"
            );
            assert_eq!(
                row[4 + c].to_bits(),
                s["final_p"][c].as_f64().unwrap().to_bits(),
                "member {i}"
            );
        }
        assert_eq!(row[6].to_bits(), s["max_rel_energy_error"].as_f64().unwrap().to_bits());
    }
}
