//! Problems from standard input (`-`), `--set key.path=value` overrides (values, bare words,
//! errors that name the key) on every command that reads a problem, and what summary.json
//! records about the run (the resolved problem, femvi's version, the command line).

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn standard_input_runs_like_the_file() {
    let file = examples().join("pendulum.toml");
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    femvi()
        .args(["run", "--quiet", "--out"])
        .arg(a.path())
        .arg(&file)
        .assert()
        .success();
    femvi()
        .args(["run", "-", "--quiet", "--out"])
        .arg(b.path())
        .write_stdin(std::fs::read(&file).unwrap())
        .assert()
        .success();
    let csv = |d: &Path| std::fs::read(d.join("trajectory.csv")).unwrap();
    assert_eq!(csv(a.path()), csv(b.path()));
    assert_eq!(summary(b.path())["name"], "pendulum");
    // check, convergence and bvp read standard input too.
    let text = std::fs::read(&file).unwrap();
    let out = femvi()
        .args(["check", "-", "--json"])
        .write_stdin(text.clone())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let c = tempfile::tempdir().unwrap();
    let out = femvi()
        .args(["convergence", "-", "--steps", "0.1,0.05", "--json", "--out"])
        .arg(c.path())
        .write_stdin(text)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bvp = std::fs::read(examples().join("bvp-pendulum.toml")).unwrap();
    femvi()
        .args(["bvp", "-", "--quiet", "--out"])
        .arg(c.path())
        .write_stdin(bvp)
        .assert()
        .success();
    // An unnamed problem from standard input is called "stdin"; errors name "<stdin>".
    let out = femvi()
        .args(["run", "-"])
        .write_stdin("[system]\nmodel = 3\n")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("<stdin>"));
}

#[test]
fn set_overrides_values_of_the_problem() {
    let file = examples().join("pendulum.toml");
    let dir = tempfile::tempdir().unwrap();
    let out = femvi()
        .args(["run", "--quiet", "--out"])
        .arg(dir.path())
        .arg(&file)
        .args(["--set", "time.step=0.02", "--set", "system.parameters.g=3.7"])
        .args([
            "--set",
            "initial.q=[0.5]",
            "--set",
            "name=renamed",
            "--set",
            "time.end=2",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s = summary(dir.path());
    assert_eq!(s["name"], "renamed", "a bare word is a string");
    assert_eq!(s["steps"], 100);
    let problem: toml::Table = s["problem"].as_str().unwrap().parse().unwrap();
    assert_eq!(problem["system"]["parameters"]["g"].as_float(), Some(3.7));
    assert_eq!(problem["initial"]["q"].as_array().unwrap()[0].as_float(), Some(0.5));
    assert_eq!(s["femvi_version"], env!("CARGO_PKG_VERSION"));
    let cmd: Vec<&str> = s["command_line"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert!(cmd.contains(&"time.step=0.02") && cmd.contains(&"run"), "{cmd:?}");
    // The recorded problem, run again from standard input, gives the same trajectory.
    let again = tempfile::tempdir().unwrap();
    femvi()
        .args(["run", "-", "--quiet", "--out"])
        .arg(again.path())
        .write_stdin(s["problem"].as_str().unwrap())
        .assert()
        .success();
    let csv = |d: &Path| std::fs::read(d.join("trajectory.csv")).unwrap();
    assert_eq!(csv(dir.path()), csv(again.path()));
}

#[test]
fn set_errors_name_the_key() {
    let file = examples().join("pendulum.toml");
    let cases: &[(&[&str], &str)] = &[
        (&["--set", "time.step.x=1"], "time.step"),
        (&["--set", "time.stpe=0.1"], "stpe"),
        (&["--set", "nokey"], "key.path=value"),
        (&["--set", "initial.q.5=1"], "initial.q"),
        (&["--set", "time..end=1"], "empty part"),
        (&["--set", "time.step=fast"], "step"),
        // An expression's parameter that the file does not declare (a typo would otherwise
        // leave g unchanged in silence).
        (
            &["--set", "system.parameters.gg=3.7"],
            "no parameter 'gg' (it has: g, l)",
        ),
    ];
    for (args, want) in cases {
        for cmd in ["run", "check"] {
            let out = femvi().arg(cmd).arg(&file).args(*args).output().unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
            assert!(err.contains(want), "{args:?}: {err}");
            assert!(!err.contains("panicked"), "{err}");
        }
    }
    // bvp and convergence take --set as well.
    let out = femvi()
        .arg("bvp")
        .arg(examples().join("bvp-pendulum.toml"))
        .args(["--set", "boundary.elements=0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = femvi()
        .arg("convergence")
        .arg(&file)
        .args(["--steps", "0.1", "--set", "scheme.degree=oops"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn apply_overrides_is_a_library_function() {
    let text = "name = \"a\"\n[time]\nstep = 0.1\nend = 1.0\n";
    assert_eq!(femvi_cli::problem::apply_overrides(text, &[]).unwrap(), text);
    let out = femvi_cli::problem::apply_overrides(text, &["time.step=0.25".into(), "output.every=5".into()]).unwrap();
    let t: toml::Table = out.parse().unwrap();
    assert_eq!(t["time"]["step"].as_float(), Some(0.25));
    assert_eq!(t["output"]["every"].as_integer(), Some(5));
    let e = femvi_cli::problem::apply_overrides(text, &["name.x=1".into()]).unwrap_err();
    assert!(e.to_string().contains("name.x"), "{e}");
}
