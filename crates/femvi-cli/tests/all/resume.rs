//! `femvi run --resume` (issue 16, Must-show): runs killed with SIGKILL at random points
//! (explicit, fixed-point, Newton, energy-mode and velocity- and time-dependent problems,
//! each running about a second in a
//! debug build) and resumed from their last checkpoint write the same trajectory.csv (and
//! trajectory.npy) bytes and the same final state in summary.json as an uninterrupted run;
//! a run stopped by SIGINT ends on a complete row, says so in summary.json, exits 130 and
//! resumes the same way; a checkpoint of another problem or output format is refused. The
//! cases include forced runs (fixed steps and time steps as variables) and constrained runs
//! (issue 33: terms of the one integrator).
//!
//! Three cases have `[[events]]`: events.csv is compared too, and "events_located" in
//! summary.json. Three draw plots (energy mode with a Poincaré section, adaptive steps with
//! one, RATTLE with the constraint residual): every plot is compared byte for byte too, and
//! no checkpoint file is left when the run is done.
//!
//! The kill times are drawn from a seed printed by the test (set FEMVI_RESUME_SEED to repeat).

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A problem of the test (`{end}` stands for its end time) and the extra arguments of its runs.
struct Case {
    name: &'static str,
    toml: &'static str,
    end: f64,
    args: &'static [&'static str],
}

const CASES: [Case; 14] = [
    Case {
        name: "explicit",
        end: 20.0,
        toml: "name = \"explicit\"\n[system]\nmodel = \"kepler\"\nparameters = { mu = 1.0 }\n[initial]\nq = [0.5, 0.0]\np = [0.0, 1.6]\n[scheme]\ndegree = 1\nquadrature = \"gauss-lobatto\"\n[time]\nstep = 0.001\nend = {end}\n",
        args: &["--checkpoint-every-steps", "997"],
    },
    Case {
        name: "fixed-point",
        end: 100.0,
        toml: "name = \"fixed-point\"\n[system]\nmodel = \"kepler\"\nparameters = { mu = 1.0 }\n[initial]\nq = [0.4, 0.0]\np = [0.0, 2.0]\n[scheme]\ndegree = 4\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.01\nend = {end}\n[output]\nevery = 7\n",
        args: &["--format", "csv,npy", "--checkpoint-every-steps", "250"],
    },
    Case {
        name: "newton",
        end: 40.0,
        toml: "name = \"newton\"\n[system]\nmodel = \"pendulum\"\n[initial]\nq = [1.0]\np = [0.0]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.01\nend = {end}\n[solver]\nmethod = \"newton\"\n[output]\nevery = 3\n",
        args: &["--checkpoint-every-seconds", "0.05"],
    },
    Case {
        name: "energy",
        end: 60.0,
        toml: "name = \"energy\"\n[system]\nmodel = \"henon-heiles\"\n[initial]\nq = [0.1, -0.1]\np = [0.3, 0.2]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nmode = \"energy\"\nstep = 0.05\nend = {end}\nmin_step = 0.0001\nmax_step = 0.5\n[[events]]\nname = \"section\"\nwhen = \"x\"\ndirection = \"rising\"\n",
        args: &["--plot", "--checkpoint-every-steps", "101", "--checkpoint-every-seconds", "0.1"],
    },
    // Velocity- and time-dependent (Newton; the energy tracker's warm-start velocity and its
    // energy balance are in the checkpoint).
    Case {
        name: "general",
        end: 110.0,
        toml: "name = \"general\"\n[system]\ncoordinates = [\"x\", \"y\"]\nlagrangian = \"0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) - 0.5*(x^2 + y^2)*(1 + 0.1*cos(t))\"\nparameters = { b = 1.0 }\n[initial]\nq = [1.0, 0.0]\nv = [0.0, 0.5]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.01\nend = {end}\n[output]\nevery = 5\n[[events]]\nname = \"x0\"\nwhen = \"x\"\n[[events]]\nname = \"y0\"\nwhen = \"y\"\ndirection = \"falling\"\n",
        args: &["--checkpoint-every-seconds", "0.05"],
    },
    // Velocity-dependent and autonomous: energies only at the kept nodes (energy_nodes =
    // "kept" by default), checkpoints between them.
    Case {
        name: "kept",
        end: 100.0,
        toml: "name = \"kept\"\n[system]\ncoordinates = [\"x\", \"y\"]\nlagrangian = \"0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2) + (x_dot^2 + y_dot^2)^2/800\"\n[initial]\nq = [0.4, 0.0]\np = [0.0, 2.0]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.01\nend = {end}\n[output]\nevery = 7\n",
        args: &["--checkpoint-every-steps", "101", "--checkpoint-every-seconds", "0.05"],
    },
    // Forces (issue 33): a velocity-dependent friction takes the forced Newton step, a force
    // of t and q alone on a mechanical L the forced fixed point; both stream their rows and
    // the work column, and resume to the same bytes.
    Case {
        name: "forced-newton",
        end: 50.0,
        toml: "name = \"forced-newton\"\n[system]\ncoordinates = [\"x\"]\nparameters = { c = 0.1, f0 = 0.3, w = 1.2 }\nlagrangian = \"0.5*x_dot^2 - 0.5*x^2 - 0.25*x^4\"\n[forces]\ngeneralized = [\"f0*cos(w*t)\"]\ndissipation = \"0.5*c*x_dot^2\"\n[initial]\nq = [1.0]\nv = [0.0]\n[scheme]\ndegree = 2\n[time]\nstep = 0.01\nend = {end}\n[output]\nevery = 5\n",
        args: &["--format", "csv,npy", "--checkpoint-every-steps", "97"],
    },
    Case {
        name: "forced-fixed-point",
        end: 50.0,
        toml: "name = \"forced-fixed-point\"\n[system]\ncoordinates = [\"x\", \"y\"]\nparameters = { f0 = 0.2 }\nlagrangian = \"0.5*(x_dot^2 + y_dot^2) - (1 - cos(x)) - 0.5*y^2 - 0.1*(1 - cos(x))*y^2\"\n[forces]\ngeneralized = [\"f0*cos(t)\", \"-0.05*y\"]\n[initial]\nq = [0.5, 0.1]\nv = [0.0, 0.2]\n[scheme]\ndegree = 3\n[time]\nstep = 0.02\nend = {end}\n",
        args: &["--checkpoint-every-seconds", "0.05"],
    },
    // Forces with time steps as variables (issue 33): the forced energy equation sets each
    // step of a damped, driven Duffing oscillator (midpoint; the drive keeps the energy up);
    // its discrete energy balance is in the checkpoint.
    Case {
        name: "forced-energy",
        end: 40.0,
        toml: "name = \"forced-energy\"\n[system]\ncoordinates = [\"x\"]\nparameters = { c = 0.1, f0 = 0.3, w = 1.2 }\nlagrangian = \"0.5*x_dot^2 - 0.5*x^2 - 0.25*x^4\"\n[forces]\ngeneralized = [\"f0*cos(w*t)\"]\ndissipation = \"0.5*c*x_dot^2\"\n[initial]\nq = [1.0]\nv = [0.0]\n[scheme]\ndegree = 1\n[time]\nmode = \"energy\"\nstep = 0.01\nend = {end}\nmin_step = 0.0001\nmax_step = 0.5\n[output]\nevery = 3\n",
        args: &["--format", "csv,npy", "--checkpoint-every-steps", "89"],
    },
    // Adaptive steps (issue 33): the rows in physical time streamed by the writer of
    // `adaptive/stream.rs`, the recorder's clock, output times and events in the checkpoint.
    Case {
        name: "adaptive-nodes",
        end: 60.0,
        toml: "name = \"adaptive-nodes\"\n[system]\nmodel = \"kepler\"\nparameters = { mu = 1.0 }\n[initial]\nq = [0.1, 0.0]\np = [0.0, 4.358898943540674]\n[scheme]\ndegree = 2\n[time]\nmode = \"adaptive\"\nds = 0.05\nend = {end}\n[output]\nevery = 3\n[[events]]\nname = \"pericentre\"\nwhen = \"y\"\ndirection = \"rising\"\n",
        args: &["--plot", "--format", "csv,npy", "--checkpoint-every-steps", "101"],
    },
    Case {
        name: "adaptive-uniform",
        end: 60.0,
        toml: "name = \"adaptive-uniform\"\n[system]\nmodel = \"kepler\"\nparameters = { mu = 1.0 }\n[initial]\nq = [0.1, 0.0]\np = [0.0, 4.358898943540674]\n[scheme]\ndegree = 2\n[time]\nmode = \"adaptive\"\nds = 0.05\nend = {end}\noutput_step = 0.1\n",
        args: &["--format", "csv,npy", "--checkpoint-every-seconds", "0.05"],
    },
    // Constraints (issue 33): RATTLE steps on the spherical pendulum, and a damped, driven
    // spherical pendulum at degree 2 (dense Newton with the discrete forces); the multipliers
    // and residuals are columns, constraints.json is compared too.
    Case {
        name: "constrained-rattle",
        end: 100.0,
        toml: "name = \"constrained-rattle\"\n[system]\ncoordinates = [\"x\", \"y\", \"z\"]\nlagrangian = \"0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z\"\n[constraints]\nholonomic = [\"x^2 + y^2 + z^2 - 1\"]\n[initial]\nq = [0.6, 0.0, -0.8]\nv = [0.3, 1.5, 0.225]\n[scheme]\ndegree = 1\nquadrature = \"trapezoid\"\n[time]\nstep = 0.001\nend = {end}\n[output]\nevery = 11\n",
        args: &["--plot", "--format", "csv,npy", "--checkpoint-every-steps", "997"],
    },
    Case {
        name: "constrained-forced",
        end: 20.0,
        toml: "name = \"constrained-forced\"\n[system]\ncoordinates = [\"x\", \"y\", \"z\"]\nparameters = { c = 0.3, f0 = 0.5, w = 2.5 }\nlagrangian = \"0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z\"\n[constraints]\nholonomic = [\"x^2 + y^2 + z^2 - 1\"]\n[forces]\ndissipation = \"0.5*c*(x_dot^2 + y_dot^2 + z_dot^2)\"\ngeneralized = [\"f0*cos(w*t)\", \"0\", \"0\"]\n[initial]\nq = [0.6, 0.0, -0.8]\nv = [0.3, 1.5, 0.225]\n[scheme]\ndegree = 2\n[time]\nstep = 0.01\nend = {end}\n[output]\nevery = 3\n",
        args: &["--checkpoint-every-seconds", "0.05"],
    },
    // Rotations (issue 37): the Lie-group element's carried momenta and guess are in the
    // checkpoint; an event on an entry of R.
    Case {
        name: "rotations",
        end: 20.0,
        toml: "name = \"rotations\"\n[system]\nmodel = \"heavy-top\"\nparameters = { chi1 = 0.1, chi2 = 0.2 }\n[initial]\nR_quaternion = [0.9689124217106447, 0.24740395925452294, 0.0, 0.0]\nR_w = [0.5, 1.0, 0.3]\n[scheme]\ndegree = 2\n[time]\nstep = 0.01\nend = {end}\n[output]\nevery = 3\n[[events]]\nname = \"level\"\nwhen = \"R33 - 0.5\"\n",
        args: &["--format", "csv,npy", "--checkpoint-every-steps", "97"],
    },
];

/// The summary.json keys that describe the final state (not the wall time or command line).
const FINAL_STATE: [&str; 18] = [
    "status",
    "energy_nodes",
    "error",
    "steps",
    "final_t",
    "final_q",
    "final_p",
    "max_rel_energy_error",
    "mean_solver_iterations",
    "max_rel_discrete_energy_error",
    "min_step",
    "max_step",
    "degenerate_steps",
    "max_rel_energy_balance_error",
    "final_work",
    "max_rel_discrete_energy_balance_error",
    "events_located",
    "stopped_by_event",
];

fn femvi() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_femvi"));
    c.stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::piped());
    c
}

/// Writes the case's problem into `dir` with an end time for which a run takes about a second
/// (as this build runs it: debug or optimised); returns the file and the run's length.
fn calibrated(case: &Case, dir: &Path) -> (std::path::PathBuf, f64) {
    let problem = dir.join(format!("{}.toml", case.name));
    let time = |end: f64| {
        std::fs::write(&problem, case.toml.replace("{end}", &format!("{end:?}"))).unwrap();
        let out = dir.join(format!("{}-calibration", case.name));
        let clock = Instant::now();
        success(&run_cmd(case, &problem, &out_args(&out)).output().unwrap(), case.name);
        clock.elapsed().as_secs_f64()
    };
    let first = time(case.end);
    let end = (case.end * (1.0 / first.max(1e-3)).clamp(1.0, 100.0)).round();
    let length = if end > case.end { time(end) } else { first };
    (problem, length)
}

/// `femvi run problem.toml --quiet <case args> <extra>` with output into `dir`.
fn run_cmd(case: &Case, problem: &Path, extra: &[&str]) -> Command {
    let mut c = femvi();
    c.arg("run").arg(problem).arg("--quiet").args(case.args).args(extra);
    c
}

fn out_args(dir: &Path) -> [&str; 2] {
    ["--out", dir.to_str().unwrap()]
}

fn resume_args(dir: &Path) -> [&str; 2] {
    ["--resume", dir.to_str().unwrap()]
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

/// Asserts that `dir` holds the outputs of `reference`, byte for byte, and its final state.
fn assert_same_outputs(case: &Case, dir: &Path, reference: &Path, what: &str) {
    for file in ["trajectory.csv", "trajectory.npy", "constraints.json", "events.csv"] {
        let (a, b) = (std::fs::read(dir.join(file)), std::fs::read(reference.join(file)));
        match (a, b) {
            (Ok(a), Ok(b)) => assert!(
                a == b,
                "{}: {what}: {file} differs ({} vs {} bytes)",
                case.name,
                a.len(),
                b.len()
            ),
            (Err(_), Err(_)) => {}
            _ => panic!("{}: {what}: {file} exists in one run only", case.name),
        }
    }
    let plots: Vec<_> = std::fs::read_dir(reference)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|f| f.ends_with(".svg"))
        .collect();
    assert_eq!(plots.is_empty(), !case.args.contains(&"--plot"), "{}: plots", case.name);
    for plot in plots {
        let (a, b) = (std::fs::read(dir.join(&plot)), std::fs::read(reference.join(&plot)));
        assert!(a.is_ok() && a.ok() == b.ok(), "{}: {what}: {plot} differs", case.name);
    }
    let (s, r) = (summary(dir), summary(reference));
    for key in FINAL_STATE {
        assert_eq!(s[key], r[key], "{}: {what}: summary.json {key}", case.name);
    }
    for file in ["checkpoint.json", "checkpoint-plots-0.bin", "checkpoint-plots-1.bin"] {
        assert!(
            !dir.join(file).exists(),
            "{}: a finished run keeps no {file}",
            case.name
        );
    }
}

fn success(out: &Output, what: &str) {
    assert!(
        out.status.success(),
        "{what}: {:?}: {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}

/// xorshift64*: the kill times (no dependency for a few random numbers).
struct Rng(u64);

impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn seed() -> u64 {
    std::env::var("FEMVI_RESUME_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_nanos() as u64
                | 1
        })
}

/// Starts a run into `dir`, SIGKILLs it after `delay`; whether it was still running then.
fn kill_after(mut cmd: Command, delay: Duration) -> bool {
    let mut child = cmd.spawn().unwrap();
    let until = Instant::now() + delay;
    while Instant::now() < until {
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    let status = child.wait().unwrap();
    // Killed by the signal, not finished just before it.
    !status.success()
}

#[test]
fn sigkill_at_random_points_then_resume_gives_identical_outputs() {
    let seed = seed();
    eprintln!("FEMVI_RESUME_SEED={seed}");
    let mut rng = Rng(seed);
    let tmp = tempfile::tempdir().unwrap();
    let clock = Instant::now();
    let mut mid_run_kills = 0;
    for (c, case) in CASES.iter().enumerate() {
        let (problem, calibration) = calibrated(case, tmp.path());
        let reference = tmp.path().join(format!("{}-reference", case.name));
        let started = Instant::now();
        success(
            &run_cmd(case, &problem, &out_args(&reference)).output().unwrap(),
            case.name,
        );
        // The machine's load varies: the shorter of two runs.
        let length = calibration.min(started.elapsed().as_secs_f64());
        let mut kills = 0;
        for attempt in 0..20 {
            if kills >= 5 {
                break;
            }
            let dir = tmp.path().join(format!("{}-{attempt}", case.name));
            let delay = Duration::from_secs_f64(length * (0.02 + 0.78 * rng.uniform()));
            if !kill_after(run_cmd(case, &problem, &out_args(&dir)), delay) {
                continue;
            }
            if !dir.join("summary.json").exists() {
                // Killed before the run wrote anything (its directory may be made, empty):
                // nothing to resume, and --resume says so rather than starting a run in a
                // mistyped or unrelated directory (as a_checkpoint_of_another_run_is_refused).
                let out = run_cmd(case, &problem, &resume_args(&dir)).output().unwrap();
                assert_eq!(out.status.code(), Some(2), "{}: resume of no directory", case.name);
                continue;
            }
            kills += 1;
            // One resume in three is itself killed once before it is resumed to the end.
            if (attempt + c) % 3 == 0 {
                let again = Duration::from_secs_f64(length * 0.5 * rng.uniform());
                if !kill_after(run_cmd(case, &problem, &resume_args(&dir)), again) {
                    // The resume finished before the kill.
                    assert_same_outputs(case, &dir, &reference, "resumed to the end");
                    continue;
                }
            }
            let resumed = run_cmd(case, &problem, &resume_args(&dir)).output().unwrap();
            let what = format!("killed after {:.3} s", delay.as_secs_f64());
            success(&resumed, &what);
            assert_same_outputs(case, &dir, &reference, &what);
        }
        assert!(kills >= 5, "{}: only {kills} kills landed mid-run", case.name);
        mid_run_kills += kills;
    }
    eprintln!(
        "{mid_run_kills} runs killed mid-run and resumed, identical outputs; {:.1} s",
        clock.elapsed().as_secs_f64()
    );
    assert!(mid_run_kills >= 20);
}

#[test]
fn sigint_stops_on_a_complete_row_and_resumes() {
    let case = &CASES[1];
    let tmp = tempfile::tempdir().unwrap();
    let (problem, length) = calibrated(case, tmp.path());
    let reference = tmp.path().join("reference");
    success(
        &run_cmd(case, &problem, &out_args(&reference)).output().unwrap(),
        "reference",
    );
    let dir = tmp.path().join("stopped");
    let child = run_cmd(case, &problem, &out_args(&dir)).spawn().unwrap();
    std::thread::sleep(Duration::from_secs_f64(length / 2.0));
    // SAFETY: kill(2) on the child's pid, which has not been waited for yet.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", String::from_utf8_lossy(&out.stderr));
    let s = summary(&dir);
    assert_eq!(s["status"], "interrupted");
    let error = s["error"].as_str().unwrap();
    assert!(error.starts_with("interrupted by SIGINT at step "), "{error}");
    let steps = s["steps"].as_u64().unwrap();
    assert!(steps > 0 && s["final_t"].as_f64().unwrap() < s["t_end"].as_f64().unwrap());
    // The CSV ends on a complete row: the node the run stopped at.
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    assert!(csv.ends_with('\n'));
    let last: Vec<&str> = csv.lines().last().unwrap().split(',').collect();
    assert_eq!(last.len(), csv.lines().next().unwrap().split(',').count());
    assert_eq!(last[0].parse::<u64>().unwrap(), steps);
    // serde_json parses floats to within an ulp (without its float_roundtrip feature).
    let (x, q) = (last[2].parse::<f64>().unwrap(), s["final_q"][0].as_f64().unwrap());
    assert!((x - q).abs() <= 2.0 * f64::EPSILON * x.abs(), "{x} vs {q}");
    // The NPY file is loadable and holds the same rows.
    let bytes = std::fs::read(dir.join("trajectory.npy")).unwrap();
    let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
    let rows = npy.shape()[0];
    assert_eq!(rows as usize, csv.lines().count() - 1);
    let data: Vec<f64> = npy.into_vec().unwrap();
    assert_eq!(data.len() as u64, rows * last.len() as u64);
    assert!(dir.join("checkpoint.json").exists());
    let resumed = run_cmd(case, &problem, &resume_args(&dir)).output().unwrap();
    success(&resumed, "resume after SIGINT");
    assert_same_outputs(case, &dir, &reference, "stopped by SIGINT");
}

#[test]
fn a_checkpoint_of_another_run_is_refused() {
    let case = &CASES[2];
    let tmp = tempfile::tempdir().unwrap();
    let (problem, length) = calibrated(case, tmp.path());
    let dir = tmp.path().join("stopped");
    assert!(kill_after(
        run_cmd(case, &problem, &out_args(&dir)),
        Duration::from_secs_f64(length / 2.0)
    ));
    let before = std::fs::read(dir.join("trajectory.csv")).unwrap();
    let refused = |extra: &[&str], message: &str| {
        let mut args = resume_args(&dir).to_vec();
        args.extend_from_slice(extra);
        let out = run_cmd(case, &problem, &args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(message), "{err}");
        // Nothing was changed.
        assert_eq!(std::fs::read(dir.join("trajectory.csv")).unwrap(), before);
    };
    refused(&["--set", "time.step=0.02"], "belongs to another problem");
    refused(&["--format", "npy"], "--format csv");
    refused(&["--plot"], "the stopped run drew none");
    let elsewhere = tmp.path().join("nothing");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let out = run_cmd(case, &problem, &resume_args(&elsewhere)).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot resume"));
}

/// A run with plots keeps their state in a side file of its checkpoint: a side file that is
/// not the checkpoint's is refused (nothing changed), and so is dropping the plots on resume;
/// with the file intact the run resumes to the uninterrupted run's plots.
#[test]
fn the_plot_state_of_a_checkpoint_is_checked() {
    let case = &CASES[3];
    assert!(case.args.contains(&"--plot"));
    let tmp = tempfile::tempdir().unwrap();
    let (problem, length) = calibrated(case, tmp.path());
    let reference = tmp.path().join("reference");
    success(
        &run_cmd(case, &problem, &out_args(&reference)).output().unwrap(),
        "reference",
    );
    let dir = tmp.path().join("stopped");
    assert!(kill_after(
        run_cmd(case, &problem, &out_args(&dir)),
        Duration::from_secs_f64(length / 2.0)
    ));
    let cp: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("checkpoint.json")).unwrap()).unwrap();
    let side = dir.join(format!("checkpoint-plots-{}.bin", cp["plots"]["slot"]));
    let good = std::fs::read(&side).unwrap();
    assert_eq!(good.len() as u64, 8 * cp["plots"]["words"].as_u64().unwrap());
    // Rows past the checkpoint, as a kill between checkpoints leaves them (a resume cuts them
    // off): a refusal must leave them too, so the check below cannot pass by luck.
    let csv = dir.join("trajectory.csv");
    let mut text = std::fs::read(&csv).unwrap();
    assert!(text.len() as u64 >= cp["csv_bytes"].as_u64().unwrap());
    text.extend_from_slice(b"rows past the checkpoint\n");
    std::fs::write(&csv, &text).unwrap();
    let before = std::fs::read(&csv).unwrap();
    let refused = |extra: &[&str], message: &str| {
        let mut cmd = femvi();
        cmd.arg("run")
            .arg(&problem)
            .args(["--quiet", "--resume"])
            .arg(&dir)
            .args(extra);
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(message), "{err}");
        assert_eq!(std::fs::read(dir.join("trajectory.csv")).unwrap(), before);
    };
    // The case's arguments without --plot.
    let without: Vec<&str> = case.args.iter().copied().filter(|a| *a != "--plot").collect();
    refused(&without, "cannot resume without plots");
    let mut damaged = good.clone();
    let last = damaged.len() - 1;
    damaged[last] ^= 1;
    std::fs::write(&side, &damaged).unwrap();
    refused(case.args, "is not the one checkpoint.json was written with");
    std::fs::write(&side, &good).unwrap();
    let resumed = run_cmd(case, &problem, &resume_args(&dir)).output().unwrap();
    success(&resumed, "resume with the side file intact");
    assert_same_outputs(case, &dir, &reference, "killed, side file checked");
}
