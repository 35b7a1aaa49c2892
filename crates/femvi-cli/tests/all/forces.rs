//! `[forces]` through the `femvi` binary (issue 19): every example in examples/forces runs
//! (`run`, or `bvp` for [boundary]) with a `work` column whose balance with the energy holds,
//! `check` reports the energy balance instead of symplecticity, the damped oscillator's
//! `bvp` meets the closed form, and every input error is exit code 2 with a message (1 for a
//! numerical failure).

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/forces")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

/// Runs `femvi ARGS… FILE --out DIR` on a problem text; (exit code, stderr, DIR).
fn run_text(args: &[&str], text: &str) -> (i32, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("problem.toml");
    std::fs::write(&file, text).unwrap();
    let res = femvi()
        .args(args)
        .arg(&file)
        .arg("--out")
        .arg(dir.path().join("out"))
        .output()
        .unwrap();
    (
        res.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&res.stderr).into_owned(),
        dir,
    )
}

const DAMPED: &str = r#"
[system]
coordinates = ["x"]
parameters = { k = 1.0, c = 0.3 }
lagrangian = "0.5*x_dot^2 - 0.5*k*x^2"
[forces]
FORCES
[initial]
q = [1.0]
v = [0.0]
[scheme]
order = 4
[time]
step = 0.1
end = 5.0
"#;

#[test]
fn every_forces_example_runs_and_balances() {
    let mut count = 0;
    for entry in std::fs::read_dir(examples()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let out = tempfile::tempdir().unwrap();
        let bvp = std::fs::read_to_string(&path).unwrap().contains("[boundary]");
        let res = femvi()
            .arg(if bvp { "bvp" } else { "run" })
            .arg(&path)
            .arg("--out")
            .arg(out.path())
            .arg("--quiet")
            .output()
            .unwrap();
        assert!(
            res.status.success(),
            "{}: {}",
            path.display(),
            String::from_utf8_lossy(&res.stderr)
        );
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
        count += 1;
        if bvp {
            assert!(summary["residual_norm"].as_f64().unwrap() <= 1e-12, "{summary}");
            continue;
        }
        // energy − energy₀ − work, recomputed from the CSV, is the summary's balance.
        let csv = std::fs::read_to_string(out.path().join("trajectory.csv")).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name);
        let (ie, iw) = (col("energy").unwrap(), col("work").unwrap());
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        if let Some(id) = col("discrete_energy") {
            // Energy mode: the rows stream, and node 0 precedes the first element, which
            // fixes Ẽ_0 (NaN there). From node 1 on, (Ẽ_k − Ẽ_1) − (W_k − W_1) is the
            // difference of two balance gaps Ẽ − Ẽ_0 − W: at most twice the reported one.
            assert!(rows[0][id].is_nan(), "{}", path.display());
            let (d1, w1) = (rows[1][id], rows[1][iw]);
            let worst = rows[1..]
                .iter()
                .fold(0.0f64, |m, r| m.max(((r[id] - d1) - (r[iw] - w1)).abs()));
            // |Ẽ_0| and |Ẽ_1| differ by one element's work (≪ 1 %).
            let reported = summary["max_rel_discrete_energy_balance_error"].as_f64().unwrap() * d1.abs() * 1.01;
            eprintln!(
                "{}: discrete balance {worst:.2e} (reported {reported:.2e})",
                path.display()
            );
            assert!(
                worst <= 2.0 * reported + 1e-300 && reported < 1e-14,
                "{worst} {reported}"
            );
            assert!(summary["max_step"].as_f64().unwrap() > summary["min_step"].as_f64().unwrap());
            assert_eq!(summary["degenerate_steps"], 0);
        }
        let e0 = rows[0][ie];
        let worst = rows.iter().fold(0.0f64, |m, r| m.max((r[ie] - e0 - r[iw]).abs()));
        let scale = if e0 != 0.0 { e0.abs() } else { 1.0 }; // relative, absolute where H0 = 0
        let reported = summary["max_rel_energy_balance_error"].as_f64().unwrap() * scale;
        assert!(
            worst <= reported * (1.0 + 1e-9) + 1e-300,
            "{}: {worst} vs {reported}",
            path.display()
        );
        assert!(
            reported < 1e-9 * e0.abs().max(1.0),
            "{}: balance {reported}",
            path.display()
        );
        assert_eq!(summary["final_work"].as_f64().unwrap(), rows.last().unwrap()[iw]);
        assert_eq!(summary["energy_conserved"], false);
    }
    assert_eq!(count, 5);
}

/// `femvi bvp` on the damped oscillator against the closed form x(t) with x(0) = 1,
/// x'(0) = 0 (x(4) from it): residual ≤ 1e-12 and errors at the element ends shrinking by 2^{2s}
/// when the elements double (s = 1, 2).
#[test]
fn bvp_damped_oscillator_against_the_closed_form() {
    let (c, k) = (0.3f64, 1.0f64);
    let g = c / 2.0;
    let wd = (k - g * g).sqrt();
    let x = |t: f64| (-g * t).exp() * ((wd * t).cos() + g / wd * (wd * t).sin());
    for s in [1usize, 2] {
        let mut errs = vec![];
        for elements in [10usize, 20] {
            let text = format!(
                "[system]\ncoordinates = [\"x\"]\nparameters = {{ k = {k}, c = {c} }}\nlagrangian = \"0.5*x_dot^2 - 0.5*k*x^2\"\n[forces]\ndissipation = \"0.5*c*x_dot^2\"\n[boundary]\nt0 = 0.0\nq0 = [1.0]\nt1 = 4.0\nq1 = [{:?}]\nelements = {elements}\n[scheme]\norder = {}\n",
                x(4.0),
                2 * s
            );
            let (code, err, dir) = run_text(&["bvp"], &text);
            assert_eq!(code, 0, "{err}");
            let out = dir.path().join("out");
            let summary: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
            assert!(summary["residual_norm"].as_f64().unwrap() <= 1e-12, "{summary}");
            let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
            let worst = csv.lines().skip(1).fold(0.0f64, |m, l| {
                let r: Vec<f64> = l.split(',').map(|v| v.parse().unwrap()).collect();
                m.max((r[2] - x(r[1])).abs())
            });
            errs.push(worst);
        }
        let order = (errs[0] / errs[1]).log2();
        assert!((order - 2.0 * s as f64).abs() < 0.3, "s = {s}: {errs:?}, order {order}");
    }
}

#[test]
fn check_reports_the_energy_balance() {
    let res = femvi()
        .arg("check")
        .arg(examples().join("forced-duffing.toml"))
        .arg("--json")
        .output()
        .unwrap();
    assert!(res.status.success(), "{}", String::from_utf8_lossy(&res.stderr));
    let report: serde_json::Value = serde_json::from_slice(&res.stdout).unwrap();
    assert!(report["note"].as_str().unwrap().contains("not symplectic"));
    assert!(report["max_energy_balance_error"].as_f64().unwrap() < 1e-9, "{report}");
    assert!(report["final_work"].as_f64().unwrap().abs() > 1e-3);
}

#[test]
fn input_errors_and_failures() {
    // A bad expression: exit 2 with its position.
    let (code, err, _d) = run_text(&["run"], &DAMPED.replace("FORCES", "generalized = [\"-c*x_dot +\"]"));
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("in [forces]: force on x") && err.contains(":7:27:") && err.contains('^'),
        "{err}"
    );
    let (code, err, _d) = run_text(&["run"], &DAMPED.replace("FORCES", "dissipation = \"0.5*c*y_dot^2\""));
    assert_eq!(code, 2);
    assert!(err.contains("unknown symbol 'y_dot'"), "{err}");
    // The wrong count of forces.
    let (code, err, _d) = run_text(&["run"], &DAMPED.replace("FORCES", "generalized = [\"0\", \"0\"]"));
    assert_eq!(code, 2);
    assert!(err.contains("2 expressions for 1 coordinates"), "{err}");
    // An empty table, an unknown key.
    let (code, err, _d) = run_text(&["run"], &DAMPED.replace("FORCES", ""));
    assert_eq!(code, 2);
    assert!(err.contains("needs `generalized`"), "{err}");
    let (code, _, _d) = run_text(&["run"], &DAMPED.replace("FORCES", "friction = \"1\""));
    assert_eq!(code, 2);
    // Newton failure (a force that is NaN): exit 1, the step and time named.
    let (code, err, _d) = run_text(&["run"], &DAMPED.replace("FORCES", "generalized = [\"sqrt(x - 10)\"]"));
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("step 0 at t = 0"), "{err}");
    // Commands refuse what the table refuses with forces in energy mode.
    let (code, err, _d) = run_text(
        &["convergence", "--steps", "0.1,0.05"],
        &DAMPED
            .replace("FORCES", "generalized = [\"-c*x_dot\"]")
            .replace("end = 5.0", "end = 5.0\nmode = \"energy\""),
    );
    assert_eq!(code, 2);
    assert!(
        err.contains("does not support [forces] in [time] mode = \"energy\""),
        "{err}"
    );
    // Energy mode: a force the energy equation cannot follow is exit 1 naming step and time;
    // the fixed-point method is an input error there.
    let energy = DAMPED
        .replace("FORCES", "generalized = [\"40*x_dot\"]")
        .replace("end = 5.0", "end = 5.0\nmode = \"energy\"");
    let (code, err, d) = run_text(&["run"], &energy);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("no admissible time step"), "{err}");
    // The step and time named are those of the last node written.
    let csv = std::fs::read_to_string(d.path().join("out/trajectory.csv")).unwrap();
    let last: Vec<&str> = csv.lines().last().unwrap().split(',').collect();
    let (k, t): (usize, f64) = (last[0].parse().unwrap(), last[1].parse().unwrap());
    assert!(err.contains(&format!("step {k} at t = {t}")), "{err} vs {k}, {t}");
    let (code, err, _d) = run_text(&["run"], &format!("{energy}\n[solver]\nmethod = \"fixed-point\"\n"));
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("Newton"), "{err}");
    // A forced run is a run of the one integrator: plots and NPY as for any run (issue 33).
    let (code, err, d) = run_text(
        &["run", "--plot", "--format", "csv,npy"],
        &DAMPED.replace("FORCES", "generalized = [\"-c*x_dot\"]"),
    );
    assert_eq!(code, 0, "{err}");
    let out = d.path().join("out");
    let svgs = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "svg"))
        .count();
    assert!(svgs > 0, "no plots in {}", out.display());
    let columns = std::fs::read_to_string(out.join("columns.txt")).unwrap();
    assert!(columns.lines().any(|c| c == "work"), "{columns}");
    // In energy mode too (issue 33: the forced energy equation is a term of the one run):
    // plots, and `--resume` of a finished run has nothing left to do (resume.rs resumes
    // killed ones byte for byte).
    let energy = DAMPED
        .replace("FORCES", "generalized = [\"-c*x_dot\"]")
        .replace("end = 5.0", "end = 5.0\nmode = \"energy\"");
    let (code, err, d) = run_text(&["run", "--plot"], &energy);
    assert_eq!(code, 0, "{err}");
    assert!(d.path().join("out/energy_error.svg").exists());
    let problem = d.path().join("problem.toml");
    let resumed = femvi()
        .args(["run", "--resume"])
        .arg(d.path().join("out"))
        .arg(&problem)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&resumed.stderr);
    assert!(err.contains("nothing to resume"), "{err}");
}

/// `[forces]` with `[time] mode = "adaptive"`: the adaptive integrator has no force terms, so
/// `run` and `check` refuse the file (they used to integrate the conservative part alone).
#[test]
fn forces_in_adaptive_mode_are_refused() {
    let text = DAMPED
        .replace("FORCES", "dissipation = \"0.5*c*x_dot^2\"")
        .replace("step = 0.1", "mode = \"adaptive\"\nmonitor = \"1 + x^2\"\nds = 0.1");
    for cmd in ["run", "check"] {
        let (code, err, _dir) = run_text(&[cmd], &text);
        assert_eq!(code, 2, "{cmd}: {err}");
        assert!(
            err.contains("[forces] are not available with [time] mode = \"adaptive\""),
            "{cmd}: {err}"
        );
    }
}
