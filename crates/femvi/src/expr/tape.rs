//! Flat instruction tapes: the nodes of a [`Dag`](super::dag::Dag) that some outputs depend on,
//! in order, each writing one register, evaluated in f64 by one loop (no recursion, no stack
//! machine). Registers hold the constants first (copied in), then the variables that occur
//! (loaded from t, q, v), then one register per instruction.

use super::dag::{eval_bin, eval_un, Bin, Dag, Id, Node, Un};
use std::cell::RefCell;
use std::collections::HashMap;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Instr {
    Un(Un, u32),
    Bin(Bin, u32, u32),
    Pick(bool, u32, u32, u32, u32),
}

/// A compiled list of outputs over the variables z = (t, q, v) (variable 0 is t, 1..=n are q,
/// n + 1..=2n are v).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Tape {
    /// The constants, in registers 0..consts.len().
    consts: Vec<f64>,
    /// The variables loaded next: (register, variable index).
    loads: Vec<(u32, u32)>,
    code: Vec<Instr>,
    /// The register of each output.
    outputs: Vec<u32>,
    registers: usize,
    /// The dimension n of q and v.
    n: usize,
}

thread_local! {
    /// Registers reused across evaluations on this thread (tapes are evaluated in the step's
    /// inner loops, where an allocation per call would cost more than the evaluation).
    static REGISTERS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
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
            let ins = match nodes[a as usize] {
                Node::Const(_) | Node::Var(_) => continue,
                Node::Un(op, x) => Instr::Un(op, r(x)),
                Node::Bin(op, x, y) => Instr::Bin(op, r(x), r(y)),
                Node::Pick(max, p, q, x, y) => Instr::Pick(max, r(p), r(q), r(x), r(y)),
            };
            reg.insert(a, (base + code.len()) as u32);
            code.push(ins);
        }
        let outputs = outputs.iter().map(|o| reg.get(o).copied().unwrap_or(0)).collect();
        Self {
            registers: base + code.len(),
            consts,
            loads,
            code,
            outputs,
            n,
        }
    }

    /// Evaluates at z = (t, q, v) and hands the output values, in order, to `out`.
    /// A variable beyond the slices reads NaN.
    #[inline]
    pub(super) fn eval(&self, t: f64, q: &[f64], v: &[f64], out: impl FnMut(usize, f64)) {
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
}
