//! The optimiser's input checks and its first iterate: the data of a [`ControlProblem`] and
//! a [`Guess`] validated (dimensions, finite values, ordered bounds), the guess interpolated
//! linearly onto the nodes and quadrature points and moved strictly inside the bounds, and the
//! barrier's duals started at μ/(distance to the bound).

use super::assemble::Model;
use super::iterate::{Bound, Iterate};
use super::system::Controls;
use super::{ControlProblem, FinalTime, Guess, OptimizeOptions};
use crate::error::{check_len, invalid, Result};
use crate::lagrangian::Lagrangian;

pub(super) fn validate<L: Lagrangian + ?Sized, C: Controls>(
    lag: &L,
    controls: &C,
    p: &ControlProblem,
    o: &OptimizeOptions,
) -> Result<()> {
    let (n, m) = (lag.dim(), controls.controls());
    if n == 0 || controls.dim() != n {
        return Err(invalid(
            "controls",
            format!(
                "the controls are for {} coordinates, the Lagrangian has {n}",
                controls.dim()
            ),
        ));
    }
    let q1: Vec<f64> = p.q1.iter().flatten().copied().collect();
    let v1: Vec<f64> = p.v1.iter().flatten().copied().collect();
    check_len("boundary q1", n, p.q1.len())?;
    check_len("boundary v1", n, p.v1.len())?;
    for (what, len, v) in [
        ("q0", n, &p.q0),
        ("v0", n, &p.v0),
        ("q1", q1.len(), &q1),
        ("v1", v1.len(), &v1),
    ] {
        check_len(&format!("boundary {what}"), len, v.len())?;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(invalid(&format!("boundary {what}"), "all values must be finite"));
        }
    }
    check_bounds("control", m, &p.lower, &p.upper)?;
    if !(p.q_lower.is_empty() && p.q_upper.is_empty()) {
        check_bounds("coordinate", n, &p.q_lower, &p.q_upper)?;
        let ends =
            p.q0.iter()
                .map(|&x| ("q0", Some(x)))
                .chain(p.q1.iter().map(|&x| ("q1", x)));
        for (i, (what, x)) in ends.enumerate() {
            let (c, lo, up) = (i % n, p.q_lower[i % n], p.q_upper[i % n]);
            if x.is_some_and(|x| x < lo || x > up) {
                return Err(invalid(
                    "coordinate bounds",
                    format!(
                        "the boundary position {what}[{c}] = {} is outside the bounds [{lo}, {up}]: no path can start or end there",
                        x.unwrap_or(f64::NAN)
                    ),
                ));
            }
        }
    }
    if p.elements == 0 {
        return Err(invalid("elements", "at least one element is needed"));
    }
    if !p.t0.is_finite() || !p.time_weight.is_finite() {
        return Err(invalid("t0 and the time weight", "must be finite"));
    }
    match p.t1 {
        FinalTime::Fixed(t1) if !(t1.is_finite() && t1 > p.t0) => {
            return Err(invalid(
                "t1",
                format!("t1 = {t1} is not a finite time after t0 = {}", p.t0),
            ));
        }
        FinalTime::Free { min, max, guess } if !(min > p.t0 && min < guess && guess < max && max.is_finite()) => {
            return Err(invalid(
                "free t1",
                format!("need t0 = {} < t1_min = {min} < guess = {guess} < t1_max = {max}", p.t0),
            ));
        }
        _ => {}
    }
    if o.tolerance.is_nan() || o.tolerance <= 0.0 || o.max_iterations == 0 {
        return Err(invalid(
            "options",
            "the tolerance must be positive and the iteration limit at least 1",
        ));
    }
    if let Some(g) = &o.guess {
        check_guess(g, n, m)?;
    }
    check_constraints(controls, p)
}

/// The given ends on the constraint manifold (g = 0 within the library's start tolerance)
/// and their given velocities tangent to it (G v = 0 to the same relative tolerance), with
/// fewer constraints than coordinates.
fn check_constraints<C: Controls>(controls: &C, p: &ControlProblem) -> Result<()> {
    use crate::constraints::limits::START_TOLERANCE;
    use num_dual::Dual64;
    let (n, mc) = (controls.dim(), controls.constraint_count());
    if mc == 0 {
        return Ok(());
    }
    if controls.constraint_dim() != n {
        return Err(invalid(
            "constraints",
            format!(
                "the constraints are on {} coordinates, the system has {n}",
                controls.constraint_dim()
            ),
        ));
    }
    if mc >= n {
        return Err(invalid(
            "constraints",
            format!("{mc} constraints on {n} coordinates leave no motion: give fewer than {n}"),
        ));
    }
    let q1: Option<Vec<f64>> = p.q1.iter().copied().collect();
    let v1: Option<Vec<f64>> = p.v1.iter().copied().collect();
    let ends = [("0", Some(&p.q0), Some(&p.v0)), ("1", q1.as_ref(), v1.as_ref())];
    let mut g = vec![Dual64::from(0.0); mc];
    let off = |x: f64, tol: f64| x.is_nan() || x.abs() > tol;
    for (end, q, v) in ends {
        let Some(q) = q else { continue };
        let zero = vec![0.0; n];
        let qd: Vec<Dual64> = q
            .iter()
            .zip(v.unwrap_or(&zero))
            .map(|(&a, &b)| Dual64::new(a, b))
            .collect();
        controls.constraints(&qd, &mut g);
        let scale = q.iter().fold(1.0f64, |a, b| a.max(b.abs()));
        let vscale = v.map_or(1.0, |v| v.iter().fold(1.0f64, |a, b| a.max(b.abs())));
        if let Some(l) = (0..mc).find(|&l| off(g[l].re, START_TOLERANCE * scale * scale)) {
            return Err(invalid(
                &format!("boundary q{end}"),
                format!(
                    "violates constraint {}: g = {:.3e} (tolerance {START_TOLERANCE:.0e} * max(1, |q|^2))",
                    l + 1,
                    g[l].re
                ),
            ));
        }
        if let Some(l) = (0..mc).find(|&l| off(g[l].eps, START_TOLERANCE * scale * scale * vscale)) {
            return Err(invalid(
                &format!("boundary v{end}"),
                format!(
                    "is not tangent to constraint {}: G v = {:.3e}; the velocity must satisfy the hidden constraint",
                    l + 1,
                    g[l].eps
                ),
            ));
        }
    }
    Ok(())
}

/// `len` pairs of bounds, each lower below upper.
fn check_bounds(what: &str, len: usize, lower: &[f64], upper: &[f64]) -> Result<()> {
    check_len(&format!("{what} lower bounds"), len, lower.len())?;
    check_len(&format!("{what} upper bounds"), len, upper.len())?;
    for (c, (lo, up)) in lower.iter().zip(upper).enumerate() {
        if lo.is_nan() || up.is_nan() || lo >= up || *lo == f64::INFINITY || *up == f64::NEG_INFINITY {
            return Err(invalid(
                &format!("{what} bounds"),
                format!("{what} {c}: lower {lo} must be below upper {up}"),
            ));
        }
    }
    Ok(())
}

fn check_guess(g: &Guess, n: usize, m: usize) -> Result<()> {
    if g.t.is_empty()
        || g.t
            .windows(2)
            .any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater))
        || g.t.iter().any(|x| !x.is_finite())
    {
        return Err(invalid(
            "guess",
            "its times must be finite and increasing, at least one",
        ));
    }
    check_len("guess positions", g.t.len() * n, g.q.len())?;
    if let Some(u) = &g.u {
        check_len("guess controls", g.t.len() * m, u.len())?;
    }
    if g.q.iter().chain(g.u.iter().flatten()).any(|x| !x.is_finite()) {
        return Err(invalid("guess", "all values must be finite"));
    }
    Ok(())
}

/// Linear interpolation of row-major `rows` (width w) at t, ends held.
pub(super) fn interpolate(times: &[f64], rows: &[f64], w: usize, t: f64, out: &mut [f64]) {
    let k = times.partition_point(|&s| s <= t);
    let (i, j, a) = if k == 0 {
        (0, 0, 0.0)
    } else if k >= times.len() {
        (times.len() - 1, times.len() - 1, 0.0)
    } else {
        (k - 1, k, (t - times[k - 1]) / (times[k] - times[k - 1]))
    };
    for c in 0..w {
        out[c] = (1.0 - a) * rows[i * w + c] + a * rows[j * w + c];
    }
}

/// The first iterate and the bounded unknowns.
pub(super) fn start<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    problem: &ControlProblem,
    guess: Option<&Guess>,
    t1: f64,
) -> Result<(Iterate, Vec<Bound>)> {
    let l = model.layout;
    let (n, m) = (l.n, l.m);
    let mut x = vec![0.0; l.size()];
    let h = (t1 - problem.t0) / l.elements as f64;
    // The straight line ends at the given q1, and stays level in a free component.
    let end = problem.q1.iter().zip(&problem.q0).map(|(x, x0)| x.unwrap_or(*x0));
    let line = Guess {
        t: vec![problem.t0, t1],
        q: problem.q0.iter().copied().chain(end).collect(),
        u: None,
    };
    let g = guess.unwrap_or(&line);
    let mut coordinate_bounds = start_positions(model, problem, g, t1, &mut x);
    let mut row = vec![0.0; n.max(m)];
    let mut bounds = Vec::new();
    for k in 0..l.elements {
        for j in 0..l.r {
            let t = problem.t0 + (k as f64 + model.element.rule.nodes[j]) * h;
            row.iter_mut().for_each(|v| *v = 0.0);
            if let Some(u) = &g.u {
                interpolate(&g.t, u, m, t, &mut row);
            }
            for c in 0..m {
                let (lo, up) = (problem.lower[c], problem.upper[c]);
                x[l.u(k, j) + c] = inside(row[c], lo, up);
                if lo.is_finite() || up.is_finite() {
                    bounds.push(Bound {
                        var: Some(l.u(k, j) + c),
                        lo,
                        up,
                    });
                }
            }
        }
    }
    bounds.append(&mut coordinate_bounds);
    if let FinalTime::Free { min, max, .. } = problem.t1 {
        bounds.push(Bound {
            var: None,
            lo: min,
            up: max,
        });
    }
    let mu = 0.1;
    let zl = bounds
        .iter()
        .map(|b| {
            if b.lo.is_finite() {
                mu / (value(&x, t1, b) - b.lo)
            } else {
                0.0
            }
        })
        .collect();
    let zu = bounds
        .iter()
        .map(|b| {
            if b.up.is_finite() {
                mu / (b.up - value(&x, t1, b))
            } else {
                0.0
            }
        })
        .collect();
    Ok((Iterate { x, t1, zl, zu }, bounds))
}

/// The guess's positions at the nodes (moved inside the coordinate bounds) and a free end
/// velocity's start into `x`; the bounded positions.
fn start_positions<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    problem: &ControlProblem,
    g: &Guess,
    t1: f64,
    x: &mut [f64],
) -> Vec<Bound> {
    let (l, n) = (model.layout, model.layout.n);
    let h = (t1 - problem.t0) / l.elements as f64;
    let mut row = vec![0.0; n];
    let (lower, upper) = coordinate_bounds(problem, n);
    let position = |x: &mut [f64], i: usize, c: usize, value: f64, bounds: &mut Vec<Bound>| {
        x[i] = inside(value, lower[c], upper[c]);
        if lower[c].is_finite() || upper[c].is_finite() {
            bounds.push(Bound {
                var: Some(i),
                lo: lower[c],
                up: upper[c],
            });
        }
    };
    let mut coordinate_bounds = Vec::new();
    for node in 0..l.nodes() {
        let (k, a) = (node / l.s, node % l.s);
        let tau = model.element.basis.nodes.get(a).copied().unwrap_or(0.0);
        interpolate(&g.t, &g.q, n, problem.t0 + (k as f64 + tau) * h, &mut row);
        for c in 0..n {
            let index = if node + 1 == l.nodes() {
                model.end_q[c]
            } else {
                l.q(node).map(|i| i + c)
            };
            if let Some(i) = index {
                position(x, i, c, row[c], &mut coordinate_bounds);
            }
        }
    }
    // A free end velocity starts at the guess's slope over the last element.
    let mut before = vec![0.0; n];
    interpolate(&g.t, &g.q, n, t1 - h, &mut before);
    interpolate(&g.t, &g.q, n, t1, &mut row);
    for c in 0..n {
        if let Some(i) = model.end_v[c] {
            x[i] = (row[c] - before[c]) / h;
        }
    }
    coordinate_bounds
}

/// The coordinates' bounds, infinite when none are given.
fn coordinate_bounds(problem: &ControlProblem, n: usize) -> (Vec<f64>, Vec<f64>) {
    if problem.q_lower.is_empty() {
        (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n])
    } else {
        (problem.q_lower.clone(), problem.q_upper.clone())
    }
}

fn value(x: &[f64], t1: f64, b: &Bound) -> f64 {
    b.var.map_or(t1, |i| x[i])
}

/// x moved strictly inside [lo, up] (by 1% of the width, or of max(1, |bound|) for one bound).
fn inside(x: f64, lo: f64, up: f64) -> f64 {
    let width = up - lo;
    let lo_in = match (lo.is_finite(), width.is_finite()) {
        (false, _) => f64::NEG_INFINITY,
        (true, true) => lo + 0.01 * width,
        (true, false) => lo + 0.01 * lo.abs().max(1.0),
    };
    let up_in = match (up.is_finite(), width.is_finite()) {
        (false, _) => f64::INFINITY,
        (true, true) => up - 0.01 * width,
        (true, false) => up - 0.01 * up.abs().max(1.0),
    };
    x.max(lo_in).min(up_in)
}
