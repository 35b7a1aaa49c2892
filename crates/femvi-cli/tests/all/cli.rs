//! The `femvi` binary driven as a user would: every bundled example runs, and every broken
//! input gives exit code 2 (bad input) or 1 (numerical failure), a message naming the problem,
//! and no panic.

mod energy_nodes;
mod non_finite_energy;

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

#[test]
fn every_example_runs() {
    let mut count = 0;
    let files = std::fs::read_dir(examples())
        .unwrap()
        .chain(std::fs::read_dir(examples().join("models")).unwrap())
        .map(|e| e.unwrap().path());
    for path in files {
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        let out = tempfile::tempdir().unwrap();
        // Optimal control problems ([controls]) are solved by `optimize`, boundary value
        // problems ([boundary]) by `bvp`, the rest by `run`.
        let text = std::fs::read_to_string(&path).unwrap();
        let command = if text.contains("[controls]") {
            "optimize"
        } else if text.contains("[boundary]") {
            "bvp"
        } else {
            "run"
        };
        let mut cmd = femvi();
        cmd.arg(command).arg(&path).arg("--out").arg(out.path()).arg("--quiet");
        if command == "run" {
            cmd.arg("--plot");
        }
        let res = cmd.output().unwrap();
        assert!(
            res.status.success(),
            "{}: {}",
            path.display(),
            String::from_utf8_lossy(&res.stderr)
        );
        let csv = std::fs::read_to_string(out.path().join("trajectory.csv")).unwrap();
        assert!(csv.lines().count() > 10, "{}", path.display());
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
        assert!(summary["error"].is_null());
        if command == "bvp" {
            assert!(summary["residual_norm"].as_f64().unwrap() < 1e-12);
            count += 1;
            continue;
        }
        if command == "optimize" {
            assert!(summary["violation"].as_f64().unwrap() < 1e-10);
            count += 1;
            continue;
        }
        // Plots: valid SVG with drawn lines.
        let svgs: Vec<_> = std::fs::read_dir(out.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "svg"))
            .collect();
        assert!(svgs.len() >= 3, "{}: {} plots", path.display(), svgs.len());
        for svg in &svgs {
            assert_svg_has_lines(svg);
        }
        let energy_error = summary["max_rel_energy_error"].as_f64().unwrap();
        // The forced oscillator's energy is not conserved; the autonomous examples' is.
        let forced = path
            .file_stem()
            .is_some_and(|s| s == "variable-steps" || s == "forced-oscillator");
        assert!(
            energy_error.is_finite() && (forced || energy_error < 1e-2),
            "{}: {summary}",
            path.display()
        );
        count += 1;
    }
    assert!(count >= 17, "{count} examples");
}

#[test]
fn csv_numbers_read_back_exactly_and_match_the_summary() {
    let out = tempfile::tempdir().unwrap();
    femvi()
        .arg("run")
        .arg(examples().join("kepler.toml"))
        .arg("--out")
        .arg(out.path())
        .assert()
        .success();
    let csv = std::fs::read_to_string(out.path().join("trajectory.csv")).unwrap();
    assert!(csv.starts_with("step,t,x,y,p_x,p_y,energy\n"));
    let last: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    assert_eq!(last[2], summary["final_q"][0].as_f64().unwrap());
    assert_eq!(last[5], summary["final_p"][1].as_f64().unwrap());
    // Energy column: H = |p|²/2 − 1/|q| recomputed from the written state.
    let h = 0.5 * (last[4] * last[4] + last[5] * last[5]) - 1.0 / (last[2] * last[2] + last[3] * last[3]).sqrt();
    assert!((h - last[6]).abs() < 1e-15);
}

const GOOD: &str = r#"
[system]
coordinates = ["x"]
lagrangian = "0.5*x_dot^2 - 0.5*x^2"

[initial]
q = [1.0]
v = [0.0]

[time]
step = 0.1
end = 1.0
"#;

/// (name, file content, expected exit code, text the message must contain).
fn corpus() -> Vec<(&'static str, Vec<u8>, i32, &'static str)> {
    let g = |from: &str, to: &str| GOOD.replacen(from, to, 1).into_bytes();
    vec![
        ("empty", b"".to_vec(), 2, "empty"),
        // A NUL byte ends the read at once (issue 34: /dev/zero); without one, bytes that
        // are not UTF-8 are named so.
        ("garbage", vec![0xff, 0xfe, 0x00, 0x13, 0x80], 2, "NUL byte"),
        ("garbage-no-nul", vec![0xff, 0xfe, 0x13, 0x80], 2, "not UTF-8"),
        ("toml-syntax", g("step = 0.1", "step = = 0.1"), 2, "toml-syntax.toml:11:8:"),
        ("unknown-top-key", format!("nmae = \"x\"\n{GOOD}").into_bytes(), 2, "did you mean 'name'"),
        ("unknown-system-key", g("coordinates", "coordinate"), 2, "unknown field `coordinate`"),
        ("unknown-time-key", g("end = 1.0", "ned = 1.0"), 2, "ned"),
        ("unknown-initial-key", g("v = [0.0]", "vel = [0.0]"), 2, "vel"),
        ("unknown-scheme-key", format!("{GOOD}\n[scheme]\ndegre = 2\n").into_bytes(), 2, "degre"),
        ("unknown-solver-key", format!("{GOOD}\n[solver]\ntol = 1e-9\n").into_bytes(), 2, "tol"),
        ("unknown-output-key", format!("{GOOD}\n[output]\ndir = \"x\"\n").into_bytes(), 2, "dir"),
        ("unknown-table", format!("{GOOD}\n[extra]\na = 1\n").into_bytes(), 2, "extra"),
        ("bad-quadrature", format!("{GOOD}\n[scheme]\nquadrature = \"gauss\"\n").into_bytes(), 2, "gauss-legendre"),
        ("bad-kind", format!("{GOOD}\n[scheme]\nkind = \"fem\"\n").into_bytes(), 2, "galerkin"),
        ("degree-zero", format!("{GOOD}\n[scheme]\ndegree = 0\n").into_bytes(), 2, "degree"),
        ("odd-order", format!("{GOOD}\n[scheme]\norder = 7\n").into_bytes(), 2, "even number"),
        ("order-and-degree", format!("{GOOD}\n[scheme]\norder = 8\ndegree = 4\n").into_bytes(), 2, "order chooses"),
        ("degenerate-rule", format!("{GOOD}\n[scheme]\ndegree = 3\nquadrature = \"midpoint\"\n").into_bytes(), 2, "degenerate"),
        ("expr-syntax", g("0.5*x^2\"", "0.5*x^2 +\""), 2, ":4:"),
        ("expr-unknown-symbol", g("0.5*x^2", "0.5*y^2"), 2, "unknown symbol 'y'"),
        ("expr-unknown-function", g("0.5*x^2", "0.5*sine(x)"), 2, "unknown function 'sine'"),
        ("expr-arity", g("0.5*x^2", "atan2(x)"), 2, "takes 2 arguments"),
        ("expr-bad-char", g("0.5*x^2", "0.5*x#2"), 2, "unexpected character"),
        ("expr-empty", g("0.5*x_dot^2 - 0.5*x^2", ""), 2, "expected a number"),
        ("q-wrong-length", g("q = [1.0]", "q = [1.0, 2.0]"), 2, "q has 2 entries"),
        ("v-wrong-length", g("v = [0.0]", "v = []"), 2, "v has 0 entries"),
        ("q-not-numbers", g("q = [1.0]", "q = [\"a\"]"), 2, "invalid type"),
        ("q-missing", g("q = [1.0]\n", ""), 2, "missing field `q`"),
        ("v-and-p", g("v = [0.0]", "v = [0.0]\np = [0.0]"), 2, "exactly one of"),
        ("no-velocity", g("v = [0.0]", ""), 2, "exactly one of"),
        ("zero-step", g("step = 0.1", "step = 0.0"), 2, "positive"),
        ("negative-step", g("step = 0.1", "step = -0.1"), 2, "positive"),
        ("nan-step", g("step = 0.1", "step = nan"), 2, "positive"),
        ("bad-step-list", g("step = 0.1", "steps = [0.1, 0.0]"), 2, "positive"),
        ("step-and-steps", g("step = 0.1", "step = 0.1\nsteps = [0.1]"), 2, "exactly one of"),
        ("end-before-start", g("end = 1.0", "end = -1.0"), 2, "not after"),
        ("degenerate-lagrangian", g("0.5*x_dot^2 - 0.5*x^2", "x_dot - 0.5*x^2"), 2, "degenerate"),
        ("mass-not-positive", b"[system]\nmodel = \"harmonic\"\nparameters = { m = -1.0 }\n[initial]\nq = [1.0]\nv = [0.0]\n[time]\nstep = 0.1\nend = 1.0\n".to_vec(), 2, "positive definite"),
        ("unknown-model", b"[system]\nmodel = \"keplr\"\n[initial]\nq = [1.0, 0.0]\nv = [0.0, 1.0]\n[time]\nstep = 0.1\nend = 1.0\n".to_vec(), 2, "did you mean 'kepler'"),
        ("unknown-model-parameter", b"[system]\nmodel = \"kepler\"\nparameters = { nu = 1.0 }\n[initial]\nq = [1.0, 0.0]\nv = [0.0, 1.0]\n[time]\nstep = 0.1\nend = 1.0\n".to_vec(), 2, "no parameter 'nu'"),
        ("model-and-lagrangian", g("coordinates", "model = \"kepler\"\ncoordinates"), 2, "both"),
        ("no-coordinates", g("coordinates = [\"x\"]\n", ""), 2, "needs `coordinates`"),
        ("duplicate-coordinates", g("[\"x\"]", "[\"x\", \"x\"]"), 2, "twice"),
        ("param-clash", g("coordinates = [\"x\"]", "coordinates = [\"x\"]\nparameters = { x = 1.0 }"), 2, "name of a variable"),
        ("bad-tolerance", format!("{GOOD}\n[solver]\ntolerance = -1.0\n").into_bytes(), 2, "tolerance"),
        ("bad-iterations", format!("{GOOD}\n[solver]\nmax_iterations = 0\n").into_bytes(), 2, "max_iterations"),
        // A mass that depends on q (GOOD itself is mechanical: its expression takes the fixed point).
        ("fixed-point-general", format!("{}\n[solver]\nmethod = \"fixed-point\"\n", GOOD.replacen("0.5*x_dot^2", "0.5*(1 + x^2)*x_dot^2", 1)).into_bytes(), 2, "mechanical"),
        ("every-zero", format!("{GOOD}\n[output]\nevery = 0\n").into_bytes(), 2, "every"),
        ("energy-mode-steps-list", g("step = 0.1", "mode = \"energy\"\nsteps = [0.1]"), 2, "needs `step`"),
        ("energy-keys-in-fixed-mode", g("step = 0.1", "step = 0.1\nmin_step = 0.01"), 2, "only to mode"),
        ("energy-bad-bounds", g("step = 0.1", "mode = \"energy\"\nstep = 0.1\nmax_step = 0.05"), 2, "max_step"),
        ("energy-bad-policy", g("step = 0.1", "mode = \"energy\"\nstep = 0.1\non_degenerate = \"skip\""), 2, "fixed"),
        ("inf-initial", g("q = [1.0]", "q = [inf]"), 2, "non-finite"),
        ("no-initial", g("[initial]\nq = [1.0]\nv = [0.0]\n", ""), 2, "needs [initial] and [time]"),
        ("accuracy-and-step", g("step = 0.1", "step = 0.1\naccuracy = 1e-6"), 2, "exactly one of `step`, `steps` or `accuracy`"),
        ("accuracy-too-small", g("step = 0.1", "accuracy = 1e-14"), 2, "outside"),
        ("accuracy-negative", g("step = 0.1", "accuracy = -1e-6"), 2, "outside"),
        ("accuracy-energy-mode", g("step = 0.1", "mode = \"energy\"\nstep = 0.1\naccuracy = 1e-6"), 2, "uniform step"),
        ("accuracy-q1-start", GOOD.replacen("v = [0.0]", "q1 = [0.99]", 1).replacen("step = 0.1", "accuracy = 1e-6", 1).into_bytes(), 2, "fixes the first step"),
        ("boundary-in-run", format!("{GOOD}\n[boundary]\nt0 = 0.0\nq0 = [0.0]\nt1 = 1.0\nq1 = [0.0]\nelements = 4\n").into_bytes(), 2, "femvi bvp"),
    ]
}

#[test]
fn broken_inputs_give_clear_errors_and_no_panic() {
    let dir = tempfile::tempdir().unwrap();
    let corpus = corpus();
    assert!(corpus.len() >= 40);
    for (name, content, code, needle) in corpus {
        let path = dir.path().join(format!("{name}.toml"));
        std::fs::write(&path, content).unwrap();
        let res = femvi()
            .arg("run")
            .arg(&path)
            .arg("--out")
            .arg(dir.path().join(name))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&res.stderr);
        assert_eq!(res.status.code(), Some(code), "{name}: {err}");
        assert!(err.contains(needle), "{name}: message lacks '{needle}':\n{err}");
        assert!(
            !err.contains("panicked") && !err.contains("internal error"),
            "{name}: {err}"
        );
    }
}

#[test]
fn expression_errors_point_into_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    std::fs::write(&path, GOOD.replacen("0.5*x^2", "0.5*y^2", 1)).unwrap();
    let res = femvi().arg("run").arg(&path).output().unwrap();
    let err = String::from_utf8_lossy(&res.stderr);
    // Line 4 of the file, column of 'y' (after `lagrangian = "0.5*x_dot^2 - 0.5*`).
    assert!(
        err.contains("p.toml:4:33: in the lagrangian: unknown symbol 'y'"),
        "{err}"
    );
    assert!(err.contains(&format!("\n  {}^", " ".repeat(32))), "{err}");
}

#[test]
fn a_step_that_cannot_converge_is_a_numerical_failure_with_output_kept() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    // Kepler passing close to the centre with a huge step: the fixed-point iteration fails.
    let text = "[system]\nmodel = \"kepler\"\n[initial]\nq = [1.0, 0.0]\nv = [0.0, 0.1]\n[scheme]\ndegree = 3\n[time]\nstep = 0.5\nend = 100.0\n";
    std::fs::write(&path, text).unwrap();
    let out = dir.path().join("out");
    let res = femvi().arg("run").arg(&path).arg("--out").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&res.stderr);
    assert_eq!(res.status.code(), Some(1), "{err}");
    assert!(
        err.contains("step ") && err.contains("residual") && err.contains("hint"),
        "{err}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let steps = summary["steps"].as_u64().unwrap() as usize;
    assert!(summary["error"].as_str().unwrap().contains("step"));
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert_eq!(
        csv.lines().count(),
        steps + 2,
        "header, node 0 and one row per completed step"
    );
}

/// `[time] accuracy`: femvi picks degree and step, reports them, and the run meets the
/// accuracy (the harmonic oscillator x'' = −x from x = 1, v = 0: x(t) = cos t).
#[test]
fn accuracy_chooses_degree_and_step_and_reports_them() {
    let dir = tempfile::tempdir().unwrap();
    for accuracy in [1e-5, 1e-9] {
        let path = dir.path().join("p.toml");
        std::fs::write(
            &path,
            GOOD.replacen("step = 0.1", &format!("accuracy = {accuracy:e}"), 1)
                .replacen("end = 1.0", "end = 300.0", 1),
        )
        .unwrap();
        let out = dir.path().join("out");
        let res = femvi().arg("run").arg(&path).arg("--out").arg(&out).output().unwrap();
        let stdout = String::from_utf8_lossy(&res.stdout);
        assert!(res.status.success(), "{}", String::from_utf8_lossy(&res.stderr));
        assert!(
            stdout.contains(&format!("accuracy {accuracy:.1e}: degree ")),
            "{stdout}"
        );
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        let auto = &summary["auto_step"];
        let degree = auto["degree"].as_u64().unwrap() as usize;
        assert_eq!(degree, femvi::step::auto::degree_for_accuracy(accuracy));
        let step = auto["step"].as_f64().unwrap();
        let steps = summary["steps"].as_u64().unwrap() as f64;
        assert!((steps - (300.0 / step).ceil()).abs() <= 1.0, "{summary}");
        let error = (summary["final_q"][0].as_f64().unwrap() - 300f64.cos()).abs();
        assert!(
            error <= accuracy && error >= accuracy / 100.0,
            "{error:e} for {accuracy:e}"
        );
    }
}

#[test]
fn energy_mode_writes_the_discrete_energy() {
    let out = tempfile::tempdir().unwrap();
    femvi()
        .arg("run")
        .arg(examples().join("energy-henon-heiles.toml"))
        .arg("--out")
        .arg(out.path())
        .assert()
        .success();
    let csv = std::fs::read_to_string(out.path().join("trajectory.csv")).unwrap();
    assert!(csv.starts_with("step,t,x,y,p_x,p_y,energy,discrete_energy\n"));
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    // Node 0 precedes the first element: its discrete energy is not defined yet (NaN).
    let e1 = rows[1][7];
    assert!(rows[1..].iter().all(|r| r[7] == e1), "the discrete energy is conserved");
    let t_end = rows.last().unwrap()[1];
    assert!(
        t_end >= 50.0 && rows[rows.len() - 2][1] < 50.0,
        "stops at the first node at or past the end"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    assert!(summary["max_rel_discrete_energy_error"].as_f64().unwrap() < 1e-13);
    assert_eq!(summary["degenerate_steps"].as_u64(), Some(0));
    assert!(summary["min_step"].as_f64().unwrap() > 0.0);
}

const BVP: &str = r#"
[system]
model = "pendulum"

[boundary]
t0 = 0.0
q0 = [0.1]
t1 = 5.0
q1 = [0.1]
elements = 100

[scheme]
degree = 2
"#;

#[test]
fn bvp_from_a_guess_file_and_its_errors() {
    let dir = tempfile::tempdir().unwrap();
    // A guess file with a large swing: the second solution of the pendulum.
    let mut guess = String::from("step,t,theta\n");
    for k in 0..=50 {
        let t = 0.1 * k as f64;
        guess.push_str(&format!(
            "{k},{t},{}\n",
            0.1 + 2.5 * (std::f64::consts::PI * t / 5.0).sin()
        ));
    }
    std::fs::write(dir.path().join("swing.csv"), guess).unwrap();
    let straight = dir.path().join("straight.toml");
    std::fs::write(&straight, BVP).unwrap();
    let swing = dir.path().join("swing.toml");
    std::fs::write(
        &swing,
        BVP.replace("elements = 100", "elements = 100\nguess = \"swing.csv\""),
    )
    .unwrap();
    let mut actions = vec![];
    for (name, path) in [("a", &straight), ("b", &swing)] {
        let out = dir.path().join(name);
        femvi().arg("bvp").arg(path).arg("--out").arg(&out).assert().success();
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        assert!(s["residual_norm"].as_f64().unwrap() <= 1e-12);
        assert_eq!(s["elements"].as_u64(), Some(100));
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        assert_eq!(csv.lines().count(), 102, "header and t_0 … t_100");
        actions.push(s["action"].as_f64().unwrap());
    }
    assert!((actions[0] - actions[1]).abs() > 1e-3, "two solutions: {actions:?}");
    // Errors: a run-style file, a bad guess file, energy mode, no solution (exit 1).
    let cases: Vec<(&str, String, i32, &str)> = vec![
        ("ivp.toml", BVP.replace("[boundary]", "[initial]\nq = [0.1]\nv = [0.0]\n[time]\nstep = 0.1\nend = 1.0\n[boundary]"), 2, "instead of [initial]"),
        ("noguess.toml", BVP.replace("elements = 100", "elements = 100\nguess = \"missing.csv\""), 2, "cannot read the guess"),
        ("mode.toml", BVP.replace("elements = 100", "elements = 100\ntime_mode = \"moving\""), 2, "time_mode"),
        // Degree 2: the time equations are nearly singular; a typed failure with its hint.
        ("energy.toml", BVP.replace("elements = 100", "elements = 100\ntime_mode = \"energy\""), 1, "moving mesh"),
        ("zero.toml", BVP.replace("elements = 100", "elements = 0"), 2, "at least one element"),
        ("length.toml", BVP.replace("q1 = [0.1]", "q1 = [0.1, 0.2]"), 2, "boundary q1"),
        (
            "bratu.toml",
            "[system]\ncoordinates = [\"u\"]\nlagrangian = \"0.5*u_dot^2 - 5*exp(u)\"\n[boundary]\nt0 = 0.0\nq0 = [0.0]\nt1 = 1.0\nq1 = [0.0]\nelements = 50\n".to_string(),
            1,
            "Newton",
        ),
    ];
    for (name, text, code, needle) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        let res = femvi()
            .arg("bvp")
            .arg(&path)
            .arg("--out")
            .arg(dir.path().join("o"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&res.stderr);
        assert_eq!(res.status.code(), Some(code), "{name}: {err}");
        assert!(err.contains(needle), "{name}: {err}");
        assert!(!err.contains("panicked"));
    }
}

#[test]
fn models_lists_and_prints_runnable_problem_files() {
    let out = femvi().arg("models").output().unwrap();
    assert!(out.status.success());
    let list = String::from_utf8_lossy(&out.stdout);
    for m in femvi::models::MODELS {
        assert!(list.contains(m.name), "{} missing from the list", m.name);
    }
    let dir = tempfile::tempdir().unwrap();
    for m in femvi::models::MODELS {
        let text = femvi().args(["models", m.name]).output().unwrap();
        assert!(text.status.success(), "{}", m.name);
        let path = dir.path().join(format!("{}.toml", m.name));
        std::fs::write(&path, &text.stdout).unwrap();
        let res = femvi()
            .arg("run")
            .arg(&path)
            .arg("--out")
            .arg(dir.path().join(m.name))
            .arg("--quiet")
            .output()
            .unwrap();
        assert!(
            res.status.success(),
            "{}: {}",
            m.name,
            String::from_utf8_lossy(&res.stderr)
        );
    }
    let bad = femvi().args(["models", "keplr"]).output().unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("did you mean 'kepler'"));
}

#[test]
fn npy_output_equals_the_csv_bit_for_bit() {
    let out = tempfile::tempdir().unwrap();
    femvi()
        .arg("run")
        .arg(examples().join("energy-henon-heiles.toml"))
        .args(["--format", "csv,npy", "--quiet", "--out"])
        .arg(out.path())
        .assert()
        .success();
    let csv = std::fs::read_to_string(out.path().join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let values: Vec<f64> = lines
        .flat_map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect::<Vec<_>>())
        .collect();
    let columns = std::fs::read_to_string(out.path().join("columns.txt")).unwrap();
    assert_eq!(columns.lines().collect::<Vec<_>>(), header);
    let bytes = std::fs::read(out.path().join("trajectory.npy")).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    assert_eq!(
        npy.shape(),
        &[(values.len() / header.len()) as u64, header.len() as u64]
    );
    let data: Vec<f64> = npy.into_vec().unwrap();
    assert_eq!(data.len(), values.len());
    for (a, b) in data.iter().zip(&values) {
        // Bit for bit (NaN, the discrete energy before the first element, compares by bits too).
        assert_eq!(a.to_bits(), b.to_bits(), "{a} vs {b}");
    }
    // NPY alone: no CSV written.
    let only = tempfile::tempdir().unwrap();
    femvi()
        .arg("run")
        .arg(examples().join("kepler.toml"))
        .args(["--format", "npy", "--out"])
        .arg(only.path())
        .assert()
        .success();
    assert!(only.path().join("trajectory.npy").exists() && !only.path().join("trajectory.csv").exists());
}

#[test]
fn no_progress_bar_without_a_terminal_or_with_quiet() {
    // stderr is a pipe here, so no bar may appear, even in a run long enough (over a second) that
    // a terminal would show one. Machines differ in speed: the run is lengthened until it takes
    // more than a second, so that the assertion on stderr could fail.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.toml");
    let mut end = 100.0;
    for quiet in [false, true] {
        loop {
            std::fs::write(
                &path,
                format!(
                    "[system]\nmodel = \"double-pendulum\"\n[initial]\nq = [1.0, 0.5]\nv = [0.0, 0.0]\n[scheme]\ndegree = 3\n[time]\nstep = 0.001\nend = {end:?}\n[output]\nevery = 1000\n"
                ),
            )
            .unwrap();
            let mut cmd = femvi();
            cmd.arg("run").arg(&path).arg("--out").arg(dir.path().join("o"));
            if quiet {
                cmd.arg("--quiet");
            }
            let start = std::time::Instant::now();
            let res = cmd.output().unwrap();
            assert!(res.status.success());
            if start.elapsed().as_secs_f64() <= 1.5 {
                assert!(end < 1e5, "the run never took longer than a second");
                end *= 4.0;
                continue;
            }
            assert!(
                res.stderr.is_empty(),
                "stderr: {}",
                String::from_utf8_lossy(&res.stderr)
            );
            assert_eq!(res.stdout.is_empty(), quiet);
            break;
        }
    }
}

/// Parses an SVG file and checks that it draws at least one line of several points.
fn assert_svg_has_lines(path: &Path) {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    let longest = doc
        .descendants()
        .filter(|n| n.tag_name().name() == "polyline")
        .map(|n| n.attribute("points").unwrap_or("").split_whitespace().count())
        .max()
        .unwrap_or(0);
    assert!(longest >= 2, "{}: no drawn line", path.display());
}

#[test]
fn convergence_plot_is_valid_svg() {
    let dir = tempfile::tempdir().unwrap();
    femvi()
        .arg("convergence")
        .arg(examples().join("models/harmonic.toml"))
        .args(["--steps", "0.2,0.1,0.05", "--l2", "--plot", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    assert_svg_has_lines(&dir.path().join("convergence.svg"));
}

#[test]
fn scheme_order_picks_the_gauss_element() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("o.toml");
    std::fs::write(&path, format!("{GOOD}\n[scheme]\norder = 8\n")).unwrap();
    let out = femvi()
        .arg("run")
        .arg(&path)
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(out.status.success());
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        s["scheme"].as_str(),
        Some("galerkin degree 4, Equispaced nodes, GaussLegendre(4)")
    );
}

#[test]
fn png_plots() {
    let dir = tempfile::tempdir().unwrap();
    femvi()
        .arg("run")
        .arg(examples().join("models/pendulum.toml"))
        .args(["--plot", "--plot-format", "png", "--quiet", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    for name in ["coordinates", "phase_theta", "energy_error"] {
        let bytes = std::fs::read(dir.path().join(format!("{name}.png"))).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{name}");
        let width = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
        let height = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
        assert_eq!((width, height), (900, 540));
        assert!(bytes.len() > 10_000, "{name}: {} bytes", bytes.len());
    }
    let bad = femvi()
        .arg("run")
        .arg(examples().join("models/pendulum.toml"))
        .args(["--plot-format", "jpg"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn a_closed_standard_output_stops_quietly_after_the_files_are_written() {
    // `femvi run p.toml | head -0`: the reader is gone before femvi prints its summary line.
    let out = tempfile::tempdir().unwrap();
    let bin = assert_cmd::cargo::cargo_bin("femvi");
    let mut child = std::process::Command::new(bin)
        .arg("run")
        .arg(examples().join("pendulum.toml"))
        .arg("--out")
        .arg(out.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let result = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(!err.contains("internal error"), "{err}");
    assert_eq!(result.status.code(), Some(141), "{err}");
    let summary = std::fs::read_to_string(out.path().join("summary.json")).unwrap();
    assert!(summary.contains("\"status\": \"done\""), "{summary}");
}
