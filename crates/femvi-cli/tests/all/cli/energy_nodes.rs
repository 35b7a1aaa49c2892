//! `[output] energy_nodes` (issue 15, item 4): for a Lagrangian without a constant mass
//! matrix `femvi run` computes H only at the nodes it writes (by default), and summary.json
//! says so; its largest error is then the one of the written energy column, and each of those
//! energies is the inverse Legendre transform's at that node.

use std::path::Path;
use std::process::Command;

/// Relativistic Kepler (c = 10) as an expression: p = v(1 + |v|²/200), no mass matrix.
const REL: &str = "name = \"rel\"\n[system]\ncoordinates = [\"x\", \"y\"]\nlagrangian = \"0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2) + (x_dot^2 + y_dot^2)^2/800\"\n[initial]\nq = [0.4, 0.0]\np = [0.0, 2.0]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.01\nend = 20.0\n[output]\nevery = 10\n";

/// Runs `femvi run` on `text` with `extra` arguments; (exit code, summary, rows of numbers).
pub(crate) fn run(dir: &Path, text: &str, extra: &[&str]) -> (Option<i32>, serde_json::Value, Vec<Vec<f64>>, String) {
    let problem = dir.join("p.toml");
    std::fs::write(&problem, text).unwrap();
    let out = dir.join("out");
    let res = Command::new(env!("CARGO_BIN_EXE_femvi"))
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&problem)
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&res.stderr).into_owned();
    let summary = std::fs::read_to_string(out.join("summary.json"))
        .map(|s| serde_json::from_str(&s).unwrap())
        .unwrap_or(serde_json::Value::Null);
    let rows = std::fs::read_to_string(out.join("trajectory.csv"))
        .unwrap_or_default()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (res.status.code(), summary, rows, stderr)
}

/// The largest |H − H0| / |H0| of an energy column, as the tracker computes it (the largest
/// deviation over |H0|: division rounds monotonically, so the same number).
fn max_rel(energy: &[f64]) -> f64 {
    let e0 = energy[0];
    energy.iter().fold(0.0f64, |m, e| m.max((e - e0).abs())) / e0.abs()
}

/// H = p·v − L at (q, p) with v from p = v(1 + |v|²/200) by bisection on |v| (an independent
/// inversion: the direction of v is p's).
fn hamiltonian(q: [f64; 2], p: [f64; 2]) -> f64 {
    let pn = p[0].hypot(p[1]);
    let (mut lo, mut hi) = (0.0, pn);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid * (1.0 + mid * mid / 200.0) < pn {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let s = 0.5 * (lo + hi);
    let v2 = s * s;
    let l = 0.5 * v2 + 1.0 / q[0].hypot(q[1]) + v2 * v2 / 800.0;
    pn * s - l
}

#[test]
fn a_general_lagrangian_gets_its_energy_at_the_written_nodes_only() {
    let tmp = tempfile::tempdir().unwrap();
    let (code, kept, rows, err) = run(tmp.path(), REL, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(kept["energy_nodes"], "kept");
    // Nodes 0, 10, 20, … and the last.
    assert!(rows.len() > 100 && rows[..rows.len() - 1].iter().all(|r| r[0] % 10.0 == 0.0));
    let energy: Vec<f64> = rows.iter().map(|r| r[6]).collect();
    let max_kept = kept["max_rel_energy_error"].as_f64().unwrap();
    assert_eq!(max_kept, max_rel(&energy));
    assert!(max_kept > 0.0 && max_kept < 1e-5, "{max_kept}");
    // Each written energy is H at that node's (q, p), to round-off.
    for r in &rows {
        let h = hamiltonian([r[2], r[3]], [r[4], r[5]]);
        assert!((r[6] - h).abs() <= 1e-13 * h.abs(), "node {}: {} vs {h}", r[0], r[6]);
    }
    // Every node asked for: the same written rows and energies (to round-off: each inversion
    // starts elsewhere), and a largest error over more nodes.
    let (code, every, rows_every, err) = run(tmp.path(), REL, &["--set", "output.energy_nodes=every"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(every["energy_nodes"], "every");
    assert_eq!(rows_every.len(), rows.len());
    for (a, b) in rows.iter().zip(&rows_every) {
        assert_eq!(a[..6], b[..6]);
        assert!((a[6] - b[6]).abs() <= 1e-14 * a[6].abs());
    }
    let max_every = every["max_rel_energy_error"].as_f64().unwrap();
    assert!(max_every >= max_kept * (1.0 - 1e-6), "{max_every} vs {max_kept}");
}

#[test]
fn a_mechanical_or_time_dependent_lagrangian_is_checked_at_every_node() {
    let tmp = tempfile::tempdir().unwrap();
    let kepler = REL.replace(" + (x_dot^2 + y_dot^2)^2/800", "");
    let (code, s, _, err) = run(tmp.path(), &kepler, &[]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(s["energy_nodes"], "every");
    // Asked for, a constant mass matrix too gets the kept nodes only.
    let (code, s, rows, err) = run(tmp.path(), &kepler, &["--set", "output.energy_nodes=kept"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(s["energy_nodes"], "kept");
    let energy: Vec<f64> = rows.iter().map(|r| r[6]).collect();
    assert_eq!(s["max_rel_energy_error"].as_f64().unwrap(), max_rel(&energy));
    // A time-dependent one: its energy balance needs every node, whatever is asked.
    let forced = REL.replace("1/sqrt(x^2 + y^2)", "(1 + 0.1*cos(t))/sqrt(x^2 + y^2)");
    let (code, s, _, err) = run(tmp.path(), &forced, &["--set", "output.energy_nodes=kept"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(s["energy_nodes"], "every");
}

#[test]
fn a_run_stopped_between_written_nodes_has_the_energy_of_its_last_node() {
    // The last node of the grid (about 2003) is not a multiple of 10: it is written, with its
    // energy.
    let tmp = tempfile::tempdir().unwrap();
    let (code, s, rows, err) = run(tmp.path(), &REL.replace("end = 20.0", "end = 20.03"), &[]);
    assert_eq!(code, Some(0), "{err}");
    let last = rows.last().unwrap();
    assert!(last[0] > 2000.0 && last[0] % 10.0 != 0.0, "{}", last[0]);
    let h = hamiltonian([last[2], last[3]], [last[4], last[5]]);
    assert!((last[6] - h).abs() <= 1e-13 * h.abs());
    let energy: Vec<f64> = rows.iter().map(|r| r[6]).collect();
    assert_eq!(s["max_rel_energy_error"].as_f64().unwrap(), max_rel(&energy));
}

#[test]
fn an_unknown_choice_is_an_input_error() {
    let tmp = tempfile::tempdir().unwrap();
    let (code, _, _, err) = run(tmp.path(), &format!("{REL}energy_nodes = \"some\"\n"), &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("energy_nodes must be \"auto\", \"every\" or \"kept\""),
        "{err}"
    );
}

#[test]
fn a_written_node_whose_energy_is_not_finite_stops_the_run_before_it_is_written() {
    // 1e-300·ln((x − 1)²) is −∞ at the start x = 1 only: the steps (quadrature points inside
    // the elements) are finite, H at node 0 is not. Written nodes only, or every node: the
    // same failure, and no row.
    let text = REL
        .replace(
            "coordinates = [\"x\", \"y\"]\nlagrangian = \"0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2) + (x_dot^2 + y_dot^2)^2/800\"",
            "coordinates = [\"x\"]\nlagrangian = \"0.5*(1 + x^2)*x_dot^2 - 0.5*x^2 + 1e-300*ln((x - 1)^2)\"",
        )
        .replace("q = [0.4, 0.0]\np = [0.0, 2.0]", "q = [1.0]\nv = [0.5]");
    for (nodes, _, rows) in failed_in_both_modes(&text, "non-finite energy at step 0") {
        assert!(rows.is_empty(), "{nodes}: a row was written");
    }
}

/// Runs `text` with the energy at the written nodes and at every node; checks that each
/// fails (exit 1) with an error beginning with `error` and says which mode it ran in; returns
/// (mode, summary, rows) of each.
fn failed_in_both_modes(text: &str, error: &str) -> Vec<(&'static str, serde_json::Value, Vec<Vec<f64>>)> {
    let mut out = vec![];
    for nodes in ["kept", "every"] {
        let tmp = tempfile::tempdir().unwrap();
        let (code, s, rows, err) = run(tmp.path(), text, &["--set", &format!("output.energy_nodes={nodes}")]);
        assert_eq!(code, Some(1), "{nodes}: {err}");
        assert_eq!(s["energy_nodes"], nodes);
        assert_eq!(s["status"], "failed");
        assert!(s["error"].as_str().unwrap().starts_with(error), "{s}");
        out.push((nodes, s, rows));
    }
    out
}

#[test]
fn a_later_written_node_whose_energy_is_not_finite_ends_the_run_on_the_node_before() {
    // A free particle (x = t, the other terms below 1e-299) reaches x = 1 at node 4, a written
    // node (every = 2). 1e-300·sqrt((x − 1)² − 0.025²) is NaN within 0.025 of x = 1, where no
    // quadrature point falls (Gauss points sit 0.053 or more from the nodes at h = 0.25), so
    // the steps are finite and H at node 4 is not. Both modes: exit 1, the error names step
    // 4, the run ends on node 3, and the rows written are nodes 0 and 2 with energy ½.
    let text = REL
        .replace(
            "coordinates = [\"x\", \"y\"]\nlagrangian = \"0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2) + (x_dot^2 + y_dot^2)^2/800\"",
            "coordinates = [\"x\"]\nlagrangian = \"0.5*x_dot^2 + 1e-300*x_dot^4 + 1e-300*sqrt((x - 1)^2 - 0.025^2)\"",
        )
        .replace("q = [0.4, 0.0]\np = [0.0, 2.0]", "q = [0.0]\nv = [1.0]")
        .replace("step = 0.01\nend = 20.0", "step = 0.25\nend = 2.0")
        .replace("every = 10", "every = 2");
    for (nodes, s, rows) in failed_in_both_modes(&text, "non-finite energy at step 4") {
        assert_eq!(s["steps"], 3, "{nodes}: {s}");
        let steps: Vec<f64> = rows.iter().map(|r| r[0]).collect();
        assert_eq!(steps, [0.0, 2.0], "{nodes}");
        // x = t and H = ½ at the written nodes (up to the 1e-300 terms, below round-off).
        for r in &rows {
            assert_eq!(r[2], r[1], "{nodes}: {r:?}");
            assert!((r[4] - 0.5).abs() <= 1e-15, "{nodes}: {r:?}");
        }
        assert_eq!(s["max_rel_energy_error"].as_f64().unwrap(), 0.0);
    }
}
