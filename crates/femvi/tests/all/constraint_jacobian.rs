//! The compiled g and G of expression constraints (`expr/jacobian.rs`:
//! `Constraints::value_and_jacobian` of `ExprConstraints`) against forward-mode automatic
//! differentiation of the same expressions (`Constraints::value` over dual numbers), at
//! points spread over the domain; and the constrained run through them equals a Rust
//! constraint written by hand.

use femvi::constraints::{solve_constrained, Constraints, ExprConstraints};
use femvi::expr::ExprLagrangian;
use femvi::{Element, Problem, Scalar, SolveOptions, Start};
use num_dual::Dual64;

fn names(n: usize) -> Vec<String> {
    ["x", "y", "z", "w"][..n].iter().map(|s| s.to_string()).collect()
}

#[test]
fn compiled_jacobians_equal_automatic_differentiation() {
    let sources: Vec<String> = [
        "x^2 + y^2 + z^2 - l^2",
        "sin(x)*exp(y) - z*w",
        "atan2(y, x) + sqrt(1 + z^2) - tanh(w)",
        "x*y*z*w - cos(x - z)^3 + ln(2 + y^2)/(1 + w^2)",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let c = ExprConstraints::new(&sources, &names(4), &[("l".into(), 1.3)]).unwrap();
    let (m, n) = (4, 4);
    let mut worst = (0.0f64, 0.0f64);
    for k in 0..50 {
        let q: Vec<f64> = (0..n)
            .map(|a| ((k * 7 + a * 13) as f64 * 0.37).sin() * 1.7 + 0.1 * a as f64)
            .collect();
        let (mut g, mut jac) = (vec![0.0; m], vec![0.0; m * n]);
        assert!(c.value_and_jacobian(&q, &mut g, &mut jac));
        for a in 0..n {
            let d: Vec<Dual64> = q
                .iter()
                .enumerate()
                .map(|(b, &x)| if a == b { Dual64::new(x, 1.0) } else { Dual64::from(x) })
                .collect();
            let mut out = vec![Dual64::from(0.0); m];
            c.value(&d, &mut out);
            for l in 0..m {
                let scale = out[l].re.abs().max(1.0);
                worst.0 = worst.0.max((g[l] - out[l].re).abs() / scale);
                let scale = out[l].eps.abs().max(1.0);
                worst.1 = worst.1.max((jac[l * n + a] - out[l].eps).abs() / scale);
            }
        }
    }
    // Rounding only: the symbolic gradient and the dual numbers order the operations apart.
    assert!(worst.0 <= 1e-14 && worst.1 <= 1e-13, "{worst:?}");
    // Slices of other lengths are not written.
    assert!(!c.value_and_jacobian(&[0.0; 3], &mut [0.0; 4], &mut [0.0; 16]));
}

/// The unit sphere as Rust code (its Jacobian by dual numbers).
struct Sphere;

impl Constraints for Sphere {
    fn dim(&self) -> usize {
        3
    }
    fn count(&self) -> usize {
        1
    }
    fn value<D: Scalar>(&self, q: &[D], out: &mut [D]) {
        out[0] = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - 1.0;
    }
}

#[test]
fn rattle_through_the_compiled_jacobian_is_the_run_of_a_hand_written_constraint() {
    // Degree 1 with the trapezoid rule (RATTLE) on the spherical pendulum: g = |q|² − 1 and
    // G = 2q are exact in floating point either way, so the runs agree bit for bit.
    let xyz = names(3);
    let lag = ExprLagrangian::new("0.5*(x_dot^2 + y_dot^2 + z_dot^2) - 9.81*z", &xyz, &[]).unwrap();
    let expr = ExprConstraints::new(&["x^2 + y^2 + z^2 - 1".to_string()], &xyz, &[]).unwrap();
    let start = Start::Velocity {
        q: vec![0.6, 0.0, -0.8],
        v: vec![0.0, 1.0, 0.0],
    };
    let problem = Problem::new(lag, start, 0.0, 5.0);
    let element = Element::galerkin(1, femvi::NodeFamily::Equispaced, femvi::QuadratureKind::Trapezoid).unwrap();
    let options = SolveOptions::step(0.01);
    let a = solve_constrained(&problem, &expr, &element, &options).unwrap().solution;
    let b = solve_constrained(&problem, &Sphere, &element, &options)
        .unwrap()
        .solution;
    assert!(a.error.is_none() && a.steps == 500);
    assert_eq!(a.q, b.q);
    assert_eq!(a.p, b.p);
}
