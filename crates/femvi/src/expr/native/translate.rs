//! Tapes and postfix programs into Cranelift functions, once for every [`Flavour`]: the
//! interpreter's registers (or the program's stack) become SSA values, each instruction the
//! code of `emit.rs`, so that every flavour performs the same operations in the same order.

use super::super::program::{Op, F1};
use super::super::tape::Tape;
use super::emit::{self, powi_with};
use super::flavour::Flavour;
use super::functions::{program_fn1, program_fn2, program_powf};
use super::{compile_with, Native, Used, MAX_INSTRUCTIONS};
use cranelift_codegen::ir::{InstBuilder, Value};

/// Compiles `tape` in `flavour`; `None` when the host is not supported or the tape is too
/// long.
pub(super) fn tape<F: Flavour + Sync>(flavour: &F, tape: &Tape) -> Option<Native> {
    if tape.code.len() > MAX_INSTRUCTIONS {
        return None;
    }
    compile_with(
        flavour.strides(tape.n, tape.outputs.len())?,
        |b, calls, [t, q, v, out]| {
            let mut regs: Vec<Value> = Vec::with_capacity(tape.registers);
            for &c in &tape.consts {
                regs.push(flavour.constant(b, c));
            }
            let mut used = Used::default();
            for &(_, i) in &tape.loads {
                regs.push(flavour.load(b, &mut used, tape.n, i as usize, [t, q, v])?);
            }
            for ins in &tape.code {
                let x = emit::emit(flavour, b, calls, &regs, *ins)?;
                regs.push(x);
            }
            for (j, &r) in tape.outputs.iter().enumerate() {
                flavour.store(b, *regs.get(r as usize)?, out, j)?;
            }
            Some(used)
        },
    )
}

/// Compiles the postfix program `ops` over t, q and v of dimension n (one output, its value)
/// in `flavour`, each operation as [`Program::eval`](super::super::Program::eval) performs it
/// in f64 (the square root and the absolute value, exact, inline; the other functions by
/// calling the program's own), so that the two agree bit for bit.
pub(super) fn program<F: Flavour + Sync>(flavour: &F, ops: &[Op], n: usize) -> Option<Native> {
    if ops.len() > MAX_INSTRUCTIONS {
        return None;
    }
    compile_with(flavour.strides(n, 1)?, |b, calls, [t, q, v, out]| {
        let mut stack: Vec<Value> = Vec::new();
        let mut used = Used::default();
        for &op in ops {
            let x = match op {
                Op::Const(c) => flavour.constant(b, c),
                Op::Var(i) => flavour.load(b, &mut used, n, i, [t, q, v])?,
                Op::Neg => {
                    let x = stack.pop()?;
                    b.ins().fneg(x)
                }
                Op::PowI(e) => {
                    let x = stack.pop()?;
                    powi_with(b, x, e, |b| flavour.constant(b, 1.0))
                }
                Op::PowF(e) => {
                    let (x, e) = (stack.pop()?, flavour.constant(b, e));
                    flavour.call(b, calls, &calls.bin, program_powf as *const () as usize, &[x, e])?
                }
                // `program::unary` takes f64::sqrt and f64::abs: exact, so inline.
                Op::Call1(F1::Sqrt) => {
                    let x = stack.pop()?;
                    b.ins().sqrt(x)
                }
                Op::Call1(F1::Abs) => {
                    let x = stack.pop()?;
                    b.ins().fabs(x)
                }
                Op::Call1(f) => {
                    let x = stack.pop()?;
                    flavour.call(b, calls, &calls.un, program_fn1(f) as *const () as usize, &[x])?
                }
                Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Call2(_) => {
                    let (y, x) = (stack.pop()?, stack.pop()?);
                    match op {
                        Op::Add => b.ins().fadd(x, y),
                        Op::Sub => b.ins().fsub(x, y),
                        Op::Mul => b.ins().fmul(x, y),
                        Op::Div => b.ins().fdiv(x, y),
                        Op::Call2(f) => {
                            flavour.call(b, calls, &calls.bin, program_fn2(f) as *const () as usize, &[x, y])?
                        }
                        _ => return None,
                    }
                }
            };
            stack.push(x);
        }
        let [x] = stack[..] else {
            return None;
        };
        flavour.store(b, x, out, 0)?;
        Some(used)
    })
}
