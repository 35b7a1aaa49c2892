//! Tangent maps against central finite differences of whole runs: shared by the tests of
//! forced and constrained tangent maps.

/// The last node (q, p) of a run, which must not have failed.
pub fn last_state(sol: &femvi::Solution) -> Vec<f64> {
    assert!(sol.error.is_none(), "{:?}", sol.error);
    let last = sol.len() - 1;
    [sol.q_row(last).unwrap(), sol.p_row(last).unwrap()].concat()
}

/// max_i |(M v)_i − fd_i| / max |M| over the directions `dirs` (each (δq, δp)), fd by central
/// differences with step eps of `run` (the final state from a start (q, p)).
pub fn fd_difference(
    m: &[f64],
    (q, p): (&[f64], &[f64]),
    dirs: &[Vec<f64>],
    eps: f64,
    run: impl Fn(Vec<f64>, Vec<f64>) -> Vec<f64>,
) -> f64 {
    let n = q.len();
    let d = 2 * n;
    let size = m.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let mut worst = 0.0f64;
    for dir in dirs {
        let shifted = |sign: f64| {
            let q: Vec<f64> = q.iter().zip(&dir[..n]).map(|(a, b)| a + sign * eps * b).collect();
            let p: Vec<f64> = p.iter().zip(&dir[n..]).map(|(a, b)| a + sign * eps * b).collect();
            run(q, p)
        };
        let (plus, minus) = (shifted(1.0), shifted(-1.0));
        for i in 0..d {
            let mv: f64 = (0..d).map(|j| m[i * d + j] * dir[j]).sum();
            worst = worst.max((mv - (plus[i] - minus[i]) / (2.0 * eps)).abs());
        }
    }
    worst / size
}

/// The unit vectors of R^d.
pub fn unit_vectors(d: usize) -> Vec<Vec<f64>> {
    (0..d)
        .map(|j| (0..d).map(|i| if i == j { 1.0 } else { 0.0 }).collect())
        .collect()
}

/// Directions (δq, δp) with G(q0) δq = 0: the tangent `dq`s with δp = 0, and δq = 0 with each
/// unit δp.
pub fn manifold_directions(dq: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = dq[0].len();
    let mut dirs: Vec<Vec<f64>> = dq.iter().map(|v| [v.clone(), vec![0.0; n]].concat()).collect();
    dirs.extend(unit_vectors(n).into_iter().map(|e| [vec![0.0; n], e].concat()));
    dirs
}
