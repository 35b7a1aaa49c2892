//! The composition matrix (issue 33): every kind of problem (plain, forced, constrained,
//! forced + constrained, adaptive, rotations) × every command and run option, through the binary. A
//! cell either works (exit 0) or is refused with exit code 2 and the message of the one
//! capability table (`femvi_cli::problem::capabilities`), and which of the two is decided by
//! the table, not by each command: a command that ignored an option the table refuses (as
//! `--format npy` on a constrained run and `--resume` on an adaptive run once were, silently)
//! or refused one the table allows fails here. The matrix is printed (`--nocapture`).

use assert_cmd::Command;
use femvi_cli::problem::capabilities::{check, Use};
use femvi_cli::problem::{load_with, Problem};
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples").join(name)
}

/// (label, example file, overrides that keep the run short).
const KINDS: [(&str, &str, &[&str]); 8] = [
    ("plain", "pendulum.toml", &["time.end=1.0"]),
    ("forced", "forces/damped-oscillator.toml", &["time.end=1.0"]),
    (
        "forced, energy mode",
        "forces/damped-oscillator-energy.toml",
        &["time.end=1.0"],
    ),
    ("constrained", "constrained/spherical-pendulum.toml", &["time.end=0.5"]),
    (
        "forced+constrained",
        "constrained/damped-spherical-pendulum.toml",
        &["time.end=0.5"],
    ),
    ("adaptive", "kepler-eccentric.toml", &["time.end=1.0"]),
    ("rotations", "rigid/heavy-top-expression.toml", &["time.end=0.5"]),
    ("forced rotations", "rigid/damped-body.toml", &["time.end=0.5"]),
];

/// An `[[events]]` table in the first coordinate, appended to a problem's text.
fn with_event(text: &str, problem: &Problem) -> String {
    let x = &problem.coordinates[0];
    format!("{text}\n[[events]]\nname = \"cross\"\nwhen = \"{x}\"\nstop = false\n")
}

/// The initial state as one row of `femvi ensemble --states` (q then p or v) and whether it
/// holds velocities.
fn state_row(problem: &Problem) -> (String, bool) {
    let (q, second, velocity) = match &problem.start {
        femvi::Start::Velocity { q, v } => (q, v, true),
        femvi::Start::Momentum { q, p } => (q, p, false),
        femvi::Start::Positions { .. } => unreachable!("the examples start from (q, v) or (q, p)"),
    };
    let row: Vec<String> = q.iter().chain(second).map(|x| format!("{x:?}")).collect();
    (row.join(",") + "\n", velocity)
}

struct Cell {
    what: &'static str,
    asked: Use,
    args: Vec<String>,
    /// The problem text to run (an event appended for the events column).
    text: String,
    /// Exit 0 is not required when allowed (resuming a finished run has nothing to resume).
    must_succeed: bool,
}

fn cells(text: &str, problem: &Problem, dir: &Path) -> Vec<Cell> {
    let out = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let (row, velocity) = state_row(problem);
    let states = dir.join("states.csv");
    std::fs::write(&states, row).unwrap();
    let mut ensemble = vec!["ensemble".into(), "--quiet".into(), "--states".into()];
    ensemble.push(states.to_string_lossy().into_owned());
    if velocity {
        ensemble.push("--velocity".into());
    }
    ensemble.extend(["--out".into(), out("ensemble")]);
    let strings = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    // `femvi chaos` in energy mode asks the table for that mode's row.
    let chaos = if problem.terms.energy_mode {
        Use::ChaosInEnergyMode
    } else {
        Use::Chaos
    };
    let cell = |what, asked, args: Vec<String>| Cell {
        what,
        asked,
        args,
        text: text.to_string(),
        must_succeed: true,
    };
    vec![
        cell(
            "npy",
            Use::Npy,
            strings(&["run", "--quiet", "--format", "csv,npy", "--out", &out("npy")]),
        ),
        cell(
            "plots",
            Use::Plots,
            strings(&["run", "--quiet", "--plot", "--out", &out("plots")]),
        ),
        Cell {
            text: with_event(text, problem),
            ..cell(
                "events",
                Use::Events,
                strings(&["run", "--quiet", "--out", &out("events")]),
            )
        },
        Cell {
            must_succeed: false,
            ..cell(
                "resume",
                Use::Resume,
                strings(&["run", "--quiet", "--resume", &out("run")]),
            )
        },
        cell("check", Use::Check, strings(&["check", "--out", &out("check")])),
        cell(
            "convergence",
            Use::Convergence,
            strings(&["convergence", "--steps", "0.1,0.05", "--out", &out("convergence")]),
        ),
        cell("ensemble", Use::Ensemble, ensemble),
        cell("chaos", chaos, strings(&["chaos", "--out", &out("chaos")])),
    ]
}

#[test]
fn every_cell_works_or_is_refused_by_the_capability_table() {
    let tmp = tempfile::tempdir().unwrap();
    let mut matrix = vec![];
    for (kind, file, sets) in KINDS {
        let dir = tmp.path().join(kind.replace(['+', ',', ' '], "-"));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("problem.toml");
        let original = std::fs::read_to_string(example(file)).unwrap();
        let overrides: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        let text = femvi_cli::problem::apply_overrides(&original, &overrides).unwrap();
        std::fs::write(&path, &text).unwrap();
        let problem = load_with(&path, &[]).unwrap();
        // The plain run of every kind works: the output directory the resume cell names.
        let first = Command::cargo_bin("femvi")
            .unwrap()
            .args(["run", "--quiet", "--out"])
            .arg(dir.join("run"))
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            first.status.success(),
            "{kind}: run: {}",
            String::from_utf8_lossy(&first.stderr)
        );
        let mut row = vec![(kind.to_string(), "run".to_string())];
        for c in cells(&text, &problem, &dir) {
            let file = dir.join(format!("{}.toml", c.what));
            std::fs::write(&file, &c.text).unwrap();
            let shown = load_with(&file, &[]).unwrap();
            let out = Command::cargo_bin("femvi")
                .unwrap()
                .args(&c.args)
                .arg(&file)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            let code = out.status.code();
            let name = format!("femvi {}", c.args[0]);
            match check(&shown.terms, c.asked, &name) {
                Err(refusal) => {
                    assert_eq!(code, Some(2), "{kind} × {}: the table refuses it: {err}", c.what);
                    assert!(
                        err.contains(&refusal),
                        "{kind} × {}: {err}\nexpected: {refusal}",
                        c.what
                    );
                    row.push((c.what.to_string(), "refused".into()));
                }
                Ok(()) => {
                    if c.must_succeed {
                        assert_eq!(code, Some(0), "{kind} × {}: the table allows it: {err}", c.what);
                    } else {
                        assert!(!err.contains("not available with"), "{kind} × {}: {err}", c.what);
                    }
                    row.push((c.what.to_string(), "works".into()));
                }
            }
        }
        matrix.push(row);
    }
    for row in &matrix {
        let cells: Vec<String> = row.iter().skip(1).map(|(what, how)| format!("{what} {how}")).collect();
        eprintln!("{:>20}: {}", row[0].0, cells.join(", "));
    }
}

/// The combinations no command runs are refused when the problem is loaded, by every command,
/// with the table's reason.
#[test]
fn term_combinations_are_refused_at_load() {
    let forced = std::fs::read_to_string(example("forces/damped-oscillator.toml")).unwrap();
    let adaptive = forced.replace("step = 0.05", "mode = \"adaptive\"\nmonitor = \"1 + x^2\"\nds = 0.05");
    let constrained = std::fs::read_to_string(example("constrained/spherical-pendulum.toml")).unwrap();
    let energy = constrained.replace("[time]", "[time]\nmode = \"energy\"");
    let cases = [
        (adaptive, "[forces] are not available with [time] mode = \"adaptive\""),
        (energy, "[time] mode = \"energy\" is not available with [constraints]"),
    ];
    let tmp = tempfile::tempdir().unwrap();
    for (text, needle) in &cases {
        let path = tmp.path().join("p.toml");
        std::fs::write(&path, text).unwrap();
        let loaded = load_with(&path, &[]);
        let Err(e) = loaded else { panic!("{needle}: loaded") };
        assert!(e.to_string().contains(needle), "{e}");
        let out = tmp.path().join("out");
        let out = out.to_str().unwrap();
        let commands = [
            &["run", "--quiet", "--out", out][..],
            &["check", "--out", out],
            &["chaos", "--out", out],
            &["convergence", "--steps", "0.1", "--out", out],
        ];
        for cmd in commands {
            let out = Command::cargo_bin("femvi")
                .unwrap()
                .args(cmd)
                .arg(&path)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(out.status.code() == Some(2) && err.contains(needle), "{cmd:?}: {err}");
        }
    }
}

/// Runs solved to the end (constraints, forces in energy mode) write trajectory.npy and
/// columns.txt when asked: the same numbers as trajectory.csv, bit for bit, under the same
/// column names (they used to write no NPY, once silently); and they draw their plots.
#[test]
fn runs_solved_to_the_end_write_the_csv_table_as_npy_and_plots() {
    let tmp = tempfile::tempdir().unwrap();
    for file in [
        "constrained/damped-spherical-pendulum.toml",
        "forces/damped-oscillator-energy.toml",
    ] {
        let out = tmp.path().join(file.replace('/', "-"));
        let run = Command::cargo_bin("femvi")
            .unwrap()
            .args([
                "run",
                "--quiet",
                "--set",
                "time.end=2.0",
                "--format",
                "csv,npy",
                "--plot",
                "--out",
            ])
            .arg(&out)
            .arg(example(file))
            .output()
            .unwrap();
        assert!(run.status.success(), "{file}: {}", String::from_utf8_lossy(&run.stderr));
        let text = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let csv: Vec<f64> = lines
            .flat_map(|l| l.split(',').map(|x| x.parse::<f64>().unwrap()))
            .collect();
        let names = std::fs::read_to_string(out.join("columns.txt")).unwrap();
        assert_eq!(names.lines().collect::<Vec<_>>(), header, "{file}");
        let bytes = std::fs::read(out.join("trajectory.npy")).unwrap();
        let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
        assert_eq!(
            npy.shape(),
            &[(csv.len() / header.len()) as u64, header.len() as u64],
            "{file}"
        );
        let values: Vec<f64> = npy.into_vec().unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&values), bits(&csv), "{file}");
        let mut plots = vec!["coordinates.svg", "energy_error.svg"];
        if header.contains(&"residual") {
            plots.push("residual.svg");
        }
        for plot in plots {
            let svg = std::fs::read_to_string(out.join(plot)).unwrap_or_default();
            assert!(svg.contains("<svg"), "{file}: {plot}");
        }
    }
}

/// `[[events]]` with `[forces]`: located on the forced element polynomials (the library's
/// `solve_forced_with`), against the closed form of the damped oscillator of the example
/// (x'' + 0.3 x' + x = 0 from x = 1 at rest: x = e^{-0.15 t}(cos ωt + 0.15/ω sin ωt),
/// ω² = 1 − 0.15²), whose zeros are at ωt = π − atan(ω/0.15) + kπ.
#[test]
fn events_of_a_forced_run_land_on_the_closed_form() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(example("forces/damped-oscillator.toml")).unwrap()
        + "\n[[events]]\nname = \"zero\"\nwhen = \"x\"\nstop = false\n";
    let path = tmp.path().join("damped.toml");
    std::fs::write(&path, text).unwrap();
    let out = tmp.path().join("out");
    let run = Command::cargo_bin("femvi")
        .unwrap()
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&path)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let events = std::fs::read_to_string(out.join("events.csv")).unwrap();
    let times: Vec<f64> = events
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    let w = (1.0f64 - 0.15 * 0.15).sqrt();
    let first = (std::f64::consts::PI - (w / 0.15).atan()) / w;
    // t ≤ 20: zeros every π/ω from the first.
    let expected: Vec<f64> = (0..)
        .map(|k| first + k as f64 * std::f64::consts::PI / w)
        .take_while(|&t| t <= 20.0)
        .collect();
    assert_eq!(times.len(), expected.len(), "{events}");
    for (t, e) in times.iter().zip(&expected) {
        assert!((t - e).abs() < 1e-6, "{t} vs {e}");
    }
    let columns = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert!(
        columns.lines().next().unwrap().ends_with("energy,work"),
        "the work column"
    );
}
