//! `femvi bvp` with `[constraints]`: the geodesic example against the great circle (closed
//! form), the multiplier and residual columns, a guess file, `[forces]` with `[constraints]`
//! (gravity as a force is gravity in the Lagrangian), and the refusals (ends off the manifold,
//! a moving mesh) with exit code 2.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/constrained/sphere-geodesic-bvp.toml")
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

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The quarter great circle q(t) = cos t q0 + sin t q1 at unit speed: nodes on it to
/// round-off, |g| ≤ 1e-13 (and the residual column is |g| recomputed), λ = |v|²/2 = 1/2 to the
/// accuracy of the momenta, Newton's residual ≤ 1e-12; with enforcement at the nodes too.
#[test]
fn geodesic_example_is_the_great_circle() {
    for enforcement in ["weak", "nodes"] {
        let out = tempfile::tempdir().unwrap();
        femvi()
            .args(["bvp", "--quiet", "--set"])
            .arg(format!("constraints.enforcement=\"{enforcement}\""))
            .arg(example())
            .arg("--out")
            .arg(out.path())
            .assert()
            .success();
        let (header, rows) = rows(out.path());
        assert_eq!(header, "step,t,x,y,z,p_x,p_y,p_z,energy,lambda_1,residual");
        assert_eq!(rows.len(), 17);
        for r in &rows {
            let (s, c) = r[1].sin_cos();
            let exact = [c, 0.6 * s, 0.8 * s];
            let err = (0..3).map(|i| (r[2 + i] - exact[i]).abs()).fold(0.0, f64::max);
            let g = r[2] * r[2] + r[3] * r[3] + r[4] * r[4] - 1.0;
            assert!(err <= 1e-14, "{enforcement}: {r:?} off by {err:e}");
            assert!(g.abs() <= 1e-13 && (r[10] - g.abs()).abs() <= 1e-15, "{r:?}");
            assert!((r[9] - 0.5).abs() <= 1e-5 && (r[8] - 0.5).abs() <= 1e-5, "{r:?}");
        }
        let summary = json(&out.path().join("summary.json"));
        assert!(summary["residual_norm"].as_f64().unwrap() <= 1e-12, "{summary}");
        assert!(summary["error"].is_null());
        let constraints = json(&out.path().join("constraints.json"));
        assert!(constraints["max_residual"].as_f64().unwrap() <= 1e-13);
        assert_eq!(constraints["enforcement"], enforcement);
    }
}

/// A trajectory file as the guess (the solution itself): Newton starts at the solution.
#[test]
fn guess_file_is_used() {
    let first = tempfile::tempdir().unwrap();
    femvi()
        .args(["bvp", "--quiet"])
        .arg(example())
        .arg("--out")
        .arg(first.path())
        .assert()
        .success();
    let guess = first.path().join("trajectory.csv");
    let out = tempfile::tempdir().unwrap();
    femvi()
        .args(["bvp", "--quiet", "--set"])
        .arg(format!("boundary.guess={:?}", guess.display().to_string()))
        .arg(example())
        .arg("--out")
        .arg(out.path())
        .assert()
        .success();
    let iterations = |dir: &Path| json(&dir.join("summary.json"))["newton_iterations"].as_u64().unwrap();
    assert!(iterations(out.path()) < iterations(first.path()));
}

/// Asserts exit code 2 and `needle` in the standard error.
fn refused(cmd: &mut Command, needle: &str) {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code() == Some(2) && err.contains(needle), "{err}");
}

#[test]
fn bad_constrained_boundary_problems_are_refused() {
    let out = tempfile::tempdir().unwrap();
    refused(
        femvi()
            .args(["bvp", "--quiet", "--set", "boundary.q1=[0.0,0.6,0.81]"])
            .arg(example())
            .arg("--out")
            .arg(out.path()),
        "boundary q1: violates the constraints: max |g| = 1.610e-2",
    );
    refused(
        femvi()
            .args(["bvp", "--quiet", "--set", "boundary.time_mode=\"energy\""])
            .arg(example())
            .arg("--out")
            .arg(out.path()),
        "moving mesh",
    );
}

/// `[forces]` with `[constraints]`: gravity as a generalized force on the geodesic example
/// gives the nodes of the same file with gravity in the Lagrangian (the spherical pendulum),
/// and dissipation on top solves with residual ≤ 1e-12.
#[test]
fn forces_with_constraints_are_solved() {
    let dir = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(example()).unwrap();
    let solve = |name: &str, text: String| {
        let path = dir.path().join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        let out = dir.path().join(name);
        femvi()
            .args(["bvp", "--quiet"])
            .arg(&path)
            .arg("--out")
            .arg(&out)
            .assert()
            .success();
        let summary = json(&out.join("summary.json"));
        assert!(summary["residual_norm"].as_f64().unwrap() <= 1e-12, "{name}: {summary}");
        rows(&out).1
    };
    let pendulum = solve(
        "pendulum",
        base.replace(
            "lagrangian = \"0.5*(x_dot^2 + y_dot^2 + z_dot^2)\"",
            "lagrangian = \"0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z\"",
        ),
    );
    let forced = solve(
        "forced",
        base.clone() + "\n[forces]\ngeneralized = [\"0\", \"0\", \"-9.81\"]\n",
    );
    let damped = solve(
        "damped",
        base + "\n[forces]\ndissipation = \"0.05*(x_dot^2 + y_dot^2 + z_dot^2)\"\n",
    );
    let (mut same, mut moved) = (0.0f64, 0.0f64);
    for ((p, f), d) in pendulum.iter().zip(&forced).zip(&damped) {
        for c in 2..5 {
            same = same.max((p[c] - f[c]).abs());
            moved = moved.max((p[c] - d[c]).abs());
        }
        assert!(d[10] <= 1e-13 && f[10] <= 1e-13);
    }
    assert!(same <= 1e-13 && moved > 1e-3, "{same:e} {moved:e}");
}
