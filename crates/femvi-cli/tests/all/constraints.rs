//! `[constraints]` through the binary: the spherical pendulum model file (residuals and the
//! multiplier columns), `femvi check` reporting the symplecticity defect on the manifold, and
//! starts, expressions and commands that cannot take constraints refused with exit code 2.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn model(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../examples/constrained/{name}.toml"))
}

/// Asserts exit code 2 and `needle` in the standard error.
fn refused(cmd: &mut Command, needle: &str) {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code() == Some(2) && err.contains(needle), "{err}");
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

#[test]
fn spherical_pendulum_runs_on_the_sphere() {
    let out = tempfile::tempdir().unwrap();
    femvi()
        .args(["run", "--quiet", "--set", "time.end=5.0"])
        .arg(model("spherical-pendulum"))
        .arg("--out")
        .arg(out.path())
        .assert()
        .success();
    let csv = std::fs::read_to_string(out.path().join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "step,t,x,y,z,p_x,p_y,p_z,energy,lambda_1,residual"
    );
    let mut count = 0;
    for line in lines {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        // |q| = 1 to round-off; the residual column is |g(q)| recomputed here.
        let g = v[2] * v[2] + v[3] * v[3] + v[4] * v[4] - 1.0;
        assert!(g.abs() <= 1e-13 && (v[10] - g.abs()).abs() <= 1e-15, "{line}");
        count += 1;
    }
    assert_eq!(count, 501);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("constraints.json")).unwrap()).unwrap();
    assert!(json["max_residual"].as_f64().unwrap() <= 1e-13);
}

#[test]
fn check_measures_symplecticity_on_the_manifold() {
    let assert = femvi()
        .args(["check", "--json", "--set", "time.end=2.0"])
        .arg(model("double-pendulum-cartesian"))
        .assert()
        .success();
    let report: serde_json::Value = serde_json::from_slice(&assert.get_output().stdout).unwrap();
    let defect = report["symplecticity_defect"].as_f64().unwrap();
    assert!(defect <= 1e-12 && report["symplecticity_samples"] == 400, "{report}");
}

#[test]
fn bad_constrained_input_is_refused() {
    let out = tempfile::tempdir().unwrap();
    // A start off the sphere names its residual.
    refused(
        femvi()
            .args(["run", "--quiet", "--set", "initial.q=[0.85,0.0,-0.5403023058681398]"])
            .arg(model("spherical-pendulum"))
            .arg("--out")
            .arg(out.path()),
        "violates the constraints: max |g(q0)| = 1.443e-2",
    );
    refused(
        femvi()
            .args(["run", "--quiet", "--set", "constraints.holonomic=[\"x^2 + w^2\"]"])
            .arg(model("spherical-pendulum")),
        "unknown symbol 'w'",
    );
    femvi()
        .args(["run", "--quiet", "--set", "time.mode=\"energy\""])
        .arg(model("spherical-pendulum"))
        .arg("--out")
        .arg(out.path())
        .assert()
        .code(2);
}

/// A file with both `[forces]` and `[constraints]`: `femvi check` reports the energy balance
/// of the forced constrained run (the constraint forces do no work) and the constraint
/// residual, the numbers `femvi run` writes for the same run.
#[test]
fn forces_with_constraints_are_checked_by_their_energy_balance() {
    let text = std::fs::read_to_string(model("spherical-pendulum")).unwrap()
        + "\n[forces]\ngeneralized = [\"-0.1*x_dot\", \"-0.1*y_dot\", \"-0.1*z_dot\"]\n";
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("both.toml");
    std::fs::write(&path, text).unwrap();
    let out = femvi().args(["check", "--json"]).arg(&path).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let check: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let run_dir = dir.path().join("run");
    femvi()
        .args(["run", "--quiet"])
        .arg(&path)
        .arg("--out")
        .arg(&run_dir)
        .assert()
        .success();
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(run_dir.join(name)).unwrap()).unwrap()
    };
    let (summary, constraints) = (read("summary.json"), read("constraints.json"));
    for (a, b) in [
        ("max_rel_energy_balance_error", "max_rel_energy_balance_error"),
        ("final_work", "final_work"),
    ] {
        assert_eq!(check[a].as_f64(), summary[b].as_f64(), "{a}");
    }
    assert_eq!(
        check["max_constraint_residual"].as_f64(),
        constraints["max_residual"].as_f64()
    );
    let residual = check["max_constraint_residual"].as_f64().unwrap();
    assert!(residual <= 1e-13, "{residual:e}");
    // The balance is a check: without the work it would be off by |W|.
    let (balance, work) = (
        check["max_energy_balance_error"].as_f64().unwrap(),
        check["final_work"].as_f64().unwrap(),
    );
    assert!(
        work < 0.0 && balance <= 1e-4 * work.abs(),
        "balance {balance:e}, work {work:e}"
    );
    let text = femvi().arg("check").arg(&path).output().unwrap();
    let shown = String::from_utf8_lossy(&text.stdout);
    assert!(
        shown.contains("max |g(q)|") && shown.contains("energy balance"),
        "{shown}"
    );
}

/// `[[events]]` with `[constraints]` (issue 33: the constrained run is the one integrator, and
/// events are located on its element polynomials): the crossings of x = 0 by the spherical
/// pendulum land on x = 0 to round-off and on the sphere to the method's error, their times
/// converge with the order of the element (a run at h/2 and h/4 as reference), and the
/// trajectory keeps its multiplier columns and constraints.json.
#[test]
fn events_of_a_constrained_run_are_located_on_its_elements() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(model("spherical-pendulum")).unwrap()
        + "\n[[events]]\nname = \"cross\"\nwhen = \"x\"\n";
    let problem = tmp.path().join("sphere-events.toml");
    std::fs::write(&problem, text).unwrap();
    let times = |h: f64| -> Vec<f64> {
        let out = tmp.path().join(format!("out-{h}"));
        femvi()
            .args(["run", "--quiet", "--set", "time.end=4.0", "--set"])
            .arg(format!("time.step={h}"))
            .arg(&problem)
            .arg("--out")
            .arg(&out)
            .assert()
            .success();
        let header = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        assert!(header.starts_with("step,t,x,y,z,p_x,p_y,p_z,energy,lambda_1,residual\n"));
        assert!(out.join("constraints.json").exists());
        let events = std::fs::read_to_string(out.join("events.csv")).unwrap();
        events
            .lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                let x: Vec<f64> = f[3..6].iter().map(|s| s.parse().unwrap()).collect();
                let r = x.iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!(x[0].abs() < 1e-12 && (r - 1.0).abs() < 1e-4, "{l}");
                f[2].parse().unwrap()
            })
            .collect()
    };
    let (a, b, c) = (times(0.02), times(0.01), times(0.005));
    assert!(
        a.len() >= 2 && a.len() == b.len() && b.len() == c.len(),
        "{a:?} {b:?} {c:?}"
    );
    let gap = |x: &[f64], y: &[f64]| x.iter().zip(y).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
    let (g1, g2) = (gap(&a, &c), gap(&b, &c));
    assert!(g1 < 1e-5 && g1 / g2 > 6.0, "{g1:e} {g2:e}");
}
