//! `femvi ensemble`: each member equals `femvi run` of the same problem with that member's
//! initial state or parameter value, bit for bit; bad input is exit 2; a failing member is
//! exit 1 with its error in its row and the others intact.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn kepler() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/kepler.toml")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

/// The rows of ensemble.csv as strings (header first).
fn rows(dir: &Path) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_path(dir.join("ensemble.csv")).unwrap();
    let mut all = vec![r.headers().unwrap().iter().map(String::from).collect()];
    all.extend(r.records().map(|x| x.unwrap().iter().map(String::from).collect()));
    all
}

/// `femvi run` of kepler.toml with `set` overrides: (final_q, final_p) from summary.json.
fn single(set: &[String]) -> (Vec<f64>, Vec<f64>) {
    let out = tempfile::tempdir().unwrap();
    let mut cmd = femvi();
    cmd.arg("run").arg(kepler()).arg("--out").arg(out.path()).arg("--quiet");
    for s in set {
        cmd.arg("--set").arg(s);
    }
    cmd.assert().success();
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    let v = |k: &str| s[k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    (v("final_q"), v("final_p"))
}

fn numbers(row: &[String], range: std::ops::Range<usize>) -> Vec<f64> {
    row[range].iter().map(|x| x.parse().unwrap()).collect()
}

#[test]
fn members_equal_single_runs() {
    let dir = tempfile::tempdir().unwrap();
    let states = dir.path().join("states.csv");
    std::fs::write(&states, "x,y,p_x,p_y\n0.4,0,0,2\n0.5,0,0,1.8\n0.6,0.1,-0.2,1.5\n").unwrap();
    let out = dir.path().join("out");
    femvi()
        .args([
            "ensemble",
            "--set",
            "time.end=5",
            "--workers",
            "2",
            "--quiet",
            "--states",
        ])
        .arg(&states)
        .arg(kepler())
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let r = rows(&out);
    assert_eq!(
        r[0],
        [
            "member",
            "final_t",
            "x",
            "y",
            "p_x",
            "p_y",
            "energy_error",
            "steps",
            "error"
        ]
    );
    assert_eq!(r.len(), 4);
    for (i, (q, p)) in [
        ("[0.4,0]", "[0,2]"),
        ("[0.5,0]", "[0,1.8]"),
        ("[0.6,0.1]", "[-0.2,1.5]"),
    ]
    .iter()
    .enumerate()
    {
        let set = [
            "time.end=5".to_string(),
            format!("initial.q={q}"),
            format!("initial.p={p}"),
        ];
        let (fq, fp) = single(&set);
        let row = &r[i + 1];
        assert_eq!(row[0], i.to_string());
        assert_eq!(numbers(row, 2..4), fq, "member {i}");
        assert_eq!(numbers(row, 4..6), fp, "member {i}");
        assert_eq!(row[8], "");
    }
    // The NPY table has the same numbers.
    let bytes = std::fs::read(out.join("ensemble.npy")).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    assert_eq!(npy.shape(), &[3, 8]);
    let v: Vec<f64> = npy.into_vec().unwrap();
    assert_eq!(v[8 + 2], r[2][2].parse::<f64>().unwrap());
}

#[test]
fn a_parameter_axis_equals_single_runs() {
    let dir = tempfile::tempdir().unwrap();
    femvi()
        .args(["ensemble", "--set", "time.end=3", "--quiet", "--param", "mu=0.9:1.1:3"])
        .arg(kepler())
        .arg("--out")
        .arg(dir.path())
        .assert()
        .success();
    let r = rows(dir.path());
    for (i, mu) in ["0.9", "1.0", "1.1"].iter().enumerate() {
        let (fq, _) = single(&["time.end=3".to_string(), format!("system.parameters.mu={mu}")]);
        assert_eq!(numbers(&r[i + 1], 2..4), fq, "mu = {mu}");
    }
}

#[test]
fn bad_input_is_exit_2_and_a_failing_member_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let states = dir.path().join("s.csv");
    std::fs::write(&states, "0.4,0,0\n").unwrap();
    let run = |args: &[&str]| {
        let mut cmd = femvi();
        cmd.arg("ensemble")
            .arg(kepler())
            .args(args)
            .arg("--quiet")
            .arg("--out")
            .arg(dir.path());
        cmd.output().unwrap()
    };
    for args in [
        vec!["--states", states.to_str().unwrap()],
        vec!["--param", "nope=1:2:3"],
        vec!["--param", "mu=1:2"],
        vec![],
    ] {
        let o = run(&args);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    }
    // Kepler through the centre (q = 0 for one member): that member fails, the other runs.
    std::fs::write(&states, "0.4,0,0,2\n0,0,0,0\n").unwrap();
    let o = run(&["--states", states.to_str().unwrap(), "--set", "time.end=1"]);
    assert_eq!(o.status.code(), Some(1), "{}", String::from_utf8_lossy(&o.stderr));
    let r = rows(dir.path());
    assert_eq!(r[1][8], "");
    assert!(!r[2][8].is_empty());
}

/// `femvi run` with `set`: (final_t, final_q, final_p, max_rel_energy_error, steps, error).
fn summary(set: &[String]) -> (f64, Vec<f64>, Vec<f64>, f64, usize, Option<String>) {
    let out = tempfile::tempdir().unwrap();
    let mut cmd = femvi();
    cmd.arg("run").arg(kepler()).arg("--out").arg(out.path()).arg("--quiet");
    for s in set {
        cmd.arg("--set").arg(s);
    }
    let _ = cmd.output().unwrap();
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("summary.json")).unwrap()).unwrap();
    let v = |k: &str| {
        s[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap_or(f64::NAN))
            .collect()
    };
    let e = s["max_rel_energy_error"].as_f64().unwrap_or(f64::NAN);
    let error = s["error"].as_str().map(String::from);
    (
        s["final_t"].as_f64().unwrap(),
        v("final_q"),
        v("final_p"),
        e,
        s["steps"].as_u64().unwrap() as usize,
        error,
    )
}

/// Störmer–Verlet (degree 1, trapezoid) and the fixed-point step of degree 2 take the
/// members eight at a time in SIMD lanes: eleven members (a chunk and a partial one), one of
/// which fails at its start (its energy overflows), each equal bit for bit to its run member
/// by member (`femvi_cli::ensemble::run_member`, the path of other schemes: the final node,
/// the energy error over every node, the steps, the error) and, where it does not fail, to
/// `femvi run` of its start.
#[test]
fn members_in_lanes_equal_single_runs() {
    // Störmer–Verlet, and degree 2 with 2-point Gauss–Legendre (the fixed-point lanes).
    lanes_against_single_runs(&["scheme.degree=1", "scheme.quadrature=trapezoid"]);
    lanes_against_single_runs(&["scheme.degree=2", "scheme.quadrature=gauss-legendre"]);
}

/// `femvi ensemble --states` of Kepler members with `scheme` against `run_member` and
/// `femvi run` of each start.
fn lanes_against_single_runs(scheme: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let states = dir.path().join("states.csv");
    let mut rows_in: Vec<[f64; 4]> = (0..10)
        .map(|i| [0.4 + 0.05 * i as f64, 0.0, 0.0, 1.2 + 0.1 * i as f64])
        .collect();
    // So fast that |p|² overflows: the energy is not finite at the start, where the member
    // ends with no node (as `femvi run` does).
    rows_in.insert(6, [0.5, 0.0, 0.0, 1.7e308]);
    let text: String = rows_in
        .iter()
        .map(|r| format!("{:?},{:?},{:?},{:?}\n", r[0], r[1], r[2], r[3]))
        .collect();
    std::fs::write(&states, text).unwrap();
    let settings: Vec<&str> = scheme.iter().copied().chain(["time.end=4", "time.step=0.01"]).collect();
    let out = dir.path().join("out");
    let mut cmd = femvi();
    cmd.args(["ensemble", "--workers", "2", "--quiet", "--states"])
        .arg(&states)
        .arg(kepler());
    for s in &settings {
        cmd.arg("--set").arg(s);
    }
    let status = cmd.arg("--out").arg(&out).output().unwrap().status;
    let r = rows(&out);
    assert_eq!(r.len(), 12);
    let set: Vec<String> = settings.iter().map(|x| x.to_string()).collect();
    let problem = femvi_cli::problem::load_with(&kepler(), &set).unwrap();
    let mut failed = 0;
    for (i, s) in rows_in.iter().enumerate() {
        let start = femvi::Start::Momentum {
            q: s[..2].to_vec(),
            p: s[2..].to_vec(),
        };
        let one = femvi_cli::ensemble::run_member(&problem, start);
        let row = &r[i + 1];
        let num = |k: usize| row[k].parse::<f64>().unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            num(1).to_bits(),
            one.final_t.to_bits(),
            "{scheme:?} member {i}: final_t"
        );
        assert_eq!(bits(&numbers(row, 2..4)), bits(&one.q), "member {i}: q");
        assert_eq!(bits(&numbers(row, 4..6)), bits(&one.p), "member {i}: p");
        assert_eq!(num(6).to_bits(), one.energy_error.to_bits(), "member {i}: energy error");
        assert_eq!(row[7], one.steps.to_string(), "member {i}: steps");
        assert_eq!(row[8], one.error.clone().unwrap_or_default(), "member {i}: error");
        if let Some(e) = &one.error {
            failed += 1;
            assert!(e.starts_with("non-finite energy at step 0"), "{e}");
            assert!(one.q.iter().all(|x| x.is_nan()) && one.steps == 0);
            continue;
        }
        let mut single = set.clone();
        single.push(format!("initial.q=[{:?},{:?}]", s[0], s[1]));
        single.push(format!("initial.p=[{:?},{:?}]", s[2], s[3]));
        let (t, q, p, e, steps, error) = summary(&single);
        assert_eq!(
            (num(1), numbers(row, 2..4), numbers(row, 4..6)),
            (t, q, p),
            "member {i}: femvi run"
        );
        assert_eq!((num(6), one.steps, error), (e, steps, None), "member {i}: femvi run");
    }
    assert_eq!(failed, 1);
    assert_eq!(status.code(), Some(1));
}

/// An expression Lagrangian (mechanical, M = I) in lanes takes the per-lane defaults of
/// `force_lanes` and `potential_lanes` (its compiled force, one lane at a time): members
/// still equal their runs one by one (`run_member`) bit for bit, 9 of them (a partial chunk).
#[test]
fn expression_members_in_lanes_equal_single_runs() {
    let dir = tempfile::tempdir().unwrap();
    let problem_file = dir.path().join("quartic.toml");
    std::fs::write(
        &problem_file,
        "[system]\ncoordinates = [\"x\", \"y\", \"z\"]\nparameters = { a = 0.3 }\n\
         lagrangian = \"0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 0.25*(x^2 + y^2 + z^2)^2 - a*sin(x)*y\"\n\
         [initial]\nq = [1.0, 0.0, 0.0]\np = [0.0, 0.5, 0.1]\n\
         [scheme]\ndegree = 1\nquadrature = \"trapezoid\"\n[time]\nstep = 0.01\nend = 3.0\n",
    )
    .unwrap();
    let rows_in: Vec<[f64; 6]> = (0..9)
        .map(|i| [1.0, 0.1 * i as f64, 0.0, 0.0, 0.5, 0.05 * i as f64])
        .collect();
    let states = dir.path().join("states.csv");
    let text: String = rows_in
        .iter()
        .map(|r| r.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    std::fs::write(&states, text).unwrap();
    let out = dir.path().join("out");
    femvi()
        .args(["ensemble", "--workers", "1", "--quiet", "--states"])
        .arg(&states)
        .arg(&problem_file)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let r = rows(&out);
    let problem = femvi_cli::problem::load_with(&problem_file, &[]).unwrap();
    for (i, s) in rows_in.iter().enumerate() {
        let start = femvi::Start::Momentum {
            q: s[..3].to_vec(),
            p: s[3..].to_vec(),
        };
        let one = femvi_cli::ensemble::run_member(&problem, start);
        let row = &r[i + 1];
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&numbers(row, 2..5)), bits(&one.q), "member {i}: q");
        assert_eq!(bits(&numbers(row, 5..8)), bits(&one.p), "member {i}: p");
        assert_eq!(
            row[8].parse::<f64>().unwrap().to_bits(),
            one.energy_error.to_bits(),
            "member {i}"
        );
        assert_eq!((row[9].as_str(), one.steps), ("300", 300), "member {i}");
    }
}
