//! Machine code across SIMD lanes (issue 39 item 2): a tape (the force of a mechanical
//! expression) or the value program of an expression Lagrangian compiled for [`LANES`] points
//! at once, all at one time t, stored coordinate by coordinate (`q[c][l]`) as the ensemble
//! lanes keep them ([`crate::ensemble`]).
//!
//! Each iteration of the compiled loop evaluates two lanes in one 128-bit register (F64X2,
//! the vector width Cranelift generates on every host it supports): this file is that
//! [`Flavour`] of the translation (`translate.rs`, `emit.rs`), which performs, on each lane,
//! the operations of the scalar code in the same order: the four
//! operations, the square root, the absolute value and the negation as vector instructions
//! (each exact, lane by lane, as IEEE 754 defines it); the sign and min/max as vector
//! comparisons and selects of the same comparison; integer powers by the same unrolled
//! products; every other function by calling the scalar code's own Rust function on each lane.
//! So every lane equals the scalar code's result, and the interpreter's, bit for bit
//! (`tests.rs`).

use super::super::program::Op;
use super::super::tape::Tape;
use super::emit::Calls;
use super::flavour::Flavour;
use super::{offset, translate, Native, Strides};
use crate::lagrangian::LANES;
use cranelift_codegen::ir::{types, Endianness, InstBuilder, MemFlagsData, Signature, Value};
use cranelift_frontend::FunctionBuilder;

/// Two lanes of doubles.
const PAIR: types::Type = types::F64X2;

/// Compiles `tape` for [`LANES`] points at once ([`Native::call_lanes`]); `None` when the host
/// is not supported or the tape is too long.
pub(in crate::expr) fn compile_lanes(tape: &Tape) -> Option<Native> {
    translate::tape(&Pair, tape)
}

/// Compiles the postfix program `ops` over t, q and v of dimension n (one output, its value)
/// for [`LANES`] points at once, each lane as [`super::compile_program`]'s code computes it.
pub(in crate::expr) fn compile_program_lanes(ops: &[Op], n: usize) -> Option<Native> {
    translate::program(&Pair, ops, n)
}

/// A pair of lanes per value: iteration i of the loop evaluates lanes 2i and 2i + 1.
struct Pair;

impl Flavour for Pair {
    /// t stays (one time for every lane); q, v and out move by two numbers within each
    /// coordinate's [`LANES`].
    fn strides(&self, n: usize, outputs: usize) -> Option<Strides> {
        if n == 0 {
            return None;
        }
        Some(Strides {
            t: 0,
            q: 16,
            v: 16,
            out: 16,
            outputs,
        })
    }

    fn constant(&self, b: &mut FunctionBuilder, c: f64) -> Value {
        let x = b.ins().f64const(c);
        b.ins().splat(PAIR, x)
    }

    fn load_time(&self, b: &mut FunctionBuilder, t: Value) -> Value {
        let x = b.ins().load(types::F64, MemFlagsData::trusted(), t, 0);
        b.ins().splat(PAIR, x)
    }

    fn load_entry(&self, b: &mut FunctionBuilder, base: Value, c: usize) -> Option<Value> {
        Some(b.ins().load(PAIR, unaligned(), base, coordinate(c)?))
    }

    fn store(&self, b: &mut FunctionBuilder, x: Value, out: Value, j: usize) -> Option<()> {
        b.ins().store(unaligned(), x, out, coordinate(j)?);
        Some(())
    }

    /// A vector comparison's mask, as the select's bits.
    fn select(&self, b: &mut FunctionBuilder, mask: Value, x: Value, y: Value) -> Value {
        let mask = b
            .ins()
            .bitcast(PAIR, MemFlagsData::new().with_endianness(Endianness::Little), mask);
        b.ins().bitselect(mask, x, y)
    }

    /// The function on each lane.
    fn call(
        &self,
        b: &mut FunctionBuilder,
        calls: &Calls,
        sig: &Signature,
        addr: usize,
        args: &[Value],
    ) -> Option<Value> {
        let lane = |b: &mut FunctionBuilder, l: u8| {
            let scalars: Vec<Value> = args.iter().map(|&x| b.ins().extractlane(x, l)).collect();
            calls.call(b, sig, addr, &scalars)
        };
        let (first, second) = (lane(b, 0)?, lane(b, 1)?);
        let pair = b.ins().scalar_to_vector(PAIR, first);
        Some(b.ins().insertlane(pair, second, 1))
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
