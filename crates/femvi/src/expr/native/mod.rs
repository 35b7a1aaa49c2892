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

mod emit;
mod flavour;
mod functions;
mod lanes;
#[cfg(test)]
mod tests;
mod translate;

use super::program::Op;
use super::tape::Tape;
use crate::lagrangian::{Lanes, LANES};
use cranelift_codegen::ir::{AbiParam, BlockArg, InstBuilder, UserFuncName, Value};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, Linkage, Module};
use flavour::Scalar;

pub(super) use lanes::{compile_lanes, compile_program_lanes};

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

impl Native {
    /// Evaluates code compiled by [`compile_lanes`] or [`compile_program_lanes`] at
    /// [`LANES`] points at time t, stored coordinate by coordinate (`q[c][l]`, `v[c][l]`),
    /// into `out[j][l]`; `false` (nothing written) when a slice is shorter than the code
    /// reads or writes.
    #[inline]
    pub(super) fn call_lanes(&self, t: f64, q: &[Lanes], v: &[Lanes], out: &mut [Lanes]) -> bool {
        if q.len() < self.q_len || v.len() < self.v_len || out.len() < self.outputs {
            return false;
        }
        // SAFETY: the code runs LANES / 2 iterations; iteration i reads the pair of lanes
        // 2i, 2i + 1 of t (one number), q[..q_len], v[..v_len] and writes that pair of
        // out[..outputs] (`lanes.rs`): in bounds by the check above.
        unsafe {
            (self.f)(
                LANES / 2,
                &t,
                q.as_ptr().cast(),
                v.as_ptr().cast(),
                out.as_mut_ptr().cast(),
            )
        };
        true
    }
}

/// Compiles `tape` (the interpreter's registers become SSA values) into a loop over points;
/// `None` when the host is not supported or the tape is too long.
pub(super) fn compile(tape: &Tape) -> Option<Native> {
    translate::tape(&Scalar, tape)
}

/// Compiles the postfix program `ops` over t, q and v of dimension n (one output, its value),
/// each operation as [`Program::eval`](super::Program::eval) performs it in f64, so that the
/// two agree bit for bit: the value of an expression Lagrangian, which the energy diagnostics
/// evaluate at every node of a run.
pub(super) fn compile_program(ops: &[Op], n: usize) -> Option<Native> {
    translate::program(&Scalar, ops, n)
}

/// How many entries of q and v a point reads (one past the highest index loaded).
#[derive(Default)]
struct Used {
    q: usize,
    v: usize,
}

/// How far the pointers (t, q, v, out) of the compiled loop move from one iteration to the
/// next, in bytes, and the outputs of an iteration.
#[derive(Clone, Copy)]
struct Strides {
    t: i64,
    q: i64,
    v: i64,
    out: i64,
    outputs: usize,
}

impl Strides {
    /// One point per iteration: t by one number, q and v by n, out by `outputs`; None for
    /// n = 0 (nothing to compile).
    fn points(n: usize, outputs: usize) -> Option<Self> {
        if n == 0 {
            return None;
        }
        let (point, out) = (i64::from(offset(n)?), i64::from(offset(outputs)?));
        Some(Self {
            t: 8,
            q: point,
            v: point,
            out,
            outputs,
        })
    }
}

/// A function `f(count, t, q, v, out)` (see [`PointsFn`]) whose loop body, for one iteration,
/// is built by `point` from the iteration's four pointers, which then move by `strides`;
/// `None` when the host is not supported or the body cannot be built.
fn compile_with(
    strides: Strides,
    point: impl FnOnce(&mut FunctionBuilder, &emit::Calls, [Value; 4]) -> Option<Used> + Send,
) -> Option<Native> {
    // The code generator runs on a thread of its own with GENERATOR_STACK, so that compiling
    // does not depend on the caller's stack. A thread that cannot start, or a failure inside
    // the code generator (it should have none on this input), costs the speed, not the run:
    // the interpreter stays.
    std::thread::scope(|scope| {
        let worker = std::thread::Builder::new()
            .name("femvi-jit".into())
            .stack_size(GENERATOR_STACK)
            .spawn_scoped(scope, || {
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| generate(strides, point)))
                    .ok()
                    .flatten()
            });
        worker.ok()?.join().ok().flatten()
    })
}

/// The stack of the code generator's thread. Cranelift's stack use grows with the nesting of
/// the expression, and much more where it is built without optimization (the `dev` profile
/// builds it at opt-level 0): the deepest expression the parser accepts overflowed a 256 KiB
/// caller's stack there (`tests/all/hostile.rs`). Reserved, not touched, beyond what is used.
const GENERATOR_STACK: usize = 16 << 20;

/// [`compile_with`]'s work.
fn generate(
    strides: Strides,
    point: impl FnOnce(&mut FunctionBuilder, &emit::Calls, [Value; 4]) -> Option<Used>,
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
    let calls = emit::Calls::new(ptr, module.make_signature());
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
        b.ins().iadd_imm_s(t, strides.t),
        b.ins().iadd_imm_s(q, strides.q),
        b.ins().iadd_imm_s(v, strides.v),
        b.ins().iadd_imm_s(out, strides.out),
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
        outputs: strides.outputs,
    })
}

/// The byte offset of element `i` of an f64 array.
fn offset(i: usize) -> Option<i32> {
    i32::try_from(i.checked_mul(8)?).ok()
}
