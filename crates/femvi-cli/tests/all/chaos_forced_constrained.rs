//! `femvi chaos` on problems with `[forces]` and `[constraints]`: one orbit's indicators as
//! JSON equal to the library's (femvi::chaos::forced_indicators / constrained_indicators) on
//! the same problem (also with both tables: forced_constrained_indicators), summary.json with
//! `--out`, maps (`--grid`) equal to one-orbit runs, and bad input.

use assert_cmd::Command;
use femvi::chaos::{
    constrained_indicators, forced_constrained_indicators, forced_indicators, ChaosOptions, ChaosReport,
};
use femvi::constraints::{Enforcement, ExprConstraints};
use femvi::expr::ExprLagrangian;
use femvi::forces::ExprForces;
use femvi::{Element, Problem, SolveOptions, Start};

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

const DRIVEN: &str = r#"
[system]
coordinates = ["x"]
parameters = { k = 1.0, c = 0.2, f0 = 0.5, w = 1.3 }
lagrangian = "0.5*x_dot^2 - 0.5*k*x^2"
[forces]
generalized = ["-c*x_dot + f0*cos(w*t)"]
[initial]
q = [0.3]
v = [0.0]
[scheme]
order = 4
[time]
step = 0.05
end = 30.0
"#;

const SPHERE: &str = r#"
[system]
coordinates = ["x", "y", "z"]
parameters = { g = 1.0 }
lagrangian = "0.5*(x_dot^2 + y_dot^2 + z_dot^2) - g*z"
[constraints]
holonomic = ["x^2 + y^2 + z^2 - 1"]
[initial]
q = [0.6, 0.0, -0.8]
v = [0.0, 0.7, 0.0]
[scheme]
order = 4
[time]
step = 0.1
end = 50.0
"#;

/// Runs `femvi chaos FILE --json --indicator megno,lyapunov,fli,spectrum --out DIR/out` (and
/// `extra`) on `text`: (exit code, stdout, stderr, DIR).
fn chaos(text: &str, extra: &[&str]) -> (i32, String, String, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("problem.toml");
    std::fs::write(&path, text).unwrap();
    let out = femvi()
        .args([
            "chaos",
            path.to_str().unwrap(),
            "--json",
            "--indicator",
            "megno,lyapunov,fli,spectrum",
        ])
        .arg("--out")
        .arg(dir.path().join("out"))
        .args(extra)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        dir,
    )
}

/// The printed indicators equal the library's report (read with the standard parser).
fn assert_equal(text: &str, r: &ChaosReport, dim: usize) {
    let raw = |key: &str| -> f64 {
        let at = text.find(&format!("\"{key}\": ")).unwrap() + key.len() + 4;
        let end = text[at..].find([',', '\n']).unwrap();
        text[at..at + end].trim().parse().unwrap()
    };
    assert_eq!(raw("megno"), r.last.mean_megno);
    assert_eq!(raw("lyapunov"), r.last.lyapunov);
    assert_eq!(raw("fli"), r.last.fli);
    let v: serde_json::Value = serde_json::from_str(text).unwrap();
    let got = v["spectrum"].as_array().unwrap();
    assert_eq!(got.len(), dim);
    for (g, want) in got.iter().zip(r.spectrum.as_ref().unwrap()) {
        assert!((g.as_f64().unwrap() - want).abs() <= 4.0 * f64::EPSILON * want.abs());
    }
    assert_eq!(v["steps"].as_u64().unwrap() as usize, r.steps);
}

fn spectrum() -> ChaosOptions {
    ChaosOptions {
        spectrum: true,
        ..ChaosOptions::default()
    }
}

#[test]
fn a_forced_orbit_as_json_equals_the_library() {
    let (code, out, err, _d) = chaos(DRIVEN, &[]);
    assert_eq!(code, 0, "{err}");
    let x = vec!["x".to_string()];
    let params = [("k", 1.0), ("c", 0.2), ("f0", 0.5), ("w", 1.3)].map(|(k, v)| (k.to_string(), v));
    let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*k*x^2", &x, &params).unwrap();
    let force = ExprForces::new(&["-c*x_dot + f0*cos(w*t)"], &x, &params).unwrap();
    let start = Start::Velocity {
        q: vec![0.3],
        v: vec![0.0],
    };
    let problem = Problem::new(lag, start, 0.0, 30.0);
    let el = Element::with_order(4).unwrap();
    let r = forced_indicators(&problem, &force, &el, &SolveOptions::step(0.05), &spectrum()).unwrap();
    assert_equal(&out, &r, 2);
    assert_eq!(r.steps, 600);
}

#[test]
fn a_constrained_orbit_as_json_equals_the_library_and_writes_a_summary() {
    let (code, out, err, dir) = chaos(SPHERE, &[]);
    assert_eq!(code, 0, "{err}");
    let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let params = [("g".to_string(), 1.0)];
    let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - g*z", &xyz, &params).unwrap();
    let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &params).unwrap();
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.0, 0.7, 0.0],
    };
    let problem = Problem::new(lag, start, 0.0, 50.0);
    let el = Element::with_order(4).unwrap();
    let options = SolveOptions::step(0.1);
    let r = constrained_indicators(&problem, &sphere, &el, &options, Enforcement::default(), &spectrum()).unwrap();
    // 2(n − m) = 4 exponents on the manifold.
    assert_equal(&out, &r, 4);
    let out_dir = dir.path().join("out");
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out_dir.join(name)).unwrap()).unwrap()
    };
    let (summary, json) = (read("summary.json"), read("chaos.json"));
    assert_eq!(summary["chaos"]["megno"], json["megno"]);
    assert_eq!(summary["steps"].as_u64().unwrap(), 500);
    let q = summary["final_q"].as_array().unwrap();
    let norm: f64 = q.iter().map(|x| x.as_f64().unwrap().powi(2)).sum();
    assert!((norm - 1.0).abs() < 1e-12, "{norm}");
}

#[test]
fn both_tables_give_the_forced_constrained_indicators_and_a_start_off_the_manifold_fails() {
    let both = SPHERE.replace(
        "[initial]",
        "[forces]\ngeneralized = [\"0\", \"0\", \"-0.1*z_dot\"]\n[initial]",
    );
    let (code, out, err, _d) = chaos(&both, &[]);
    assert_eq!(code, 0, "{err}");
    let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let params = [("g".to_string(), 1.0)];
    let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - g*z", &xyz, &params).unwrap();
    let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &params).unwrap();
    let force = ExprForces::new(&["0", "0", "-0.1*z_dot"], &xyz, &params).unwrap();
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.0, 0.7, 0.0],
    };
    let problem = Problem::new(lag, start, 0.0, 50.0);
    let el = Element::with_order(4).unwrap();
    let r = forced_constrained_indicators(
        &problem,
        &force,
        &sphere,
        &el,
        &SolveOptions::step(0.1),
        Enforcement::default(),
        &spectrum(),
    )
    .unwrap();
    assert_equal(&out, &r, 4);
    // A start off the manifold: the orbit fails (exit code 1, as a failed start of an
    // unconstrained problem), its error naming the residual.
    let off = SPHERE.replace("q = [0.6, 0.0, -0.8]", "q = [0.6, 0.0, -0.9]");
    let (code, out, _, _d) = chaos(&off, &[]);
    assert_eq!(code, 1);
    assert!(out.contains("violates the constraints"), "{out}");
}

/// The MEGNO column of chaos_map.csv.
fn megno_column(dir: &std::path::Path) -> Vec<f64> {
    let text = std::fs::read_to_string(dir.join("out").join("chaos_map.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "megno").unwrap();
    lines.map(|l| l.split(',').nth(col).unwrap().parse().unwrap()).collect()
}

#[test]
fn maps_equal_one_orbit_runs_of_the_library() {
    // Forced: a start axis and a parameter axis (the damping c, also in the force).
    let (code, _, err, dir) = chaos(
        DRIVEN,
        &["--grid", "x=0.1:0.5:3", "--grid", "c=0.1:0.3:2", "--threads", "2"],
    );
    assert_eq!(code, 0, "{err}");
    let got = megno_column(dir.path());
    assert_eq!(got.len(), 6);
    let x = vec!["x".to_string()];
    let el = Element::with_order(4).unwrap();
    for (i, g) in got.iter().enumerate() {
        let (x0, c) = (0.1 + 0.2 * (i % 3) as f64, 0.1 + 0.2 * (i / 3) as f64);
        let params = [("k", 1.0), ("c", c), ("f0", 0.5), ("w", 1.3)].map(|(k, v)| (k.to_string(), v));
        let lag = ExprLagrangian::new("0.5*x_dot^2 - 0.5*k*x^2", &x, &params).unwrap();
        let force = ExprForces::new(&["-c*x_dot + f0*cos(w*t)"], &x, &params).unwrap();
        let start = Start::Velocity {
            q: vec![x0],
            v: vec![0.0],
        };
        let problem = Problem::new(lag, start, 0.0, 30.0);
        let r = forced_indicators(&problem, &force, &el, &SolveOptions::step(0.05), &spectrum()).unwrap();
        assert_eq!(*g, r.last.mean_megno, "point {i}");
    }
    // Constrained: a velocity axis.
    let (code, _, err, dir) = chaos(SPHERE, &["--grid", "y_dot=0.5:0.9:3"]);
    assert_eq!(code, 0, "{err}");
    let got = megno_column(dir.path());
    let xyz: Vec<String> = ["x", "y", "z"].iter().map(|s| s.to_string()).collect();
    let params = [("g".to_string(), 1.0)];
    for (i, g) in got.iter().enumerate() {
        let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - g*z", &xyz, &params).unwrap();
        let sphere = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &params).unwrap();
        let start = Start::Velocity {
            q: vec![0.6, 0.0, -0.8],
            v: vec![0.0, 0.5 + 0.2 * i as f64, 0.0],
        };
        let problem = Problem::new(lag, start, 0.0, 50.0);
        let r = constrained_indicators(
            &problem,
            &sphere,
            &el,
            &SolveOptions::step(0.1),
            Enforcement::default(),
            &spectrum(),
        )
        .unwrap();
        assert_eq!(*g, r.last.mean_megno, "point {i}");
    }
}
