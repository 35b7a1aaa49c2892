//! Issue 16's rule, no non-finite value written, for the runs that go through the library's
//! other solvers: a forced run (`[forces]`), a constrained one (`[constraints]`) and an
//! adaptive one (`mode = "adaptive"`) that reach a node whose energy is not finite stop there
//! with exit 1, the error naming the node, and the rows before it (before, the forced and the
//! constrained runs wrote the NaN and exited 0).

use std::path::Path;
use std::process::Command;

/// A free particle (x = t, the other terms below 1e-299) that reaches x = 1 at node 4 (h =
/// 0.25, every = 2: a written node), where 1e-300·sqrt((x − 1)² − 0.025²) is NaN; no Gauss
/// point of degree 2 falls within 0.025 of x = 1, so the steps are finite. `extra` goes
/// after `[system]`'s Lagrangian; `coordinates` and the start are given.
fn problem(coordinates: &str, lagrangian: &str, extra: &str, start: &str) -> String {
    format!(
        "name = \"late\"\n[system]\ncoordinates = {coordinates}\nlagrangian = \"{lagrangian}\"\n{extra}\n[initial]\n{start}\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.25\nend = 2.0\n[output]\nevery = 2\n"
    )
}

/// Runs `femvi run` on `text`: (exit code, summary, rows of numbers, stderr).
fn run(dir: &Path, text: &str) -> (Option<i32>, serde_json::Value, Vec<Vec<f64>>, String) {
    let problem = dir.join("p.toml");
    std::fs::write(&problem, text).unwrap();
    let out = dir.join("out");
    let res = Command::new(env!("CARGO_BIN_EXE_femvi"))
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&problem)
        .output()
        .unwrap();
    let summary = std::fs::read_to_string(out.join("summary.json"))
        .map(|s| serde_json::from_str(&s).unwrap())
        .unwrap_or(serde_json::Value::Null);
    let rows = std::fs::read_to_string(out.join("trajectory.csv"))
        .unwrap_or_default()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (
        res.status.code(),
        summary,
        rows,
        String::from_utf8_lossy(&res.stderr).into_owned(),
    )
}

/// The checks both runs share: exit 1, the error at node 4, rows 0 and 2 with x = t, every
/// number written finite.
fn check(case: &str, text: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let (code, s, rows, err) = run(tmp.path(), text);
    assert_eq!(code, Some(1), "{case}: {err}");
    assert_eq!(s["status"], "failed", "{case}");
    assert!(
        s["error"]
            .as_str()
            .unwrap()
            .starts_with("non-finite energy at step 4, t = 1"),
        "{case}: {s}"
    );
    assert!(err.contains("check that L is finite"), "{case}: {err}");
    let steps: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(steps, [0.0, 2.0], "{case}");
    for r in &rows {
        assert_eq!(r[2], r[1], "{case}: {r:?}");
        assert!(r.iter().all(|x| x.is_finite()), "{case}: {r:?}");
    }
}

const L: &str = "0.5*x_dot^2 + 1e-300*x_dot^4 + 1e-300*sqrt((x - 1)^2 - 0.025^2)";

#[test]
fn a_forced_run_stops_at_a_node_whose_energy_is_not_finite() {
    let text = problem(
        "[\"x\"]",
        L,
        "[forces]\ngeneralized = [\"0*x\"]",
        "q = [0.0]\nv = [1.0]",
    );
    check("forced", &text);
}

#[test]
fn a_constrained_run_stops_at_a_node_whose_energy_is_not_finite() {
    let lag = L.replace("x_dot^2 +", "(x_dot^2 + y_dot^2) +");
    let text = problem(
        "[\"x\", \"y\"]",
        &lag,
        "[constraints]\nholonomic = [\"y\"]",
        "q = [0.0, 0.0]\nv = [1.0, 0.0]",
    );
    check("constrained", &text);
}

#[test]
fn an_adaptive_run_stops_at_a_node_whose_energy_is_not_finite() {
    // g = 1: the fictitious time is the physical one, the nodes the same as above.
    let text = problem("[\"x\"]", L, "", "q = [0.0]\nv = [1.0]")
        .replace("step = 0.25", "mode = \"adaptive\"\nmonitor = \"1\"\nds = 0.25");
    check("adaptive", &text);
}
