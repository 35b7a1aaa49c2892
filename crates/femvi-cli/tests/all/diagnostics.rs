//! `femvi check` and `femvi convergence` driven as a user would, with JSON output parsed.

use assert_cmd::Command;
use std::path::Path;

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn json(cmd: &mut Command) -> serde_json::Value {
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

/// A Kepler problem (μ = 1, a = 1) with eccentricity e over `periods` periods.
fn kepler_file(e: f64, periods: f64, scheme: &str) -> String {
    format!(
        "[system]\nmodel = \"kepler\"\n[initial]\nq = [{:?}, 0.0]\np = [0.0, {:?}]\n[scheme]\n{scheme}\n[time]\nstep = 0.1\nend = {:?}\n",
        1.0 - e,
        ((1.0 + e) / (1.0 - e)).sqrt(),
        periods * 2.0 * std::f64::consts::PI
    )
}

#[test]
fn convergence_recovers_order_2s_on_kepler_and_2_for_midpoint() {
    let dir = tempfile::tempdir().unwrap();
    // (scheme, expected order, eccentricity, periods, step counts): windows chosen by a scan
    // between the pre-asymptotic range and the round-off floor.
    let cases = [
        ("kind = \"midpoint\"", 2.0, 0.3, 1.0, vec![100, 140, 200, 300]),
        ("degree = 1", 2.0, 0.3, 1.0, vec![100, 140, 200, 300]),
        ("degree = 2", 4.0, 0.3, 1.0, vec![50, 60, 80, 100, 140]),
        ("degree = 3", 6.0, 0.1, 10.0, vec![340, 400, 500, 600, 800]),
        ("degree = 4", 8.0, 0.1, 10.0, vec![200, 240, 280, 340, 400]),
    ];
    for (i, (scheme, want, e, periods, counts)) in cases.into_iter().enumerate() {
        let path = write(dir.path(), &format!("k{i}.toml"), &kepler_file(e, periods, scheme));
        let t_end = periods * 2.0 * std::f64::consts::PI;
        let steps: Vec<String> = counts.iter().map(|n| format!("{:?}", t_end / *n as f64)).collect();
        let v = json(
            femvi()
                .arg("convergence")
                .arg(&path)
                .arg("--steps")
                .arg(steps.join(","))
                .arg("--json")
                .arg("--out")
                .arg(dir.path().join(format!("out{i}"))),
        );
        let order = v["order"].as_f64().unwrap();
        eprintln!("{scheme}: order {order:.3}, reference {}", v["reference"]);
        assert!((order - want).abs() <= 0.2, "{scheme}: order {order}");
        assert!(v["reference"].as_str().unwrap().contains("exact"));
        assert_eq!(v["runs"].as_array().unwrap().len(), counts.len());
        assert!(v["runs"][1]["order_from_previous"].as_f64().is_some());
        let csv = std::fs::read_to_string(dir.path().join(format!("out{i}/convergence.csv"))).unwrap();
        assert_eq!(csv.lines().count(), counts.len() + 1);
    }
}

#[test]
fn convergence_reference_choices() {
    let dir = tempfile::tempdir().unwrap();
    // Hénon–Heiles has no closed form: exact is refused, finest is used by default.
    let hh = "[system]\nmodel = \"henon-heiles\"\n[initial]\nq = [0.1, -0.1]\np = [0.3, 0.2]\n[scheme]\ndegree = 2\n[time]\nstep = 0.1\nend = 10.0\n";
    let path = write(dir.path(), "hh.toml", hh);
    let out = femvi()
        .arg("convergence")
        .arg(&path)
        .arg("--steps")
        .arg("0.2,0.1")
        .arg("--reference")
        .arg("exact")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no closed form"));
    let v = json(
        femvi()
            .arg("convergence")
            .arg(&path)
            .arg("--steps")
            .arg("0.2,0.1,0.05")
            .arg("--json")
            .arg("--out")
            .arg(dir.path()),
    );
    assert!(
        v["reference"].as_str().unwrap().contains("degree 4"),
        "{}",
        v["reference"]
    );
    assert!((v["order"].as_f64().unwrap() - 4.0).abs() < 0.3, "{v}");
    let bad = femvi()
        .arg("convergence")
        .arg(&path)
        .arg("--steps")
        .arg("0.2,-1")
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn check_reports_angular_momentum_and_flags_a_broken_symmetry() {
    let dir = tempfile::tempdir().unwrap();
    // Kepler over 10⁵ steps of degree 2: rotation invariance declared by the model.
    let text = "[system]\nmodel = \"kepler\"\n[initial]\nq = [0.4, 0.0]\np = [0.0, 2.0]\n[scheme]\ndegree = 2\n[time]\nstep = 0.01\nend = 1000.0\n";
    let path = write(dir.path(), "kepler.toml", text);
    let v = json(femvi().arg("check").arg(&path).arg("--json"));
    assert_eq!(v["steps"].as_u64(), Some(100_000));
    let drift = v["momentum_drift"]["rotation(x,y)"].as_f64().unwrap();
    eprintln!(
        "kepler: angular momentum drift {drift:.2e}, defect {}",
        v["symplecticity_defect"]
    );
    assert!(drift <= 1e-13, "{drift}");
    assert!(v["symplecticity_defect"].as_f64().unwrap() <= 1e-12);
    assert_eq!(v["symplecticity_samples"].as_u64(), Some(1000));
    assert!(v["time_reversal_error"].as_f64().unwrap() < 1e-9);
    for key in ["max_rel_energy_error", "energy_drift"] {
        assert!(v[key].as_f64().is_some(), "{key}");
    }
    // Hénon–Heiles is not rotation invariant: the declared "momentum" visibly drifts.
    let text = "[system]\nmodel = \"henon-heiles\"\n[initial]\nq = [0.1, -0.1]\np = [0.3, 0.2]\n[scheme]\ndegree = 2\n[time]\nstep = 0.05\nend = 100.0\n[symmetries]\nrotations = [[0, 1]]\n";
    let path = write(dir.path(), "hh.toml", text);
    let v = json(femvi().arg("check").arg(&path).arg("--json"));
    let drift = v["momentum_drift"]["rotation(x,y)"].as_f64().unwrap();
    eprintln!("henon-heiles: 'angular momentum' drift {drift:.2e}");
    assert!(drift > 1e-2, "{drift}");
    // A bad symmetry declaration is an input error.
    let bad = write(dir.path(), "bad.toml", &text.replace("[[0, 1]]", "[[0, 2]]"));
    let out = femvi().arg("check").arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("rotation"));
}

#[test]
fn check_in_energy_mode_and_with_time_dependence() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let v = json(
        femvi()
            .arg("check")
            .arg(root.join("energy-henon-heiles.toml"))
            .arg("--json")
            .arg("--out")
            .arg(dir.path()),
    );
    // Extended map (3.6); degree 2 makes it ill-conditioned, so the relative defect is the check.
    assert!(v["symplecticity_defect_relative"].as_f64().unwrap() < 1e-13, "{v}");
    assert!(v["symplecticity_samples"].as_u64().unwrap() > 100);
    assert!(v["max_rel_discrete_energy_error"].as_f64().unwrap() < 1e-13);
    assert!(dir.path().join("check.json").exists());
    let v = json(femvi().arg("check").arg(root.join("variable-steps.toml")).arg("--json"));
    assert!(v["time_reversal_error"].is_null(), "the forced oscillator depends on t");
    assert!(v["symplecticity_defect"].as_f64().unwrap() < 1e-12);
}

#[test]
fn check_compares_the_two_form_with_the_paper() {
    let dir = tempfile::tempdir().unwrap();
    let base = "[system]\nmodel = \"pendulum\"\n[initial]\nq = [1.0]\nv = [0.0]\n[time]\nstep = 0.1\nend = 20.0\n";
    for (scheme, formula) in [
        ("[scheme]\nkind = \"midpoint\"\n", "(2.21)"),
        ("[scheme]\ndegree = 1\nquadrature = \"simpson\"\n", "(2.31)"),
        ("[scheme]\ndegree = 2\npoints = 3\n", "(2.51) corrected"),
    ] {
        let path = write(dir.path(), "p.toml", &format!("{base}{scheme}"));
        let v = json(femvi().arg("check").arg(&path).arg("--json"));
        assert_eq!(v["two_form"]["formula"].as_str(), Some(formula), "{v}");
        let d = v["two_form"]["max_rel_difference"].as_f64().unwrap();
        eprintln!("{formula}: max relative difference {d:.2e}");
        assert!(d < 1e-12, "{formula}: {d}");
        assert_eq!(v["two_form"]["samples"].as_u64(), Some(200));
    }
    // Not the paper's form (a general Lagrangian): no comparison.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let v = json(
        femvi()
            .arg("check")
            .arg(root.join("double-pendulum.toml"))
            .arg("--json"),
    );
    assert!(v.get("two_form").is_none());
}

#[test]
fn convergence_l2_orders_of_2_33_and_2_56() {
    let dir = tempfile::tempdir().unwrap();
    for (degree, want) in [(1, 2.0), (2, 3.0)] {
        let text = format!("[system]\nmodel = \"harmonic\"\n[initial]\nq = [1.0]\nv = [0.0]\n[scheme]\ndegree = {degree}\n[time]\nstep = 0.1\nend = 4.0\n");
        let path = write(dir.path(), "h.toml", &text);
        for reference in ["exact", "finest"] {
            let v = json(
                femvi()
                    .arg("convergence")
                    .arg(&path)
                    .args([
                        "--steps",
                        "0.2,0.1,0.05,0.025",
                        "--l2",
                        "--json",
                        "--reference",
                        reference,
                        "--out",
                    ])
                    .arg(dir.path()),
            );
            let order = v["l2_order"].as_f64().unwrap();
            eprintln!("degree {degree}, reference {reference}: L2 order {order:.3}");
            assert!((order - want).abs() < 0.1, "{order}");
            assert!(v["runs"][0]["l2_error"].as_f64().unwrap() > 0.0);
        }
    }
}
