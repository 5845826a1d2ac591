//! Graph → tape: dead-code removal (only nodes the outputs reach are kept), then register
//! allocation by a linear scan over the SSA in id order. Inputs and constants get fixed
//! registers; each instruction gets the lowest free working register, and an operand's register
//! is freed after its last use (after the instruction's output is allocated, so an instruction
//! never overwrites its own operand: the batch evaluator relies on that).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::ir::{DistId, Graph, Node, NodeId};
use super::tape::{Instr, Op, Reg, Tape, VerifyError};

/// Why allocation failed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum AllocError {
    #[error("the expression needs more than {max} registers")]
    TooManyRegisters { max: usize },
    #[error("the expression needs more than {max} distinct dist() children")]
    TooManyChildren { max: usize },
    #[error("internal error: the compiled tape failed verification: {0}")]
    Verify(#[from] VerifyError),
}

/// The tape of `outputs` over `graph`, and the `dist` targets its children stand for, in
/// child order.
pub fn allocate(
    graph: &Graph,
    outputs: &[NodeId],
    input_names: Vec<String>,
) -> Result<(Tape, Vec<DistId>), AllocError> {
    let nodes = graph.nodes();
    let mut live = vec![false; nodes.len()];
    for &o in outputs {
        live[o.index()] = true;
    }
    // Ids are a topological order: one backward sweep marks everything reachable.
    for i in (0..nodes.len()).rev() {
        if !live[i] {
            continue;
        }
        match nodes[i] {
            Node::Unary(_, a) => live[a.index()] = true,
            Node::Binary(_, a, b) => {
                live[a.index()] = true;
                live[b.index()] = true;
            }
            _ => {}
        }
    }

    let max_regs = usize::from(u16::MAX) + 1;
    let inputs = input_names.len();
    let mut reg: Vec<Option<Reg>> = vec![None; nodes.len()];
    let mut constants = Vec::new();
    for (i, node) in nodes.iter().enumerate() {
        match *node {
            Node::Input(k) => reg[i] = Some(Reg(u16::from(k))),
            Node::Const(bits) if live[i] => {
                let r = inputs + constants.len();
                if r >= max_regs {
                    return Err(AllocError::TooManyRegisters { max: max_regs });
                }
                reg[i] = Some(Reg(r as u16));
                constants.push(f64::from_bits(bits));
            }
            _ => {}
        }
    }
    let first_work = inputs + constants.len();

    // Last use of every node, as an index into the list of live computed nodes.
    let computed: Vec<usize> = (0..nodes.len())
        .filter(|&i| {
            live[i] && matches!(nodes[i], Node::Unary(..) | Node::Binary(..) | Node::Dist(_))
        })
        .collect();
    let mut last_use = vec![0usize; nodes.len()];
    for (t, &i) in computed.iter().enumerate() {
        match nodes[i] {
            Node::Unary(_, a) => last_use[a.index()] = t,
            Node::Binary(_, a, b) => {
                last_use[a.index()] = t;
                last_use[b.index()] = t;
            }
            _ => {}
        }
    }
    for &o in outputs {
        last_use[o.index()] = usize::MAX;
    }

    let mut free: BinaryHeap<Reverse<usize>> = BinaryHeap::new();
    let mut next = first_work;
    let mut instrs = Vec::with_capacity(computed.len());
    let mut children: Vec<DistId> = Vec::new();
    let operand = |reg: &[Option<Reg>], n: NodeId| reg[n.index()].unwrap_or(Reg(0));
    for (t, &i) in computed.iter().enumerate() {
        let (op, reads, child) = match nodes[i] {
            Node::Unary(op, a) => (op, [Some(a), None], None),
            Node::Binary(op, a, b) => (op, [Some(a), Some(b)], None),
            Node::Dist(d) => {
                let k = match children.iter().position(|&c| c == d) {
                    Some(k) => k,
                    None => {
                        children.push(d);
                        children.len() - 1
                    }
                };
                if k > usize::from(u16::MAX) {
                    return Err(AllocError::TooManyChildren {
                        max: usize::from(u16::MAX) + 1,
                    });
                }
                (Op::Dist, [None, None], Some(Reg(k as u16)))
            }
            Node::Input(_) | Node::Const(_) => continue,
        };
        let out = match free.pop() {
            Some(Reverse(r)) => r,
            None => {
                next += 1;
                next - 1
            }
        };
        if out >= max_regs {
            return Err(AllocError::TooManyRegisters { max: max_regs });
        }
        let out = Reg(out as u16);
        reg[i] = Some(out);
        let a = child.unwrap_or_else(|| reads[0].map_or(Reg(0), |n| operand(&reg, n)));
        let b = reads[1].map_or(Reg(0), |n| operand(&reg, n));
        instrs.push(Instr { op, out, a, b });
        let mut freed: Option<Reg> = None;
        for n in reads.into_iter().flatten() {
            let r = operand(&reg, n);
            if last_use[n.index()] == t && r.index() >= first_work && freed != Some(r) {
                free.push(Reverse(r.index()));
                freed = Some(r);
            }
        }
    }
    let outs = outputs.iter().map(|&o| operand(&reg, o)).collect();
    let tape = Tape::new(input_names, constants, instrs, outs, next, children.len())?;
    Ok((tape, children))
}
