//! The register tape: a straight-line program over f64 registers, checked by a verifier before
//! anything runs it, with a readable listing (`surfc bytecode`).
//!
//! Register layout: `r0 .. r{inputs}` hold the inputs (x, y, z for a surface; u, v for a
//! patch), then one register per constant (loaded once, when an evaluator is built), then the
//! working registers the instructions write. Invariants the verifier establishes: every
//! instruction writes a working register different from its operands, every operand names an
//! input, a constant or a register written by an earlier instruction, every output register is
//! written, and every `dist` names an existing child.

use std::fmt;

/// A register of the tape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Reg(pub u16);

impl Reg {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl fmt::Display for Reg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "r{}", self.0)
    }
}

/// An external child surface of a tape (the target of a `dist` instruction).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ChildId(pub u16);

impl ChildId {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Opcodes. Unary ops read `a`; binary ops read `a` and `b`; `Dist` reads no register: its
/// `a` field is a [`ChildId`], and it evaluates that child at the input point (x, y, z).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Op {
    Neg,
    /// a·a (x^2, and every squaring of an integer power).
    Square,
    /// 1/a (negative integer powers).
    Recip,
    Sqrt,
    Abs,
    Exp,
    Ln,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Add,
    Sub,
    Mul,
    Div,
    /// a^b for a non-integer or non-constant exponent b (`powf`).
    Pow,
    /// atan2(a, b), the angle of the point (b, a).
    Atan2,
    Min,
    Max,
    Hypot,
    /// The value (and gradient) of child surface `a` at the input point.
    Dist,
}

/// How many registers an opcode reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Arity {
    /// `Dist`: reads the input point, not a register.
    Child,
    Unary,
    Binary,
}

impl Op {
    pub const ALL: [Op; 26] = [
        Op::Neg,
        Op::Square,
        Op::Recip,
        Op::Sqrt,
        Op::Abs,
        Op::Exp,
        Op::Ln,
        Op::Sin,
        Op::Cos,
        Op::Tan,
        Op::Asin,
        Op::Acos,
        Op::Atan,
        Op::Sinh,
        Op::Cosh,
        Op::Tanh,
        Op::Add,
        Op::Sub,
        Op::Mul,
        Op::Div,
        Op::Pow,
        Op::Atan2,
        Op::Min,
        Op::Max,
        Op::Hypot,
        Op::Dist,
    ];

    pub fn arity(self) -> Arity {
        match self {
            Op::Dist => Arity::Child,
            Op::Add
            | Op::Sub
            | Op::Mul
            | Op::Div
            | Op::Pow
            | Op::Atan2
            | Op::Min
            | Op::Max
            | Op::Hypot => Arity::Binary,
            _ => Arity::Unary,
        }
    }

    /// Whether a op b == b op a for every a, b (NaN included: `min`/`max` propagate NaN).
    pub fn is_commutative(self) -> bool {
        matches!(self, Op::Add | Op::Mul | Op::Min | Op::Max | Op::Hypot)
    }

    /// The mnemonic of the listing.
    pub fn name(self) -> &'static str {
        match self {
            Op::Neg => "neg",
            Op::Square => "square",
            Op::Recip => "recip",
            Op::Sqrt => "sqrt",
            Op::Abs => "abs",
            Op::Exp => "exp",
            Op::Ln => "ln",
            Op::Sin => "sin",
            Op::Cos => "cos",
            Op::Tan => "tan",
            Op::Asin => "asin",
            Op::Acos => "acos",
            Op::Atan => "atan",
            Op::Sinh => "sinh",
            Op::Cosh => "cosh",
            Op::Tanh => "tanh",
            Op::Add => "add",
            Op::Sub => "sub",
            Op::Mul => "mul",
            Op::Div => "div",
            Op::Pow => "pow",
            Op::Atan2 => "atan2",
            Op::Min => "min",
            Op::Max => "max",
            Op::Hypot => "hypot",
            Op::Dist => "dist",
        }
    }
}

/// One instruction: `out = op a, b`. Eight bytes, so a tape streams through the cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Instr {
    pub op: Op,
    pub out: Reg,
    /// First operand; for `Dist` the child index.
    pub a: Reg,
    /// Second operand of a binary op; `r0` (unread) otherwise.
    pub b: Reg,
}

impl Instr {
    /// The child a `Dist` instruction evaluates.
    pub fn child(self) -> ChildId {
        ChildId(self.a.0)
    }
}

/// Why a tape was rejected. Every variant is a compiler bug, never a user error: the verifier
/// exists so that such a bug stops here instead of computing garbage.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum VerifyError {
    #[error("the tape declares {declared} registers but needs at least {needed}")]
    RegisterCount { declared: usize, needed: usize },
    #[error("instruction {index} writes {out}, which is an input or constant register")]
    WritesFixedRegister { index: usize, out: Reg },
    #[error("instruction {index} names {reg}, beyond the {registers} registers of the tape")]
    RegisterOutOfRange {
        index: usize,
        reg: Reg,
        registers: usize,
    },
    #[error("instruction {index} reads {reg} before any instruction writes it")]
    ReadBeforeWrite { index: usize, reg: Reg },
    #[error("instruction {index} writes {out}, which it also reads")]
    OutputIsOperand { index: usize, out: Reg },
    #[error("instruction {index} ({op}) has an operand its arity does not allow")]
    Arity { index: usize, op: &'static str },
    #[error("instruction {index} evaluates child {child}, but the tape has {children} children")]
    NoSuchChild {
        index: usize,
        child: u16,
        children: usize,
    },
    #[error("output {output} is {reg}, which is never written")]
    OutputNotWritten { output: usize, reg: Reg },
    #[error("a tape needs at least one output")]
    NoOutput,
}

/// A verified tape. The only way to make one is [`Tape::new`], which runs the verifier, so an
/// evaluator may rely on the invariants of the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct Tape {
    input_names: Vec<String>,
    constants: Vec<f64>,
    instrs: Vec<Instr>,
    outputs: Vec<Reg>,
    registers: usize,
    children: usize,
}

impl Tape {
    /// Checks the tape and wraps it.
    pub fn new(
        input_names: Vec<String>,
        constants: Vec<f64>,
        instrs: Vec<Instr>,
        outputs: Vec<Reg>,
        registers: usize,
        children: usize,
    ) -> Result<Tape, VerifyError> {
        let tape = Tape {
            input_names,
            constants,
            instrs,
            outputs,
            registers,
            children,
        };
        tape.verify()?;
        Ok(tape)
    }

    fn verify(&self) -> Result<(), VerifyError> {
        let fixed = self.first_work_register();
        if self.registers < fixed || self.registers > usize::from(u16::MAX) + 1 {
            return Err(VerifyError::RegisterCount {
                declared: self.registers,
                needed: fixed,
            });
        }
        let mut written = vec![false; self.registers];
        written[..fixed].fill(true);
        for (index, ins) in self.instrs.iter().enumerate() {
            let in_range = |reg: Reg| {
                if reg.index() < self.registers {
                    Ok(())
                } else {
                    Err(VerifyError::RegisterOutOfRange {
                        index,
                        reg,
                        registers: self.registers,
                    })
                }
            };
            in_range(ins.out)?;
            if ins.out.index() < fixed {
                return Err(VerifyError::WritesFixedRegister {
                    index,
                    out: ins.out,
                });
            }
            let reads: &[Reg] = match ins.op.arity() {
                Arity::Child => {
                    if ins.child().index() >= self.children {
                        return Err(VerifyError::NoSuchChild {
                            index,
                            child: ins.a.0,
                            children: self.children,
                        });
                    }
                    if ins.b != Reg(0) {
                        return Err(VerifyError::Arity {
                            index,
                            op: ins.op.name(),
                        });
                    }
                    &[]
                }
                Arity::Unary => {
                    if ins.b != Reg(0) {
                        return Err(VerifyError::Arity {
                            index,
                            op: ins.op.name(),
                        });
                    }
                    &[ins.a][..]
                }
                Arity::Binary => &[ins.a, ins.b][..],
            };
            for &reg in reads {
                in_range(reg)?;
                if !written[reg.index()] {
                    return Err(VerifyError::ReadBeforeWrite { index, reg });
                }
                if reg == ins.out {
                    return Err(VerifyError::OutputIsOperand { index, out: reg });
                }
            }
            // Unread operands are r0; an instruction must not write them either, so that the
            // batch evaluator can borrow out, a and b apart.
            if ins.op.arity() != Arity::Child && (ins.out == ins.a || ins.out == ins.b) {
                return Err(VerifyError::OutputIsOperand {
                    index,
                    out: ins.out,
                });
            }
            written[ins.out.index()] = true;
        }
        if self.outputs.is_empty() {
            return Err(VerifyError::NoOutput);
        }
        for (output, &reg) in self.outputs.iter().enumerate() {
            if reg.index() >= self.registers || !written[reg.index()] {
                return Err(VerifyError::OutputNotWritten { output, reg });
            }
        }
        Ok(())
    }

    /// Number of inputs (3 for a surface, 2 for a patch); they are `r0 ..`.
    pub fn inputs(&self) -> usize {
        self.input_names.len()
    }

    pub fn input_names(&self) -> &[String] {
        &self.input_names
    }

    /// The constants; constant i lives in register `inputs() + i`.
    pub fn constants(&self) -> &[f64] {
        &self.constants
    }

    pub fn instrs(&self) -> &[Instr] {
        &self.instrs
    }

    pub fn outputs(&self) -> &[Reg] {
        &self.outputs
    }

    /// Total number of registers (inputs, constants and working registers).
    pub fn registers(&self) -> usize {
        self.registers
    }

    /// Number of external child surfaces the `dist` instructions name.
    pub fn children(&self) -> usize {
        self.children
    }

    /// The first register an instruction may write.
    pub fn first_work_register(&self) -> usize {
        self.inputs() + self.constants.len()
    }

    /// The listing: a header naming the input and constant registers, then one numbered
    /// instruction a line (`  3  r7 = mul r5, r6`), then the outputs.
    pub fn listing(&self) -> String {
        self.to_string()
    }
}

impl fmt::Display for Tape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "; {} inputs, {} constants, {} registers, {} instructions, {} children",
            self.inputs(),
            self.constants.len(),
            self.registers,
            self.instrs.len(),
            self.children
        )?;
        for (i, name) in self.input_names.iter().enumerate() {
            writeln!(f, "; r{i} = {name}")?;
        }
        for (i, c) in self.constants.iter().enumerate() {
            writeln!(f, "; r{} = {c:?}", self.inputs() + i)?;
        }
        let width = self.instrs.len().saturating_sub(1).to_string().len().max(3);
        for (i, ins) in self.instrs.iter().enumerate() {
            write!(f, "{i:>width$}  {} = {}", ins.out, ins.op.name())?;
            match ins.op.arity() {
                Arity::Child => writeln!(f, " #{}", ins.a.0)?,
                Arity::Unary => writeln!(f, " {}", ins.a)?,
                Arity::Binary => writeln!(f, " {}, {}", ins.a, ins.b)?,
            }
        }
        let outs: Vec<String> = self.outputs.iter().map(|r| r.to_string()).collect();
        writeln!(f, "; output {}", outs.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        vec!["x".into(), "y".into(), "z".into()]
    }

    #[test]
    fn instruction_is_eight_bytes() {
        assert_eq!(std::mem::size_of::<Instr>(), 8);
    }

    #[test]
    fn verifier_accepts_a_good_tape() {
        let ins = vec![
            Instr {
                op: Op::Square,
                out: Reg(4),
                a: Reg(0),
                b: Reg(0),
            },
            Instr {
                op: Op::Sub,
                out: Reg(5),
                a: Reg(4),
                b: Reg(3),
            },
        ];
        let tape = Tape::new(names(), vec![4.0], ins, vec![Reg(5)], 6, 0);
        assert!(tape.is_ok(), "{tape:?}");
    }

    #[test]
    fn verifier_rejects_each_broken_invariant() {
        let i = |op, out, a, b| Instr {
            op,
            out: Reg(out),
            a: Reg(a),
            b: Reg(b),
        };
        let check = |ins: Vec<Instr>, outputs: Vec<u16>, regs: usize, children: usize| {
            Tape::new(
                names(),
                vec![1.0],
                ins,
                outputs.into_iter().map(Reg).collect(),
                regs,
                children,
            )
            .unwrap_err()
        };
        assert_eq!(
            check(vec![i(Op::Add, 4, 5, 0)], vec![4], 6, 0),
            VerifyError::ReadBeforeWrite {
                index: 0,
                reg: Reg(5)
            }
        );
        assert_eq!(
            check(vec![i(Op::Neg, 2, 0, 0)], vec![2], 6, 0),
            VerifyError::WritesFixedRegister {
                index: 0,
                out: Reg(2)
            }
        );
        assert_eq!(
            check(vec![i(Op::Add, 4, 9, 0)], vec![4], 6, 0),
            VerifyError::RegisterOutOfRange {
                index: 0,
                reg: Reg(9),
                registers: 6
            }
        );
        assert_eq!(
            check(
                vec![i(Op::Neg, 4, 0, 0), i(Op::Add, 4, 4, 0)],
                vec![4],
                6,
                0
            ),
            VerifyError::OutputIsOperand {
                index: 1,
                out: Reg(4)
            }
        );
        assert_eq!(
            check(vec![i(Op::Neg, 4, 0, 1)], vec![4], 6, 0),
            VerifyError::Arity {
                index: 0,
                op: "neg"
            }
        );
        assert_eq!(
            check(vec![i(Op::Dist, 4, 1, 0)], vec![4], 6, 1),
            VerifyError::NoSuchChild {
                index: 0,
                child: 1,
                children: 1
            }
        );
        assert_eq!(
            check(vec![i(Op::Neg, 4, 0, 0)], vec![5], 6, 0),
            VerifyError::OutputNotWritten {
                output: 0,
                reg: Reg(5)
            }
        );
        assert_eq!(check(vec![], vec![], 6, 0), VerifyError::NoOutput);
        assert_eq!(
            check(vec![], vec![0], 2, 0),
            VerifyError::RegisterCount {
                declared: 2,
                needed: 4
            }
        );
    }
}

/// Why a VM could not be built on a tape (`eval::Vm::new`).
#[derive(Debug, thiserror::Error)]
pub enum VmError {
    #[error("the tape evaluates {expected} child surfaces, but {found} were given")]
    ChildCount { expected: usize, found: usize },
}
