//! Compilation of a syntax tree into a postfix program with constants folded, and its
//! evaluation over any scalar type without allocation (a fixed stack for the usual depths).

use super::parse::{Ast, ExprError, Parser};
use crate::lagrangian::Scalar;

#[derive(Debug, Clone, Copy, PartialEq)]
enum F1 {
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
enum F2 {
    Atan2,
    Pow,
    Min,
    Max,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
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

const FUNCS1: &[(&str, F1)] = &[
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
const FUNCS2: &[(&str, F2)] = &[
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

/// Folded constant or code.
enum Node {
    Const(f64),
    Code(Vec<Op>, usize),
}

impl Node {
    fn into_code(self) -> (Vec<Op>, usize) {
        match self {
            Node::Const(c) => (vec![Op::Const(c)], 1),
            Node::Code(ops, d) => (ops, d),
        }
    }
}

impl Program {
    /// Compiles `source`; `vars[i]` names variable i, `params` are folded as constants.
    ///
    /// # Errors
    /// Syntax errors, unknown symbols and functions, wrong argument counts, name clashes.
    pub fn compile(source: &str, vars: &[String], params: &[(String, f64)]) -> Result<Self, ExprError> {
        for (name, _) in params {
            if vars.contains(name) {
                return Err(ExprError::at(
                    source,
                    0,
                    format!("parameter '{name}' has the name of a variable"),
                ));
            }
        }
        let ast = Parser::parse(source)?;
        let node = Self::lower(source, &ast, vars, params)?;
        let (ops, depth) = node.into_code();
        Ok(Self { ops, depth })
    }

    /// Whether variable `i` occurs.
    pub fn uses_variable(&self, i: usize) -> bool {
        self.ops.contains(&Op::Var(i))
    }

    fn lower(src: &str, ast: &Ast, vars: &[String], params: &[(String, f64)]) -> Result<Node, ExprError> {
        Ok(match ast {
            Ast::Num(v) => Node::Const(*v),
            Ast::Name(name, at) => {
                if let Some(i) = vars.iter().position(|v| v == name) {
                    Node::Code(vec![Op::Var(i)], 1)
                } else if let Some((_, v)) = params.iter().find(|(p, _)| p == name) {
                    Node::Const(*v)
                } else if name == "pi" {
                    Node::Const(std::f64::consts::PI)
                } else {
                    return Err(ExprError::at(src, *at, format!("unknown symbol '{name}'")));
                }
            }
            Ast::Neg(a) => match Self::lower(src, a, vars, params)? {
                Node::Const(c) => Node::Const(-c),
                n => Self::combine(vec![n], Op::Neg),
            },
            Ast::Bin(op, a, b) => {
                let (a, b) = (Self::lower(src, a, vars, params)?, Self::lower(src, b, vars, params)?);
                if let (Node::Const(x), Node::Const(y)) = (&a, &b) {
                    return Ok(Node::Const(apply_f64(*op, *x, *y)));
                }
                if *op == '^' {
                    if let Node::Const(e) = b {
                        let op = if e.fract() == 0.0 && e.abs() <= 64.0 {
                            Op::PowI(e as i32)
                        } else {
                            Op::PowF(e)
                        };
                        return Ok(Self::combine(vec![a], op));
                    }
                    return Ok(Self::combine(vec![a, b], Op::Call2(F2::Pow)));
                }
                let op = match op {
                    '+' => Op::Add,
                    '-' => Op::Sub,
                    '*' => Op::Mul,
                    _ => Op::Div,
                };
                Self::combine(vec![a, b], op)
            }
            Ast::Call(name, args, at) => {
                let lowered: Vec<Node> = args
                    .iter()
                    .map(|a| Self::lower(src, a, vars, params))
                    .collect::<Result<_, _>>()?;
                let arity = |want: usize| {
                    if args.len() == want {
                        Ok(())
                    } else {
                        let s = if want == 1 { "" } else { "s" };
                        Err(ExprError::at(
                            src,
                            *at,
                            format!("function '{name}' takes {want} argument{s}, found {}", args.len()),
                        ))
                    }
                };
                if let Some((_, f)) = FUNCS1.iter().find(|(n, _)| n == name) {
                    arity(1)?;
                    Self::combine(lowered, Op::Call1(*f))
                } else if let Some((_, f)) = FUNCS2.iter().find(|(n, _)| n == name) {
                    arity(2)?;
                    if *f == F2::Pow {
                        if let Node::Const(e) = lowered[1] {
                            let base = lowered.into_iter().next().unwrap_or(Node::Const(0.0));
                            let op = if e.fract() == 0.0 && e.abs() <= 64.0 {
                                Op::PowI(e as i32)
                            } else {
                                Op::PowF(e)
                            };
                            return Ok(Self::combine(vec![base], op));
                        }
                    }
                    Self::combine(lowered, Op::Call2(*f))
                } else {
                    return Err(ExprError::at(src, *at, format!("unknown function '{name}'")));
                }
            }
        })
    }

    /// Code of the operands in order, then `op`; folds when all operands are constant.
    fn combine(args: Vec<Node>, op: Op) -> Node {
        if args.iter().all(|a| matches!(a, Node::Const(_))) {
            let vals: Vec<f64> = args
                .iter()
                .map(|a| match a {
                    Node::Const(c) => *c,
                    Node::Code(..) => 0.0,
                })
                .collect();
            let p = Program {
                ops: vals.iter().map(|&c| Op::Const(c)).chain([op]).collect(),
                depth: vals.len().max(1),
            };
            return Node::Const(p.eval::<f64>(|_| 0.0));
        }
        let mut ops = Vec::new();
        let mut depth = 0;
        for (k, a) in args.into_iter().enumerate() {
            let (code, d) = a.into_code();
            depth = depth.max(k + d);
            ops.extend(code);
        }
        ops.push(op);
        Node::Code(ops, depth.max(1))
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
                Op::Neg => stack[sp - 1] = -stack[sp - 1],
                Op::PowI(e) => stack[sp - 1] = stack[sp - 1].powi(e),
                Op::PowF(e) => stack[sp - 1] = stack[sp - 1].powf(e),
                Op::Call1(f) => stack[sp - 1] = call1(f, stack[sp - 1]),
                Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Call2(_) => {
                    let (a, b) = (stack[sp - 2], stack[sp - 1]);
                    sp -= 1;
                    stack[sp - 1] = match *op {
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
                    };
                }
            }
        }
        stack[0]
    }
}

fn apply_f64(op: char, x: f64, y: f64) -> f64 {
    match op {
        '+' => x + y,
        '-' => x - y,
        '*' => x * y,
        '/' => x / y,
        _ => x.powf(y),
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
