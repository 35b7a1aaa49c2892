//! The optimiser's Hessian against differences of its gradient, and the node reading of the
//! controls against polynomials it must reproduce.

use super::assemble::{Border, Model};
use super::layout::Layout;
use super::{Controls, Element, ExprControls, WithConstraints};
use crate::constraints::ExprConstraints;
use crate::expr::ExprLagrangian;
use crate::solve::BandMatrix;

/// The assembled Hessian is the derivative of the assembled gradient (central
/// differences), free final time, free end components and a terminal cost included.
#[test]
fn hessian_matches_differences_of_the_gradient() {
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let coords = names(&["x", "th"]);
    let lag = ExprLagrangian::new(
        "0.5*2.5*x_dot^2 + 0.25*x_dot*th_dot*cos(th) + 0.0625*th_dot^2 + 2.4*cos(th) + t*x",
        &coords,
        &[],
    )
    .unwrap();
    let ctl = ExprControls::new(
        &coords,
        &names(&["u"]),
        &names(&["u*(1+0.1*x)", "0.2*u*th_dot"]),
        "u^2 + x*th_dot^2 + t*u",
        &[],
    )
    .unwrap()
    .with_terminal(&coords, "x*th_dot^2 + t*th + x_dot^2*cos(x)", &[])
    .unwrap();
    // (order, free t1, free end position components, free end velocity components)
    for (order, free, fq, fv) in [(2, false, 0, 0), (4, false, 1, 2), (6, true, 2, 1), (2, true, 1, 1)] {
        check(&lag, &ctl, order, free, fq, fv);
    }
    let circle = ExprConstraints::new(&names(&["x^2 + sin(th)*x - 1"]), &coords, &[]).unwrap();
    let held = WithConstraints {
        controls: &ctl,
        constraints: &circle,
    };
    for (order, free, fq, fv) in [(2, false, 0, 0), (4, true, 1, 2), (6, false, 2, 1)] {
        check(&lag, &held, order, free, fq, fv);
    }
}

fn check<C: Controls>(lag: &ExprLagrangian, ctl: &C, order: usize, free: bool, fq: usize, fv: usize) {
    {
        let element = Element::with_order(order).unwrap();
        let layout = Layout {
            n: 2,
            m: 1,
            s: element.degree(),
            r: element.points(),
            elements: 3,
            free_q: fq,
            free_v: fv,
            mc: ctl.constraint_count(),
            hidden: ctl.constraint_count() > 0 && fq + fv > 0,
        };
        // The last `fq` position and first `fv` velocity components are free.
        let end_q = (0..2)
            .map(|i| (i + fq >= 2).then(|| layout.end_q(i + fq - 2)))
            .collect();
        let end_v = (0..2).map(|i| (i < fv).then(|| layout.end_v(i))).collect();
        let model = Model {
            lag,
            ctl,
            element: &element,
            layout,
            t0: 0.1,
            free,
            q0: vec![0.1, 0.2],
            q1: vec![0.8, 3.0],
            v1: vec![0.3, -0.2],
            end_q,
            end_v,
            p0: vec![0.5, 0.1],
            time_weight: 0.7,
        };
        let size = layout.size();
        let x: Vec<f64> = (0..size).map(|i| ((i * 7919) % 97) as f64 / 97.0 - 0.5).collect();
        let t1 = 2.0;
        let bw = layout.bandwidth();
        let mut band = BandMatrix::zeros(size, bw, bw).unwrap();
        let mut grad = vec![0.0; size];
        let mut border = Border {
            col: vec![0.0; size],
            diag: 0.0,
            grad: 0.0,
        };
        model.assemble(&x, t1, &mut band, &mut grad, &mut border).unwrap();
        // The line search's residuals are the gradient's multiplier rows.
        let c = model.values(&x, t1).c;
        let mut rows: Vec<usize> = (0..layout.nodes())
            .flat_map(|g| layout.lambda(g)..layout.lambda(g) + 2)
            .collect();
        let mc = layout.mc;
        rows.extend(
            (0..layout.nodes())
                .filter_map(|g| layout.kappa(g))
                .flat_map(|k| k..k + mc),
        );
        rows.extend(layout.hidden().map(|h| h..h + mc).into_iter().flatten());
        for &i in &rows {
            assert!(
                (c[i] - grad[i]).abs() <= 1e-12 * (1.0 + grad[i].abs()),
                "row {i}: {} {}",
                c[i],
                grad[i]
            );
        }
        let eps = 1e-6;
        let grad_at = |x: &[f64], t1: f64| {
            let mut b = BandMatrix::zeros(size, bw, bw).unwrap();
            let mut g = vec![0.0; size];
            let mut bd = Border {
                col: vec![0.0; size],
                diag: 0.0,
                grad: 0.0,
            };
            model.assemble(x, t1, &mut b, &mut g, &mut bd).unwrap();
            (g, bd.grad)
        };
        let mut worst = 0.0f64;
        for j in 0..size {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[j] += eps;
            xm[j] -= eps;
            let ((gp, tp), (gm, tm)) = (grad_at(&xp, t1), grad_at(&xm, t1));
            for i in 0..size {
                let fd = (gp[i] - gm[i]) / (2.0 * eps);
                worst = worst.max((fd - band.get(i, j)).abs() / (1.0 + fd.abs()));
            }
            if free {
                worst = worst.max(((tp - tm) / (2.0 * eps) - border.col[j]).abs());
            }
        }
        if free {
            let ((gp, tp), (gm, tm)) = (grad_at(&x, t1 + eps), grad_at(&x, t1 - eps));
            for i in 0..size {
                worst = worst.max(((gp[i] - gm[i]) / (2.0 * eps) - border.col[i]).abs());
            }
            worst = worst.max(((tp - tm) / (2.0 * eps) - border.diag).abs() / (1.0 + border.diag.abs()));
        }
        assert!(worst < 1e-6, "order {order}: worst relative difference {worst:.3e}");
    }
}

/// The node reading of the controls reproduces a control that is a polynomial of degree
/// below the number of points it uses: a Gauss rule (points inside the elements) and a
/// Lobatto one (points shared at the nodes, merged); and clamps into the bounds.
#[test]
fn node_controls_reproduce_polynomials_and_keep_the_bounds() {
    let f = |t: f64| [1.0 + 2.0 * t - 0.5 * t * t, 3.0 - t];
    let s3 = 0.6f64.sqrt();
    let rules: [&[f64]; 2] = [&[0.5 - 0.5 * s3, 0.5, 0.5 + 0.5 * s3], &[0.0, 0.5, 1.0]];
    for c in rules {
        for elements in [1, 2, 5] {
            let u: Vec<f64> = (0..elements)
                .flat_map(|k| c.iter().flat_map(move |cj| f(k as f64 + cj)))
                .collect();
            let open = [f64::NEG_INFINITY; 2];
            let closed = [f64::INFINITY; 2];
            let nodes = super::finish::node_controls(c, elements, 2, &u, (&open, &closed));
            assert_eq!(nodes.len(), (elements + 1) * 2);
            for (k, row) in nodes.chunks(2).enumerate() {
                let want = f(k as f64);
                assert!(
                    (row[0] - want[0]).abs() < 1e-12 && (row[1] - want[1]).abs() < 1e-12,
                    "{c:?} {k} {row:?}"
                );
            }
            let clamped = super::finish::node_controls(c, elements, 2, &u, (&[1.5, 0.0], &[2.0, 2.5]));
            assert!(clamped
                .chunks(2)
                .all(|r| (1.5..=2.0).contains(&r[0]) && (0.0..=2.5).contains(&r[1])));
            assert_eq!(clamped[0], 1.5);
        }
    }
}
