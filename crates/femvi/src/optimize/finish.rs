//! The optimiser's result: the best iterate read off as an [`Optimum`] (positions and
//! momenta at the element end nodes, controls at the quadrature points, the end velocity),
//! with the reason a run stopped short, and with constraints the momenta projected onto the
//! cotangent space of the manifold.

use super::assemble::Model;
use super::solver::Outcome;
use super::system::{self, Controls};
use super::Optimum;
use crate::error::Error;
use crate::lagrangian::Lagrangian;

/// The [`Optimum`] of a finished iteration.
pub(super) fn optimum<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    out: &Outcome,
    tolerance: f64,
    bounds: (&[f64], &[f64]),
) -> Optimum {
    let l = model.layout;
    let (n, m) = (l.n, l.m);
    let it = &out.best;
    let vals = model.values(&it.x, it.t1);
    let h = model.step(it.t1);
    let nodes = model.positions(&it.x);
    let q: Vec<f64> = (0..=l.elements)
        .flat_map(|k| nodes[k * l.s * n..(k * l.s + 1) * n].to_vec())
        .collect();
    let mut u = Vec::with_capacity(l.elements * l.r * m);
    let mut control_t = Vec::with_capacity(l.elements * l.r);
    for k in 0..l.elements {
        for j in 0..l.r {
            control_t.push(model.t0 + (k as f64 + model.element.rule.nodes[j]) * h);
            u.extend_from_slice(&it.x[l.u(k, j)..l.u(k, j) + m]);
        }
    }
    let error = (!out.converged).then(|| Error::NotConverged {
        what: "optimal control".to_string(),
        iterations: out.iterations,
        residual: out.violation.max(out.optimality),
        reason: stalled(out.reason.clone().unwrap_or_default(), out.violation, tolerance),
    });
    let (p, unprojected) = momenta(model, &it.x, it.t1, &q);
    let error = error.or_else(|| {
        unprojected.map(|reason| Error::NotConverged {
            what: "optimal control's output".to_string(),
            iterations: out.iterations,
            residual: out.violation.max(out.optimality),
            reason,
        })
    });
    Optimum {
        objective: vals.objective,
        t1: it.t1,
        iterations: out.iterations,
        violation: out.violation,
        optimality: out.optimality,
        t: (0..=l.elements).map(|k| model.t0 + k as f64 * h).collect(),
        q,
        p,
        control_t,
        u_nodes: node_controls(&model.element.rule.nodes, l.elements, m, &u, bounds),
        u,
        v1: (0..n).map(|i| model.end_velocity(&it.x, i).0).collect(),
        error,
        stages: Vec::new(),
    }
}

/// The controls at the element end nodes, read off the quadrature values `u` (N·r rows of m
/// at the rule's nodes `c` ∈ [0, 1]): at each node, the polynomial through the quadrature
/// values of the two elements nearest to it (the two it joins; the first or last two at the
/// ends; points that coincide, as a Lobatto rule's at a shared node, merged by their mean),
/// evaluated at the node. Inside the mesh this interpolates across the node; the mean of two
/// one-sided extrapolations, one from each element, reads a smooth control two orders of
/// magnitude less accurately (the cart-pole example, degree 2, 100 elements, against a 16×
/// finer solve: 0.09 for that mean, 9.5e-4 for this reading, of a control of size 27). The
/// result is clamped into the control bounds, which the quadrature values satisfy.
/// (N + 1) rows of m; empty for no elements.
pub(super) fn node_controls(
    c: &[f64],
    elements: usize,
    m: usize,
    u: &[f64],
    (lower, upper): (&[f64], &[f64]),
) -> Vec<f64> {
    let r = c.len();
    if elements == 0 || r == 0 || m == 0 {
        return Vec::new();
    }
    let mut out = Vec::with_capacity((elements + 1) * m);
    let mut points: Vec<(f64, usize)> = Vec::with_capacity(2 * r);
    for node in 0..=elements {
        // The elements [first, first + 1] (or the only one), in units of h from the node.
        let first = node.saturating_sub(1).min(elements.saturating_sub(2));
        points.clear();
        for k in first..(first + 2).min(elements) {
            for (j, cj) in c.iter().enumerate() {
                points.push((k as f64 + cj - node as f64, k * r + j));
            }
        }
        for a in 0..m {
            let mut merged: Vec<(f64, f64)> = Vec::with_capacity(points.len());
            for &(tau, row) in &points {
                let value = u[row * m + a];
                match merged.iter_mut().find(|(t, _)| (t - tau).abs() < 1e-12) {
                    Some(p) => p.1 = 0.5 * (p.1 + value),
                    None => merged.push((tau, value)),
                }
            }
            let value: f64 = (0..merged.len())
                .map(|j| {
                    let w: f64 = (0..merged.len())
                        .filter(|&i| i != j)
                        .map(|i| (0.0 - merged[i].0) / (merged[j].0 - merged[i].0))
                        .product();
                    w * merged[j].1
                })
                .sum();
            let lo = lower.get(a).copied().unwrap_or(f64::NEG_INFINITY);
            let hi = upper.get(a).copied().unwrap_or(f64::INFINITY);
            out.push(value.max(lo).min(hi));
        }
    }
    out
}

/// The discrete momenta at the element end nodes; with constraints projected onto the
/// cotangent space of the constraint manifold (the hidden constraint G ∂H/∂p = 0 fixes the
/// node impulse's split between the two elements, as in the initial value problem).
pub(super) fn momenta<L: Lagrangian + ?Sized, C: Controls>(
    model: &Model<'_, L, C>,
    x: &[f64],
    t1: f64,
    q: &[f64],
) -> (Vec<f64>, Option<String>) {
    use crate::constraints::{jet::ConstraintJet, project::Projector};
    let mut p = model.momenta(x, t1);
    let (n, mc, elements) = (model.layout.n, model.layout.mc, model.layout.elements);
    if mc == 0 || elements == 0 {
        return (p, None);
    }
    let held = system::Held(model.ctl);
    let (mut jet, mut projector) = (ConstraintJet::new(mc, n), Projector::new(n, mc));
    let h = model.step(t1);
    let (mut v, mut out) = (vec![0.0; n], vec![0.0; n]);
    let mut failed = None;
    for k in 0..=elements {
        let a = k.saturating_sub(1).min(elements - 1);
        (0..n).for_each(|i| v[i] = (q[(a + 1) * n + i] - q[a * n + i]) / h);
        let qk = &q[k * n..(k + 1) * n];
        jet.eval(&held, qk, false);
        let t = model.t0 + k as f64 * h;
        let row = &mut p[k * n..(k + 1) * n];
        match projector.project(model.lag, &jet, t, qk, row, &mut v, &mut out, 1e-13, 20) {
            Ok(_) => row.copy_from_slice(&out),
            // A node where G is singular or the projection does not converge keeps no
            // momentum: NaN, and the first such node is reported.
            Err(e) => {
                row.iter_mut().for_each(|x| *x = f64::NAN);
                failed.get_or_insert((k, e));
            }
        }
    }
    (
        p,
        failed.map(|(k, e)| {
            format!("the momentum at node {k} could not be projected onto the constraint manifold ({e:?}); it is NaN")
        }),
    )
}

/// The reason of a failed run, with the likely cause when the equations stay violated: no
/// control within the bounds steers the system between the given ends (in the given time).
fn stalled(reason: String, violation: f64, tolerance: f64) -> String {
    if violation > 1e3 * tolerance.max(1e-9) {
        format!(
            "{reason}; the discrete equations are still violated by {violation:.2e}: the end data may be out of reach within the bounds and t1"
        )
    } else {
        reason
    }
}
