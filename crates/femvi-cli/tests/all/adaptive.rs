//! `[time] mode = "adaptive"` through the binary: physical times in trajectory.csv (nodes
//! with their s, or uniform rows with `output_step`), a Kepler orbit of eccentricity 0.99
//! against its closed form, and bad settings rejected with exit code 2.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

fn rows(dir: &Path) -> (String, Vec<Vec<f64>>) {
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn uniform_physical_times_land_on_the_closed_form() {
    // Ten periods of e = 0.99: after each period the orbit is back at pericentre (0.01, 0).
    let period = 2.0 * std::f64::consts::PI;
    let out = eccentric_run(&[]);
    let (header, rows) = rows(out.path());
    assert_eq!(header, "row,t,x,y,p_x,p_y,energy");
    assert_eq!(rows.len(), 41);
    let mut worst = 0.0f64;
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r[1], i as f64 * (period / 4.0), "row {i}: t is the requested time");
        if i % 4 == 0 {
            worst = worst.max((r[2] - 0.01).abs()).max(r[3].abs());
        }
    }
    println!("adaptive CLI, Kepler e = 0.99, 10 periods: max distance from pericentre at whole periods {worst:.2e}");
    assert!(worst < 1e-8, "{worst:e}");
    // A successful run's summary says so.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["status"], "done");
    assert!(summary["error"].is_null());
}

#[test]
fn nodes_carry_physical_time_and_fictitious_time() {
    let text = r#"
name = "oscillator-adaptive"
[system]
coordinates = ["x"]
parameters = { k = 4.0 }
lagrangian = "0.5*x_dot^2 - 0.5*k*x^2"
[initial]
q = [1.0]
v = [0.0]
[scheme]
order = 4
[time]
mode = "adaptive"
monitor = "1/sqrt(k) + 0*x"
ds = 0.1
end = 3.0
"#;
    let out = tempfile::tempdir().unwrap();
    femvi()
        .args(["run", "-", "--quiet", "--out"])
        .arg(out.path())
        .write_stdin(text)
        .assert()
        .success();
    let (header, rows) = rows(out.path());
    assert_eq!(header, "step,t,x,p_x,energy,s");
    // A constant monitor g = 1/2: t = s/2 (to round-off), and q = cos(2t).
    for r in &rows {
        assert!((r[1] - 0.5 * r[5]).abs() < 1e-12, "{r:?}");
        assert!((r[2] - (2.0 * r[1]).cos()).abs() < 1e-4, "{r:?}");
    }
    let last = rows.last().unwrap();
    assert!(
        last[1] >= 3.0 && last[1] < 3.0 + 0.05 + 1e-12,
        "stops at the first node past the end: {last:?}"
    );
}

#[test]
fn bad_adaptive_settings_are_bad_input() {
    let kepler = examples().join("kepler-eccentric.toml");
    for (key, value, message) in [
        ("time.step", "0.1", "takes `ds`"),
        ("time.ds", "-1.0", "ds"),
        ("time.monitor", "nbody", "n-body"),
        ("time.monitor", "x +", "monitor"),
        ("time.monitor", "z", "unknown symbol"),
        ("time.mode", "fixed", "apply only to mode"),
    ] {
        let out = tempfile::tempdir().unwrap();
        let res = femvi()
            .args(["run", "--quiet", "--set"])
            .arg(format!("{key}={value}"))
            .arg(&kepler)
            .arg("--out")
            .arg(out.path())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&res.stderr);
        assert_eq!(res.status.code(), Some(2), "{key}={value}: {stderr}");
        assert!(stderr.contains(message), "{key}={value}: {stderr}");
    }
}

/// The commands that integrate with fixed steps refuse an adaptive problem (they would run
/// its nominal grid) with exit 2 and a message, instead of a silently different run.
/// (`femvi ensemble` runs adaptive members: `forced_commands.rs`; `femvi check` checks the
/// step map in s: below.)
#[test]
fn fixed_step_commands_refuse_adaptive_problems() {
    let file = examples().join("kepler-eccentric.toml");
    let out = tempfile::tempdir().unwrap();
    let cases: [&[&str]; 2] = [&["convergence", "--steps", "0.1,0.05"], &["chaos"]];
    for args in cases {
        let o = femvi()
            .arg(args[0])
            .arg(&file)
            .args(&args[1..])
            .arg("--out")
            .arg(out.path())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("adaptive"), "{args:?}: {err}");
    }
}

/// `[[events]]` in adaptive mode: pericentre passages of the e = 0.99 orbit (y = 0 rising, at
/// t = 2πk by the closed form) in events.csv and summary.json; a stopping apocentre event;
/// and trajectory.npy equal to trajectory.csv bit for bit.
#[test]
fn adaptive_events_and_npy() {
    let period = 2.0 * std::f64::consts::PI;
    let events = "\n[[events]]\nname = \"pericentre\"\nwhen = \"y\"\ndirection = \"rising\"\n";
    let text = std::fs::read_to_string(examples().join("kepler-eccentric.toml")).unwrap() + events;
    let out = tempfile::tempdir().unwrap();
    femvi()
        .args(["run", "-", "--quiet", "--format", "csv,npy", "--set"])
        .arg(format!("time.end={:?}", 5.5 * period))
        .arg("--out")
        .arg(out.path())
        .write_stdin(text.clone())
        .assert()
        .success();
    let csv = std::fs::read_to_string(out.path().join("events.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), "event,step,t,x,y,p_x,p_y");
    let located: Vec<Vec<String>> = lines.map(|l| l.split(',').map(String::from).collect()).collect();
    assert_eq!(located.len(), 5, "{csv}");
    for (k, r) in located.iter().enumerate() {
        let (t, x, y): (f64, f64, f64) = (r[2].parse().unwrap(), r[3].parse().unwrap(), r[4].parse().unwrap());
        assert_eq!(r[0], "pericentre");
        let dt = (t - (k + 1) as f64 * period).abs();
        assert!(dt < 1e-9 && (x - 0.01).abs() < 1e-9 && y.abs() < 1e-9, "{r:?}: {dt:e}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["events_located"], 5);
    assert!(summary["stopped_by_event"].is_null());
    // The NPY table is the CSV's.
    let (header, values) = rows(out.path());
    let columns = std::fs::read_to_string(out.path().join("columns.txt")).unwrap();
    assert_eq!(
        columns.lines().collect::<Vec<_>>(),
        header.split(',').collect::<Vec<_>>()
    );
    let bytes = std::fs::read(out.path().join("trajectory.npy")).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    let data: Vec<f64> = npy.into_vec().unwrap();
    let flat: Vec<f64> = values.concat();
    assert_eq!(data.len(), flat.len());
    assert!(data.iter().zip(&flat).all(|(a, b)| a.to_bits() == b.to_bits()));
    // A stopping event: the run ends in the step of the first apocentre (t = π).
    let stop = text.replace("direction = \"rising\"", "direction = \"falling\"\nstop = true");
    let out = tempfile::tempdir().unwrap();
    femvi()
        .args(["run", "-", "--quiet", "--out"])
        .arg(out.path())
        .write_stdin(stop)
        .assert()
        .success();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["stopped_by_event"], "pericentre");
    let final_t = summary["final_t"].as_f64().unwrap();
    assert!(
        (std::f64::consts::PI..std::f64::consts::PI + 0.2).contains(&final_t),
        "{final_t}"
    );
}

/// `end = 1e12` with rows at `output_step`: their number is known before the run, so the
/// output estimate refuses it up front, naming `output_step` as the way out (the run used to
/// allocate the 1.6e12 output times first and grow until it was killed).
#[test]
fn an_adaptive_run_with_too_many_output_times_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let clock = std::time::Instant::now();
    let out = femvi()
        .args(["run", "--quiet", "--set", "time.end=1e12", "--out"])
        .arg(dir.path().join("out"))
        .arg(examples().join("kepler-eccentric.toml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("1.592e12 rows") && err.contains("--set time.output_step="),
        "{err}"
    );
    assert!(clock.elapsed().as_secs_f64() < 10.0, "{:?}", clock.elapsed());
    assert!(!dir.path().join("out").exists(), "nothing is written");
    // Within the limit the run goes on as before.
    let ok = femvi()
        .args(["run", "--quiet", "--set", "time.end=62.83185307179586", "--out"])
        .arg(dir.path().join("ok"))
        .arg(examples().join("kepler-eccentric.toml"))
        .output()
        .unwrap();
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
}

/// `femvi check` on an adaptive problem (Kepler, e = 0.9, two periods, order 8): the step map
/// (q, p) ↦ (q, p) in s is symplectic to round-off and retraces itself under time reversal,
/// the angular momentum is kept, and the energy figures are the physical ones of `femvi run`:
/// the same steps and largest energy error, and an energy drift equal to the least-squares
/// slope recomputed here from trajectory.csv.
#[test]
fn check_measures_the_step_map_in_s_and_the_physical_energy() {
    let text = r#"
name = "kepler-adaptive-check"
[system]
model = "kepler"
parameters = { mu = 1.0 }
[initial]
q = [0.1, 0.0]
p = [0.0, 4.358898943540674]
[scheme]
degree = 4
quadrature = "gauss-legendre"
[time]
mode = "adaptive"
ds = 0.1
end = 12.566370614359172
"#;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("problem.toml");
    std::fs::write(&file, text).unwrap();
    let res = femvi().arg("check").arg(&file).arg("--json").output().unwrap();
    assert!(res.status.success(), "{}", String::from_utf8_lossy(&res.stderr));
    let report: serde_json::Value = serde_json::from_slice(&res.stdout).unwrap();
    assert!(report["symplecticity_samples"].as_u64().unwrap() > 10, "{report}");
    assert!(
        report["symplecticity_defect_relative"].as_f64().unwrap() < 1e-12,
        "{report}"
    );
    assert!(report["time_reversal_error"].as_f64().unwrap() < 1e-9, "{report}");
    let drift = report["momentum_drift"].as_object().unwrap();
    assert!(drift.values().all(|d| d.as_f64().unwrap() < 1e-12), "{report}");
    let out = dir.path().join("run");
    femvi()
        .arg("run")
        .arg(&file)
        .arg("--quiet")
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(report["steps"], summary["steps"]);
    assert_eq!(report["final_t"], summary["final_t"]);
    assert_eq!(report["max_rel_energy_error"], summary["max_rel_energy_error"]);
    // The drift: slope of (H − E0)/|E0| against t over the rows, E0 the first row's H (the
    // run's level E0 is H(q0, p0) in double-double; the two differ by an ulp of H).
    let (header, rows) = rows(&out);
    assert!(header.starts_with("step,t,x,y,p_x,p_y,energy"), "{header}");
    let e0 = rows[0][6];
    let m = rows.len() as f64;
    let err = |r: &Vec<f64>| (r[6] - e0) / e0.abs();
    let (st, se) = (
        rows.iter().map(|r| r[1]).sum::<f64>() / m,
        rows.iter().map(err).sum::<f64>() / m,
    );
    let num: f64 = rows.iter().map(|r| (r[1] - st) * (err(r) - se)).sum();
    let den: f64 = rows.iter().map(|r| (r[1] - st) * (r[1] - st)).sum();
    let slope = num / den;
    let reported = report["energy_drift"].as_f64().unwrap();
    assert!(
        (reported - slope).abs() <= 1e-3 * slope.abs() + 1e-17,
        "{reported} vs {slope}"
    );
}

/// Runs `kepler-eccentric.toml` for ten periods with rows every quarter period, with the
/// extra overrides; returns the rows.
fn eccentric_rows(extra: &[&str]) -> Vec<Vec<f64>> {
    rows(eccentric_run(extra).path()).1
}

/// Runs `kepler-eccentric.toml` for ten periods with rows every quarter period, with the
/// extra overrides; returns the output directory.
fn eccentric_run(extra: &[&str]) -> tempfile::TempDir {
    let out = tempfile::tempdir().unwrap();
    let period = 2.0 * std::f64::consts::PI;
    femvi()
        .args(["run", "--quiet", "--set"])
        .arg(format!("time.end={:?}", 10.0 * period))
        .arg("--set")
        .arg(format!("time.output_step={:?}", period / 4.0))
        .args(extra)
        .arg(examples().join("kepler-eccentric.toml"))
        .arg("--out")
        .arg(out.path())
        .assert()
        .success();
    out
}

#[test]
fn the_fixed_point_solver_runs_adaptive_steps_as_full_newton_does() {
    // `[solver] method = "fixed-point"` on a mechanical L: the same step equations solved
    // without Hessians (issue 39), so the rows agree with the default (full Newton) run up to
    // the round-off of ten eccentric orbits, and whole periods land on pericentre as the
    // closed form says.
    let newton = eccentric_rows(&[]);
    let fixed = eccentric_rows(&["--set", "solver.method=\"fixed-point\""]);
    assert_eq!(newton.len(), fixed.len());
    let mut diff = 0.0f64;
    let mut worst = 0.0f64;
    for (i, (a, b)) in newton.iter().zip(&fixed).enumerate() {
        assert_eq!(a[1], b[1], "row {i}: the same requested time");
        for c in 2..6 {
            diff = diff.max((a[c] - b[c]).abs() / (1.0 + a[c].abs()));
        }
        if i % 4 == 0 {
            worst = worst.max((b[2] - 0.01).abs()).max(b[3].abs());
        }
    }
    println!("fixed point against full Newton, 10 periods of e = 0.99: {diff:.2e}; at pericentre {worst:.2e}");
    assert!(diff > 0.0, "another solver gives other bits");
    // The runs differ by a shift along the orbit: at pericentre |dp/dt| = 1/r² = 1e4, so a
    // shift of 1e-12 in t (1.6e-14 of the span) moves p by 1e-8 (measured 2.1e-9).
    assert!(diff < 1e-8, "{diff:e}");
    assert!(worst < 1e-8, "{worst:e}");
}

#[test]
fn the_fixed_point_solver_is_refused_for_a_lagrangian_that_is_not_mechanical() {
    let text = r#"
name = "not-mechanical"
[system]
coordinates = ["x"]
lagrangian = "0.5*x_dot^2*(1 + x^2) - 0.5*x^2"
[initial]
q = [1.0]
v = [0.0]
[scheme]
order = 4
[time]
mode = "adaptive"
monitor = "1 + 0*x"
ds = 0.1
end = 3.0
[solver]
method = "fixed-point"
"#;
    let dir = tempfile::tempdir().unwrap();
    let out = femvi()
        .args(["run", "-", "--quiet", "--out"])
        .arg(dir.path())
        .write_stdin(text)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("fixed-point iteration needs a mechanical Lagrangian"),
        "{err}"
    );
}
