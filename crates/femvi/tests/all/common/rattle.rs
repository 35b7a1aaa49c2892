//! RATTLE for the spherical pendulum written out by hand (the reference of
//! `tests/all/constraints.rs` and `tests/all/rattle_exact.rs`).

/// RATTLE for L = ½|v|² − g z on |q| = 1, written out: the position constraint is a quadratic
/// in the multiplier (solved in closed form), the momentum projection a dot product. Written in
/// increments d = q_{k+1} − q_k (the quadratic's coefficients from d, not from |q_{k+1}|² − 1,
/// which cancels) with q accumulated by compensated summation: the RATTLE map evaluated to
/// round-off, as femvi's step is, so that the two trajectories differ by round-off only.
pub fn rattle(q0: [f64; 3], p0: [f64; 3], h: f64, g: f64, steps: usize) -> Vec<([f64; 3], [f64; 3])> {
    let (mut q, mut p) = (q0, p0);
    let mut comp = [0.0; 3];
    let grad_v = [0.0, 0.0, g];
    let mut out = vec![(q, p)];
    for _ in 0..steps {
        // d = e − c q with e the unconstrained drift and c from |q + d|² = 1:
        // |q|² c² − 2 c (|q|² + q·e) + (|q|² − 1 + 2 q·e + |e|²) = 0, the smaller root.
        let e: [f64; 3] = std::array::from_fn(|i| h * (p[i] - 0.5 * h * grad_v[i]));
        let (qq, qe, ee) = (dot(&q, &q), dot(&q, &e), dot(&e, &e));
        let (b, c0) = (qq + qe, (qq - 1.0) + 2.0 * qe + ee);
        let c = c0 / (b + (b * b - qq * c0).sqrt());
        let d: [f64; 3] = std::array::from_fn(|i| e[i] - c * q[i]);
        let mut q1 = [0.0; 3];
        for i in 0..3 {
            let y = d[i] + comp[i];
            q1[i] = q[i] + y;
            comp[i] = y - (q1[i] - q[i]);
        }
        let pt: [f64; 3] = std::array::from_fn(|i| d[i] / h - 0.5 * h * grad_v[i]);
        let mu = dot(&q1, &pt) / dot(&q1, &q1);
        p = std::array::from_fn(|i| pt[i] - mu * q1[i]);
        q = q1;
        out.push((q, p));
    }
    out
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
