//! Machine code against the interpreter and the postfix program, bit for bit, on random
//! points for every operation.

use super::super::tape::Tape;
use super::super::ExprLagrangian;

/// Uniform numbers in [-3, 3) from a fixed xorshift sequence.
fn points(seed: u64, count: usize) -> Vec<f64> {
    let mut s = seed;
    (0..count)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0
        })
        .collect()
}

/// Every tape of `l` run as machine code gives the interpreter's outputs bit for bit.
fn same_bits(src: &str, names: &[&str]) {
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let l = ExprLagrangian::new(src, &names, &[("k".into(), 1.7)]).unwrap();
    let n = names.len();
    let tapes: Vec<&Tape> = [&l.fast.force, &l.fast.gyro, &l.fast.first, &l.fast.second]
        .into_iter()
        .flatten()
        .collect();
    assert!(!tapes.is_empty(), "{src}: no tape");
    for tape in tapes {
        assert!(tape.is_native(), "{src}: not compiled");
        let plain = tape.interpreted();
        let k = tape.outputs.len();
        for (p, z) in points(0x9e37_79b9_7f4a_7c15 ^ src.len() as u64, 200 * (2 * n + 1))
            .chunks_exact(2 * n + 1)
            .enumerate()
        {
            // Some points on ties and zeros, where min, max, sign and abs branch.
            let z: Vec<f64> = z.iter().map(|&x| if p % 7 == 3 { x.round() } else { x }).collect();
            let (t, q, v) = (z[0], &z[1..=n], &z[n + 1..]);
            let (mut a, mut b) = (vec![0.0; k], vec![0.0; k]);
            tape.eval(t, q, v, |j, x| a[j] = x);
            plain.eval(t, q, v, |j, x| b[j] = x);
            for (j, (x, y)) in a.iter().zip(&b).enumerate() {
                assert!(
                    x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                    "{src} output {j} at {z:?}: {x} vs {y}"
                );
            }
        }
        // Several points at once (the solvers' path), against the interpreter's lanes.
        let z = points(7 + k as u64, 5 * (1 + 2 * n));
        let (t, qv) = z.split_at(5);
        let (q, v) = qv.split_at(5 * n);
        let (mut a, mut b) = (vec![0.0; 5 * k], vec![0.0; 5 * k]);
        tape.eval_points(t, q, v, &mut a);
        plain.eval_points(t, q, v, &mut b);
        for (x, y) in a.iter().zip(&b) {
            assert!(
                x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                "{src}: {x} vs {y}"
            );
        }
    }
}

#[test]
fn machine_code_equals_the_interpreter_for_every_operation() {
    let cases: &[(&str, &[&str])] = &[
        ("0.5*l_dot^2 + k*cos(l)", &["l"]),
        ("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &["x", "y"]),
        (
            "0.5*(x_dot^2 + y_dot^2) + x*y_dot - y*x_dot + (1 - k)/sqrt((x + k)^2 + y^2)",
            &["x", "y"],
        ),
        (
            "0.5*x_dot^2 - sin(x)*tan(x/5) + exp(-x^2) + ln(1 + x^2) + abs(x)^3",
            &["x"],
        ),
        (
            "0.5*x_dot^2 + sinh(x/3) - cosh(x/4) + tanh(x) + asin(x/4) + acos(x/5) + atan(x)",
            &["x"],
        ),
        (
            "0.5*x_dot^2 + atan2(x, t + 4) + pow(abs(x) + 1, t/3) + min(x, t) + max(x, 1)",
            &["x"],
        ),
        ("x_dot^4/12 + x^-3 + x^2.5 + x^(1/3) - sqrt(1 - x_dot^2/9)", &["x"]),
        // Integer powers, unrolled inline (the loop of f64::powi): `same_value` compares them
        // with the program's f64::powi.
        (
            "x_dot^2 + x^0*x^1 - x^3 + x^5 - x^7/9 + x^-1 - x^-2 + x^12/1e6 - (x/3)^31 + (x/3)^-64 + (x + 0.1)^-5",
            &["x"],
        ),
        (
            "-k*sqrt(1 - (x_dot^2 + y_dot^2)/100) + 1/sqrt(x^2 + y^2) + t*x",
            &["x", "y"],
        ),
        (
            "0.5*(a_dot^2 + b_dot^2 + c_dot^2) - a*b*c + min(a, b)*max(b, c) + abs(a - c)",
            &["a", "b", "c"],
        ),
    ];
    for (src, names) in cases {
        same_bits(src, names);
        same_value(src, names);
        same_lanes(src, names);
    }
}

/// The code across lanes (`lanes.rs`) of every tape and of the value gives, on every lane,
/// the interpreter's and the program's bits: LANES points at one time t, many times over.
fn same_lanes(src: &str, names: &[&str]) {
    use super::{compile_lanes, compile_program_lanes};
    use crate::lagrangian::{Lanes, LANES};
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let lag = ExprLagrangian::new(src, &names, &[("k".into(), 1.7)]).unwrap();
    let n = names.len();
    let tapes: Vec<&Tape> = [&lag.fast.force, &lag.fast.gyro, &lag.fast.first, &lag.fast.second]
        .into_iter()
        .flatten()
        .collect();
    let value = compile_program_lanes(lag.program.ops(), n).expect("value across lanes");
    let codes: Vec<_> = tapes
        .iter()
        .map(|tape| compile_lanes(tape).expect("tape across lanes"))
        .collect();
    let width = 1 + 2 * n * LANES;
    for (p, z) in points(0x5851_f42d_4c95_7f2d ^ src.len() as u64, 60 * width)
        .chunks_exact(width)
        .enumerate()
    {
        // Some groups on ties and zeros, where min, max, sign and abs branch; some lanes NaN.
        let z: Vec<f64> = z
            .iter()
            .enumerate()
            .map(|(i, &x)| match (p % 5, i % 11) {
                (3, _) => x.round(),
                (4, 7) => f64::NAN,
                _ => x,
            })
            .collect();
        let t = z[0];
        let lanes = |c: usize| -> Lanes { std::array::from_fn(|l| z[1 + c * LANES + l]) };
        let q: Vec<Lanes> = (0..n).map(lanes).collect();
        let v: Vec<Lanes> = (n..2 * n).map(lanes).collect();
        let point =
            |l: usize| -> (Vec<f64>, Vec<f64>) { (q.iter().map(|c| c[l]).collect(), v.iter().map(|c| c[l]).collect()) };
        let same = |x: f64, y: f64| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
        for (tape, code) in tapes.iter().zip(&codes) {
            let k = tape.outputs.len();
            let mut out = vec![[0.0; LANES]; k];
            assert!(code.call_lanes(t, &q, &v, &mut out), "{src}: call");
            let plain = tape.interpreted();
            for l in 0..LANES {
                let (ql, vl) = point(l);
                let mut want = vec![0.0; k];
                plain.eval(t, &ql, &vl, |j, x| want[j] = x);
                for (j, w) in want.iter().enumerate() {
                    assert!(
                        same(out[j][l], *w),
                        "{src} output {j} lane {l} at t = {t}, q {ql:?}, v {vl:?}: {} vs {w}",
                        out[j][l]
                    );
                }
            }
        }
        let mut out = [[0.0; LANES]];
        assert!(value.call_lanes(t, &q, &v, &mut out), "{src}: value call");
        for l in 0..LANES {
            let (ql, vl) = point(l);
            let want: f64 = lag.program.eval(|i| {
                if i == 0 {
                    t
                } else if i <= n {
                    ql[i - 1]
                } else {
                    vl[i - 1 - n]
                }
            });
            assert!(same(out[0][l], want), "{src} value lane {l}: {} vs {want}", out[0][l]);
        }
    }
    // Slices shorter than the code reads or writes: refused, nothing written.
    if let Some(code) = codes.first() {
        let mut out = vec![[7.0; LANES]; 1];
        assert!(!code.call_lanes(0.0, &[], &[], &mut out) || tapes[0].outputs.is_empty());
        assert_eq!(out[0], [7.0; LANES]);
    }
}

/// The value's machine code gives `Program::eval`'s f64 bit for bit.
fn same_value(src: &str, names: &[&str]) {
    use crate::Lagrangian;
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let l = ExprLagrangian::new(src, &names, &[("k".into(), 1.7)]).unwrap();
    assert!(l.fast.value.is_some(), "{src}: value not compiled");
    let n = names.len();
    for (p, z) in points(0x2545_f491_4f6c_dd1d ^ src.len() as u64, 200 * (2 * n + 1))
        .chunks_exact(2 * n + 1)
        .enumerate()
    {
        let z: Vec<f64> = z.iter().map(|&x| if p % 7 == 3 { x.round() } else { x }).collect();
        let (t, q, v) = (z[0], &z[1..=n], &z[n + 1..]);
        let native: f64 = l.value(t, q, v);
        let program: f64 = l.program.eval(|i| z[i]);
        assert!(
            native.to_bits() == program.to_bits() || (native.is_nan() && program.is_nan()),
            "{src} at {z:?}: {native} vs {program}"
        );
    }
}
