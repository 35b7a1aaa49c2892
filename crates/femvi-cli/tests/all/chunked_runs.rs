//! `femvi run` drives its runs in chunks up to the next kept node (issue 15, item 4), with the
//! energy still computed at every node (`energy_nodes = "every"`, which the general Lagrangian
//! below would not get by default; `cli::energy_nodes` tests the default): a run keeping
//! every 7th node (chunks of up to 7 steps, or of up to the chunk cap when every node of 10⁵
//! is kept) writes exactly the rows of the run keeping every node at those nodes, and its
//! summary (final state, steps, largest energy
//! error over all nodes, solver iterations) is the same bit for bit. Explicit fast path,
//! fixed point, Newton on a general expression, and energy mode (driven node by node).

use assert_cmd::Command;
use std::path::Path;

const PROBLEMS: [(&str, &str); 4] = [
    (
        "verlet",
        "name = \"verlet\"\n[system]\nmodel = \"kepler\"\nparameters = { mu = 1.0 }\n[initial]\nq = [0.4, 0.0]\np = [0.0, 2.0]\n[scheme]\ndegree = 1\nquadrature = \"trapezoid\"\n[time]\nstep = 0.01\nend = 30.0\n",
    ),
    (
        "fixed-point",
        "name = \"fp\"\n[system]\nmodel = \"kepler\"\nparameters = { mu = 1.0 }\n[initial]\nq = [0.4, 0.0]\np = [0.0, 2.0]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.02\nend = 20.0\n",
    ),
    (
        "newton",
        "name = \"magnetic\"\n[system]\ncoordinates = [\"x\", \"y\"]\nlagrangian = \"0.5*(x_dot^2 + y_dot^2) + 0.5*b*(x*y_dot - y*x_dot) - 0.5*(x^2 + y^2)\"\nparameters = { b = 1.0 }\n[initial]\nq = [1.0, 0.0]\nv = [0.0, 0.5]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nstep = 0.05\nend = 10.0\n",
    ),
    (
        "energy-mode",
        "name = \"hh\"\n[system]\nmodel = \"henon-heiles\"\n[initial]\nq = [0.1, -0.1]\np = [0.3, 0.2]\n[scheme]\ndegree = 2\nquadrature = \"gauss-legendre\"\n[time]\nmode = \"energy\"\nstep = 0.1\nend = 10.0\n",
    ),
];

fn run(text: &str, every: usize, dir: &Path) -> (Vec<String>, serde_json::Value) {
    let file = dir.join("p.toml");
    std::fs::write(&file, text).unwrap();
    let out = dir.join(format!("out{every}"));
    let res = Command::cargo_bin("femvi")
        .unwrap()
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .arg(&file)
        .args([
            "--set",
            &format!("output.every={every}"),
            "--set",
            "output.energy_nodes=every",
        ])
        .output()
        .unwrap();
    assert!(res.status.success(), "{}", String::from_utf8_lossy(&res.stderr));
    let rows = std::fs::read_to_string(out.join("trajectory.csv"))
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    let summary = serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    (rows, summary)
}

#[test]
fn chunked_runs_equal_node_by_node_runs() {
    for (name, text) in PROBLEMS {
        let tmp = tempfile::tempdir().unwrap();
        let (all, s1) = run(text, 1, tmp.path());
        assert!(all.len() > 100, "{name}: {} rows", all.len());
        for every in [7, 100_000] {
            let (kept, s) = run(text, every, tmp.path());
            let last = all.len() - 2;
            let want: Vec<&String> = std::iter::once(&all[0])
                .chain(
                    all[1..]
                        .iter()
                        .enumerate()
                        .filter(|(k, _)| k % every == 0 || *k == last)
                        .map(|(_, r)| r),
                )
                .collect();
            assert_eq!(kept.iter().collect::<Vec<_>>(), want, "{name}, every {every}");
            for key in [
                "status",
                "steps",
                "final_t",
                "final_q",
                "final_p",
                "max_rel_energy_error",
                "mean_solver_iterations",
                "max_rel_discrete_energy_error",
            ] {
                assert_eq!(s[key], s1[key], "{name}, every {every}: {key}");
            }
            assert!(s["max_rel_energy_error"].as_f64().unwrap() > 0.0, "{name}");
        }
    }
}

/// The command's chunked run ends where the library's node-by-node `step()` does, bit for
/// bit (Kepler, degree 1 trapezoid: the explicit fast loop against the single step), so the
/// chunked path is not only compared with itself.
#[test]
fn chunked_run_ends_at_the_node_of_step_by_step_library_run() {
    use femvi::{models, Element, Integrator, NodeFamily, QuadratureKind, SolverOptions, Start, TimeGrid};
    let tmp = tempfile::tempdir().unwrap();
    let (_, s) = run(PROBLEMS[0].1, 7, tmp.path());
    let lag = models::kepler(1.0).unwrap();
    let el = Element::galerkin(1, NodeFamily::Equispaced, QuadratureKind::Trapezoid).unwrap();
    let start = Start::Momentum {
        q: vec![0.4, 0.0],
        p: vec![0.0, 2.0],
    };
    let grid = TimeGrid::uniform(0.0, 0.01, 30.0).unwrap();
    let mut it = Integrator::new(&lag, &el, grid, start, SolverOptions::default()).unwrap();
    while it.step().unwrap() {}
    let node = it.node();
    let from_json =
        |key: &str| -> Vec<f64> { s[key].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
    assert_eq!(s["steps"].as_u64(), Some(node.k as u64));
    assert_eq!(from_json("final_q"), node.q.to_vec());
    assert_eq!(from_json("final_p"), node.p.to_vec());
}
