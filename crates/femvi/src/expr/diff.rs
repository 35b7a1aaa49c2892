//! Symbolic differentiation on the expression graph: the gradient by reverse mode (adjoints
//! accumulated from the root down, one pass for all variables) and derivatives with respect to
//! one variable or along a direction by forward mode (used on the gradient for the Hessian and
//! for the force's directional derivative), with the chain rule of
//! every operation the parser knows. New nodes go through the simplifying constructors of
//! [`Dag`], so derivatives share subexpressions with the expression and with each other.

use super::dag::{Bin, Dag, Id, Node, Un, NODE_BUDGET};
use super::program::F1;
use std::collections::HashMap;

impl Dag {
    /// The derivatives of `roots` with respect to variable `var` (forward mode over the nodes
    /// they depend on, each derivative built once); None beyond the node budget.
    pub(super) fn derivative(&mut self, roots: &[Id], var: usize) -> Option<Vec<Id>> {
        let one = self.constant(1.0);
        self.directional(roots, &|i| (i == var).then_some(one))
    }

    /// The derivatives of `roots` along the direction that moves variable i at the rate
    /// `seed(i)` (a node; None: 0), by forward mode: with seed(i) = 1 for one variable this
    /// is [`Dag::derivative`]; with seed(q_j) = v_j, the directional derivative in q along v.
    /// None beyond the node budget.
    pub(super) fn directional(&mut self, roots: &[Id], seed: &dyn Fn(usize) -> Option<Id>) -> Option<Vec<Id>> {
        let order = self.reachable(roots);
        let zero = self.constant(0.0);
        let mut d: HashMap<Id, Id> = HashMap::with_capacity(order.len());
        for &a in &order {
            let da = self.derivative_of(a, seed, &d, zero);
            d.insert(a, da);
            if self.len() > NODE_BUDGET {
                return None;
            }
        }
        Some(roots.iter().map(|r| d.get(r).copied().unwrap_or(zero)).collect())
    }

    /// The gradient of `root` with respect to variables 0..vars (reverse mode: adjoints
    /// accumulated from the root down, one pass whatever the number of variables); None
    /// beyond the node budget.
    pub(super) fn gradient(&mut self, root: Id, vars: usize) -> Option<Vec<Id>> {
        let order = self.reachable(&[root]);
        let zero = self.constant(0.0);
        let mut adj: HashMap<Id, Id> = HashMap::with_capacity(order.len());
        adj.insert(root, self.constant(1.0));
        let mut grad = vec![zero; vars];
        for &a in order.iter().rev() {
            let Some(&g) = adj.get(&a) else { continue };
            if g == zero {
                continue;
            }
            let mut push = |dag: &mut Self, x: Id, c: Id| {
                let prev = adj.get(&x).copied().unwrap_or(zero);
                let sum = dag.add(prev, c);
                adj.insert(x, sum);
            };
            match self.nodes()[a as usize] {
                Node::Const(_) => {}
                Node::Var(i) => {
                    if let Some(slot) = grad.get_mut(i as usize) {
                        *slot = g;
                    }
                }
                Node::Un(op, x) => {
                    let f = self.un_derivative(op, x, a);
                    let c = self.mul(g, f);
                    push(self, x, c);
                }
                Node::Bin(op, x, y) => {
                    let (cx, cy) = self.bin_partials(op, x, y, a, g);
                    push(self, x, cx);
                    push(self, y, cy);
                }
                Node::Pick(max, p, q, x, y) => {
                    let cx = self.pick(max, p, q, g, zero);
                    let cy = self.pick(max, p, q, zero, g);
                    push(self, x, cx);
                    push(self, y, cy);
                }
            }
            if self.len() > NODE_BUDGET {
                return None;
            }
        }
        Some(grad)
    }

    /// g ∂a/∂x and g ∂a/∂y for the two-operand node `a = x op y`.
    fn bin_partials(&mut self, op: Bin, x: Id, y: Id, a: Id, g: Id) -> (Id, Id) {
        match op {
            Bin::Add => (g, g),
            Bin::Sub => (g, self.neg(g)),
            Bin::Mul => (self.mul(g, y), self.mul(g, x)),
            Bin::Div => {
                let cx = self.div(g, y);
                let r = self.mul(cx, a);
                (cx, self.neg(r))
            }
            Bin::Atan2 => {
                let x2 = self.mul(x, x);
                let y2 = self.mul(y, y);
                let den = self.add(x2, y2);
                let s = self.div(g, den);
                let cy = self.mul(s, x);
                (self.mul(s, y), self.neg(cy))
            }
            Bin::Pow => {
                // ∂/∂x = y a / x, ∂/∂y = a ln x
                let ga = self.mul(g, a);
                let q = self.div(ga, x);
                let lx = self.f(F1::Ln, x);
                (self.mul(q, y), self.mul(ga, lx))
            }
        }
    }

    /// The derivative of node `a` given those of its children in `d`.
    fn derivative_of(&mut self, a: Id, seed: &dyn Fn(usize) -> Option<Id>, d: &HashMap<Id, Id>, zero: Id) -> Id {
        let dd = |x: Id| d.get(&x).copied().unwrap_or(zero);
        match self.nodes()[a as usize] {
            Node::Const(_) => zero,
            Node::Var(i) => seed(i as usize).unwrap_or(zero),
            Node::Un(op, x) => {
                let dx = dd(x);
                if dx == zero {
                    return zero;
                }
                let f = self.un_derivative(op, x, a);
                self.mul(f, dx)
            }
            Node::Bin(op, x, y) => {
                let (dx, dy) = (dd(x), dd(y));
                if dx == zero && dy == zero {
                    return zero;
                }
                self.bin_derivative(op, x, y, a, dx, dy)
            }
            Node::Pick(max, p, q, x, y) => {
                let (dx, dy) = (dd(x), dd(y));
                self.pick(max, p, q, dx, dy)
            }
        }
    }

    /// f'(x) for the one-operand node `a = f(x)`.
    fn un_derivative(&mut self, op: Un, x: Id, a: Id) -> Id {
        match op {
            Un::Neg => self.constant(-1.0),
            Un::Sign => self.constant(0.0),
            Un::PowI(e) => {
                let p = self.un(Un::PowI(e.saturating_sub(1)), x);
                let c = self.constant(f64::from(e));
                self.mul(c, p)
            }
            Un::PowF(bits) => {
                let e = f64::from_bits(bits);
                let p = self.un(Un::PowF((e - 1.0).to_bits()), x);
                let c = self.constant(e);
                self.mul(c, p)
            }
            Un::F(f) => self.f1_derivative(f, x, a),
        }
    }

    fn f1_derivative(&mut self, f: F1, x: Id, a: Id) -> Id {
        let one = self.constant(1.0);
        match f {
            F1::Sin => self.f(F1::Cos, x),
            F1::Cos => {
                let s = self.f(F1::Sin, x);
                self.neg(s)
            }
            F1::Tan => {
                let a2 = self.mul(a, a);
                self.add(one, a2)
            }
            F1::Exp => a,
            F1::Ln => self.div(one, x),
            F1::Sqrt => {
                let half = self.constant(0.5);
                self.div(half, a)
            }
            F1::Abs => self.un(Un::Sign, x),
            F1::Sinh => self.f(F1::Cosh, x),
            F1::Cosh => self.f(F1::Sinh, x),
            F1::Tanh => {
                let a2 = self.mul(a, a);
                self.sub(one, a2)
            }
            F1::Asin | F1::Acos => {
                let x2 = self.mul(x, x);
                let s = self.sub(one, x2);
                let s = self.f(F1::Sqrt, s);
                let r = self.div(one, s);
                if f == F1::Asin {
                    r
                } else {
                    self.neg(r)
                }
            }
            F1::Atan => {
                let x2 = self.mul(x, x);
                let s = self.add(one, x2);
                self.div(one, s)
            }
        }
    }

    /// d(x op y) from dx, dy for the two-operand node `a = x op y`.
    fn bin_derivative(&mut self, op: Bin, x: Id, y: Id, a: Id, dx: Id, dy: Id) -> Id {
        match op {
            Bin::Add => self.add(dx, dy),
            Bin::Sub => self.sub(dx, dy),
            Bin::Mul => {
                let l = self.mul(dx, y);
                let r = self.mul(x, dy);
                self.add(l, r)
            }
            Bin::Div => {
                // (dx − a dy) / y
                let r = self.mul(a, dy);
                let num = self.sub(dx, r);
                self.div(num, y)
            }
            Bin::Atan2 => {
                // (y dx − x dy) / (x² + y²)
                let l = self.mul(y, dx);
                let r = self.mul(x, dy);
                let num = self.sub(l, r);
                let x2 = self.mul(x, x);
                let y2 = self.mul(y, y);
                let den = self.add(x2, y2);
                self.div(num, den)
            }
            Bin::Pow => {
                // a (dy ln x + y dx / x)
                let lx = self.f(F1::Ln, x);
                let l = self.mul(dy, lx);
                let q = self.div(dx, x);
                let r = self.mul(y, q);
                let s = self.add(l, r);
                self.mul(a, s)
            }
        }
    }
}
