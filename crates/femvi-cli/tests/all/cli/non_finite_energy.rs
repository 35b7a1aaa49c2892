//! Issue 16's rule, no non-finite value written, for the runs that go through the library's
//! other solvers: a forced run (`[forces]`), a constrained one (`[constraints]`) and an
//! adaptive one (`mode = "adaptive"`) that reach a node whose energy is not finite stop there
//! with exit 1, the error naming the node, and the rows before it (before, the forced and the
//! constrained runs wrote the NaN and exited 0).

use std::path::Path;

/// A free particle (x = t, the other terms below 1e-299) that reaches x = 1 at node 4 (h =
/// 0.25, every = 2: a written node), where 1e-300·sqrt((x − 1)² − 0.025²) is NaN; no Gauss
/// point of degree 2 falls within 0.025 of x = 1, so the steps are finite. `extra` goes
/// after `[system]`'s Lagrangian; `coordinates` and the start are given.
fn problem(coordinates: &str, lagrangian: &str, extra: &str, start: &str) -> String {
    format!(
        "name = \"late\"\n[system]\ncoordinates = {coordinates}\nlagrangian = \"{lagrangian}\"\n{extra}\n[initial]\n{start}\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.25\nend = 2.0\n[output]\nevery = 2\n"
    )
}

/// Runs `femvi run` on `text` (the helper of `energy_nodes.rs`, no extra arguments).
fn run(dir: &Path, text: &str) -> (Option<i32>, serde_json::Value, Vec<Vec<f64>>, String) {
    crate::cli::energy_nodes::run(dir, text, &[])
}

/// The checks the runs share: exit 1, the error at node 4, the written rows (node indices
/// `kept`) at x = t.
fn check(case: &str, text: &str, kept: &[f64]) {
    check_at(case, text, "non-finite energy at step 4, t = 1", kept);
}

/// [`check`] with the error's beginning given.
fn check_at(case: &str, text: &str, error: &str, kept: &[f64]) {
    let tmp = tempfile::tempdir().unwrap();
    let (code, s, rows, err) = run(tmp.path(), text);
    assert_eq!(code, Some(1), "{case}: {err}");
    assert_eq!(s["status"], "failed", "{case}");
    assert!(s["error"].as_str().unwrap().starts_with(error), "{case}: {s}");
    assert!(err.contains("check that L is finite"), "{case}: {err}");
    let steps: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(steps, kept, "{case}");
    for r in &rows {
        assert_eq!(r[2], r[1], "{case}: {r:?}");
    }
}

const L: &str = "0.5*x_dot^2 + 1e-300*x_dot^4 + 1e-300*sqrt((x - 1)^2 - 0.025^2)";

/// The constrained problem: (x, y) with y = 0 held by a constraint, `extra` after it.
fn constrained(x0: &str, extra: &str) -> String {
    let lag = L.replace("x_dot^2 +", "(x_dot^2 + y_dot^2) +");
    let start = format!("q = [{x0}, 0.0]\nv = [1.0, 0.0]");
    problem(
        "[\"x\", \"y\"]",
        &lag,
        &format!("[constraints]\nholonomic = [\"y\"]\n{extra}"),
        &start,
    )
}

/// The forced, constrained and adaptive problems as (name, text), started at x = `x0`. With
/// g = 1 the adaptive run's fictitious time is the physical one, its nodes the same.
fn cases(x0: &str) -> Vec<(&'static str, String)> {
    let start = format!("q = [{x0}]\nv = [1.0]");
    let adaptive = "mode = \"adaptive\"\nmonitor = \"1\"\nds = 0.25";
    vec![
        (
            "forced",
            problem("[\"x\"]", L, "[forces]\ngeneralized = [\"0*x\"]", &start),
        ),
        ("constrained", constrained(x0, "")),
        (
            "adaptive",
            problem("[\"x\"]", L, "", &start).replace("step = 0.25", adaptive),
        ),
    ]
}

#[test]
fn each_solver_stops_at_a_node_whose_energy_is_not_finite() {
    for (case, text) in cases("0.0") {
        check(case, &text, &[0.0, 2.0]);
    }
}

#[test]
fn a_start_whose_energy_is_not_finite_is_a_failed_run_with_no_row() {
    // x = 1 at node 0: exit 1 (a numerical failure, not a bad input: the constrained run
    // returned an error before, exit 2), no row. The adaptive run refuses the start before
    // it runs (its time transformation needs E0 = H at the start): exit 2, naming E0.
    for (case, text) in cases("1.0") {
        if case == "adaptive" {
            let tmp = tempfile::tempdir().unwrap();
            let (code, _, rows, err) = run(tmp.path(), &text);
            assert_eq!(code, Some(2), "{err}");
            assert!(err.contains("the energy level E0 = NaN is not finite"), "{err}");
            assert!(rows.is_empty());
        } else {
            check_at(case, &text, "non-finite energy at step 0, t = 0", &[]);
        }
    }
}

#[test]
fn a_forced_constrained_run_checks_the_nodes_it_does_not_write() {
    // every = 3: node 4 is not written, but its energy enters the energy balance; the run
    // ends there with rows 0 and 3 (before, the NaN was skipped and the run went on, exit 0).
    let text = constrained("0.0", "[forces]\ngeneralized = [\"0*x\", \"0*y\"]").replace("every = 2", "every = 3");
    check("forced constrained", &text, &[0.0, 3.0]);
}
