//! Flat instruction tapes: the nodes of a [`Dag`](super::dag::Dag) that some outputs depend on,
//! in order, each writing one register, evaluated in f64 by one loop (no recursion, no stack
//! machine). Registers hold the constants first (copied in), then the variables that occur
//! (loaded from t, q, v), then one register per instruction.

use super::dag::{eval_bin, eval_un, Bin, Dag, Id, Node, Un};
use super::program::F1;
use std::cell::RefCell;
use std::collections::HashMap;

/// An instruction on registers; the most common operations have their own variants so that
/// the evaluation loop dispatches once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Instr {
    Add(u32, u32),
    Sub(u32, u32),
    Mul(u32, u32),
    Div(u32, u32),
    Neg(u32),
    Square(u32),
    Sqrt(u32),
    Un(Un, u32),
    Bin(Bin, u32, u32),
    Pick(bool, u32, u32, u32, u32),
}

impl Instr {
    fn new(node: Node, r: impl Fn(Id) -> u32) -> Option<Self> {
        Some(match node {
            Node::Const(_) | Node::Var(_) => return None,
            Node::Un(Un::Neg, x) => Instr::Neg(r(x)),
            Node::Un(Un::PowI(2), x) => Instr::Square(r(x)),
            Node::Un(Un::F(F1::Sqrt), x) => Instr::Sqrt(r(x)),
            Node::Un(op, x) => Instr::Un(op, r(x)),
            Node::Bin(Bin::Add, x, y) => Instr::Add(r(x), r(y)),
            Node::Bin(Bin::Sub, x, y) => Instr::Sub(r(x), r(y)),
            Node::Bin(Bin::Mul, x, y) => Instr::Mul(r(x), r(y)),
            Node::Bin(Bin::Div, x, y) => Instr::Div(r(x), r(y)),
            Node::Bin(op, x, y) => Instr::Bin(op, r(x), r(y)),
            Node::Pick(max, p, q, x, y) => Instr::Pick(max, r(p), r(q), r(x), r(y)),
        })
    }
}

/// A compiled list of outputs over the variables z = (t, q, v) (variable 0 is t, 1..=n are q,
/// n + 1..=2n are v).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Tape {
    /// The constants, in registers 0..consts.len().
    pub(super) consts: Vec<f64>,
    /// The variables loaded next: (register, variable index).
    pub(super) loads: Vec<(u32, u32)>,
    pub(super) code: Vec<Instr>,
    /// The register of each output.
    pub(super) outputs: Vec<u32>,
    pub(super) registers: usize,
    /// The dimension n of q and v.
    pub(super) n: usize,
    /// The same tape as machine code, when it could be compiled (same results, bit for bit).
    native: NativeSlot,
}

/// A tape's machine code, shared by its clones (compared as equal: it is a function of the
/// tape).
#[derive(Debug, Clone, Default)]
struct NativeSlot(#[cfg(feature = "jit")] Option<std::sync::Arc<super::native::Native>>);

impl PartialEq for NativeSlot {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Points evaluated together by [`Tape::eval_points`]: each instruction is decoded once and
/// applied to this many lanes (the quadrature points of an element), which the compiler turns
/// into vector instructions.
const LANES: usize = 4;
/// Lanes for elements with one or two points.
const FEW_LANES: usize = 2;
/// Tapes with at most this many registers keep them on the stack (two sizes, so that the
/// smallest tapes do not pay for clearing the larger array).
const TINY: usize = 8;
const SMALL: usize = 32;

thread_local! {
    /// Registers reused across evaluations on this thread (tapes are evaluated in the step's
    /// inner loops, where an allocation per call would cost more than the evaluation).
    static REGISTERS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    /// The same for [`Tape::eval_points`].
    static LANE_REGISTERS: RefCell<Vec<[f64; LANES]>> = const { RefCell::new(Vec::new()) };
    static FEW_LANE_REGISTERS: RefCell<Vec<[f64; FEW_LANES]>> = const { RefCell::new(Vec::new()) };
}

impl Tape {
    /// The tape of `outputs` (node ids of `dag`) over t, q and v of dimension n.
    pub(super) fn new(dag: &Dag, outputs: &[Id], n: usize) -> Self {
        let order = dag.reachable(outputs);
        let mut reg: HashMap<Id, u32> = HashMap::with_capacity(order.len());
        let mut consts = Vec::new();
        let mut loads = Vec::new();
        let nodes = dag.nodes();
        for &a in &order {
            if let Node::Const(bits) = nodes[a as usize] {
                reg.insert(a, consts.len() as u32);
                consts.push(f64::from_bits(bits));
            }
        }
        for &a in &order {
            if let Node::Var(i) = nodes[a as usize] {
                reg.insert(a, (consts.len() + loads.len()) as u32);
                loads.push(((consts.len() + loads.len()) as u32, i));
            }
        }
        let mut code = Vec::new();
        let base = consts.len() + loads.len();
        for &a in &order {
            let r = |x: Id| reg.get(&x).copied().unwrap_or(0);
            let Some(ins) = Instr::new(nodes[a as usize], r) else {
                continue;
            };
            reg.insert(a, (base + code.len()) as u32);
            code.push(ins);
        }
        let outputs = outputs.iter().map(|o| reg.get(o).copied().unwrap_or(0)).collect();
        let tape = Self {
            registers: base + code.len(),
            consts,
            loads,
            code,
            outputs,
            n,
            native: NativeSlot::default(),
        };
        #[cfg(feature = "jit")]
        let tape = Self {
            native: NativeSlot(super::native::compile(&tape).map(std::sync::Arc::new)),
            ..tape
        };
        tape
    }

    /// The interpreted tape alone (no machine code), for comparisons.
    #[cfg(all(test, feature = "jit"))]
    pub(super) fn interpreted(&self) -> Self {
        Self {
            native: NativeSlot::default(),
            ..self.clone()
        }
    }

    /// Whether the tape runs as machine code.
    #[cfg(all(test, feature = "jit"))]
    pub(super) fn is_native(&self) -> bool {
        self.native.0.is_some()
    }

    /// Evaluates at z = (t, q, v) and hands the output values, in order, to `out`.
    /// A variable beyond the slices reads NaN.
    #[inline]
    pub(super) fn eval(
        &self,
        t: f64,
        q: &[f64],
        v: &[f64],
        #[cfg_attr(not(feature = "jit"), allow(unused_mut))] mut out: impl FnMut(usize, f64),
    ) {
        #[cfg(feature = "jit")]
        if let Some(native) = &self.native.0 {
            let k = self.outputs.len();
            let mut buf = [0.0; TINY];
            if let Some(buf) = buf.get_mut(..k) {
                if native.call(t, q, v, buf) {
                    return buf.iter().enumerate().for_each(|(j, &x)| out(j, x));
                }
            } else {
                let done = REGISTERS.with(|cell| match cell.try_borrow_mut() {
                    Ok(mut regs) => {
                        if regs.len() < k {
                            regs.resize(k, 0.0);
                        }
                        let ok = native.call(t, q, v, &mut regs[..k]);
                        if ok {
                            regs[..k].iter().enumerate().for_each(|(j, &x)| out(j, x));
                        }
                        ok
                    }
                    Err(_) => false,
                });
                if done {
                    return;
                }
            }
        }
        REGISTERS.with(|cell| match cell.try_borrow_mut() {
            Ok(mut regs) => self.eval_in(&mut regs, t, q, v, out),
            Err(_) => self.eval_in(&mut Vec::new(), t, q, v, out),
        });
    }

    fn eval_in(&self, regs: &mut Vec<f64>, t: f64, q: &[f64], v: &[f64], mut out: impl FnMut(usize, f64)) {
        if regs.len() < self.registers {
            regs.resize(self.registers, 0.0);
        }
        let n = self.n;
        regs[..self.consts.len()].copy_from_slice(&self.consts);
        for &(r, i) in &self.loads {
            let i = i as usize;
            regs[r as usize] = if i == 0 {
                t
            } else if i <= n {
                q.get(i - 1).copied().unwrap_or(f64::NAN)
            } else {
                v.get(i - 1 - n).copied().unwrap_or(f64::NAN)
            };
        }
        let base = self.consts.len() + self.loads.len();
        for (k, ins) in self.code.iter().enumerate() {
            let x = match *ins {
                Instr::Add(a, b) => regs[a as usize] + regs[b as usize],
                Instr::Sub(a, b) => regs[a as usize] - regs[b as usize],
                Instr::Mul(a, b) => regs[a as usize] * regs[b as usize],
                Instr::Div(a, b) => regs[a as usize] / regs[b as usize],
                Instr::Neg(a) => -regs[a as usize],
                Instr::Square(a) => regs[a as usize] * regs[a as usize],
                Instr::Sqrt(a) => regs[a as usize].sqrt(),
                Instr::Un(op, a) => eval_un(op, regs[a as usize]),
                Instr::Bin(op, a, b) => eval_bin(op, regs[a as usize], regs[b as usize]),
                Instr::Pick(max, p, q, x, y) => {
                    let (p, q) = (regs[p as usize], regs[q as usize]);
                    let second = if max { q > p } else { q < p };
                    regs[if second { y } else { x } as usize]
                }
            };
            regs[base + k] = x;
        }
        for (j, &r) in self.outputs.iter().enumerate() {
            out(j, regs[r as usize]);
        }
    }

    /// Evaluates the tape at several points: point j is (t[j], q[j n..(j + 1) n],
    /// v[j n..(j + 1) n]) (velocities beyond `v`, e.g. all of them when it is empty, read
    /// NaN), and its outputs go to `out[j k..(j + 1) k]` for k outputs. Points are taken
    /// [`LANES`] at a time, each instruction decoded once per group.
    pub(super) fn eval_points(&self, t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        #[cfg(feature = "jit")]
        if let Some(native) = &self.native.0 {
            if native.call_points(self.n, t, q, v, out) {
                return;
            }
        }
        if t.len() <= FEW_LANES {
            self.eval_points_with::<FEW_LANES>(&FEW_LANE_REGISTERS, t, q, v, out);
        } else {
            self.eval_points_with::<LANES>(&LANE_REGISTERS, t, q, v, out);
        }
    }

    /// Registers on the stack for small tapes, else the thread's.
    #[inline]
    fn eval_points_with<const W: usize>(
        &self,
        key: &'static std::thread::LocalKey<RefCell<Vec<[f64; W]>>>,
        t: &[f64],
        q: &[f64],
        v: &[f64],
        out: &mut [f64],
    ) {
        if self.registers <= TINY {
            let mut regs = [[0.0; W]; TINY];
            return self.eval_points_in(&mut regs, t, q, v, out);
        }
        if self.registers <= SMALL {
            let mut regs = [[0.0; W]; SMALL];
            return self.eval_points_in(&mut regs, t, q, v, out);
        }
        key.with(|cell| match cell.try_borrow_mut() {
            Ok(mut regs) => {
                if regs.len() < self.registers {
                    regs.resize(self.registers, [0.0; W]);
                }
                self.eval_points_in(&mut regs, t, q, v, out)
            }
            Err(_) => self.eval_points_in(&mut vec![[0.0; W]; self.registers], t, q, v, out),
        });
    }

    /// `regs` has at least `self.registers` entries.
    fn eval_points_in<const W: usize>(&self, regs: &mut [[f64; W]], t: &[f64], q: &[f64], v: &[f64], out: &mut [f64]) {
        let (n, k) = (self.n, self.outputs.len());
        if n == 0 || k == 0 || regs.len() < self.registers {
            return;
        }
        for (c, r) in self.consts.iter().zip(regs.iter_mut()) {
            *r = [*c; W];
        }
        let base = self.consts.len() + self.loads.len();
        let points = t.len().min(q.len() / n).min(out.len() / k);
        for first in (0..points).step_by(W) {
            // Lanes past the last point repeat it (their results are dropped); the costly
            // functions skip them.
            let point: [usize; W] = std::array::from_fn(|lane| (first + lane).min(points - 1));
            let live = W.min(points - first);
            for &(r, i) in &self.loads {
                let i = i as usize;
                regs[r as usize] = if i == 0 {
                    point.map(|j| t[j])
                } else if i <= n {
                    point.map(|j| q.get(j * n + i - 1).copied().unwrap_or(f64::NAN))
                } else {
                    point.map(|j| v.get(j * n + i - 1 - n).copied().unwrap_or(f64::NAN))
                };
            }
            for (kk, ins) in self.code.iter().enumerate() {
                let (src, dst) = regs.split_at_mut(base + kk);
                let lanes2 = |a: u32, b: u32, f: fn(f64, f64) -> f64| {
                    let (x, y) = (&src[a as usize], &src[b as usize]);
                    std::array::from_fn(|l| f(x[l], y[l]))
                };
                dst[0] = match *ins {
                    Instr::Add(a, b) => lanes2(a, b, |x, y| x + y),
                    Instr::Sub(a, b) => lanes2(a, b, |x, y| x - y),
                    Instr::Mul(a, b) => lanes2(a, b, |x, y| x * y),
                    Instr::Div(a, b) => lanes2(a, b, |x, y| x / y),
                    Instr::Neg(a) => src[a as usize].map(|x| -x),
                    Instr::Square(a) => src[a as usize].map(|x| x * x),
                    Instr::Sqrt(a) => src[a as usize].map(f64::sqrt),
                    Instr::Un(op, a) => lanes_un(op, &src[a as usize], live),
                    Instr::Bin(op, a, b) => lanes_bin(op, &src[a as usize], &src[b as usize], live),
                    Instr::Pick(max, p, q, x, y) => {
                        let (p, q, x, y) = (src[p as usize], src[q as usize], src[x as usize], src[y as usize]);
                        std::array::from_fn(|l| {
                            let second = if max { q[l] > p[l] } else { q[l] < p[l] };
                            if second {
                                y[l]
                            } else {
                                x[l]
                            }
                        })
                    }
                };
            }
            for lane in 0..live {
                let j = first + lane;
                for (o, &r) in out[j * k..(j + 1) * k].iter_mut().zip(&self.outputs) {
                    *o = regs[r as usize][lane];
                }
            }
        }
    }
}

/// A one-operand operation on the first `live` lanes (the others left 0: their points do not
/// exist, and costly functions are not evaluated for them).
#[inline]
fn lanes_un<const W: usize>(op: Un, x: &[f64; W], live: usize) -> [f64; W] {
    let mut r = [0.0; W];
    for (r, &x) in r.iter_mut().zip(x).take(live) {
        *r = eval_un(op, x);
    }
    r
}

/// A two-operand operation on the first `live` lanes (as [`lanes_un`]).
#[inline]
fn lanes_bin<const W: usize>(op: Bin, x: &[f64; W], y: &[f64; W], live: usize) -> [f64; W] {
    let mut r = [0.0; W];
    for l in 0..live {
        r[l] = eval_bin(op, x[l], y[l]);
    }
    r
}
