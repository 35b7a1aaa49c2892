//! Expressions as a directed acyclic graph with hash-consing, for symbolic differentiation.
//!
//! Every node is stored once (a node equal to an existing one gets its id: common
//! subexpressions are shared), children always have smaller ids than their parents (the arena
//! is in topological order, so every pass is a loop, never a recursion), and the constructors
//! simplify lightly: operations on constants are folded with the same f64 arithmetic the
//! program evaluates, and `x + 0`, `x - 0`, `0 - x`, `x * 0`, `x * 1`, `x * -1`, `x / 1`,
//! `0 / x`, `--x` are rewritten. (`x * 0 = 0` differs from IEEE arithmetic when x is infinite
//! or NaN; derivatives are only asked for where the expression is finite.) The operands of
//! `+` and `*` are put in the order of their ids: IEEE addition and multiplication commute, so
//! this changes no value and lets `a*b` and `b*a` share one node.
//!
//! The graph is grown by [`Dag::add_program`] and by differentiation (`diff.rs`) up to a node budget;
//! beyond it they return `None` and the caller keeps automatic differentiation.

use super::program::{Op, F1, F2};
use std::collections::HashMap;

/// Index of a node in the arena.
pub(super) type Id = u32;

/// One-operand operations. `Sign` is the derivative of `abs` (1 if x > 0, else −1, as in
/// num-dual).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Un {
    Neg,
    PowI(i32),
    /// `powf` with the exponent's bits.
    PowF(u64),
    F(F1),
    Sign,
}

/// Two-operand operations. `Pow` is x^y with both operands variable (f64 `powf`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Bin {
    Add,
    Sub,
    Mul,
    Div,
    Atan2,
    Pow,
}

/// A node. `Pick(max, a, b, x, y)` is `y` if b < a (b > a when `max`), else `x`: `min(a, b)`
/// is `Pick(false, a, b, a, b)`, and its derivative picks the derivatives the same way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Node {
    /// A constant, by its bits.
    Const(u64),
    Var(u32),
    Un(Un, Id),
    Bin(Bin, Id, Id),
    Pick(bool, Id, Id, Id, Id),
}

/// The most nodes a graph may grow to (about 50 MB with its index).
pub(super) const NODE_BUDGET: usize = 400_000;

/// An arena of unique nodes.
#[derive(Debug, Clone, Default)]
pub(super) struct Dag {
    nodes: Vec<Node>,
    index: HashMap<Node, Id>,
}

impl Dag {
    /// The nodes, children before parents.
    pub(super) fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Number of nodes.
    pub(super) fn len(&self) -> usize {
        self.nodes.len()
    }

    /// The constant value of node `a`, if it is a constant.
    pub(super) fn konst(&self, a: Id) -> Option<f64> {
        match self.nodes.get(a as usize) {
            Some(Node::Const(bits)) => Some(f64::from_bits(*bits)),
            _ => None,
        }
    }

    /// x if node `a` is −x (a negation, or a negative constant: then x is its magnitude).
    fn negated(&self, a: Id) -> Option<Id> {
        match self.nodes.get(a as usize) {
            Some(Node::Un(Un::Neg, x)) => Some(*x),
            _ => None,
        }
    }

    /// (x, true) if `a` is −x, else (a, false); a negative constant −c gives (c, true).
    fn unsigned(&mut self, a: Id) -> (Id, bool) {
        if let Some(x) = self.negated(a) {
            return (x, true);
        }
        match self.konst(a) {
            Some(c) if c.is_sign_negative() && !c.is_nan() => (self.constant(-c), true),
            _ => (a, false),
        }
    }

    fn is(&self, a: Id, c: f64) -> bool {
        self.konst(a) == Some(c)
    }

    /// The id of `node`, added if new.
    fn intern(&mut self, node: Node) -> Id {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = self.nodes.len() as Id;
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    /// The constant `c`.
    pub(super) fn constant(&mut self, c: f64) -> Id {
        self.intern(Node::Const(c.to_bits()))
    }

    /// Variable `i`.
    pub(super) fn var(&mut self, i: usize) -> Id {
        self.intern(Node::Var(i as u32))
    }

    /// A one-operand node, folded if `a` is a constant.
    pub(super) fn un(&mut self, op: Un, a: Id) -> Id {
        if let Some(x) = self.konst(a) {
            return self.constant(eval_un(op, x));
        }
        match (op, self.nodes[a as usize]) {
            (Un::Neg, Node::Un(Un::Neg, b)) => b,
            (Un::PowI(0), _) => self.constant(1.0),
            (Un::PowI(1), _) => a,
            _ => self.intern(Node::Un(op, a)),
        }
    }

    /// A two-operand node, folded and simplified.
    pub(super) fn bin(&mut self, op: Bin, a: Id, b: Id) -> Id {
        if let (Some(x), Some(y)) = (self.konst(a), self.konst(b)) {
            return self.constant(eval_bin(op, x, y));
        }
        match op {
            Bin::Add if self.is(a, 0.0) => b,
            Bin::Add if self.is(b, 0.0) => a,
            Bin::Sub if self.is(b, 0.0) => a,
            Bin::Sub if self.is(a, 0.0) => self.un(Un::Neg, b),
            Bin::Mul if self.is(a, 0.0) || self.is(b, 0.0) => self.constant(0.0),
            Bin::Mul if self.is(a, 1.0) => b,
            Bin::Mul if self.is(b, 1.0) => a,
            Bin::Mul if self.is(a, -1.0) => self.un(Un::Neg, b),
            Bin::Mul if self.is(b, -1.0) => self.un(Un::Neg, a),
            Bin::Div if self.is(b, 1.0) => a,
            Bin::Div if self.is(a, 0.0) => self.constant(0.0),
            // Signs move outwards, into constants, or cancel: negation is exact, so
            // (−x)·y = −(x·y), (−x)/y = −(x/y), x + (−y) = x − y and x − (−y) = x + y bit for bit.
            Bin::Mul | Bin::Div if self.negated(a).is_some() || self.negated(b).is_some() => {
                let (mut x, sx) = self.unsigned(a);
                let (mut y, sy) = self.unsigned(b);
                if sx == sy {
                    return self.bin(op, x, y);
                }
                // One sign left: into a constant operand if there is one, else outside.
                if let Some(c) = self.konst(x) {
                    x = self.constant(-c);
                } else if let Some(c) = self.konst(y) {
                    y = self.constant(-c);
                } else {
                    let r = self.bin(op, x, y);
                    return self.neg(r);
                }
                self.bin(op, x, y)
            }
            Bin::Add if self.negated(b).is_some() => {
                let y = self.negated(b).unwrap_or(b);
                self.sub(a, y)
            }
            Bin::Add if self.negated(a).is_some() => {
                let x = self.negated(a).unwrap_or(a);
                self.sub(b, x)
            }
            Bin::Sub if self.negated(b).is_some() => {
                let y = self.negated(b).unwrap_or(b);
                self.add(a, y)
            }
            Bin::Add | Bin::Mul if b < a => self.intern(Node::Bin(op, b, a)),
            _ => self.intern(Node::Bin(op, a, b)),
        }
    }

    /// `Pick(max, a, b, x, y)` (see [`Node::Pick`]), folded when it can be decided.
    pub(super) fn pick(&mut self, max: bool, a: Id, b: Id, x: Id, y: Id) -> Id {
        if x == y {
            return x;
        }
        if let (Some(ca), Some(cb)) = (self.konst(a), self.konst(b)) {
            let second = if max { cb > ca } else { cb < ca };
            return if second { y } else { x };
        }
        self.intern(Node::Pick(max, a, b, x, y))
    }

    pub(super) fn add(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Add, a, b)
    }
    pub(super) fn sub(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Sub, a, b)
    }
    pub(super) fn mul(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Mul, a, b)
    }
    pub(super) fn div(&mut self, a: Id, b: Id) -> Id {
        self.bin(Bin::Div, a, b)
    }
    pub(super) fn neg(&mut self, a: Id) -> Id {
        self.un(Un::Neg, a)
    }
    pub(super) fn f(&mut self, f: F1, a: Id) -> Id {
        self.un(Un::F(f), a)
    }

    /// The graph of a compiled program (postfix operations), and the id of its result; None
    /// if it exceeds the node budget or is malformed.
    pub(super) fn add_program(&mut self, ops: &[Op]) -> Option<Id> {
        let mut stack: Vec<Id> = Vec::new();
        for op in ops {
            let id = match *op {
                Op::Const(c) => self.constant(c),
                Op::Var(i) => self.var(i),
                Op::Neg => {
                    let a = stack.pop()?;
                    self.neg(a)
                }
                Op::PowI(e) => {
                    let a = stack.pop()?;
                    self.un(Un::PowI(e), a)
                }
                Op::PowF(e) => {
                    let a = stack.pop()?;
                    self.un(Un::PowF(e.to_bits()), a)
                }
                Op::Call1(f) => {
                    let a = stack.pop()?;
                    self.f(f, a)
                }
                Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Call2(_) => {
                    let b = stack.pop()?;
                    let a = stack.pop()?;
                    match *op {
                        Op::Add => self.add(a, b),
                        Op::Sub => self.sub(a, b),
                        Op::Mul => self.mul(a, b),
                        Op::Div => self.div(a, b),
                        Op::Call2(F2::Atan2) => self.bin(Bin::Atan2, a, b),
                        Op::Call2(F2::Pow) => self.bin(Bin::Pow, a, b),
                        Op::Call2(F2::Min) => self.pick(false, a, b, a, b),
                        _ => self.pick(true, a, b, a, b),
                    }
                }
            };
            stack.push(id);
            if self.len() > NODE_BUDGET {
                return None;
            }
        }
        match stack[..] {
            [top] => Some(top),
            _ => None,
        }
    }

    /// The nodes that `roots` depend on (themselves included), in increasing order.
    pub(super) fn reachable(&self, roots: &[Id]) -> Vec<Id> {
        let mut seen = vec![false; self.nodes.len()];
        let mut todo: Vec<Id> = roots.to_vec();
        while let Some(a) = todo.pop() {
            if std::mem::replace(&mut seen[a as usize], true) {
                continue;
            }
            match self.nodes[a as usize] {
                Node::Const(_) | Node::Var(_) => {}
                Node::Un(_, x) => todo.push(x),
                Node::Bin(_, x, y) => todo.extend([x, y]),
                Node::Pick(_, a, b, x, y) => todo.extend([a, b, x, y]),
            }
        }
        (0..self.nodes.len() as Id).filter(|&i| seen[i as usize]).collect()
    }
}

/// x^e by square and multiply, the loop of `f64::powi` (compiler-builtins' `__powidf2`:
/// r = 1; for each bit of |e| from the lowest, r ← r·x if it is set, then x ← x·x; 1/r for
/// e < 0), here inline: the same operations in the same order, so the same bits, without the
/// call. The native code unrolls the same loop (`native/emit.rs`).
#[inline]
pub(super) fn powi(x: f64, e: i32) -> f64 {
    let (mut a, mut pow, mut r) = (x, e.unsigned_abs(), 1.0);
    loop {
        if pow & 1 != 0 {
            r *= a;
        }
        pow >>= 1;
        if pow == 0 {
            break;
        }
        a *= a;
    }
    if e < 0 {
        1.0 / r
    } else {
        r
    }
}

/// A one-operand operation in f64, as the program evaluates it, except sine and cosine, taken
/// from the `libm` crate as the built-in models take them (correctly rounded in most cases,
/// and about twice as fast as glibc's on the hosts measured; see README).
#[inline]
pub(super) fn eval_un(op: Un, x: f64) -> f64 {
    match op {
        Un::Neg => -x,
        Un::PowI(e) => powi(x, e),
        Un::PowF(bits) => x.powf(f64::from_bits(bits)),
        Un::F(f) => match f {
            F1::Sin => libm::sin(x),
            F1::Cos => libm::cos(x),
            F1::Tan => x.tan(),
            F1::Exp => x.exp(),
            F1::Ln => x.ln(),
            F1::Sqrt => x.sqrt(),
            F1::Abs => x.abs(),
            F1::Sinh => x.sinh(),
            F1::Cosh => x.cosh(),
            F1::Tanh => x.tanh(),
            F1::Asin => x.asin(),
            F1::Acos => x.acos(),
            F1::Atan => x.atan(),
        },
        Un::Sign => {
            if x > 0.0 {
                1.0
            } else {
                -1.0
            }
        }
    }
}

/// A two-operand operation in f64, as the program evaluates it.
#[inline]
pub(super) fn eval_bin(op: Bin, x: f64, y: f64) -> f64 {
    match op {
        Bin::Add => x + y,
        Bin::Sub => x - y,
        Bin::Mul => x * y,
        Bin::Div => x / y,
        Bin::Atan2 => x.atan2(y),
        Bin::Pow => x.powf(y),
    }
}

#[cfg(test)]
mod tests {
    /// The inline square and multiply gives `f64::powi`'s bits for every exponent the
    /// expressions use (|e| ≤ 64) on ordinary and special values.
    #[test]
    fn powi_equals_f64_powi_bit_for_bit() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut xs = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            1e-300,
            1e300,
        ];
        for _ in 0..500 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            xs.push(((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 8.0);
        }
        for &x in &xs {
            for e in -64..=64 {
                let (a, b) = (super::powi(x, e), x.powi(e));
                assert!(
                    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                    "{x}^{e}: {a} vs {b}"
                );
            }
        }
    }
}
