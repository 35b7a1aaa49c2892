//! A compiled expression: a postfix program with constants folded (built by `compile.rs`), and
//! its evaluation over any scalar type without allocation (a fixed stack for the usual depths).

use super::compile::{Compiler, Names};
use super::parse::{ExprError, Parser};
use crate::lagrangian::Scalar;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum F1 {
    Sin,
    Cos,
    Tan,
    Exp,
    Ln,
    Sqrt,
    Abs,
    Sinh,
    Cosh,
    Tanh,
    Asin,
    Acos,
    Atan,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum F2 {
    Atan2,
    Pow,
    Min,
    Max,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Op {
    Const(f64),
    Var(usize),
    Neg,
    Add,
    Sub,
    Mul,
    Div,
    PowI(i32),
    PowF(f64),
    Call1(F1),
    Call2(F2),
}

pub(super) const FUNCS1: &[(&str, F1)] = &[
    ("sin", F1::Sin),
    ("cos", F1::Cos),
    ("tan", F1::Tan),
    ("exp", F1::Exp),
    ("ln", F1::Ln),
    ("log", F1::Ln),
    ("sqrt", F1::Sqrt),
    ("abs", F1::Abs),
    ("sinh", F1::Sinh),
    ("cosh", F1::Cosh),
    ("tanh", F1::Tanh),
    ("asin", F1::Asin),
    ("acos", F1::Acos),
    ("atan", F1::Atan),
];
pub(super) const FUNCS2: &[(&str, F2)] = &[
    ("atan2", F2::Atan2),
    ("pow", F2::Pow),
    ("min", F2::Min),
    ("max", F2::Max),
];

/// A compiled expression: a postfix program over numbered variables.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    ops: Vec<Op>,
    depth: usize,
}

impl Program {
    /// Compiles `source`; `vars[i]` names variable i, `params` are folded as constants.
    ///
    /// # Errors
    /// Syntax errors, unknown symbols and functions, wrong argument counts, name clashes, and
    /// nesting deeper than [`MAX_NESTING`](super::MAX_NESTING).
    pub fn compile(source: &str, vars: &[String], params: &[(String, f64)]) -> Result<Self, ExprError> {
        let names = Names::new(vars, params);
        if let Some((name, _)) = params.iter().find(|(name, _)| names.is_variable(name)) {
            return Err(ExprError::at(
                source,
                0,
                format!("parameter '{name}' has the name of a variable"),
            ));
        }
        let items = Parser::parse(source)?;
        let mut compiler = Compiler::new(source, items.len());
        for item in &items {
            compiler.item(item, &names)?;
        }
        let (ops, depth) = compiler.finish()?;
        Ok(Self { ops, depth })
    }

    /// The postfix operations.
    pub(super) fn ops(&self) -> &[Op] {
        &self.ops
    }

    /// Whether variable `i` occurs.
    pub fn uses_variable(&self, i: usize) -> bool {
        self.ops.contains(&Op::Var(i))
    }

    /// Evaluates with variable values from `var`.
    pub fn eval<D: Scalar>(&self, var: impl Fn(usize) -> D) -> D {
        let mut fixed = [D::from(0.0); 32];
        let mut heap = Vec::new();
        let stack: &mut [D] = if self.depth <= 32 {
            &mut fixed
        } else {
            heap.resize(self.depth, D::from(0.0));
            &mut heap
        };
        let mut sp = 0;
        for op in &self.ops {
            match *op {
                Op::Const(c) => {
                    stack[sp] = D::from(c);
                    sp += 1;
                }
                Op::Var(i) => {
                    stack[sp] = var(i);
                    sp += 1;
                }
                Op::Neg | Op::PowI(_) | Op::PowF(_) | Op::Call1(_) => stack[sp - 1] = unary(*op, stack[sp - 1]),
                Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Call2(_) => {
                    sp -= 1;
                    stack[sp - 1] = binary(*op, stack[sp - 1], stack[sp]);
                }
            }
        }
        stack[0]
    }
}

/// An operation on one operand (`Neg`, `PowI`, `PowF`, `Call1`); `x` itself for the others.
#[inline]
pub(super) fn unary<D: Scalar>(op: Op, x: D) -> D {
    match op {
        Op::Neg => -x,
        Op::PowI(e) => x.powi(e),
        Op::PowF(e) => x.powf(e),
        Op::Call1(f) => call1(f, x),
        _ => x,
    }
}

/// An operation on two operands (`Add`, `Sub`, `Mul`, `Div`, `Call2`); `a` for the others.
#[inline]
pub(super) fn binary<D: Scalar>(op: Op, a: D, b: D) -> D {
    match op {
        Op::Add => a + b,
        Op::Sub => a - b,
        Op::Mul => a * b,
        Op::Div => a / b,
        Op::Call2(F2::Atan2) => a.atan2(b),
        Op::Call2(F2::Pow) => a.powd(b),
        Op::Call2(F2::Min) => {
            if b.re() < a.re() {
                b
            } else {
                a
            }
        }
        Op::Call2(F2::Max) => {
            if b.re() > a.re() {
                b
            } else {
                a
            }
        }
        _ => a,
    }
}

/// The operation of a power with a constant exponent: repeated multiplication for small
/// integers (exact derivatives at zero), `powf` otherwise.
pub(super) fn pow_op(e: f64) -> Op {
    if e.fract() == 0.0 && e.abs() <= 64.0 {
        Op::PowI(e as i32)
    } else {
        Op::PowF(e)
    }
}

fn call1<D: Scalar>(f: F1, x: D) -> D {
    match f {
        F1::Sin => x.sin(),
        F1::Cos => x.cos(),
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
    }
}
