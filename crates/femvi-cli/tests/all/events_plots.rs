//! `[[events]]` in problem files (events.csv against the library's `solve` with the same
//! event, number for number; `stop = true`; a run with events writes the trajectory of one
//! without), every plot the CLI draws parsed as XML, and the diagnostics of time-dependent
//! and non-reversible Lagrangians.

use assert_cmd::Command;
use femvi::solution::{Direction, Event};
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn run(file: &Path, dir: &Path, extra: &[&str]) {
    let out = femvi()
        .arg("run")
        .arg(file)
        .arg("--out")
        .arg(dir)
        .arg("--quiet")
        .args(extra)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn events_csv_equals_the_library_solve() {
    let file = examples().join("henon-heiles-section.toml");
    let dir = tempfile::tempdir().unwrap();
    run(&file, dir.path(), &["--set", "time.end=300"]);
    let problem = femvi_cli::problem::load_with(&file, &["time.end=300".into()]).unwrap();
    let lib = femvi::Problem::new(femvi::models::henon_heiles(), problem.start.clone(), 0.0, 300.0);
    let options = femvi::SolveOptions {
        events: vec![Event::new("section", |_t, q, _v| q[1]).direction(Direction::Rising)],
        every: 0,
        ..femvi::SolveOptions::step(0.05)
    };
    let sol = femvi::solve(&lib, &problem.element, &options).unwrap();
    let text = std::fs::read_to_string(dir.path().join("events.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("event,step,t,x,y,p_x,p_y"));
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(String::from).collect()).collect();
    assert!(rows.len() > 30, "{} events", rows.len());
    assert_eq!(rows.len(), sol.events.len());
    for (row, e) in rows.iter().zip(&sol.events) {
        assert_eq!(row[0], "section");
        assert_eq!(row[1].parse::<usize>().unwrap(), e.step);
        let nums: Vec<f64> = row[2..].iter().map(|x| x.parse().unwrap()).collect();
        let want: Vec<f64> = std::iter::once(e.t).chain(e.q.clone()).chain(e.p.clone()).collect();
        assert_eq!(nums, want, "bit for bit");
        assert!(e.q[1].abs() < 1e-12 && e.v[1] > 0.0);
    }
    let s = json(&dir.path().join("summary.json"));
    assert_eq!(s["events_located"], rows.len());
    assert!(s["stopped_by_event"].is_null());
}

#[test]
fn stop_ends_the_run_at_the_first_event() {
    let file = examples().join("henon-heiles-section.toml");
    let dir = tempfile::tempdir().unwrap();
    run(&file, dir.path(), &["--set", "events.0.stop=true"]);
    let s = json(&dir.path().join("summary.json"));
    assert_eq!(s["stopped_by_event"], "section");
    assert_eq!(s["events_located"], 1);
    let t = s["final_t"].as_f64().unwrap();
    let events = std::fs::read_to_string(dir.path().join("events.csv")).unwrap();
    let te: f64 = events
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(2)
        .unwrap()
        .parse()
        .unwrap();
    assert!(te <= t && t < te + 0.05 + 1e-12, "stopped at {t}, event at {te}");
    // The node the run stopped on is the last row of trajectory.csv, whatever `every` is.
    let csv = std::fs::read_to_string(dir.path().join("trajectory.csv")).unwrap();
    let last: f64 = csv.lines().last().unwrap().split(',').nth(1).unwrap().parse().unwrap();
    assert_eq!(last, t);
    assert!(s["error"].is_null());
}

#[test]
fn an_event_that_never_occurs_leaves_the_outputs_of_a_run_without_events() {
    let file = examples().join("pendulum.toml");
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    run(&file, a.path(), &["--format", "csv,npy"]);
    let with = [
        "--format",
        "csv,npy",
        "--set",
        "events=[{ name = \"never\", when = \"1 + theta^2\" }]",
    ];
    run(&file, b.path(), &with);
    for f in ["trajectory.csv", "trajectory.npy"] {
        assert_eq!(
            std::fs::read(a.path().join(f)).unwrap(),
            std::fs::read(b.path().join(f)).unwrap(),
            "{f}"
        );
    }
    let (sa, sb) = (
        json(&a.path().join("summary.json")),
        json(&b.path().join("summary.json")),
    );
    for k in [
        "steps",
        "final_t",
        "final_q",
        "final_p",
        "max_rel_energy_error",
        "mean_solver_iterations",
    ] {
        assert_eq!(sa[k], sb[k], "{k}");
    }
    assert_eq!(sb["events_located"], 0);
    assert!(sa.get("events_located").is_none());
}

#[test]
fn bad_events_are_input_errors() {
    let file = examples().join("henon-heiles-section.toml");
    for (set, want) in [
        ("events.0.when=z + 1", "unknown symbol 'z'"),
        ("events.0.direction=up", "unknown variant"),
        ("events.0.name=a b", "not allowed"),
        ("events.0.stpo=true", "stpo"),
    ] {
        let out = femvi().arg("run").arg(&file).args(["--set", set]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{set}: {err}");
        assert!(err.contains(want), "{set}: {err}");
    }
}

/// Parses an SVG and returns (its text, number of circles, number of paths/polylines).
fn svg(path: &Path) -> (String, usize, usize) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    let count = |names: &[&str]| {
        doc.descendants()
            .filter(|n| names.contains(&n.tag_name().name()))
            .count()
    };
    let words: String = doc.descendants().filter_map(|n| n.text()).collect::<Vec<_>>().join(" ");
    (words, count(&["circle"]), count(&["polyline", "path"]))
}

#[test]
fn every_plot_is_well_formed_and_titled_with_scheme_and_step() {
    let d = tempfile::tempdir().unwrap();
    let dir = |s: &str| d.path().join(s);
    run(&examples().join("models/kepler.toml"), &dir("kepler"), &["--plot"]);
    run(
        &examples().join("models/outer-solar-system.toml"),
        &dir("oss"),
        &["--plot", "--set", "time.end=2000"],
    );
    run(&examples().join("models/n-body.toml"), &dir("nbody"), &["--plot"]);
    run(
        &examples().join("energy-henon-heiles.toml"),
        &dir("energy"),
        &["--plot"],
    );
    run(
        &examples().join("henon-heiles-section.toml"),
        &dir("hh"),
        &["--plot", "--set", "time.end=300"],
    );
    let files = [
        "kepler/coordinates.svg",
        "kepler/phase_x.svg",
        "kepler/phase_y.svg",
        "kepler/energy_error.svg",
        "kepler/orbit.svg",
        "oss/orbit.svg",
        "nbody/orbit.svg",
        "energy/step_size.svg",
        "hh/poincare_section.svg",
    ];
    for f in files {
        let (text, _, lines) = svg(&dir(f));
        assert!(text.contains("h = "), "{f}: {text}");
        assert!(text.contains("degree") || text.contains("midpoint"), "{f}: {text}");
        assert!(lines > 0, "{f}");
    }
    let (text, _, _) = svg(&dir("oss/orbit.svg"));
    for body in ["Sun", "Jupiter", "Saturn", "Uranus", "Neptune", "Pluto"] {
        assert!(text.contains(body), "{body}");
    }
    let (_, circles, _) = svg(&dir("hh/poincare_section.svg"));
    let events = std::fs::read_to_string(dir("hh/events.csv")).unwrap().lines().count() - 1;
    assert!(circles >= events, "{circles} points for {events} events");
    assert!(!dir("hh/orbit.svg").exists(), "Hénon–Heiles has no bodies");
    // convergence (markers on the measured points) and bvp (coordinates, moving-mesh steps).
    let out = femvi()
        .arg("convergence")
        .arg(examples().join("models/kepler.toml"))
        .args(["--steps", "0.1,0.05,0.025", "--plot", "--json", "--out"])
        .arg(dir("conv"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let (text, circles, _) = svg(&dir("conv/convergence.svg"));
    assert!(
        circles >= 3 && text.contains("h = 0.1, 0.05, 0.025"),
        "{circles}: {text}"
    );
    for (example, files) in [
        ("bvp-pendulum.toml", &["coordinates.svg"][..]),
        ("bvp-moving-mesh.toml", &["coordinates.svg", "steps.svg"][..]),
    ] {
        let out = dir(example);
        femvi()
            .arg("bvp")
            .arg(examples().join(example))
            .args(["--plot", "--quiet", "--out"])
            .arg(&out)
            .assert()
            .success();
        for f in files {
            let (text, _, lines) = svg(&out.join(f));
            assert!(lines > 0 && text.contains("elements"), "{example} {f}: {text}");
        }
    }
}

#[test]
fn the_palette_never_repeats_within_a_plot() {
    let colors: Vec<_> = (0..200)
        .map(|i| {
            let c = femvi_cli::plot::color(i);
            (c.0, c.1, c.2)
        })
        .collect();
    for (i, c) in colors.iter().enumerate() {
        assert!(!colors[..i].contains(c), "colour {i} repeats");
    }
}

#[test]
fn time_dependent_and_non_reversible_lagrangians_are_reported_truthfully() {
    let d = tempfile::tempdir().unwrap();
    let forced = examples().join("models/forced-oscillator.toml");
    let out = femvi()
        .arg("run")
        .arg(&forced)
        .arg("--out")
        .arg(d.path())
        .output()
        .unwrap();
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("energy change") && stdout.contains("not conserved"),
        "{stdout}"
    );
    let s = json(&d.path().join("summary.json"));
    assert_eq!(s["energy_conserved"], false);
    let balance = s["max_rel_energy_balance_error"].as_f64().unwrap();
    assert!(
        balance < 1e-3 && balance < s["max_rel_energy_error"].as_f64().unwrap(),
        "{balance}"
    );
    let check = |file: &Path, set: &[&str]| -> serde_json::Value {
        let out = femvi().arg("check").arg(file).arg("--json").args(set).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let c = check(&forced, &[]);
    assert_eq!(c["energy_conserved"], false);
    assert!(c["notes"].to_string().contains("not conserved"));
    // A charged particle in a magnetic field: L(q, -v) != L(q, v), no time-reversal test.
    let magnetic = [
        "--set",
        "system.coordinates=[\"x\", \"y\"]",
        "--set",
        "system.parameters={ b = 2.0 }",
        "--set",
        "system.lagrangian=0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot)",
        "--set",
        "initial.q=[1.0, 0.0]",
        "--set",
        "initial.v=[0.0, 1.0]",
    ];
    let c = check(&examples().join("pendulum.toml"), &magnetic);
    assert!(c["time_reversal_error"].is_null());
    assert!(
        c["notes"].to_string().contains("time reversal not tested"),
        "{}",
        c["notes"]
    );
    assert_eq!(c["energy_conserved"], true);
    let c = check(&examples().join("pendulum.toml"), &[]);
    assert!(c["time_reversal_error"].as_f64().unwrap() < 1e-8);
}
