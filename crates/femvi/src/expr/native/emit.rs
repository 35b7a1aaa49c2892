//! The code of one tape instruction in any [`Flavour`] (one number, or a pair of lanes):
//! inline where the machine instruction is exact (the four operations, square root, absolute
//! value, negation, sign, min/max), a call of the interpreter's own Rust function otherwise.

use super::super::dag::{Bin, Un};
use super::super::program::F1;
use super::super::tape::Instr;
use super::flavour::Flavour;
use super::functions::{acos, asin, atan, atan2, cos, cosh, exp, ln, powf, sin, sinh, tan, tanh};
use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{types, AbiParam, InstBuilder, Signature, Value};
use cranelift_frontend::FunctionBuilder;

/// Signatures of the Rust functions the code calls: f64 → f64 and (f64, f64) → f64.
pub(super) struct Calls {
    pub(super) ptr: types::Type,
    pub(super) un: Signature,
    pub(super) bin: Signature,
}

impl Calls {
    pub(super) fn new(ptr: types::Type, base: Signature) -> Self {
        let mut un = base.clone();
        un.params.push(AbiParam::new(types::F64));
        un.returns.push(AbiParam::new(types::F64));
        let mut bin = un.clone();
        bin.params.push(AbiParam::new(types::F64));
        Self { ptr, un, bin }
    }

    /// Calls the function at `addr` with signature `sig` on `args`.
    pub(super) fn call(&self, b: &mut FunctionBuilder, sig: &Signature, addr: usize, args: &[Value]) -> Option<Value> {
        let sig = b.import_signature(sig.clone());
        let callee = b.ins().iconst(self.ptr, i64::try_from(addr).ok()?);
        let call = b.ins().call_indirect(sig, callee, args);
        b.inst_results(call).first().copied()
    }
}

/// x^e as the unrolled loop of `dag::powi` (that of `f64::powi`): the same multiplications in
/// the same order, so the same bits as the interpreter, inline instead of a call; `one` makes
/// the flavour's 1.
pub(super) fn powi_with(
    b: &mut FunctionBuilder,
    x: Value,
    e: i32,
    one: impl Fn(&mut FunctionBuilder) -> Value,
) -> Value {
    let (mut a, mut pow) = (x, e.unsigned_abs());
    // None stands for r = 1 (1·a = a exactly, so the first product is a itself).
    let mut r: Option<Value> = None;
    loop {
        if pow & 1 != 0 {
            r = Some(match r {
                None => a,
                Some(r) => b.ins().fmul(r, a),
            });
        }
        pow >>= 1;
        if pow == 0 {
            break;
        }
        a = b.ins().fmul(a, a);
    }
    let r = r.unwrap_or_else(|| one(b));
    if e < 0 {
        let one = one(b);
        b.ins().fdiv(one, r)
    } else {
        r
    }
}

/// The code of one instruction over the values of the registers so far, in `flavour`.
pub(super) fn emit<F: Flavour>(
    flavour: &F,
    b: &mut FunctionBuilder,
    calls: &Calls,
    regs: &[Value],
    ins: Instr,
) -> Option<Value> {
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
        Instr::Un(op, x) => emit_un(flavour, b, calls, op, r(x)?)?,
        Instr::Bin(op @ (Bin::Atan2 | Bin::Pow), x, y) => {
            let f: extern "C" fn(f64, f64) -> f64 = if op == Bin::Atan2 { atan2 } else { powf };
            flavour.call(b, calls, &calls.bin, f as usize, &[r(x)?, r(y)?])?
        }
        Instr::Pick(max, p, q, x, y) => {
            let cc = if max { FloatCC::GreaterThan } else { FloatCC::LessThan };
            let second = b.ins().fcmp(cc, r(q)?, r(p)?);
            flavour.select(b, second, r(y)?, r(x)?)
        }
    })
}

/// The code of a one-operand operation: inline where the instruction is exact, else a call.
fn emit_un<F: Flavour>(flavour: &F, b: &mut FunctionBuilder, calls: &Calls, op: Un, x: Value) -> Option<Value> {
    Some(match op {
        Un::Neg => b.ins().fneg(x),
        Un::F(F1::Sqrt) => b.ins().sqrt(x),
        Un::F(F1::Abs) => b.ins().fabs(x),
        Un::Sign => {
            let zero = flavour.constant(b, 0.0);
            let positive = b.ins().fcmp(FloatCC::GreaterThan, x, zero);
            let (one, minus) = (flavour.constant(b, 1.0), flavour.constant(b, -1.0));
            flavour.select(b, positive, one, minus)
        }
        Un::PowI(e) => powi_with(b, x, e, |b| flavour.constant(b, 1.0)),
        Un::PowF(bits) => {
            let y = flavour.constant(b, f64::from_bits(bits));
            flavour.call(b, calls, &calls.bin, powf as *const () as usize, &[x, y])?
        }
        Un::F(f) => flavour.call(b, calls, &calls.un, un_function(f)? as usize, &[x])?,
    })
}

/// The Rust function that the code calls for the one-operand function f; None for the square
/// root and the absolute value, which are inline.
pub(super) fn un_function(f: F1) -> Option<extern "C" fn(f64) -> f64> {
    Some(match f {
        F1::Sin => sin,
        F1::Cos => cos,
        F1::Tan => tan,
        F1::Exp => exp,
        F1::Ln => ln,
        F1::Sinh => sinh,
        F1::Cosh => cosh,
        F1::Tanh => tanh,
        F1::Asin => asin,
        F1::Acos => acos,
        F1::Atan => atan,
        F1::Sqrt | F1::Abs => return None,
    })
}
