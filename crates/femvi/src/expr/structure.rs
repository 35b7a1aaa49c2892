//! Structure detection: whether an expression Lagrangian has the form
//! L = ½vᵀMv + A(t, q)·v + c₀(t, q) (DESIGN's mechanical systems, (2.18) of the paper, when
//! A = 0 and M is constant; gyroscopic when A ≠ 0). The expression graph is expanded as a
//! polynomial of degree ≤ 2 in the velocities, node by node in topological order: sums,
//! differences, negations, products whose degrees add up to at most 2, quotients by
//! velocity-free denominators and squares stay polynomials; any other operation on a
//! velocity-dependent operand ends the detection (the Lagrangian is general). The coefficients
//! are graph nodes free of v; the quadratic ones must fold to constants for M to be constant.

use super::dag::{Bin, Dag, Id, Node, Un};
use std::collections::{BTreeMap, HashMap};

/// A polynomial of degree ≤ 2 in v with coefficients free of v (graph nodes).
#[derive(Debug, Clone, Default)]
struct Poly {
    c0: Option<Id>,
    /// Coefficient of v_i (i counted from 0).
    c1: BTreeMap<usize, Id>,
    /// Coefficient of v_i v_j, i ≤ j.
    c2: BTreeMap<(usize, usize), Id>,
}

/// A mass matrix by its diagonal and its upper off-diagonal entries (i, j, value), i < j.
pub(super) type MassEntries = (Vec<f64>, Vec<(usize, usize, f64)>);

/// The expansion of a Lagrangian: L = Σ_{i≤j} c2[i,j] v_i v_j + Σ c1[i] v_i + c0.
#[derive(Debug, Clone)]
pub(super) struct Expansion {
    /// The velocity-free part (None when it is 0).
    pub(super) c0: Option<Id>,
    /// Linear coefficients (the vector potential A), by velocity index.
    pub(super) c1: BTreeMap<usize, Id>,
    /// Constant quadratic coefficients, by (i, j) with i ≤ j; None if one is not constant.
    pub(super) c2: Option<BTreeMap<(usize, usize), f64>>,
}

impl Expansion {
    /// The mass matrix's entries as (diagonal, off-diagonal (i, j, value) with i < j):
    /// M_ii = 2 c2[i,i], M_ij = M_ji = c2[i,j]. None if a quadratic coefficient is not constant.
    pub(super) fn mass(&self, n: usize) -> Option<MassEntries> {
        let c2 = self.c2.as_ref()?;
        let mut diag = vec![0.0; n];
        let mut off = Vec::new();
        for (&(i, j), &c) in c2 {
            if i == j {
                *diag.get_mut(i)? = 2.0 * c;
            } else {
                off.push((i, j, c));
            }
        }
        Some((diag, off))
    }
}

/// Expands `root` (a graph over t = var 0, q = vars 1..=n, v = vars n+1..=2n); None if it is
/// not a polynomial of degree ≤ 2 in v.
pub(super) fn expand(dag: &mut Dag, root: Id, n: usize) -> Option<Expansion> {
    let order = dag.reachable(&[root]);
    let children = |node: Node| -> Vec<Id> {
        match node {
            Node::Const(_) | Node::Var(_) => vec![],
            Node::Un(_, x) => vec![x],
            Node::Bin(_, x, y) => vec![x, y],
            Node::Pick(_, p, q, x, y) => vec![p, q, x, y],
        }
    };
    // How often each node is used, so that an expansion used once is moved, not copied
    // (a sum of many velocity terms then costs O(terms), not O(terms²)).
    let mut uses: HashMap<Id, usize> = HashMap::with_capacity(order.len());
    for &a in &order {
        for c in children(dag.nodes()[a as usize]) {
            *uses.entry(c).or_insert(0) += 1;
        }
    }
    // The expansions of the nodes that depend on v.
    let mut polys: HashMap<Id, Poly> = HashMap::new();
    let mut take = |polys: &mut HashMap<Id, Poly>, x: Id| -> Poly {
        let left = uses.get_mut(&x).map_or(0, |u| {
            *u = u.saturating_sub(1);
            *u
        });
        let p = if left == 0 {
            polys.remove(&x)
        } else {
            polys.get(&x).cloned()
        };
        p.unwrap_or(Poly {
            c0: Some(x),
            ..Poly::default()
        })
    };
    for &a in &order {
        let node = dag.nodes()[a as usize];
        if let Node::Var(i) = node {
            let i = i as usize;
            if i > n && i <= 2 * n {
                let one = dag.constant(1.0);
                let mut p = Poly::default();
                p.c1.insert(i - n - 1, one);
                polys.insert(a, p);
            }
            continue;
        }
        let kids = children(node);
        if kids.iter().all(|c| !polys.contains_key(c)) {
            continue; // free of v
        }
        let p = match node {
            Node::Un(Un::Neg, x) => scale(dag, take(&mut polys, x), None),
            Node::Un(Un::PowI(2), x) => {
                let px = take(&mut polys, x);
                mul(dag, &px, &px)?
            }
            Node::Bin(op, x, y) => {
                let y_free = !polys.contains_key(&y);
                let (px, py) = (take(&mut polys, x), take(&mut polys, y));
                match op {
                    Bin::Add => add(dag, px, py, false),
                    Bin::Sub => add(dag, px, py, true),
                    Bin::Mul => mul(dag, &px, &py)?,
                    Bin::Div if y_free => scale(dag, px, Some(y)),
                    _ => return None,
                }
            }
            _ => return None,
        };
        polys.insert(a, p);
    }
    let p = polys.remove(&root).unwrap_or(Poly {
        c0: Some(root),
        ..Poly::default()
    });
    let c2 =
        p.c2.iter()
            .map(|(&k, &c)| dag.konst(c).map(|v| (k, v)))
            .collect::<Option<BTreeMap<_, _>>>();
    Some(Expansion { c0: p.c0, c1: p.c1, c2 })
}

/// The sum of two optional coefficients (None is 0), or their difference.
fn add_coef(dag: &mut Dag, a: Option<Id>, b: Option<Id>, minus: bool) -> Option<Id> {
    match (a, b, minus) {
        (a, None, _) => a,
        (None, Some(b), false) => Some(b),
        (None, Some(b), true) => Some(dag.neg(b)),
        (Some(a), Some(b), false) => Some(dag.add(a, b)),
        (Some(a), Some(b), true) => Some(dag.sub(a, b)),
    }
}

/// Removes coefficients that folded to 0.
fn prune<K: Ord>(dag: &Dag, map: &mut BTreeMap<K, Id>) {
    map.retain(|_, c| dag.konst(*c) != Some(0.0));
}

/// a + b, or a − b if `minus`; the smaller is merged into the larger.
fn add(dag: &mut Dag, mut a: Poly, mut b: Poly, minus: bool) -> Poly {
    if minus {
        b = scale(dag, b, None);
    } else if a.c1.len() + a.c2.len() < b.c1.len() + b.c2.len() {
        std::mem::swap(&mut a, &mut b);
    }
    merge(dag, &mut a.c1, b.c1);
    merge(dag, &mut a.c2, b.c2);
    a.c0 = add_coef(dag, a.c0, b.c0, false);
    a
}

/// Adds the coefficients of `from` into `into`, dropping those that fold to 0.
fn merge<K: Ord + Copy>(dag: &mut Dag, into: &mut BTreeMap<K, Id>, from: BTreeMap<K, Id>) {
    for (k, c) in from {
        let s = match into.get(&k) {
            Some(&prev) => dag.add(prev, c),
            None => c,
        };
        if dag.konst(s) == Some(0.0) {
            into.remove(&k);
        } else {
            into.insert(k, s);
        }
    }
}

/// p / d if `div` is Some(d), else −p.
fn scale(dag: &mut Dag, mut p: Poly, div: Option<Id>) -> Poly {
    let f = |dag: &mut Dag, c: &mut Id| {
        *c = match div {
            Some(d) => dag.div(*c, d),
            None => dag.neg(*c),
        }
    };
    if let Some(c) = p.c0.as_mut() {
        f(dag, c);
    }
    p.c1.values_mut().for_each(|c| f(dag, c));
    p.c2.values_mut().for_each(|c| f(dag, c));
    p
}

/// c·p for a coefficient c free of v.
fn times(dag: &mut Dag, c: Id, p: &Poly) -> Poly {
    let mut out = Poly {
        c0: p.c0.map(|x| dag.mul(c, x)),
        ..Poly::default()
    };
    for (&k, &x) in &p.c1 {
        out.c1.insert(k, dag.mul(c, x));
    }
    for (&k, &x) in &p.c2 {
        out.c2.insert(k, dag.mul(c, x));
    }
    prune(dag, &mut out.c1);
    prune(dag, &mut out.c2);
    out
}

/// a·b, None if the degree would exceed 2.
fn mul(dag: &mut Dag, a: &Poly, b: &Poly) -> Option<Poly> {
    let deg = |p: &Poly| {
        if !p.c2.is_empty() {
            2
        } else {
            usize::from(!p.c1.is_empty())
        }
    };
    if deg(a) + deg(b) > 2 {
        return None;
    }
    let mut out = Poly::default();
    if let Some(c) = a.c0 {
        let t = times(dag, c, b);
        out = add(dag, out, t, false);
    }
    if let Some(c) = b.c0 {
        let mut rest = a.clone();
        rest.c0 = None;
        let t = times(dag, c, &rest);
        out = add(dag, out, t, false);
    }
    for (&i, &x) in &a.c1 {
        for (&j, &y) in &b.c1 {
            let key = (i.min(j), i.max(j));
            let xy = dag.mul(x, y);
            let s = add_coef(dag, out.c2.get(&key).copied(), Some(xy), false);
            out.c2.extend(s.map(|s| (key, s)));
        }
    }
    prune(dag, &mut out.c2);
    Some(out)
}
