//! `[forces]` together with `[constraints]` through `femvi run` (issue 19): the damped, driven
//! spherical pendulum example (constraint residual recomputed from the written positions, the
//! `work` column against the energy, summary.json's balance, the final state against the
//! library's run built by hand), a zero force written out equal to no force, the
//! `femvi models` entry, and input errors refused with exit code 2.

use assert_cmd::Command;
use femvi::constraints::{solve_constrained_forced, Enforcement, ExprConstraints};
use femvi::expr::ExprLagrangian;
use femvi::forces::ExprForces;
use femvi::{Element, Problem, SolveOptions, Start};
use std::path::{Path, PathBuf};

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/constrained/damped-spherical-pendulum.toml")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

/// Rows of a trajectory.csv (header, values).
fn read_csv(dir: &Path) -> (String, Vec<Vec<f64>>) {
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn damped_spherical_pendulum_runs_on_the_sphere_with_its_work() {
    let out = tempfile::tempdir().unwrap();
    femvi()
        .args(["run", "--quiet", "--set", "time.end=5.0"])
        .arg(example())
        .arg("--out")
        .arg(out.path())
        .assert()
        .success();
    let (header, rows) = read_csv(out.path());
    assert_eq!(header, "step,t,x,y,z,p_x,p_y,p_z,energy,work,lambda_1,residual");
    assert_eq!(rows.len(), 501);
    let (h0, mut worst) = (rows[0][8], 0.0f64);
    for v in &rows {
        let g = v[2] * v[2] + v[3] * v[3] + v[4] * v[4] - 1.0;
        assert!(g.abs() <= 1e-13 && (v[11] - g.abs()).abs() <= 1e-15, "{v:?}");
        worst = worst.max((v[8] - h0 - v[9]).abs() / h0.abs());
    }
    let last = &rows[rows.len() - 1];
    // The friction takes energy: H falls by several units over 5 s, as the work says.
    assert!(last[8] - h0 < -1.0 && last[9] < -1.0, "{last:?}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    let balance = summary["max_rel_energy_balance_error"].as_f64().unwrap();
    println!("balance over the written nodes {worst:.2e}, over every node {balance:.2e}");
    assert!(worst <= balance && balance < 1e-6, "{worst} {balance}");
    assert_eq!(summary["final_work"].as_f64().unwrap(), last[9]);
    assert_eq!(summary["energy_conserved"], false);
    let constraints: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("constraints.json")).unwrap()).unwrap();
    assert!(constraints["max_residual"].as_f64().unwrap() <= 1e-13);

    // The same problem through the library, written out by hand: the friction as a
    // generalized force −c v instead of the Rayleigh function's derivative.
    let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z", &xyz, &[]).unwrap();
    let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[]).unwrap();
    let force = ExprForces::new(&["-0.3*x_dot + 0.5*cos(2.5*t)", "-0.3*y_dot", "-0.3*z_dot"], &xyz, &[]).unwrap();
    let start = Start::Velocity {
        q: rows[0][2..5].to_vec(),
        v: vec![0.0, 1.682941969615793, 0.0],
    };
    let run = solve_constrained_forced(
        &Problem::new(lag, start, 0.0, 5.0),
        &force,
        &sphere,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.01),
        Enforcement::default(),
    )
    .unwrap();
    let sol = &run.constrained.solution;
    let q = sol.q_row(sol.len() - 1).unwrap();
    let dq = q
        .iter()
        .zip(&last[2..5])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let dw = (run.work[run.work.len() - 1] - last[9]).abs();
    assert!(dq <= 1e-12 && dw <= 1e-12, "{dq} {dw}");
}

/// Runs `femvi run` on a problem text; (exit code, stderr, out dir).
fn run_text(text: &str, extra: &[&str]) -> (i32, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("problem.toml");
    std::fs::write(&file, text).unwrap();
    let res = femvi()
        .args(["run", "--quiet"])
        .args(extra)
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

/// The example without its `[forces]` table.
fn unforced() -> String {
    let text = std::fs::read_to_string(example()).unwrap();
    let start = text.find("\n[forces]").unwrap();
    let end = text.find("\n[initial]").unwrap();
    format!("{}{}", &text[..start], &text[end..])
}

#[test]
fn zero_force_writes_the_unforced_trajectory() {
    // Forces take dense Newton; so does the plain run with `method = "newton"` (with the
    // default it takes the fixed point of the library's `constraints/shake/`).
    let plain = format!("{}\n[solver]\nmethod = \"newton\"\n", unforced());
    let zero = plain.replace(
        "\n[initial]",
        "\n[forces]\ngeneralized = [\"0\", \"0\", \"0\"]\n\n[initial]",
    );
    let set = ["--set", "time.end=3.0"];
    let (code_a, err_a, a) = run_text(&plain, &set);
    let (code_b, err_b, b) = run_text(&zero, &set);
    assert!(code_a == 0 && code_b == 0, "{err_a} {err_b}");
    let (ha, ra) = read_csv(&a.path().join("out"));
    let (hb, rb) = read_csv(&b.path().join("out"));
    assert_eq!(ha.replace(",energy,", ",energy,work,"), hb);
    assert_eq!(ra.len(), rb.len());
    for (x, y) in ra.iter().zip(&rb) {
        // Every column but the work (0) written bit for bit.
        assert_eq!(y[9], 0.0);
        let y: Vec<f64> = y[..9].iter().chain(&y[10..]).copied().collect();
        assert_eq!(
            x.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            y.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
    }
}

#[test]
fn models_prints_the_example() {
    let out = femvi().args(["models", "damped-spherical-pendulum"]).output().unwrap();
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        std::fs::read_to_string(example()).unwrap()
    );
    let list = femvi().arg("models").output().unwrap();
    assert!(String::from_utf8_lossy(&list.stdout).contains("damped-spherical-pendulum"));
}

#[test]
fn bad_input_with_both_tables_is_refused() {
    let text = std::fs::read_to_string(example()).unwrap();
    let cases: [(String, &[&str], &str); 4] = [
        (
            text.replace(
                "generalized = [\"f0*cos(w*t)\", \"0\", \"0\"]",
                "generalized = [\"0\", \"0\"]",
            ),
            &[],
            "2 expressions for 3 coordinates",
        ),
        (
            text.replace("q = [0.8414709848078965,", "q = [0.9,"),
            &[],
            "violates the constraints",
        ),
        (
            text.clone(),
            &["--set", "time.mode=\"energy\""],
            "mode = \"energy\" is not available with [constraints]",
        ),
        (
            text.replace("dissipation = ", "dissipation = \"0.5*c*x_dot^2 + u\"\n# "),
            &[],
            "unknown symbol 'u'",
        ),
    ];
    for (case, extra, needle) in &cases {
        let (code, err, _dir) = run_text(case, extra);
        assert!(code == 2 && err.contains(needle), "{needle}: code {code}, {err}");
    }
}
