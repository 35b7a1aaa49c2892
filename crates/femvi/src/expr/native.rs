//! Native code for a [`Tape`]: each tape is translated once, at load, into one machine-code
//! function of a point (t, q, v) ↦ outputs by Cranelift, so that the solvers' inner loops call
//! straight-line code instead of decoding instructions (the interpreter's fixed cost, 15–20 ns
//! a call, was most of an expression's overhead over the built-in models: issue 15).
//!
//! The function performs exactly the tape's operations in the tape's order, in IEEE double
//! precision with no fusion or reassociation (Cranelift never contracts a multiply and an add),
//! and calls the same Rust functions for everything but the arithmetic, the square root, the
//! absolute value, the sign and min/max: so its results equal the interpreter's bit for bit
//! (tested below on random points for every operation). Where Cranelift does not support the
//! host, or a tape is too long to be worth compiling, the interpreter stays.
//!
//! Hand-written because no crate turns an expression graph into native code; Cranelift (the
//! code generator of Wasmtime) does the code generation, register allocation and linking.

use super::dag::{eval_bin, eval_un, Bin, Un};
use super::program::{self, Op, F1, F2};
use super::tape::{Instr, Tape};
use cranelift_codegen::ir::condcodes::FloatCC;
use cranelift_codegen::ir::{types, AbiParam, BlockArg, InstBuilder, MemFlagsData, Signature, UserFuncName, Value};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, Linkage, Module};

/// Tapes longer than this stay interpreted (compile time grows with the length, and such
/// tapes, large Hessians, are dominated by their arithmetic, not by decoding).
const MAX_INSTRUCTIONS: usize = 20_000;

/// The compiled function: `f(count, t, q, v, out)` evaluates `count` points, point j at
/// (t[j], q[j n..], v[j n..]) into out[j k..j k + k] for k outputs; a point reads
/// `q[..q_len]` and `v[..v_len]` of its own.
type PointsFn = unsafe extern "C" fn(usize, *const f64, *const f64, *const f64, *mut f64);

/// A tape's machine code, with the module that owns the code's memory.
pub(super) struct Native {
    /// Only `None` while being dropped.
    module: Option<JITModule>,
    f: PointsFn,
    /// How many entries of q and v the code reads (one past the highest index read).
    q_len: usize,
    v_len: usize,
    outputs: usize,
}

// SAFETY: after `finalize_definitions` the module's code is immutable and `f` touches nothing
// but its arguments and pure Rust functions, so calling it from several threads at once is
// sound; the module itself is used again only by `Drop`, which has exclusive access.
unsafe impl Send for Native {}
unsafe impl Sync for Native {}

impl Drop for Native {
    fn drop(&mut self) {
        if let Some(module) = self.module.take() {
            // SAFETY: `self` owns the only pointer to the code and is going away, so the code
            // is neither running nor called afterwards.
            unsafe { module.free_memory() };
        }
    }
}

impl std::fmt::Debug for Native {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Native")
    }
}

impl Native {
    /// Evaluates at one point into `out`; `false` (and nothing written) when a slice is
    /// shorter than the code reads or writes (the caller then interprets: the interpreter
    /// reads NaN past the slices).
    #[inline]
    pub(super) fn call(&self, t: f64, q: &[f64], v: &[f64], out: &mut [f64]) -> bool {
        if q.len() < self.q_len || v.len() < self.v_len || out.len() < self.outputs {
            return false;
        }
        // SAFETY: the code reads q[..q_len] and v[..v_len] and writes out[..outputs], all
        // in bounds by the check above; it has no other side effects.
        unsafe { (self.f)(1, &t, q.as_ptr(), v.as_ptr(), out.as_mut_ptr()) };
        true
    }

    /// Evaluates at `points` points laid out as [`Tape::eval_points`] reads them; `false`
    /// (nothing written) when any slice is too short for any point.
    #[inline]
    pub(super) fn call_points(&self, n: usize, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) -> bool {
        let (k, points) = (self.outputs, t.len());
        let fits = |len: usize, stride: usize, need: usize| {
            need == 0
                || (points > 0
                    && (points - 1)
                        .checked_mul(stride)
                        .and_then(|s| s.checked_add(need))
                        .is_some_and(|e| e <= len))
        };
        if !(fits(q.len(), n, self.q_len) && fits(v.len(), n, self.v_len) && fits(out.len(), k, k)) {
            return false;
        }
        // SAFETY: point j reads t[j], q[j n..j n + q_len], v[j n..j n + v_len] and writes
        // out[j k..j k + k], in bounds by `fits` (the code only offsets the pointers of an
        // unread slice, when q_len or v_len is 0, never dereferences them).
        unsafe { (self.f)(points, t.as_ptr(), q.as_ptr(), v.as_ptr(), out.as_mut_ptr()) };
        true
    }
}

/// Compiles `tape` (the interpreter's registers become SSA values) into a loop over points;
/// `None` when the host is not supported or the tape is too long.
pub(super) fn compile(tape: &Tape) -> Option<Native> {
    if tape.code.len() > MAX_INSTRUCTIONS {
        return None;
    }
    compile_with(tape.n, tape.outputs.len(), |b, calls, [t, q, v, out]| {
        let mem = MemFlagsData::trusted();
        let mut regs: Vec<Value> = Vec::with_capacity(tape.registers);
        for &c in &tape.consts {
            regs.push(b.ins().f64const(c));
        }
        let mut used = Used::default();
        for &(_, i) in &tape.loads {
            regs.push(used.load(b, tape.n, i as usize, [t, q, v])?);
        }
        for ins in &tape.code {
            let x = emit(b, calls, &regs, *ins)?;
            regs.push(x);
        }
        for (j, &r) in tape.outputs.iter().enumerate() {
            let x = *regs.get(r as usize)?;
            b.ins().store(mem, x, out, offset(j)?);
        }
        Some(used)
    })
}

/// Compiles the postfix program `ops` over t, q and v of dimension n (one output, its value),
/// each operation as [`Program::eval`](super::Program::eval) performs it in f64, so that the
/// two agree bit for bit: the value of an expression Lagrangian, which the energy diagnostics
/// evaluate at every node of a run.
pub(super) fn compile_program(ops: &[Op], n: usize) -> Option<Native> {
    if ops.len() > MAX_INSTRUCTIONS {
        return None;
    }
    compile_with(n, 1, |b, calls, [t, q, v, out]| {
        let mut stack: Vec<Value> = Vec::new();
        let mut used = Used::default();
        for &op in ops {
            let x = match op {
                Op::Const(c) => b.ins().f64const(c),
                Op::Var(i) => used.load(b, n, i, [t, q, v])?,
                Op::Neg => {
                    let x = stack.pop()?;
                    b.ins().fneg(x)
                }
                Op::PowI(e) => {
                    let (x, e) = (stack.pop()?, b.ins().iconst(types::I32, i64::from(e)));
                    calls.call(b, &calls.powi, program_powi as *const () as usize, &[x, e])?
                }
                Op::PowF(e) => {
                    let (x, e) = (stack.pop()?, b.ins().f64const(e));
                    calls.call(b, &calls.bin, program_powf as *const () as usize, &[x, e])?
                }
                Op::Call1(f) => {
                    let x = stack.pop()?;
                    calls.call(b, &calls.un, program_fn1(f) as *const () as usize, &[x])?
                }
                Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Call2(_) => {
                    let (y, x) = (stack.pop()?, stack.pop()?);
                    match op {
                        Op::Add => b.ins().fadd(x, y),
                        Op::Sub => b.ins().fsub(x, y),
                        Op::Mul => b.ins().fmul(x, y),
                        Op::Div => b.ins().fdiv(x, y),
                        Op::Call2(f) => calls.call(b, &calls.bin, program_fn2(f) as *const () as usize, &[x, y])?,
                        _ => return None,
                    }
                }
            };
            stack.push(x);
        }
        let [x] = stack[..] else {
            return None;
        };
        b.ins().store(MemFlagsData::trusted(), x, out, 0);
        Some(used)
    })
}

/// How many entries of q and v a point reads (one past the highest index loaded).
#[derive(Default)]
struct Used {
    q: usize,
    v: usize,
}

impl Used {
    /// Loads variable i (0 is t, 1..=n are q, n + 1..=2n are v) from the point's pointers.
    fn load(&mut self, b: &mut FunctionBuilder, n: usize, i: usize, [t, q, v]: [Value; 3]) -> Option<Value> {
        let mem = MemFlagsData::trusted();
        Some(if i == 0 {
            b.ins().load(types::F64, mem, t, 0)
        } else if i <= n {
            self.q = self.q.max(i);
            b.ins().load(types::F64, mem, q, offset(i - 1)?)
        } else {
            self.v = self.v.max(i - n);
            b.ins().load(types::F64, mem, v, offset(i - 1 - n)?)
        })
    }
}

/// A function `f(count, t, q, v, out)` (see [`PointsFn`]) whose loop body, for one point, is
/// built by `point` from the point's four pointers; `None` when the host is not supported or
/// the body cannot be built.
fn compile_with(
    n: usize,
    outputs: usize,
    point: impl FnOnce(&mut FunctionBuilder, &Calls, [Value; 4]) -> Option<Used>,
) -> Option<Native> {
    if n == 0 {
        return None;
    }
    // A failure inside the code generator (it should have none on this input) costs the
    // speed, not the run: the interpreter stays.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| generate(n, outputs, point))).ok()?
}

/// [`compile_with`]'s work.
fn generate(
    n: usize,
    outputs: usize,
    point: impl FnOnce(&mut FunctionBuilder, &Calls, [Value; 4]) -> Option<Used>,
) -> Option<Native> {
    let mut flags = settings::builder();
    flags.set("opt_level", "speed").ok()?;
    flags.set("use_colocated_libcalls", "false").ok()?;
    flags.set("is_pic", "false").ok()?;
    let isa = cranelift_native::builder()
        .ok()?
        .finish(settings::Flags::new(flags))
        .ok()?;
    let mut module = JITModule::new(JITBuilder::with_isa(isa, default_libcall_names()));
    let ptr = module.target_config().pointer_type();
    let mut ctx = module.make_context();
    let mut sig = module.make_signature();
    for _ in 0..5 {
        sig.params.push(AbiParam::new(ptr));
    }
    ctx.func.signature = sig.clone();
    let id = module.declare_function("points", Linkage::Local, &sig).ok()?;
    ctx.func.name = UserFuncName::user(0, id.as_u32());
    let calls = Calls::new(ptr, module.make_signature());
    let mut fctx = FunctionBuilderContext::new();
    let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
    let (entry, head, body, exit) = (b.create_block(), b.create_block(), b.create_block(), b.create_block());
    b.append_block_params_for_function_params(entry);
    for _ in 0..5 {
        b.append_block_param(head, ptr);
    }
    b.switch_to_block(entry);
    let args: Vec<BlockArg> = b.block_params(entry).iter().map(|&x| BlockArg::Value(x)).collect();
    b.ins().jump(head, &args);
    b.switch_to_block(head);
    let &[count, t, q, v, out] = b.block_params(head) else {
        return None;
    };
    b.ins().brif(count, body, &[], exit, &[]);
    b.switch_to_block(body);
    let used = point(&mut b, &calls, [t, q, v, out])?;
    let next = [
        b.ins().iadd_imm_s(count, -1),
        b.ins().iadd_imm_s(t, 8),
        b.ins().iadd_imm_s(q, i64::from(offset(n)?)),
        b.ins().iadd_imm_s(v, i64::from(offset(n)?)),
        b.ins().iadd_imm_s(out, i64::from(offset(outputs)?)),
    ]
    .map(BlockArg::Value);
    b.ins().jump(head, &next);
    b.switch_to_block(exit);
    b.ins().return_(&[]);
    b.seal_all_blocks();
    b.finalize(module.target_config());
    module.define_function(id, &mut ctx).ok()?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().ok()?;
    let code = module.get_finalized_function(id);
    // SAFETY: `code` is the function just defined with the signature of `PointsFn` (five
    // pointer-sized arguments, no result) in the platform's C calling convention.
    let f = unsafe { std::mem::transmute::<*const u8, PointsFn>(code) };
    Some(Native {
        module: Some(module),
        f,
        q_len: used.q,
        v_len: used.v,
        outputs,
    })
}

/// The byte offset of element `i` of an f64 array.
fn offset(i: usize) -> Option<i32> {
    i32::try_from(i.checked_mul(8)?).ok()
}

/// Signatures of the Rust functions the code calls: f64 → f64, (f64, f64) → f64 and
/// (f64, i32) → f64.
struct Calls {
    ptr: types::Type,
    un: Signature,
    bin: Signature,
    powi: Signature,
}

impl Calls {
    fn new(ptr: types::Type, base: Signature) -> Self {
        let mut un = base.clone();
        un.params.push(AbiParam::new(types::F64));
        un.returns.push(AbiParam::new(types::F64));
        let mut bin = un.clone();
        bin.params.push(AbiParam::new(types::F64));
        let mut powi = un.clone();
        powi.params.push(AbiParam::new(types::I32));
        Self { ptr, un, bin, powi }
    }

    /// Calls the function at `addr` with signature `sig` on `args`.
    fn call(&self, b: &mut FunctionBuilder, sig: &Signature, addr: usize, args: &[Value]) -> Option<Value> {
        let sig = b.import_signature(sig.clone());
        let callee = b.ins().iconst(self.ptr, i64::try_from(addr).ok()?);
        let call = b.ins().call_indirect(sig, callee, args);
        b.inst_results(call).first().copied()
    }
}

/// The code of one instruction over the values of the registers so far.
fn emit(b: &mut FunctionBuilder, calls: &Calls, regs: &[Value], ins: Instr) -> Option<Value> {
    let r = |a: u32| regs.get(a as usize).copied();
    Some(match ins {
        Instr::Add(x, y) => b.ins().fadd(r(x)?, r(y)?),
        Instr::Sub(x, y) => b.ins().fsub(r(x)?, r(y)?),
        Instr::Mul(x, y) => b.ins().fmul(r(x)?, r(y)?),
        Instr::Div(x, y) => b.ins().fdiv(r(x)?, r(y)?),
        Instr::Neg(x) => b.ins().fneg(r(x)?),
        Instr::Square(x) => {
            let x = r(x)?;
            b.ins().fmul(x, x)
        }
        Instr::Sqrt(x) => b.ins().sqrt(r(x)?),
        Instr::Un(op, x) => emit_un(b, calls, op, r(x)?)?,
        Instr::Bin(op, x, y) => {
            let f: extern "C" fn(f64, f64) -> f64 = match op {
                Bin::Add => return Some(b.ins().fadd(r(x)?, r(y)?)),
                Bin::Sub => return Some(b.ins().fsub(r(x)?, r(y)?)),
                Bin::Mul => return Some(b.ins().fmul(r(x)?, r(y)?)),
                Bin::Div => return Some(b.ins().fdiv(r(x)?, r(y)?)),
                Bin::Atan2 => atan2,
                Bin::Pow => powf,
            };
            let sig = calls.bin.clone();
            calls.call(b, &sig, f as usize, &[r(x)?, r(y)?])?
        }
        Instr::Pick(max, p, q, x, y) => {
            let cc = if max { FloatCC::GreaterThan } else { FloatCC::LessThan };
            let second = b.ins().fcmp(cc, r(q)?, r(p)?);
            b.ins().select(second, r(y)?, r(x)?)
        }
    })
}

/// The code of a one-operand operation: inline where the instruction is exact, else a call.
fn emit_un(b: &mut FunctionBuilder, calls: &Calls, op: Un, x: Value) -> Option<Value> {
    let f: extern "C" fn(f64) -> f64 = match op {
        Un::Neg => return Some(b.ins().fneg(x)),
        Un::F(F1::Sqrt) => return Some(b.ins().sqrt(x)),
        Un::F(F1::Abs) => return Some(b.ins().fabs(x)),
        Un::Sign => {
            let zero = b.ins().f64const(0.0);
            let positive = b.ins().fcmp(FloatCC::GreaterThan, x, zero);
            let (one, minus) = (b.ins().f64const(1.0), b.ins().f64const(-1.0));
            return Some(b.ins().select(positive, one, minus));
        }
        Un::PowI(e) => {
            let e = b.ins().iconst(types::I32, i64::from(e));
            let sig = calls.powi.clone();
            return calls.call(b, &sig, powi as *const () as usize, &[x, e]);
        }
        Un::PowF(bits) => {
            let y = b.ins().f64const(f64::from_bits(bits));
            let sig = calls.bin.clone();
            return calls.call(b, &sig, powf as *const () as usize, &[x, y]);
        }
        Un::F(f) => match f {
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
        },
    };
    let sig = calls.un.clone();
    calls.call(b, &sig, f as usize, &[x])
}

/// The Rust functions the code calls, each the interpreter's own evaluation of that operation
/// (so the two agree bit for bit).
macro_rules! un_fns {
    ($($name:ident => $f:ident),* $(,)?) => {
        $(extern "C" fn $name(x: f64) -> f64 {
            eval_un(Un::F(F1::$f), x)
        })*
    };
}
un_fns!(sin => Sin, cos => Cos, tan => Tan, exp => Exp, ln => Ln, sinh => Sinh, cosh => Cosh,
    tanh => Tanh, asin => Asin, acos => Acos, atan => Atan);

/// The program's own f64 functions (`program::unary` / `binary`), for the value code.
macro_rules! program_fns {
    ($($name:ident => $f:ident),* $(,)?) => {
        $(extern "C" fn $name(x: f64) -> f64 {
            program::unary::<f64>(Op::Call1(F1::$f), x)
        })*
        fn program_fn1(f: F1) -> extern "C" fn(f64) -> f64 {
            match f { $(F1::$f => $name,)* }
        }
    };
}
program_fns!(program_sin => Sin, program_cos => Cos, program_tan => Tan, program_exp => Exp,
    program_ln => Ln, program_sqrt => Sqrt, program_abs => Abs, program_sinh => Sinh,
    program_cosh => Cosh, program_tanh => Tanh, program_asin => Asin, program_acos => Acos,
    program_atan => Atan);

fn program_fn2(f: F2) -> extern "C" fn(f64, f64) -> f64 {
    extern "C" fn atan2(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Atan2), x, y)
    }
    extern "C" fn pow(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Pow), x, y)
    }
    extern "C" fn min(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Min), x, y)
    }
    extern "C" fn max(x: f64, y: f64) -> f64 {
        program::binary::<f64>(Op::Call2(F2::Max), x, y)
    }
    match f {
        F2::Atan2 => atan2,
        F2::Pow => pow,
        F2::Min => min,
        F2::Max => max,
    }
}

extern "C" fn program_powi(x: f64, e: i32) -> f64 {
    program::unary::<f64>(Op::PowI(e), x)
}

extern "C" fn program_powf(x: f64, e: f64) -> f64 {
    program::unary::<f64>(Op::PowF(e), x)
}

extern "C" fn powi(x: f64, e: i32) -> f64 {
    eval_un(Un::PowI(e), x)
}

extern "C" fn powf(x: f64, y: f64) -> f64 {
    eval_bin(Bin::Pow, x, y)
}

extern "C" fn atan2(x: f64, y: f64) -> f64 {
    eval_bin(Bin::Atan2, x, y)
}

#[cfg(test)]
mod tests {
    use super::super::tape::Tape;
    use super::super::ExprLagrangian;

    /// Uniform numbers in [-3, 3) from a fixed xorshift sequence.
    fn points(seed: u64, count: usize) -> Vec<f64> {
        let mut s = seed;
        (0..count)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64 * 6.0 - 3.0
            })
            .collect()
    }

    /// Every tape of `l` run as machine code gives the interpreter's outputs bit for bit.
    fn same_bits(src: &str, names: &[&str]) {
        let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        let l = ExprLagrangian::new(src, &names, &[("k".into(), 1.7)]).unwrap();
        let n = names.len();
        let tapes: Vec<&Tape> = [&l.fast.force, &l.fast.gyro, &l.fast.first, &l.fast.second]
            .into_iter()
            .flatten()
            .collect();
        assert!(!tapes.is_empty(), "{src}: no tape");
        for tape in tapes {
            assert!(tape.is_native(), "{src}: not compiled");
            let plain = tape.interpreted();
            let k = tape.outputs.len();
            for (p, z) in points(0x9e37_79b9_7f4a_7c15 ^ src.len() as u64, 200 * (2 * n + 1))
                .chunks_exact(2 * n + 1)
                .enumerate()
            {
                // Some points on ties and zeros, where min, max, sign and abs branch.
                let z: Vec<f64> = z.iter().map(|&x| if p % 7 == 3 { x.round() } else { x }).collect();
                let (t, q, v) = (z[0], &z[1..=n], &z[n + 1..]);
                let (mut a, mut b) = (vec![0.0; k], vec![0.0; k]);
                tape.eval(t, q, v, |j, x| a[j] = x);
                plain.eval(t, q, v, |j, x| b[j] = x);
                for (j, (x, y)) in a.iter().zip(&b).enumerate() {
                    assert!(
                        x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                        "{src} output {j} at {z:?}: {x} vs {y}"
                    );
                }
            }
            // Several points at once (the solvers' path), against the interpreter's lanes.
            let z = points(7 + k as u64, 5 * (1 + 2 * n));
            let (t, qv) = z.split_at(5);
            let (q, v) = qv.split_at(5 * n);
            let (mut a, mut b) = (vec![0.0; 5 * k], vec![0.0; 5 * k]);
            tape.eval_points(t, q, v, &mut a);
            plain.eval_points(t, q, v, &mut b);
            for (x, y) in a.iter().zip(&b) {
                assert!(
                    x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                    "{src}: {x} vs {y}"
                );
            }
        }
    }

    #[test]
    fn machine_code_equals_the_interpreter_for_every_operation() {
        let cases: &[(&str, &[&str])] = &[
            ("0.5*l_dot^2 + k*cos(l)", &["l"]),
            ("0.5*(x_dot^2 + y_dot^2) + 1/sqrt(x^2 + y^2)", &["x", "y"]),
            (
                "0.5*(x_dot^2 + y_dot^2) + x*y_dot - y*x_dot + (1 - k)/sqrt((x + k)^2 + y^2)",
                &["x", "y"],
            ),
            (
                "0.5*x_dot^2 - sin(x)*tan(x/5) + exp(-x^2) + ln(1 + x^2) + abs(x)^3",
                &["x"],
            ),
            (
                "0.5*x_dot^2 + sinh(x/3) - cosh(x/4) + tanh(x) + asin(x/4) + acos(x/5) + atan(x)",
                &["x"],
            ),
            (
                "0.5*x_dot^2 + atan2(x, t + 4) + pow(abs(x) + 1, t/3) + min(x, t) + max(x, 1)",
                &["x"],
            ),
            ("x_dot^4/12 + x^-3 + x^2.5 + x^(1/3) - sqrt(1 - x_dot^2/9)", &["x"]),
            (
                "-k*sqrt(1 - (x_dot^2 + y_dot^2)/100) + 1/sqrt(x^2 + y^2) + t*x",
                &["x", "y"],
            ),
            (
                "0.5*(a_dot^2 + b_dot^2 + c_dot^2) - a*b*c + min(a, b)*max(b, c) + abs(a - c)",
                &["a", "b", "c"],
            ),
        ];
        for (src, names) in cases {
            same_bits(src, names);
            same_value(src, names);
        }
    }

    /// The value's machine code gives `Program::eval`'s f64 bit for bit.
    fn same_value(src: &str, names: &[&str]) {
        use crate::Lagrangian;
        let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        let l = ExprLagrangian::new(src, &names, &[("k".into(), 1.7)]).unwrap();
        assert!(l.fast.value.is_some(), "{src}: value not compiled");
        let n = names.len();
        for (p, z) in points(0x2545_f491_4f6c_dd1d ^ src.len() as u64, 200 * (2 * n + 1))
            .chunks_exact(2 * n + 1)
            .enumerate()
        {
            let z: Vec<f64> = z.iter().map(|&x| if p % 7 == 3 { x.round() } else { x }).collect();
            let (t, q, v) = (z[0], &z[1..=n], &z[n + 1..]);
            let native: f64 = l.value(t, q, v);
            let program: f64 = l.program.eval(|i| z[i]);
            assert!(
                native.to_bits() == program.to_bits() || (native.is_nan() && program.is_nan()),
                "{src} at {z:?}: {native} vs {program}"
            );
        }
    }
}
