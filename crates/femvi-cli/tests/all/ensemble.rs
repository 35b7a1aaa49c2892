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
