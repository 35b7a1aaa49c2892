//! `femvi chaos`, `convergence` and `ensemble` on problems with rotations (issue 37, item 3):
//! the same commands as for coordinates, through the one integrator of the problem's terms.
//! The convergence study fits the element's nodal order 2s (independently established
//! against the 50-digit reference in the library's `rotations.rs`); a chaos map's axis over a
//! component of the body angular velocity gives, at each point, the one-orbit indicators of
//! the file with that start; an ensemble member is the `femvi run` of its start bit for bit
//! (its body columns too), and a start off SO(3) fails its member alone.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../examples/{name}.toml"))
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The one-orbit indicators of `problem` with `set`, from `femvi chaos --json`.
fn one_orbit(problem: &Path, set: &[&str]) -> serde_json::Value {
    let mut cmd = femvi();
    cmd.arg("chaos").arg(problem).arg("--json");
    for s in set {
        cmd.args(["--set", s]);
    }
    let dir = tempfile::tempdir().unwrap();
    let out = cmd.arg("--out").arg(dir.path()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn convergence_fits_the_nodal_order_on_so3() {
    let dir = tempfile::tempdir().unwrap();
    let out = femvi()
        .arg("convergence")
        .arg(example("rigid/free-body"))
        .args(["--steps", "0.04,0.02,0.01", "--set", "time.end=2.0", "--json", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let fitted = study["order"].as_f64().unwrap();
    // Degree 2: nodal order 4.
    assert!((fitted - 4.0).abs() < 0.1, "fitted order {fitted}");
}

#[test]
fn the_l2_study_follows_the_rotations_on_so3() {
    // The L² error of q_h between nodes is of the interpolation order s + 1 (the paper's
    // (2.33)), with each rotation on its element's path on SO(3).
    let dir = tempfile::tempdir().unwrap();
    for (degree, want) in [(1, 2.0), (2, 3.0)] {
        let out = femvi()
            .arg("convergence")
            .arg(example("rigid/free-body"))
            .args([
                "--steps",
                "0.08,0.04,0.02,0.01",
                "--l2",
                "--set",
                "time.end=2.0",
                "--json",
            ])
            .args(["--set", &format!("scheme.degree={degree}"), "--out"])
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let fitted = study["l2_order"].as_f64().unwrap();
        assert!((fitted - want).abs() < 0.15, "degree {degree}: L2 order {fitted}");
    }
}

#[test]
fn chaos_of_the_free_body_is_regular_and_of_a_tilted_asymmetric_top_chaotic() {
    let free = one_orbit(&example("rigid/free-body"), &["time.end=300.0"]);
    let megno = free["megno"].as_f64().unwrap();
    assert!((megno - 2.0).abs() < 0.3, "free body: <Y> = {megno}");
    // The heavy top with its centre of mass off every principal axis and unequal moments.
    let top = one_orbit(
        &example("models/heavy-top"),
        &[
            "system.parameters.I2=2.0",
            "system.parameters.I3=3.0",
            "system.parameters.chi1=0.3",
            "system.parameters.chi2=0.2",
            "initial.R_w=[0.5, 1.0, 0.3]",
            "time.step=0.01",
            "time.end=400.0",
        ],
    );
    let (megno, lyapunov) = (top["megno"].as_f64().unwrap(), top["lyapunov"].as_f64().unwrap());
    assert!(
        megno > 10.0 && lyapunov > 0.05,
        "top: <Y> = {megno}, lambda = {lyapunov}"
    );
}

#[test]
fn a_map_over_the_body_angular_velocity_is_the_one_orbit_runs() {
    let dir = tempfile::tempdir().unwrap();
    let free = example("rigid/free-body");
    femvi()
        .arg("chaos")
        .arg(&free)
        .args(["--set", "time.end=20.0", "--grid", "R_w3=0.3:0.5:2", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    let map = std::fs::read_to_string(dir.path().join("chaos_map.csv")).unwrap();
    let rows: Vec<Vec<f64>> = map
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    for (row, w3) in rows.iter().zip(["0.3", "0.5"]) {
        let set = format!("initial.R_w=[0.5, 1.0, {w3}]");
        let one = one_orbit(&free, &["time.end=20.0", &set]);
        assert_eq!(
            row[1].to_bits(),
            one["megno"].as_f64().unwrap().to_bits(),
            "R_w3 = {w3}"
        );
        assert_eq!(
            row[2].to_bits(),
            one["lyapunov"].as_f64().unwrap().to_bits(),
            "R_w3 = {w3}"
        );
    }
    // An axis of the body momentum needs a start in momentum.
    let out = femvi()
        .arg("chaos")
        .arg(&free)
        .args(["--grid", "p_R1=0.3:0.5:2", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(2) && err.contains("a p_X axis initial p_X"),
        "{err}"
    );
}

#[test]
fn ensemble_members_are_their_runs_and_a_start_off_so3_fails_alone() {
    let dir = tempfile::tempdir().unwrap();
    let free = example("rigid/free-body");
    // (R, Ṙ = R ŵ) rows: the file's start (R = 1, w = (0.5, 1, 0.3)), and R stretched off SO(3).
    let row = "1,0,0,0,1,0,0,0,1,0,-0.3,1,0.3,0,-0.5,-1,0.5,0";
    let off = "1,0,0,0,1.01,0,0,0,1,0,-0.3,1,0.3,0,-0.5,-1,0.5,0";
    let states = dir.path().join("states.csv");
    std::fs::write(&states, format!("{row}\n{off}\n")).unwrap();
    let out = femvi()
        .arg("ensemble")
        .arg(&free)
        .args(["--set", "time.end=2.0", "--velocity", "--quiet", "--states"])
        .arg(&states)
        .arg("--out")
        .arg(dir.path().join("ensemble"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    femvi()
        .args(["run", "--quiet"])
        .arg(&free)
        .args(["--set", "time.end=2.0", "--out"])
        .arg(dir.path().join("run"))
        .assert()
        .success();
    let summary = json(&dir.path().join("run/summary.json"));
    let table = std::fs::read_to_string(dir.path().join("ensemble/ensemble.csv")).unwrap();
    let lines: Vec<Vec<&str>> = table.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let numbers =
        |v: &serde_json::Value| -> Vec<f64> { v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
    let expected: Vec<f64> = [numbers(&summary["final_q"]), numbers(&summary["final_p"])].concat();
    let member: Vec<f64> = lines[0][2..20].iter().map(|x| x.parse().unwrap()).collect();
    assert_eq!(member.len(), 18);
    for (a, b) in member.iter().zip(&expected) {
        assert_eq!(a.to_bits(), b.to_bits(), "member 0 against femvi run");
    }
    assert!(lines[1].last().unwrap().contains("not a rotation"), "{:?}", lines[1]);
    // The body columns (R_w1 … p_R3) are those of the run's last trajectory row, which
    // `femvi run` computes on its own path (the recorder's rows).
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let traj = std::fs::read_to_string(dir.path().join("run/trajectory.csv")).unwrap();
    let run_header: Vec<&str> = traj.lines().next().unwrap().split(',').collect();
    let last: Vec<&str> = traj.lines().last().unwrap().split(',').collect();
    let t = run_header.iter().position(|h| *h == "t").unwrap();
    assert_eq!(last[t].parse::<f64>().unwrap(), 2.0, "the run's last row is at t = 2");
    let body = ["R_w1", "R_w2", "R_w3", "p_R1", "p_R2", "p_R3"];
    for name in body {
        let (e, r) = (
            header.iter().position(|h| *h == name).expect(name),
            run_header.iter().position(|h| *h == name).expect(name),
        );
        let (a, b): (f64, f64) = (lines[0][e].parse().unwrap(), last[r].parse().unwrap());
        assert_eq!(a.to_bits(), b.to_bits(), "{name}: ensemble {a}, run {b}");
        assert!(
            lines[1][e].parse::<f64>().unwrap().is_nan(),
            "{name} of the member that failed"
        );
    }
}

#[test]
fn torques_damp_the_spatial_momentum_as_the_closed_form_and_balance_the_energy() {
    // examples/rigid/damped-body.toml: τ = −c Π, so m = R Π = m0 e^{−ct} (m0 = I w0).
    let dir = tempfile::tempdir().unwrap();
    let damped = example("rigid/damped-body");
    femvi()
        .args(["run", "--quiet"])
        .arg(&damped)
        .args(["--format", "csv,npy", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    let csv = std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let m0 = [0.5, 2.0, 0.9];
    let mut worst: f64 = 0.0;
    for line in lines {
        let row: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let t = row[col("t")];
        let r = |i: usize, j: usize| row[col(&format!("R{i}{j}"))];
        let pi = [1, 2, 3].map(|k| row[col(&format!("p_R{k}"))]);
        for i in 1..=3 {
            let m = r(i, 1) * pi[0] + r(i, 2) * pi[1] + r(i, 3) * pi[2];
            worst = worst.max((m - m0[i - 1] * (-0.2 * t).exp()).abs());
        }
    }
    assert!(worst < 1e-9, "spatial momentum against the closed form: {worst:e}");
    // femvi check: the energy balance H − H0 = W on the Lie-group element.
    let out = femvi()
        .arg("check")
        .arg(&damped)
        .args(["--set", "time.end=2.0", "--json", "--out"])
        .arg(dir.path().join("check"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let balance = report["max_rel_energy_balance_error"].as_f64().unwrap();
    assert!(balance < 1e-10, "energy balance {balance:e}");
    assert!(report["final_work"].as_f64().unwrap() < 0.0);
    // Chaos of a forced Lie-group step is refused with its reason.
    let out = femvi().arg("chaos").arg(&damped).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(2) && err.contains("tangent map of a forced Lie-group step"),
        "{err}"
    );
    // A torque on a name that is not a rotation is an input error.
    let text = std::fs::read_to_string(&damped)
        .unwrap()
        .replace("torques = { R =", "torques = { S =");
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, text).unwrap();
    let out = femvi().args(["run", "--quiet"]).arg(&bad).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(2) && err.contains("'S' is not a rotation"),
        "{err}"
    );
}
