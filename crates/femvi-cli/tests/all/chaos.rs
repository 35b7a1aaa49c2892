//! `femvi chaos` driven as a user would: one orbit's indicators as JSON (equal to the
//! library's on the same problem, bit for bit), a map over two axes (CSV and NPY with the
//! expected shape, the same numbers on 1 and 2 threads), and bad input.

use assert_cmd::Command;
use femvi::chaos::{indicators, ChaosOptions};
use femvi::{models, Element, Problem, SolveOptions, Start};

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

const FILE: &str = "[system]\nmodel = \"henon-heiles\"\n[initial]\nq = [0.0, -0.1]\np = [0.5, 0.1]\n[scheme]\norder = 4\n[time]\nstep = 0.1\nend = 300.0\n";

#[test]
fn one_orbit_as_json_equals_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hh.toml");
    std::fs::write(&path, FILE).unwrap();
    let out = femvi()
        .args([
            "chaos",
            path.to_str().unwrap(),
            "--json",
            "--indicator",
            "megno,lyapunov,fli,spectrum",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    // The numbers as printed, read with the standard (correctly rounded) parser: serde_json's
    // own float parsing may be off by an ulp.
    let raw = |key: &str| -> f64 {
        let at = text.find(&format!("\"{key}\": ")).unwrap() + key.len() + 4;
        let end = text[at..].find([',', '\n']).unwrap();
        text[at..at + end].trim().parse().unwrap()
    };
    let start = Start::Momentum {
        q: vec![0.0, -0.1],
        p: vec![0.5, 0.1],
    };
    let problem = Problem::new(models::henon_heiles(), start, 0.0, 300.0);
    let chaos = ChaosOptions {
        spectrum: true,
        ..ChaosOptions::default()
    };
    let r = indicators(
        &problem,
        &Element::with_order(4).unwrap(),
        &SolveOptions::step(0.1),
        &chaos,
    )
    .unwrap();
    assert_eq!(raw("megno"), r.last.mean_megno);
    assert_eq!(raw("lyapunov"), r.last.lyapunov);
    assert_eq!(raw("fli"), r.last.fli);
    let spectrum = r.spectrum.unwrap();
    let got = v["spectrum"].as_array().unwrap();
    assert_eq!(got.len(), 4);
    for (g, want) in got.iter().zip(&spectrum) {
        assert!((g.as_f64().unwrap() - want).abs() <= 4.0 * f64::EPSILON * want.abs());
    }
    assert_eq!(v["steps"].as_u64().unwrap(), 3000);
}

#[test]
fn a_map_over_two_axes_is_written_and_independent_of_threads() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hh.toml");
    let file = FILE
        .replace("end = 300.0", "end = 50.0")
        .replace("p = [0.5, 0.1]", "p = [0.3, 0.1]");
    std::fs::write(&path, file).unwrap();
    let map = |threads: &str, out: &str| {
        let out_dir = dir.path().join(out);
        femvi()
            .args([
                "chaos",
                path.to_str().unwrap(),
                "--grid",
                "x=-0.2:0.2:5",
                "--grid",
                "p_y=0.1:0.3:3",
            ])
            .args(["--threads", threads, "--out", out_dir.to_str().unwrap()])
            .assert()
            .success();
        std::fs::read_to_string(out_dir.join("chaos_map.csv")).unwrap()
    };
    let one = map("1", "one");
    assert_eq!(one, map("2", "two"));
    let lines: Vec<&str> = one.lines().collect();
    assert_eq!(lines[0], "x,p_y,megno,lyapunov,fli");
    assert_eq!(lines.len(), 1 + 15);
    // The first axis varies fastest.
    assert!(lines[1].starts_with("-0.2,0.1,") && lines[2].starts_with("-0.1,0.1,"));
    let npy = std::fs::read(dir.path().join("one").join("chaos_map.npy")).unwrap();
    assert!(npy.starts_with(b"\x93NUMPY"));
    assert!(String::from_utf8_lossy(&npy[..128]).contains("(15, 5, )"));
}

#[test]
fn plots_of_maps_over_one_and_two_axes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hh.toml");
    let file = FILE
        .replace("end = 300.0", "end = 20.0")
        .replace("p = [0.5, 0.1]", "p = [0.3, 0.1]");
    std::fs::write(&path, file).unwrap();
    let draw = |grids: &[&str], out: &str| {
        let out_dir = dir.path().join(out);
        let mut cmd = femvi();
        cmd.args([
            "chaos",
            path.to_str().unwrap(),
            "--plot",
            "--out",
            out_dir.to_str().unwrap(),
        ]);
        for g in grids {
            cmd.args(["--grid", g]);
        }
        cmd.assert().success();
        std::fs::read_to_string(out_dir.join("chaos_map.svg")).unwrap()
    };
    // Two axes: one cell per point (15) and the colour bar's 200 bands.
    let heat = draw(&["x=-0.2:0.2:5", "p_y=0.1:0.3:3"], "two");
    assert!(
        heat.matches("<rect").count() >= 15 + 200,
        "{}",
        heat.matches("<rect").count()
    );
    assert!(heat.contains("MEGNO"));
    // One axis: the indicator against the axis, a line.
    let line = draw(&["x=-0.2:0.2:5"], "one");
    assert!(line.contains("<polyline") || line.contains("<path"));
}

#[test]
fn bad_axes_and_indicators_are_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hh.toml");
    std::fs::write(&path, FILE).unwrap();
    for args in [
        vec!["--grid", "z=0:1:3"],
        vec!["--grid", "x=0:1"],
        vec!["--grid", "x=0:nan:3"],
        vec!["--indicator", "entropy"],
        vec!["--grid", "x_dot=0:1:3"],
    ] {
        let out = femvi()
            .args(["chaos", path.to_str().unwrap()])
            .args(&args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(String::from_utf8_lossy(&out.stderr).starts_with("error: "), "{args:?}");
    }
}

/// Energy mode (time steps as variables): the command gives the library's indicators.
#[test]
fn energy_mode_orbit_equals_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hh.toml");
    let file = FILE.replace("order = 4", "order = 2").replace(
        "step = 0.1\n",
        "mode = \"energy\"\nstep = 0.1\nmin_step = 0.0001\nmax_step = 1.0\n",
    );
    std::fs::write(&path, file).unwrap();
    let out = femvi()
        .args(["chaos", path.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    let at = text.find("\"megno\": ").unwrap() + 9;
    let end = text[at..].find([',', '\n']).unwrap();
    let megno: f64 = text[at..at + end].trim().parse().unwrap();
    let start = Start::Momentum {
        q: vec![0.0, -0.1],
        p: vec![0.5, 0.1],
    };
    let problem = Problem::new(models::henon_heiles(), start, 0.0, 300.0);
    let options = SolveOptions {
        steps: femvi::Steps::Energy {
            step: 0.1,
            options: femvi::EnergyOptions {
                min_step: 1e-4,
                max_step: 1.0,
                on_degenerate: femvi::Degenerate::Error,
            },
        },
        ..SolveOptions::step(0.1)
    };
    let r = indicators(
        &problem,
        &Element::with_order(2).unwrap(),
        &options,
        &ChaosOptions::default(),
    )
    .unwrap();
    assert!(r.error.is_none() && r.steps > 1000);
    assert_eq!(megno, r.last.mean_megno);
}

/// A map over a parameter and a coordinate: each point equals a one-point run of the file
/// with that parameter set by `--set` (bit for bit), and an unknown name is an input error.
#[test]
fn a_map_over_a_parameter_equals_one_point_runs() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hhl.toml");
    let file = "[system]\ncoordinates = [\"x\", \"y\"]\nparameters = { lam = 1.0 }\n\
        lagrangian = \"0.5*(x_dot^2 + y_dot^2) - 0.5*(x^2 + y^2) - lam*(x^2*y - y^3/3)\"\n\
        [initial]\nq = [0.0, -0.1]\np = [0.5, 0.1]\n[scheme]\norder = 4\n[time]\nstep = 0.1\nend = 100.0\n";
    std::fs::write(&path, file).unwrap();
    let out_dir = dir.path().join("map");
    let out = femvi()
        .args([
            "chaos",
            path.to_str().unwrap(),
            "--grid",
            "lam=0.6:1.0:3",
            "--grid",
            "y=-0.1:0.1:2",
        ])
        .args(["--indicator", "megno", "--out", out_dir.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(out_dir.join("chaos_map.csv")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 6);
    let distinct: std::collections::HashSet<u64> = rows.iter().map(|r| r[2].to_bits()).collect();
    assert_eq!(distinct.len(), 6, "every point differs: {rows:?}");
    for r in &rows {
        let one = femvi()
            .args(["chaos", path.to_str().unwrap(), "--json", "--indicator", "megno"])
            .args(["--set", &format!("system.parameters.lam={:?}", r[0])])
            .args(["--set", &format!("initial.q=[0.0, {:?}]", r[1])])
            .output()
            .unwrap();
        assert!(one.status.success(), "{}", String::from_utf8_lossy(&one.stderr));
        let t = String::from_utf8(one.stdout).unwrap();
        let at = t.find("\"megno\": ").unwrap() + 9;
        let end = t[at..].find([',', '\n']).unwrap();
        assert_eq!(t[at..at + end].trim().parse::<f64>().unwrap(), r[2], "{r:?}");
    }
    let bad = femvi()
        .args(["chaos", path.to_str().unwrap(), "--grid", "mu=0:1:3"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&bad.stderr).contains("mu"),
        "{}",
        String::from_utf8_lossy(&bad.stderr)
    );
}

/// `--out DIR` for one orbit writes summary.json: the indicators of chaos.json under `chaos`
/// and the final state of `femvi run` on the same file.
#[test]
fn one_orbit_summary_holds_the_indicators_and_the_final_state() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hh.toml");
    std::fs::write(&path, FILE).unwrap();
    let (c, r) = (dir.path().join("c"), dir.path().join("r"));
    femvi()
        .args(["chaos", path.to_str().unwrap(), "--out", c.to_str().unwrap()])
        .assert()
        .success();
    femvi()
        .args(["run", path.to_str().unwrap(), "--quiet", "--out", r.to_str().unwrap()])
        .assert()
        .success();
    let read = |p: std::path::PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (summary, chaos, run) = (
        read(c.join("summary.json")),
        read(c.join("chaos.json")),
        read(r.join("summary.json")),
    );
    assert_eq!(summary["status"], "done");
    assert_eq!(summary["steps"], 3000);
    assert_eq!(summary["chaos"]["megno"], chaos["megno"]);
    assert_eq!(summary["chaos"]["fli"], chaos["fli"]);
    assert_eq!(summary["final_q"], run["final_q"]);
    assert_eq!(summary["final_p"], run["final_p"]);
}
