//! The defects of issue 16 that concern `femvi run` itself, each as a test: signals that
//! killed the run at once (no summary, a CSV cut mid-row), rows that sat in an 8 KiB buffer,
//! a stale summary.json of an earlier run claiming success next to a new partial CSV,
//! non-finite rows written before an unstable run stopped, and runs that silently started to
//! write without bound.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A Kepler orbit by fixed-point iteration: runs for long (it is stopped).
const KEPLER: &str = "name = \"kepler\"\n[system]\nmodel = \"kepler\"\nparameters = { mu = 1.0 }\n[initial]\nq = [0.4, 0.0]\np = [0.0, 2.0]\n[scheme]\ndegree = 4\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.01\nend = 200000.0\n";

/// The same run writing one row in 100 (2·10⁵ rows, ~30 MB): the runs below are stopped after
/// a fraction of a second, and a run whose full output would not fit the free space is refused
/// before it starts (CI machines may have only a few GB free).
fn kepler_bounded() -> String {
    format!("{KEPLER}[output]\nevery = 100\n")
}

fn femvi() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_femvi"));
    c.stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::piped());
    c
}

fn write_problem(dir: &Path, text: &str) -> std::path::PathBuf {
    let path = dir.join("problem.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// Whether every line of the CSV text is complete: ends with a newline, same column count.
fn complete_rows(csv: &str) -> bool {
    let columns = csv.lines().next().map_or(0, |h| h.split(',').count());
    csv.ends_with('\n') && csv.lines().all(|l| l.split(',').count() == columns)
}

#[test]
fn sigterm_and_sighup_stop_the_run_with_a_summary_and_exit_code() {
    for (sig, name, code) in [(libc::SIGTERM, "SIGTERM", 143), (libc::SIGHUP, "SIGHUP", 129)] {
        let tmp = tempfile::tempdir().unwrap();
        let problem = write_problem(tmp.path(), &kepler_bounded());
        let out = tmp.path().join("out");
        let child = femvi()
            .args(["run", "--quiet", "--out"])
            .arg(&out)
            .arg(&problem)
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(400));
        // SAFETY: kill(2) on the child's pid, which has not been waited for yet.
        assert_eq!(unsafe { libc::kill(child.id() as i32, sig) }, 0);
        let res = child.wait_with_output().unwrap();
        assert_eq!(
            res.status.code(),
            Some(code),
            "{name}: {}",
            String::from_utf8_lossy(&res.stderr)
        );
        let s = summary(&out);
        assert_eq!(s["status"], "interrupted");
        let error = s["error"].as_str().unwrap();
        assert!(error.starts_with(&format!("interrupted by {name} at step ")), "{error}");
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        assert!(complete_rows(&csv), "{name}: the CSV ends mid-row");
        assert!(out.join("checkpoint.json").exists());
    }
}

#[test]
fn rows_reach_the_disk_within_about_a_second() {
    // A row about every 0.25 s (a few hundred bytes a second, far below the 8 KiB buffer):
    // `every` from the speed of a short run of the same problem in this build.
    let tmp = tempfile::tempdir().unwrap();
    let short = write_problem(tmp.path(), &KEPLER.replace("end = 200000.0", "end = 1000.0"));
    let clock = Instant::now();
    let res = femvi()
        .args(["run", "--quiet", "--out"])
        .arg(tmp.path().join("short"))
        .arg(&short)
        .output()
        .unwrap();
    assert!(res.status.success());
    let steps_per_second = 1e5 / clock.elapsed().as_secs_f64();
    let every = (0.25 * steps_per_second).ceil() as u64;
    let problem = write_problem(tmp.path(), &format!("{KEPLER}[output]\nevery = {every}\n"));
    let out = tmp.path().join("out");
    let mut child = femvi()
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&problem)
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut rows_seen = 0;
    while start.elapsed() < Duration::from_secs(10) && child.try_wait().unwrap().is_none() {
        std::thread::sleep(Duration::from_millis(50));
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap_or_default();
        rows_seen = csv.lines().count().saturating_sub(1);
        // Row 0 is flushed with the first checkpoint; the next rows only by the flush policy.
        if rows_seen >= 4 {
            assert!(complete_rows(&csv));
            break;
        }
    }
    let running = child.try_wait().unwrap().is_none();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(running, "the run ended before 4 rows were seen on disk");
    assert!(
        rows_seen >= 4,
        "only {rows_seen} rows on disk after {:?} (every = {every})",
        start.elapsed()
    );
}

#[test]
fn a_stale_summary_is_replaced_at_the_start_of_a_run() {
    let tmp = tempfile::tempdir().unwrap();
    let problem = write_problem(tmp.path(), &kepler_bounded());
    let out = tmp.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("summary.json"), "{\"status\": \"done\", \"error\": null}\n").unwrap();
    std::fs::write(out.join("checkpoint.json"), "{}").unwrap();
    let mut child = femvi()
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&problem)
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(400));
    child.kill().unwrap();
    child.wait().unwrap();
    let s = summary(&out);
    assert_eq!(s["status"], "running");
    assert!(s["problem"].as_str().unwrap().contains("kepler"));
    // The old checkpoint is gone or replaced by one of this run.
    let cp = std::fs::read_to_string(out.join("checkpoint.json")).unwrap_or_default();
    assert!(cp.is_empty() || cp.contains("problem_sha256"));
    // No temporary files are left by the atomic writes.
    let names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
}

#[test]
fn an_unstable_run_stops_at_the_first_non_finite_node() {
    // Störmer–Verlet (degree 1, Lobatto) on x'' = -x is unstable for h > 2: with h = 2.5 the
    // amplitude grows by |λ| ≈ 3.8 per step and overflows after some 500 steps.
    let tmp = tempfile::tempdir().unwrap();
    let text = "name = \"unstable\"\n[system]\nmodel = \"harmonic\"\nparameters = { m = 1.0, k = 1.0 }\n[initial]\nq = [1.0]\np = [0.0]\n[scheme]\ndegree = 1\nquadrature = \"gauss-lobatto\"\n[time]\nstep = 2.5\nend = 5000.0\n";
    let problem = write_problem(tmp.path(), text);
    let out = tmp.path().join("out");
    let res = femvi()
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&problem)
        .output()
        .unwrap();
    assert_eq!(res.status.code(), Some(1));
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert!(complete_rows(&csv));
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() > 100, "{} rows", rows.len());
    assert!(
        rows.iter().flatten().all(|x| x.is_finite()),
        "a non-finite value was written"
    );
    // The rows are consecutive from step 0, and the next step is the non-finite one.
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r[0], k as f64);
    }
    let s = summary(&out);
    let error = s["error"].as_str().unwrap();
    assert!(
        error.contains(&format!("non-finite energy at step {}", rows.len())),
        "{error}"
    );
    assert_eq!(s["steps"].as_u64().unwrap() as usize, rows.len() - 1);
    let last = rows.last().unwrap();
    // The summary's final state is that row's (serde_json parses floats to within an ulp).
    for (key, x) in [("final_q", last[2]), ("final_p", last[3])] {
        let v = s[key][0].as_f64().unwrap();
        assert!((v - x).abs() <= 2.0 * f64::EPSILON * x.abs(), "{key}: {v} vs {x}");
    }
}

#[test]
fn an_oversized_output_is_refused_before_the_run() {
    let tmp = tempfile::tempdir().unwrap();
    // 10¹² steps of a 1-D oscillator: some 10¹⁴ bytes of CSV.
    let text = "name = \"huge\"\n[system]\nmodel = \"harmonic\"\n[initial]\nq = [1.0]\np = [0.0]\n[time]\nstep = 1e-6\nend = 1e6\n";
    let problem = write_problem(tmp.path(), text);
    let out = tmp.path().join("out");
    let clock = Instant::now();
    let res = femvi()
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&problem)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&res.stderr);
    assert_eq!(res.status.code(), Some(2), "{err}");
    assert!(
        err.contains("would write about") && err.contains("every") && err.contains("--max-output"),
        "{err}"
    );
    assert!(!out.exists(), "nothing is written");
    assert!(clock.elapsed() < Duration::from_secs(10));
    // The way out the message gives: every, as suggested, fits.
    let every = err.split("output.every=").nth(1).unwrap().split(')').next().unwrap();
    let small = "name = \"small\"\n[system]\nmodel = \"harmonic\"\n[initial]\nq = [1.0]\np = [0.0]\n[time]\nstep = 0.001\nend = 10.0\n";
    let problem = write_problem(tmp.path(), small);
    let limited = |extra: &[&str]| {
        femvi()
            .args(["run", "--quiet", "--out"])
            .arg(&out)
            .arg(&problem)
            .args(extra)
            .output()
            .unwrap()
    };
    // 10 001 rows of about 100 bytes: refused under 100 kB, accepted with every = 100.
    let res = limited(&["--max-output", "100k"]);
    assert_eq!(res.status.code(), Some(2));
    assert!(!out.exists());
    // Each row has at least 5 numbers of at least 3 characters and a separator: 2·10¹³ bytes
    // or more against 10¹⁰ allowed.
    assert!(every.parse::<u64>().unwrap() >= 2000, "{every}");
    let res = limited(&["--max-output", "100k", "--set", "output.every=100"]);
    assert!(res.status.success(), "{}", String::from_utf8_lossy(&res.stderr));
    let written = std::fs::metadata(out.join("trajectory.csv")).unwrap().len();
    assert!(written < 100_000);
}
