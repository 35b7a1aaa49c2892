//! The two-body chain (issue 37, item 4: `femvi models rigid-chain`,
//! `examples/rigid/double-pendulum-3d.toml`): two rigid links in space hanging from ball
//! joints, a Lagrangian of two rotations. Its expression is checked against an independent
//! derivation — each link as a set of point masses with the link's mass, centre of mass and
//! inertia, T = Σ ½ μ |ẋ|² and V = g Σ μ z summed point by point (no parallel-axis theorem, no
//! inertia tensor) — at random states of T(SO(3) × SO(3)); its runs are symplectic on
//! T*(SO(3) × SO(3)) and converge at the element's nodal order.

use assert_cmd::Command;
use femvi::rotation::embedded_velocity;
use femvi::rotation::so3::{from_quaternion, mul};
use femvi::Lagrangian;
use std::path::{Path, PathBuf};

fn chain() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/rigid/double-pendulum-3d.toml")
}

/// A link: mass, length, moments about its centre of mass.
struct Link {
    m: f64,
    l: f64,
    j: [f64; 3],
}

/// Point masses (mass, body-frame position) with the link's mass, centre of mass at
/// (0, 0, −l/2) and principal moments j about it: μ_k at ± e_k from the centre with
/// 2 μ_k = S_k, S = the second moments (J₂ + J₃ − J₁)/2, …, and the rest of the mass at the
/// centre.
fn points(link: &Link) -> Vec<(f64, [f64; 3])> {
    let [j1, j2, j3] = link.j;
    let s = [(j2 + j3 - j1) / 2.0, (j1 + j3 - j2) / 2.0, (j1 + j2 - j3) / 2.0];
    let c = [0.0, 0.0, -link.l / 2.0];
    let mut out = vec![(link.m - s.iter().sum::<f64>(), c)];
    for k in 0..3 {
        for sign in [1.0, -1.0] {
            let mut x = c;
            x[k] += sign;
            out.push((s[k] / 2.0, x));
        }
    }
    out
}

fn apply(r: &[f64; 9], x: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| r[3 * i] * x[0] + r[3 * i + 1] * x[1] + r[3 * i + 2] * x[2])
}

/// L = T − V of the two links from their point masses: A's points at A b, B's at
/// −l_A A e₃ + B b.
fn point_mass_lagrangian(
    links: [&Link; 2],
    (a, da): ([f64; 9], [f64; 9]),
    (b, db): ([f64; 9], [f64; 9]),
    g: f64,
) -> f64 {
    let joint = [0.0, 0.0, -links[0].l];
    let (pivot, dpivot) = (apply(&a, &joint), apply(&da, &joint));
    let mut l = 0.0;
    for (k, link) in links.iter().enumerate() {
        let (r, dr, base, dbase) = if k == 0 {
            (a, da, [0.0; 3], [0.0; 3])
        } else {
            (b, db, pivot, dpivot)
        };
        for (mu, x) in points(link) {
            let (p, dp) = (apply(&r, &x), apply(&dr, &x));
            let v: [f64; 3] = std::array::from_fn(|i| dbase[i] + dp[i]);
            let z = base[2] + p[2];
            l += 0.5 * mu * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) - g * mu * z;
        }
    }
    l
}

#[test]
fn the_chain_lagrangian_is_that_of_its_point_masses() {
    let problem = femvi_cli::problem::load_with(&chain(), &[]).unwrap();
    let femvi_cli::problem::System::Expr(lag) = &problem.system else {
        panic!("the chain is an expression")
    };
    let p = |name: &str| problem.parameters.iter().find(|(k, _)| k == name).unwrap().1;
    let link = |x: &str| Link {
        m: p(&format!("m{x}")),
        l: p(&format!("l{x}")),
        j: [1, 2, 3].map(|c| p(&format!("J{x}{c}"))),
    };
    let (la, lb) = (link("A"), link("B"));
    // A small deterministic generator of states.
    let mut seed = 12345u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for _ in 0..20 {
        let mut rotation = || from_quaternion([next(), next(), next(), next()]).unwrap();
        let (a, b) = (rotation(), rotation());
        let (wa, wb) = (
            [next(), next(), next()].map(|x| 3.0 * x),
            [next(), next(), next()].map(|x| 3.0 * x),
        );
        let (da, db) = (embedded_velocity(&a, &wa), embedded_velocity(&b, &wb));
        let q: Vec<f64> = a.iter().chain(&b).copied().collect();
        let v: Vec<f64> = da.iter().chain(&db).copied().collect();
        let expr = lag.value(0.0, &q, &v);
        let direct = point_mass_lagrangian([&la, &lb], (a, da), (b, db), p("g"));
        assert!(
            (expr - direct).abs() < 1e-12 * direct.abs().max(1.0),
            "{expr} against {direct}"
        );
        // Off T SO(3) only the tangent part of each Ẋ counts (plus the regulariser, which
        // vanishes to first order): adding a normal velocity X S (S symmetric) at first
        // order leaves L unchanged to second order.
        let s = [0.3, 0.1, -0.2, 0.1, 0.5, 0.4, -0.2, 0.4, -0.1];
        let eps = 1e-6;
        let normal = mul(&a, &s);
        let v2: Vec<f64> = v
            .iter()
            .enumerate()
            .map(|(i, x)| if i < 9 { x + eps * normal[i] } else { *x })
            .collect();
        assert!(
            (lag.value(0.0, &q, &v2) - expr).abs() < 1e-10,
            "normal velocity changes L"
        );
    }
}

fn femvi() -> Command {
    Command::cargo_bin("femvi").unwrap()
}

#[test]
fn the_chain_is_symplectic_conserves_energy_and_converges_at_order_four() {
    let dir = tempfile::tempdir().unwrap();
    let out = femvi()
        .arg("check")
        .arg(chain())
        .args(["--set", "time.end=1.0", "--json", "--out"])
        .arg(dir.path().join("check"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let defect = report["symplecticity_defect"].as_f64().unwrap();
    assert!(defect < 1e-12, "defect {defect}");
    let out = femvi()
        .arg("convergence")
        .arg(chain())
        .args(["--steps", "0.04,0.02,0.01", "--set", "time.end=1.0", "--json", "--out"])
        .arg(dir.path().join("convergence"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let study: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let order = study["order"].as_f64().unwrap();
    assert!((order - 4.0).abs() < 0.15, "fitted order {order}");
}
