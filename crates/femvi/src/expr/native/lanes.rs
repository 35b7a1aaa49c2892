//! Machine code across SIMD lanes (issue 39 item 2): a tape (the force of a mechanical
//! expression) or the value program of an expression Lagrangian compiled for [`LANES`] points
//! at once, all at one time t, stored coordinate by coordinate (`q[c][l]`) as the ensemble
//! lanes keep them ([`crate::ensemble`]).
//!
//! Each iteration of the compiled loop evaluates two lanes in one 128-bit register (F64X2,
//! the vector width Cranelift generates on every host it supports) and performs, on each lane,
//! the operations of the scalar code (`mod.rs`, `emit.rs`) in the same order: the four
//! operations, the square root, the absolute value and the negation as vector instructions
//! (each exact, lane by lane, as IEEE 754 defines it); the sign and min/max as vector
//! comparisons and selects of the same comparison; integer powers by the same unrolled
//! products; every other function by calling the scalar code's own Rust function on each lane.
//! So every lane equals the scalar code's result, and the interpreter's, bit for bit
//! (`tests.rs`).

use super::super::dag::{Bin, Un};
use super::super::program::{Op, F1};
use super::super::tape::{Instr, Tape};
use super::emit::{powi_with, un_function, Calls};
use super::functions::{atan2, powf, program_fn1, program_fn2, program_powf};
use super::{compile_with, offset, Native, Strides, Used, MAX_INSTRUCTIONS};
use crate::lagrangian::LANES;
use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{types, Endianness, InstBuilder, MemFlagsData, Signature, Value};
use cranelift_frontend::FunctionBuilder;

/// Two lanes of doubles.
const PAIR: types::Type = types::F64X2;

/// Compiles `tape` for [`LANES`] points at once ([`Native::call_lanes`]); `None` when the host
/// is not supported or the tape is too long.
pub(in crate::expr) fn compile_lanes(tape: &Tape) -> Option<Native> {
    if tape.code.len() > MAX_INSTRUCTIONS {
        return None;
    }
    compile_with(
        Strides::lanes(tape.n, tape.outputs.len())?,
        |b, calls, [t, q, v, out]| {
            let mut regs: Vec<Value> = Vec::with_capacity(tape.registers);
            for &c in &tape.consts {
                regs.push(splat(b, c));
            }
            let mut used = Used::default();
            for &(_, i) in &tape.loads {
                regs.push(load(b, &mut used, tape.n, i as usize, [t, q, v])?);
            }
            for ins in &tape.code {
                let x = emit(b, calls, &regs, *ins)?;
                regs.push(x);
            }
            for (j, &r) in tape.outputs.iter().enumerate() {
                let x = *regs.get(r as usize)?;
                b.ins().store(unaligned(), x, out, coordinate(j)?);
            }
            Some(used)
        },
    )
}

/// Compiles the postfix program `ops` over t, q and v of dimension n (one output, its value)
/// for [`LANES`] points at once, each lane as [`super::compile_program`]'s code computes it.
pub(in crate::expr) fn compile_program_lanes(ops: &[Op], n: usize) -> Option<Native> {
    if ops.len() > MAX_INSTRUCTIONS {
        return None;
    }
    compile_with(Strides::lanes(n, 1)?, |b, calls, [t, q, v, out]| {
        let mut stack: Vec<Value> = Vec::new();
        let mut used = Used::default();
        for &op in ops {
            let x = match op {
                Op::Const(c) => splat(b, c),
                Op::Var(i) => load(b, &mut used, n, i, [t, q, v])?,
                Op::Neg => {
                    let x = stack.pop()?;
                    b.ins().fneg(x)
                }
                Op::PowI(e) => {
                    let x = stack.pop()?;
                    powi_with(b, x, e, |b| splat(b, 1.0))
                }
                Op::PowF(e) => {
                    let (x, e) = (stack.pop()?, splat(b, e));
                    lanewise(b, calls, &calls.bin, program_powf as *const () as usize, &[x, e])?
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
                    lanewise(b, calls, &calls.un, program_fn1(f) as *const () as usize, &[x])?
                }
                Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Call2(_) => {
                    let (y, x) = (stack.pop()?, stack.pop()?);
                    match op {
                        Op::Add => b.ins().fadd(x, y),
                        Op::Sub => b.ins().fsub(x, y),
                        Op::Mul => b.ins().fmul(x, y),
                        Op::Div => b.ins().fdiv(x, y),
                        Op::Call2(f) => lanewise(b, calls, &calls.bin, program_fn2(f) as *const () as usize, &[x, y])?,
                        _ => return None,
                    }
                }
            };
            stack.push(x);
        }
        let [x] = stack[..] else {
            return None;
        };
        b.ins().store(unaligned(), x, out, 0);
        Some(used)
    })
}

impl Strides {
    /// Two lanes per iteration: t stays (one time for every lane), q, v and out move by two
    /// numbers within each coordinate's [`LANES`]; None for n = 0.
    fn lanes(n: usize, outputs: usize) -> Option<Self> {
        if n == 0 {
            return None;
        }
        Some(Self {
            t: 0,
            q: 16,
            v: 16,
            out: 16,
            outputs,
        })
    }
}

/// Vector loads and stores that do not assume 16-byte alignment (a `[[f64; LANES]]` is
/// aligned to 8).
fn unaligned() -> MemFlagsData {
    MemFlagsData::new().with_notrap()
}

/// The byte offset of coordinate (or output) c's lanes.
fn coordinate(c: usize) -> Option<i32> {
    offset(c.checked_mul(LANES)?)
}

/// c in both lanes.
fn splat(b: &mut FunctionBuilder, c: f64) -> Value {
    let x = b.ins().f64const(c);
    b.ins().splat(PAIR, x)
}

/// Variable i (0 is t, 1..=n are q, n + 1..=2n are v) at the iteration's two lanes.
fn load(b: &mut FunctionBuilder, used: &mut Used, n: usize, i: usize, [t, q, v]: [Value; 3]) -> Option<Value> {
    Some(if i == 0 {
        let x = b.ins().load(types::F64, MemFlagsData::trusted(), t, 0);
        b.ins().splat(PAIR, x)
    } else if i <= n {
        used.q = used.q.max(i);
        b.ins().load(PAIR, unaligned(), q, coordinate(i - 1)?)
    } else {
        used.v = used.v.max(i - n);
        b.ins().load(PAIR, unaligned(), v, coordinate(i - 1 - n)?)
    })
}

/// The lanes of `x` where `mask` (a comparison of two pairs) is set, else those of `y`.
fn select(b: &mut FunctionBuilder, mask: Value, x: Value, y: Value) -> Value {
    let mask = b
        .ins()
        .bitcast(PAIR, MemFlagsData::new().with_endianness(Endianness::Little), mask);
    b.ins().bitselect(mask, x, y)
}

/// The Rust function at `addr` (signature `sig`) called on each lane of `args`.
fn lanewise(b: &mut FunctionBuilder, calls: &Calls, sig: &Signature, addr: usize, args: &[Value]) -> Option<Value> {
    let lane = |b: &mut FunctionBuilder, l: u8| {
        let scalars: Vec<Value> = args.iter().map(|&x| b.ins().extractlane(x, l)).collect();
        calls.call(b, sig, addr, &scalars)
    };
    let (first, second) = (lane(b, 0)?, lane(b, 1)?);
    let pair = b.ins().scalar_to_vector(PAIR, first);
    Some(b.ins().insertlane(pair, second, 1))
}

/// The code of one tape instruction on two lanes (`emit::emit` on one).
fn emit(b: &mut FunctionBuilder, calls: &Calls, regs: &[Value], ins: Instr) -> Option<Value> {
    let r = |a: u32| regs.get(a as usize).copied();
    Some(match ins {
        Instr::Add(x, y) | Instr::Bin(Bin::Add, x, y) => b.ins().fadd(r(x)?, r(y)?),
        Instr::Sub(x, y) | Instr::Bin(Bin::Sub, x, y) => b.ins().fsub(r(x)?, r(y)?),
        Instr::Mul(x, y) | Instr::Bin(Bin::Mul, x, y) => b.ins().fmul(r(x)?, r(y)?),
        Instr::Div(x, y) | Instr::Bin(Bin::Div, x, y) => b.ins().fdiv(r(x)?, r(y)?),
        Instr::Neg(x) => b.ins().fneg(r(x)?),
        Instr::Square(x) => {
            let x = r(x)?;
            b.ins().fmul(x, x)
        }
        Instr::Sqrt(x) => b.ins().sqrt(r(x)?),
        Instr::Un(op, x) => emit_un(b, calls, op, r(x)?)?,
        Instr::Bin(Bin::Atan2, x, y) => lanewise(b, calls, &calls.bin, atan2 as *const () as usize, &[r(x)?, r(y)?])?,
        Instr::Bin(Bin::Pow, x, y) => lanewise(b, calls, &calls.bin, powf as *const () as usize, &[r(x)?, r(y)?])?,
        Instr::Pick(max, p, q, x, y) => {
            let cc = if max { FloatCC::GreaterThan } else { FloatCC::LessThan };
            let second = b.ins().fcmp(cc, r(q)?, r(p)?);
            select(b, second, r(y)?, r(x)?)
        }
    })
}

/// A one-operand operation on two lanes (`emit::emit_un` on one).
fn emit_un(b: &mut FunctionBuilder, calls: &Calls, op: Un, x: Value) -> Option<Value> {
    Some(match op {
        Un::Neg => b.ins().fneg(x),
        Un::F(F1::Sqrt) => b.ins().sqrt(x),
        Un::F(F1::Abs) => b.ins().fabs(x),
        Un::Sign => {
            let zero = splat(b, 0.0);
            let positive = b.ins().fcmp(FloatCC::GreaterThan, x, zero);
            let (one, minus) = (splat(b, 1.0), splat(b, -1.0));
            select(b, positive, one, minus)
        }
        Un::PowI(e) => powi_with(b, x, e, |b| splat(b, 1.0)),
        Un::PowF(bits) => {
            let y = splat(b, f64::from_bits(bits));
            lanewise(b, calls, &calls.bin, powf as *const () as usize, &[x, y])?
        }
        Un::F(f) => lanewise(b, calls, &calls.un, un_function(f)? as *const () as usize, &[x])?,
    })
}
