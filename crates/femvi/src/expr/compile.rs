//! Compilation of the parser's postfix items into a [`Program`](super::Program): names
//! resolved to variables or folded parameters, operations on constants folded, the evaluation
//! stack measured. One pass over the items with a stack of operands, so nothing recurses
//! however long or deep the expression.
//!
//! Folding follows fixed rules, so that a program's value does not depend on how it was
//! written beyond them: `a ^ b` of two constants is `powf`; a power with a constant exponent
//! (`x ^ 3`, `pow(x, 3)`) is `powi` for integers up to 64 in magnitude and `powf` otherwise,
//! also when the base is a constant inside `pow`; every other operation on constants is
//! evaluated as the program would evaluate it.

use super::parse::{ExprError, Item};
use super::program::{binary, pow_op, unary, Op, F2, FUNCS1, FUNCS2};
use std::collections::HashMap;

/// What a name stands for: variable i or a parameter's value (the first of each name).
pub(super) struct Names<'n> {
    vars: HashMap<&'n str, usize>,
    params: HashMap<&'n str, f64>,
}

impl<'n> Names<'n> {
    /// The names of `vars` and `params`, looked up in O(1) whatever their number.
    pub(super) fn new(vars: &'n [String], params: &'n [(String, f64)]) -> Self {
        let mut names = Self {
            vars: HashMap::with_capacity(vars.len()),
            params: HashMap::with_capacity(params.len()),
        };
        for (i, v) in vars.iter().enumerate() {
            names.vars.entry(v).or_insert(i);
        }
        for (p, v) in params {
            names.params.entry(p).or_insert(*v);
        }
        names
    }

    /// Whether `name` names a variable.
    pub(super) fn is_variable(&self, name: &str) -> bool {
        self.vars.contains_key(name)
    }
}

/// An operand on the compiler's stack: where its code starts in the program, its value if it
/// is a constant (its code is then that one constant), and the evaluation stack it needs.
#[derive(Debug, Clone, Copy)]
struct Operand {
    start: usize,
    konst: Option<f64>,
    depth: usize,
}

/// The program under construction and the operands of the items read so far.
pub(super) struct Compiler<'s> {
    src: &'s str,
    ops: Vec<Op>,
    stack: Vec<Operand>,
}

impl<'s> Compiler<'s> {
    /// A compiler for `src` (for error positions), with room for `items` operations.
    pub(super) fn new(src: &'s str, items: usize) -> Self {
        Self {
            src,
            ops: Vec::with_capacity(items),
            stack: Vec::new(),
        }
    }

    /// The program and its stack depth.
    ///
    /// Errors: items that do not form one expression (the parser never produces them).
    pub(super) fn finish(self) -> Result<(Vec<Op>, usize), ExprError> {
        match self.stack[..] {
            [top] => Ok((self.ops, top.depth)),
            _ => Err(ExprError::at(self.src, 0, "malformed expression")),
        }
    }

    /// Compiles one item; variables are looked up in `names`, parameters folded as constants.
    pub(super) fn item(&mut self, item: &Item, names: &Names<'_>) -> Result<(), ExprError> {
        match item {
            Item::Num(v) => self.constant(self.ops.len(), *v),
            Item::Name(name, at) => {
                if let Some(&i) = names.vars.get(name.as_str()) {
                    self.stack.push(Operand {
                        start: self.ops.len(),
                        konst: None,
                        depth: 1,
                    });
                    self.ops.push(Op::Var(i));
                } else if let Some(&v) = names.params.get(name.as_str()) {
                    self.constant(self.ops.len(), v);
                } else if name == "pi" {
                    self.constant(self.ops.len(), std::f64::consts::PI);
                } else {
                    return Err(ExprError::at(self.src, *at, format!("unknown symbol '{name}'")));
                }
            }
            Item::Neg => {
                let a = self.pop()?;
                self.apply1(a, Op::Neg);
            }
            Item::Bin(op) => {
                let (b, a) = (self.pop()?, self.pop()?);
                self.binary_operator(*op, a, b);
            }
            Item::Call(name, args, at) => self.call(name, *args, *at)?,
        }
        Ok(())
    }

    fn pop(&mut self) -> Result<Operand, ExprError> {
        self.stack
            .pop()
            .ok_or_else(|| ExprError::at(self.src, 0, "malformed expression"))
    }

    /// Replaces the code from `start` on by the constant `v`.
    fn constant(&mut self, start: usize, v: f64) {
        self.ops.truncate(start);
        self.ops.push(Op::Const(v));
        self.stack.push(Operand {
            start,
            konst: Some(v),
            depth: 1,
        });
    }

    /// `op` on one operand, folded if it is a constant.
    fn apply1(&mut self, a: Operand, op: Op) {
        match a.konst {
            Some(c) => self.constant(a.start, unary(op, c)),
            None => {
                self.ops.push(op);
                self.stack.push(Operand { konst: None, ..a });
            }
        }
    }

    /// `op` on two operands, folded if both are constants.
    fn apply2(&mut self, a: Operand, b: Operand, op: Op) {
        if let (Some(x), Some(y)) = (a.konst, b.konst) {
            return self.constant(a.start, binary(op, x, y));
        }
        self.ops.push(op);
        self.stack.push(Operand {
            start: a.start,
            konst: None,
            depth: a.depth.max(1 + b.depth),
        });
    }

    /// `a op b` for the operators `+ - * / ^`.
    fn binary_operator(&mut self, op: char, a: Operand, b: Operand) {
        if let (Some(x), Some(y)) = (a.konst, b.konst) {
            let v = match op {
                '+' => x + y,
                '-' => x - y,
                '*' => x * y,
                '/' => x / y,
                _ => x.powf(y),
            };
            return self.constant(a.start, v);
        }
        let op = match op {
            '^' => return self.power(a, b),
            '+' => Op::Add,
            '-' => Op::Sub,
            '*' => Op::Mul,
            _ => Op::Div,
        };
        self.apply2(a, b, op);
    }

    /// a^b: with a constant exponent a one-operand power, else the two-operand `pow`.
    fn power(&mut self, a: Operand, b: Operand) {
        match b.konst {
            Some(e) => {
                self.ops.truncate(b.start);
                self.apply1(a, pow_op(e));
            }
            None => self.apply2(a, b, Op::Call2(F2::Pow)),
        }
    }

    /// A call of the function `name` on the last `args` operands.
    fn call(&mut self, name: &str, args: usize, at: usize) -> Result<(), ExprError> {
        let arity = |want: usize| {
            if args == want {
                Ok(())
            } else {
                let s = if want == 1 { "" } else { "s" };
                Err(ExprError::at(
                    self.src,
                    at,
                    format!("function '{name}' takes {want} argument{s}, found {args}"),
                ))
            }
        };
        if let Some((_, f)) = FUNCS1.iter().find(|(n, _)| *n == name) {
            arity(1)?;
            let a = self.pop()?;
            self.apply1(a, Op::Call1(*f));
        } else if let Some((_, f)) = FUNCS2.iter().find(|(n, _)| *n == name) {
            arity(2)?;
            let (b, a) = (self.pop()?, self.pop()?);
            if *f == F2::Pow {
                self.power(a, b);
            } else {
                self.apply2(a, b, Op::Call2(*f));
            }
        } else {
            return Err(ExprError::at(self.src, at, format!("unknown function '{name}'")));
        }
        Ok(())
    }
}
