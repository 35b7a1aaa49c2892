//! Issue 34's three defects through the command: a regular double pendulum reported as
//! degenerate, files named by the user read without bound, a panic on a constrained start
//! that is not finite.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn femvi() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_femvi"));
    c.stdin(Stdio::null());
    c
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("summary is JSON")
}

/// The issue's reproduction: it stopped at t = 10.44 with "the Lagrangian is degenerate".
const PENDULUM_SETS: &[&str] = &[
    "system.parameters.g=9.81",
    "system.parameters.l2=0.8",
    "initial.q=[0.5,0.3]",
    "initial.v=[0.0,0.0]",
    "scheme.degree=2",
    "time.step=0.01",
    "time.end=20",
];

fn run_with_sets(file: &Path, sets: &[&str], out: &Path) -> Output {
    let mut c = femvi();
    c.args([
        "run",
        &file.display().to_string(),
        "--quiet",
        "--out",
        &out.display().to_string(),
    ]);
    for s in sets {
        c.args(["--set", s]);
    }
    c.output().expect("femvi runs")
}

#[test]
fn the_regular_double_pendulum_runs_to_the_end() {
    let dir = tempfile::tempdir().expect("temp dir");
    let model = femvi()
        .args(["models", "double-pendulum"])
        .output()
        .expect("femvi models");
    assert!(model.status.success());
    let file = dir.path().join("dp.toml");
    std::fs::write(&file, &model.stdout).expect("write");
    let out = dir.path().join("out");
    let o = run_with_sets(&file, PENDULUM_SETS, &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let s = summary(&out);
    assert_eq!(s["steps"], 2000, "{s}");
    assert!((s["final_t"].as_f64().expect("final_t") - 20.0).abs() < 1e-9, "{s}");
    let energy = s["max_rel_energy_error"].as_f64().expect("energy error reported");
    assert!(energy.is_finite() && energy < 1e-3, "{energy}");
}

/// The same system written as an expression (it stopped at t = 1.67).
#[test]
fn the_double_pendulum_as_an_expression_runs_to_the_end() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("dp.toml");
    std::fs::write(
        &file,
        r#"name = "dp-expression"
[system]
coordinates = ["a", "b"]
parameters = { m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 0.8, g = 9.81 }
lagrangian = "0.5*(m1 + m2)*l1^2*a_dot^2 + 0.5*m2*l2^2*b_dot^2 + m2*l1*l2*a_dot*b_dot*cos(a - b) + (m1 + m2)*g*l1*cos(a) + m2*g*l2*cos(b)"
[initial]
q = [0.5, 0.3]
v = [0.0, 0.0]
[scheme]
degree = 2
[time]
step = 0.01
end = 20.0
"#,
    )
    .expect("write");
    let out = dir.path().join("out");
    let o = run_with_sets(&file, &[], &out);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(summary(&out)["steps"], 2000);
}

/// A problem whose ∂²L/∂v² is singular is still refused, with its condition number and a hint
/// about the kinetic energy rather than about steps and iterations.
#[test]
fn a_degenerate_lagrangian_is_still_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("degenerate.toml");
    std::fs::write(
        &file,
        "[system]\ncoordinates = [\"x\", \"y\"]\nlagrangian = \"0.5*(x_dot + y_dot)^2 - 0.5*(x^2 + y^2)\"\n\
         [initial]\nq = [0.1, 0.2]\nv = [0.3, -0.1]\n[scheme]\ndegree = 2\n[time]\nstep = 0.01\nend = 1.0\n",
    )
    .expect("write");
    let o = run_with_sets(&file, &[], &dir.path().join("out"));
    assert!(matches!(o.status.code(), Some(1 | 2)), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("degenerate") && e.contains("condition number"), "{e}");
    assert!(!e.contains("max_iterations"), "{e}");
}

/// A bounded wait for a child: its output, and the time it took (panics past `limit`).
fn output_within(mut c: Command, limit: Duration) -> (Output, Duration) {
    let began = Instant::now();
    let child = c.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn");
    let id = child.id();
    let killer = std::thread::spawn(move || {
        std::thread::sleep(limit);
        // SAFETY: kill(2) on a pid of our own child (at worst already reaped: harmless ESRCH).
        unsafe { libc::kill(id as i32, libc::SIGKILL) };
    });
    let o = child.wait_with_output().expect("wait");
    let took = began.elapsed();
    assert!(took < limit, "no answer within {limit:?}");
    drop(killer);
    (o, took)
}

#[test]
fn a_guess_of_dev_zero_is_refused_at_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut c = femvi();
    c.args([
        "bvp",
        &examples().join("bvp-pendulum.toml").display().to_string(),
        "--quiet",
        "--out",
        &dir.path().join("out").display().to_string(),
        "--set",
        "boundary.guess=\"/dev/zero\"",
    ]);
    let (o, took) = output_within(c, Duration::from_secs(20));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("NUL"), "{}", stderr(&o));
    eprintln!("guess = /dev/zero refused in {took:?}");
}

#[test]
fn states_from_dev_zero_are_refused_at_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut c = femvi();
    c.args([
        "ensemble",
        &examples().join("kepler.toml").display().to_string(),
        "--states",
        "/dev/zero",
        "--quiet",
        "--out",
        &dir.path().join("out").display().to_string(),
    ]);
    let (o, took) = output_within(c, Duration::from_secs(20));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    eprintln!("--states /dev/zero refused in {took:?}");
}

/// A named FIFO whose writer never stops: a problem file of endless comment lines is refused
/// at the problem-file limit, and a guess of one endless line at the line limit.
#[test]
fn endless_fifos_are_refused() {
    let dir = tempfile::tempdir().expect("temp dir");
    let fifo = dir.path().join("endless");
    let c_path = std::ffi::CString::new(fifo.display().to_string()).expect("path");
    // SAFETY: mkfifo(3) on a NUL-terminated path in our own temporary directory.
    assert_eq!(unsafe { libc::mkfifo(c_path.as_ptr(), 0o600) }, 0, "mkfifo");
    let feed = |fifo: PathBuf, head: &'static [u8], body: &'static [u8]| {
        std::thread::spawn(move || {
            let Ok(mut f) = std::fs::OpenOptions::new().write(true).open(&fifo) else {
                return;
            };
            let _ = f.write_all(head);
            let chunk = body.repeat(1 << 14);
            // Ends when the reader closes the FIFO (EPIPE).
            while f.write_all(&chunk).is_ok() {}
        })
    };
    let writer = feed(fifo.clone(), b"", b"# an endless comment line\n");
    let mut c = femvi();
    c.args([
        "run",
        &fifo.display().to_string(),
        "--quiet",
        "--out",
        &dir.path().join("o1").display().to_string(),
    ]);
    let (o, took) = output_within(c, Duration::from_secs(60));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("limit"), "{}", stderr(&o));
    writer.join().expect("writer");
    eprintln!("an endless problem FIFO refused in {took:?}");

    let writer = feed(fifo.clone(), b"t,theta\n", b"0");
    let mut c = femvi();
    c.args([
        "bvp",
        &examples().join("bvp-pendulum.toml").display().to_string(),
        "--quiet",
        "--out",
        &dir.path().join("o2").display().to_string(),
        "--set",
        &format!("boundary.guess=\"{}\"", fifo.display()),
    ]);
    let (o, took) = output_within(c, Duration::from_secs(60));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("line longer"), "{}", stderr(&o));
    writer.join().expect("writer");
    eprintln!("an endless guess line refused in {took:?}");
}

/// The issue's constrained start: degree 7 and the last coordinate −1e308 panicked in the SVD.
#[test]
fn a_constrained_start_that_is_not_finite_names_its_constraint() {
    let dir = tempfile::tempdir().expect("temp dir");
    let o = run_with_sets(
        &examples().join("constrained/double-pendulum-cartesian.toml"),
        &[
            "scheme.degree=7",
            "initial.q=[0.8414709848078965,-0.5403023058681398,1.3208965234120995,-1e308]",
        ],
        &dir.path().join("out"),
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert!(e.contains("constraint 2") && e.contains("(x2 - x1)^2"), "{e}");
}
