//! What a compiled tape or program is made of, per value: one number (the scalar code, a
//! point per iteration of the loop) or a pair of lanes (`lanes.rs`). The translation of
//! `translate.rs` and the instructions of `emit.rs` are written once over [`Flavour`]; a
//! flavour says how a constant, a variable, an output, a select on a comparison and a call of
//! a Rust function look in its values, and how far the loop's pointers move.

use super::emit::Calls;
use super::{offset, Strides, Used};
use cranelift_codegen::ir::{types, InstBuilder, MemFlagsData, Signature, Value};
use cranelift_frontend::FunctionBuilder;

/// The values of one kind of compiled code.
pub(super) trait Flavour {
    /// How the loop's pointers move per iteration for n coordinates and `outputs` outputs;
    /// None for n = 0 (nothing to compile) or offsets out of range.
    fn strides(&self, n: usize, outputs: usize) -> Option<Strides>;
    /// The constant c.
    fn constant(&self, b: &mut FunctionBuilder, c: f64) -> Value;
    /// The time at pointer t.
    fn load_time(&self, b: &mut FunctionBuilder, t: Value) -> Value;
    /// Entry c of q or v at pointer `base`.
    fn load_entry(&self, b: &mut FunctionBuilder, base: Value, c: usize) -> Option<Value>;
    /// Variable i (0 is t, 1..=n are q, n + 1..=2n are v) from the iteration's pointers,
    /// counted in `used`.
    fn load(
        &self,
        b: &mut FunctionBuilder,
        used: &mut Used,
        n: usize,
        i: usize,
        [t, q, v]: [Value; 3],
    ) -> Option<Value> {
        if i == 0 {
            Some(self.load_time(b, t))
        } else if i <= n {
            used.q = used.q.max(i);
            self.load_entry(b, q, i - 1)
        } else {
            used.v = used.v.max(i - n);
            self.load_entry(b, v, i - 1 - n)
        }
    }
    /// Stores output j.
    fn store(&self, b: &mut FunctionBuilder, x: Value, out: Value, j: usize) -> Option<()>;
    /// x where `mask` (a comparison of two values) holds, else y.
    fn select(&self, b: &mut FunctionBuilder, mask: Value, x: Value, y: Value) -> Value;
    /// The Rust function at `addr` (signature `sig`) on `args`.
    fn call(
        &self,
        b: &mut FunctionBuilder,
        calls: &Calls,
        sig: &Signature,
        addr: usize,
        args: &[Value],
    ) -> Option<Value>;
}

/// One number per value, one point per iteration.
pub(super) struct Scalar;

impl Flavour for Scalar {
    fn strides(&self, n: usize, outputs: usize) -> Option<Strides> {
        Strides::points(n, outputs)
    }

    fn constant(&self, b: &mut FunctionBuilder, c: f64) -> Value {
        b.ins().f64const(c)
    }

    fn load_time(&self, b: &mut FunctionBuilder, t: Value) -> Value {
        b.ins().load(types::F64, MemFlagsData::trusted(), t, 0)
    }

    fn load_entry(&self, b: &mut FunctionBuilder, base: Value, c: usize) -> Option<Value> {
        Some(b.ins().load(types::F64, MemFlagsData::trusted(), base, offset(c)?))
    }

    fn store(&self, b: &mut FunctionBuilder, x: Value, out: Value, j: usize) -> Option<()> {
        b.ins().store(MemFlagsData::trusted(), x, out, offset(j)?);
        Some(())
    }

    fn select(&self, b: &mut FunctionBuilder, mask: Value, x: Value, y: Value) -> Value {
        b.ins().select(mask, x, y)
    }

    fn call(
        &self,
        b: &mut FunctionBuilder,
        calls: &Calls,
        sig: &Signature,
        addr: usize,
        args: &[Value],
    ) -> Option<Value> {
        calls.call(b, sig, addr, args)
    }
}
