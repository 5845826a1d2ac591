//! Native code for a surface tape: the tape is translated, once, into Cranelift functions
//! that run the whole tape for two points at a time with every register held in a two-lane
//! vector (f64x2), so a point's intermediates stay in CPU registers instead of streaming
//! through the VM's registers. One function computes values, another values and gradients;
//! each serves batches, and single points as a pair of copies.
//!
//! The translation is a partial evaluation of the batch VM's arithmetic: each register is
//! either a constant known at translation time or a vector, and each partial derivative
//! either a constant (0 where the VM's masks say structurally zero) or a vector. Operations
//! on constants are folded with `ops::value`; the others are emitted with exactly the VM's
//! formulas, so the results are the batch VM's bit for bit in the values and up to the sign
//! of zero in the partials (the dual-number rules of `ops` are the reference for both).
//! Opcodes without a vector form here (the elementary functions, `pow`, `atan2`) call back
//! into `ops` for each pair of points. `hypot` has one: √(a·a + b·b) where a·a + b·b is a
//! normal number (`values::hypot`), a lane flag where it is not, and the pair runs again
//! with the call back where a flag is set (see `Emitter::pair`): a CAD part's cylinders made
//! sixteen call backs a point. So do the gradients of `min max abs sqrt recip`, whose NaN
//! cases send the pair to the second copy as the unguarded terms' do. Tapes with `dist` children, or without three inputs, stay on
//! the VM, as does any host Cranelift cannot compile for.
//!
//! A thread compiles a tape once while some VM holds its code (`NativeTape::shared`): the
//! fresh oracles of one surface forked for each march (the slabs, the smooth pieces of a
//! creased surface, the survey, the report) would otherwise each compile the same tape again.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::{Rc, Weak};

use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::types::{F64X2, I8, I8X16, I32, I64X2};
use cranelift_codegen::ir::{
    AbiParam, ConstantData, Endianness, Function, InstBuilder, MemFlagsData, SigRef, Signature,
    StackSlot, StackSlotData, StackSlotKind, Value,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module, ModuleError};
use glam::DVec3;

use super::ops::{self, Grad};
use crate::compile::tape::{Arity, Instr, Op, Reg, Tape};
use crate::values::ValueGrad;

/// Why a tape has no native code (the VM evaluates it instead).
#[derive(Debug, thiserror::Error)]
pub enum NativeError {
    #[error("native code is for surface tapes with three inputs and no `dist` children")]
    UnsupportedTape,
    #[error("Cranelift does not support this machine: {0}")]
    UnsupportedHost(String),
    #[error("Cranelift could not compile the tape: {0}")]
    Codegen(String),
}

impl From<ModuleError> for NativeError {
    fn from(e: ModuleError) -> Self {
        NativeError::Codegen(e.to_string())
    }
}

/// The largest tape Cranelift optimises (`opt_level = speed`) and whose gradient function gets
/// an unguarded fast copy (see `Emitter::pair`); larger ones are compiled once, without the
/// e-graph pass, whose time grows faster than the tape. Measured: 1 000
/// instructions 0.06 s, 2 000 0.19 s, 12 000 11–30 s with it, 0.5–0.8 s without; without it
/// the gallery's tapes run up to ~25% slower for values, alike for gradients.
const OPTIMISE_LIMIT: usize = 1024;

/// Points a vector: f64x2.
const WIDTH: usize = 2;

/// Lanes picked by a shuffle of two vectors: [first's, second's].
const LOW_LOW: [u8; 2] = [0, 0];
const LOW_HIGH: [u8; 2] = [0, 1];
const HIGH_LOW: [u8; 2] = [1, 0];
const HIGH_HIGH: [u8; 2] = [1, 1];

/// `fn(points, out, pairs)`: `pairs` pairs of points in, one result a point out.
type BatchFn<T> = unsafe extern "C" fn(*const DVec3, *mut T, usize);

/// A tape compiled to native code: values, and values with gradients.
pub struct NativeTape {
    /// Owns the executable memory of both functions; freed on drop.
    module: Option<JITModule>,
    values: BatchFn<f64>,
    value_grads: BatchFn<ValueGrad>,
}

impl std::fmt::Debug for NativeTape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NativeTape").finish_non_exhaustive()
    }
}

impl Drop for NativeTape {
    fn drop(&mut self) {
        if let Some(module) = self.module.take() {
            // SAFETY: the only pointers into the module's memory are `values` and
            // `value_grads`, which die with `self`.
            unsafe { module.free_memory() };
        }
    }
}

// The generated code stores a `ValueGrad` as four f64s: value, ∂x, ∂y, ∂z.
const _: () = {
    assert!(std::mem::size_of::<ValueGrad>() == 32);
    assert!(std::mem::offset_of!(ValueGrad, value) == 0);
    assert!(std::mem::offset_of!(ValueGrad, gradient) == 8);
    assert!(std::mem::size_of::<DVec3>() == 24);
};

/// What the code compiled from a tape depends on: its shape, instructions and outputs, and
/// its constants by their bits (the input names do not matter).
#[derive(PartialEq, Eq, Hash)]
struct TapeKey {
    inputs: usize,
    registers: usize,
    children: usize,
    constants: Vec<u64>,
    instrs: Vec<Instr>,
    outputs: Vec<Reg>,
}

impl TapeKey {
    fn of(tape: &Tape) -> TapeKey {
        TapeKey {
            inputs: tape.inputs(),
            registers: tape.registers(),
            children: tape.children(),
            constants: tape.constants().iter().map(|c| c.to_bits()).collect(),
            instrs: tape.instrs().to_vec(),
            outputs: tape.outputs().to_vec(),
        }
    }
}

thread_local! {
    /// The code this thread compiled, by tape, while a VM still holds it.
    static COMPILED: RefCell<HashMap<TapeKey, Weak<NativeTape>>> = RefCell::new(HashMap::new());
}

impl NativeTape {
    /// The code of `tape`: the copy this thread compiled of the same tape while a VM still
    /// holds it (the same code, so the same bits), else compiled now (about a millisecond
    /// for a small tape).
    pub fn shared(tape: &Tape) -> Result<Rc<NativeTape>, NativeError> {
        let key = TapeKey::of(tape);
        if let Some(code) = COMPILED.with_borrow(|m| m.get(&key).and_then(Weak::upgrade)) {
            return Ok(code);
        }
        let code = Rc::new(NativeTape::new(tape)?);
        COMPILED.with_borrow_mut(|m| {
            m.retain(|_, held| held.strong_count() > 0);
            m.insert(key, Rc::downgrade(&code));
        });
        Ok(code)
    }

    /// Compiles `tape` for this machine.
    pub fn new(tape: &Tape) -> Result<NativeTape, NativeError> {
        if tape.inputs() != 3 || tape.children() != 0 || tape.outputs().is_empty() {
            return Err(NativeError::UnsupportedTape);
        }
        let mut flags = settings::builder();
        let mut set = |name: &str, value: &str| {
            flags
                .set(name, value)
                .map_err(|e| NativeError::Codegen(e.to_string()))
        };
        let optimise = tape.instrs().len() <= OPTIMISE_LIMIT;
        set("opt_level", if optimise { "speed" } else { "none" })?;
        set("use_colocated_libcalls", "false")?;
        set("is_pic", "false")?;
        let isa = cranelift_native::builder()
            .map_err(|e| NativeError::UnsupportedHost(e.to_string()))?
            .finish(settings::Flags::new(flags))
            .map_err(|e| NativeError::Codegen(e.to_string()))?;
        let mut module = JITModule::new(JITBuilder::with_isa(
            isa,
            cranelift_module::default_libcall_names(),
        ));
        let built = (|| {
            let values = define(&mut module, tape, false)?;
            let grads = define(&mut module, tape, true)?;
            module.finalize_definitions()?;
            Ok::<_, NativeError>((values, grads))
        })();
        let (values, grads) = match built {
            Ok(ids) => ids,
            Err(e) => {
                // SAFETY: nothing points into the module's memory yet.
                unsafe { module.free_memory() };
                return Err(e);
            }
        };
        // SAFETY: both functions were defined with the signature `BatchFn` describes
        // (pointer, pointer, pointer-sized integer; the host's C calling convention).
        let (values, value_grads) = unsafe {
            (
                std::mem::transmute::<*const u8, BatchFn<f64>>(
                    module.get_finalized_function(values),
                ),
                std::mem::transmute::<*const u8, BatchFn<ValueGrad>>(
                    module.get_finalized_function(grads),
                ),
            )
        };
        Ok(NativeTape {
            module: Some(module),
            values,
            value_grads,
        })
    }

    /// f at each point: `out[i] = f(points[i])` for i below the shorter length.
    pub fn values(&self, points: &[DVec3], out: &mut [f64]) {
        run(self.values, points, out);
    }

    /// f and ∇f at each point, for i below the shorter length.
    pub fn value_grads(&self, points: &[DVec3], out: &mut [ValueGrad]) {
        run(self.value_grads, points, out);
    }

    /// f at one point.
    pub fn value_at(&self, p: DVec3) -> f64 {
        at_point(self.values, p, 0.0)
    }

    /// f and ∇f at one point.
    pub fn value_grad_at(&self, p: DVec3) -> ValueGrad {
        let unset = ValueGrad {
            value: 0.0,
            gradient: DVec3::ZERO,
        };
        at_point(self.value_grads, p, unset)
    }
}

/// Runs `f` over the whole pairs of points, then over the odd last point.
fn run<T: Copy>(f: BatchFn<T>, points: &[DVec3], out: &mut [T]) {
    let n = points.len().min(out.len());
    let pairs = n / WIDTH;
    // SAFETY: `f` reads 2·pairs points and writes 2·pairs results, all within the slices.
    unsafe { f(points.as_ptr(), out.as_mut_ptr(), pairs) };
    if n % WIDTH == 1 {
        out[n - 1] = at_point(f, points[n - 1], out[n - 1]);
    }
}

/// `f` at one point, run as a pair of copies (`unset` fills the result slots first).
fn at_point<T: Copy>(f: BatchFn<T>, p: DVec3, unset: T) -> T {
    let pad = [p; WIDTH];
    let mut out = [unset; WIDTH];
    // SAFETY: one pair in, one pair out, both local arrays.
    unsafe { f(pad.as_ptr(), out.as_mut_ptr(), 1) };
    out[0]
}

/// Defines the batch function of `tape`: values only, or values and gradients.
fn define(module: &mut JITModule, tape: &Tape, gradients: bool) -> Result<FuncId, NativeError> {
    let pointer = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    sig.params.extend([
        AbiParam::new(pointer),
        AbiParam::new(pointer),
        AbiParam::new(pointer),
    ]);
    let name = if gradients { "value_grads" } else { "values" };
    let id = module.declare_function(name, Linkage::Local, &sig)?;
    let mut ctx = module.make_context();
    ctx.func = Function::with_name_signature(Default::default(), sig.clone());
    let mut builder_ctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut builder_ctx);
        let entry = b.create_block();
        let header = b.create_block();
        let body = b.create_block();
        let exit = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        let params = b.block_params(entry).to_vec();
        let (points, out, pairs) = (params[0], params[1], params[2]);
        let i = b.declare_var(pointer);
        let zero = b.ins().iconst(pointer, 0);
        b.def_var(i, zero);
        b.ins().jump(header, &[]);

        b.switch_to_block(header);
        let at = b.use_var(i);
        let more = b.ins().icmp(IntCC::UnsignedLessThan, at, pairs);
        b.ins().brif(more, body, &[], exit, &[]);

        b.switch_to_block(body);
        let mut e = Emitter::new(&mut b, pointer, tape, gradients);
        e.pair(points, out, at);
        let next = b.ins().iadd_imm_u(at, 1);
        b.def_var(i, next);
        b.ins().jump(header, &[]);

        b.switch_to_block(exit);
        b.ins().return_(&[]);
        b.seal_all_blocks();
        b.finalize(module.target_config());
    }
    module.define_function(id, &mut ctx)?;
    module.clear_context(&mut ctx);
    Ok(id)
}

/// A register's value, or a partial, for both lanes: known at translation time, or computed.
#[derive(Clone, Copy, Debug)]
enum Lanes {
    Const(f64),
    Vector(Value),
}

use Lanes::{Const, Vector};

/// Structurally zero: the VM's masks leave such a partial out.
const ZERO: Lanes = Const(0.0);

impl Lanes {
    fn is_zero(self) -> bool {
        matches!(self, Const(c) if c == 0.0)
    }
}

/// A register: value and the partials by x, y, z.
#[derive(Clone, Copy, Debug)]
struct Dual {
    v: Lanes,
    d: [Lanes; 3],
}

/// Emits one pair of points' evaluation into the current block.
struct Emitter<'a, 'b> {
    b: &'a mut FunctionBuilder<'b>,
    pointer: cranelift_codegen::ir::Type,
    tape: &'a Tape,
    gradients: bool,
    /// Splatted constants, by bit pattern (emitted once in the block).
    splats: HashMap<u64, Value>,
    /// The scratch memory and the signature of the calls back into `ops`, made at the first.
    scratch: Option<(StackSlot, SigRef)>,
    /// Whether `term` keeps `ops::term`'s guard (see `pair`).
    guards: bool,
    /// Whether this is a pair's fast copy (see `pair`): `hypot`, and the gradients of `min max
    /// abs sqrt recip`, inline instead of called back.
    fast: bool,
    /// The lanes where every inlined `hypot` had a² + b² normal (all ones), once one is.
    hypot_in_range: Option<Value>,
}

/// Scratch layout of a call back into `ops`: operand a, operand b, the result; each four
/// components (value, ∂x, ∂y, ∂z) of two lanes.
const SCRATCH_DUALS: usize = 3;
const DUAL_BYTES: i32 = 4 * 16;

impl<'a, 'b> Emitter<'a, 'b> {
    fn new(
        b: &'a mut FunctionBuilder<'b>,
        pointer: cranelift_codegen::ir::Type,
        tape: &'a Tape,
        gradients: bool,
    ) -> Self {
        Emitter {
            b,
            pointer,
            tape,
            gradients,
            splats: HashMap::new(),
            scratch: None,
            guards: true,
            fast: false,
            hypot_in_range: None,
        }
    }

    /// Loads pair `at` of `points`, runs the tape, stores the pair's results into `out`.
    /// Leaves the builder in a block that falls through to the next pair.
    ///
    /// With gradients the tape runs first without `ops::term`'s guards (k·d where d = 0 and k
    /// is ±∞ or NaN gives NaN where the term is 0). Such a NaN always reaches the output:
    /// every rule combines partials only through terms and sums, and a NaN d keeps k·d NaN.
    /// So where no output partial is NaN, the guards would have changed nothing but the sign
    /// of zeros, and the results are stored; otherwise the pair runs again with the guards.
    ///
    /// That first copy (and, for values, a first copy where the tape has `hypot`) also
    /// computes `hypot` inline, in `values::hypot`'s first form, and notes the lanes where
    /// a² + b² was not normal (there `values::hypot` takes the host's scaled form): where one
    /// is, the pair runs again with `hypot` called back. A large tape has only the second copy.
    fn pair(&mut self, points: Value, out: Value, at: Value) {
        // Cannot trap (the caller checked the lengths); not `aligned`: a vector store into
        // `out` is only as aligned as an f64.
        let flags = MemFlagsData::new().with_notrap();
        let base = self.b.ins().imul_imm_u(at, (WIDTH * 24) as i64);
        let base = self.b.ins().iadd(points, base);
        // The pair is x0 y0 z0 x1 y1 z1: three vector loads [x0 y0] [z0 x1] [y1 z1], then one
        // shuffle an input.
        let [v0, v1, v2] = [0, 16, 32].map(|offset| self.b.ins().load(F64X2, flags, base, offset));
        let inputs = [
            self.shuffle(v0, v1, LOW_HIGH),
            self.shuffle(v0, v2, HIGH_LOW),
            self.shuffle(v1, v2, LOW_HIGH),
        ];
        let large = self.tape.instrs().len() > OPTIMISE_LIMIT;
        if !self.gradients {
            let base = self.b.ins().imul_imm_u(at, (WIDTH * 8) as i64);
            let base = self.b.ins().iadd(out, base);
            let has_hypot = self.tape.instrs().iter().any(|i| i.op == Op::Hypot);
            if large || !has_hypot {
                let result = self.run_tape(inputs, false, false);
                let v = self.vector(result.v);
                self.b.ins().store(flags, v, base, 0);
                return;
            }
            let fast = self.run_tape(inputs, false, true);
            let fast = self.vector(fast.v);
            let again = self.hypot_out_of_range();
            self.keep_or_redo(
                again,
                |e| {
                    e.b.ins().store(flags, fast, base, 0);
                },
                |e| {
                    let slow = e.run_tape(inputs, false, false);
                    let slow = e.vector(slow.v);
                    e.b.ins().store(flags, slow, base, 0);
                },
            );
            return;
        }
        let base = self.b.ins().imul_imm_u(at, (WIDTH * 32) as i64);
        let base = self.b.ins().iadd(out, base);
        if large {
            // A large tape: one guarded copy, for half the compile time.
            let guarded = self.run_tape(inputs, true, false);
            let guarded = self.components(guarded);
            self.store_grads(guarded, base, flags);
            return;
        }
        let fast = self.run_tape(inputs, false, true);
        let fast = self.components(fast);
        let nan = self.mask(FloatCC::Unordered, fast[1], fast[2]);
        let nan_z = self.mask(FloatCC::Unordered, fast[3], fast[3]);
        let nan = self.b.ins().bor(nan, nan_z);
        let nan = self.b.ins().bitcast(I64X2, MemFlagsData::new(), nan);
        let any_nan = self.b.ins().vany_true(nan);
        let hypot_again = self.hypot_out_of_range();
        let again = self.b.ins().bor(any_nan, hypot_again);
        self.keep_or_redo(
            again,
            |e| e.store_grads(fast, base, flags),
            |e| {
                let slow = e.run_tape(inputs, true, false);
                let slow = e.components(slow);
                e.store_grads(slow, base, flags);
            },
        );
    }

    /// Where `again` (an i8) is 0, `keep` (the fast copy's stores); else `redo` (the pair
    /// run again). Leaves the builder in the block after both.
    fn keep_or_redo(
        &mut self,
        again: Value,
        keep: impl FnOnce(&mut Self),
        redo: impl FnOnce(&mut Self),
    ) {
        let (slow, fast, done) = (
            self.b.create_block(),
            self.b.create_block(),
            self.b.create_block(),
        );
        self.b.ins().brif(again, slow, &[], fast, &[]);
        self.b.switch_to_block(fast);
        keep(self);
        self.b.ins().jump(done, &[]);
        self.b.switch_to_block(slow);
        redo(self);
        self.b.ins().jump(done, &[]);
        self.b.switch_to_block(done);
    }

    /// Whether an inlined `hypot` of the copy just run had a lane out of its range (an i8,
    /// 0 where none had or none was inlined).
    fn hypot_out_of_range(&mut self) -> Value {
        match self.hypot_in_range.take() {
            Some(in_range) => {
                let in_range = self.b.ins().bitcast(I64X2, MemFlagsData::new(), in_range);
                let all = self.b.ins().vall_true(in_range);
                self.b.ins().bxor_imm_u(all, 1)
            }
            None => self.b.ins().iconst(I8, 0),
        }
    }

    /// The tape at the inputs' lanes: the output register (values only, unless computing
    /// gradients; `guards`: whether `ops::term` keeps its zero guard; `fast`:
    /// whether `hypot` is inlined, its lanes' range noted for `hypot_out_of_range`).
    fn run_tape(&mut self, inputs: [Value; 3], guards: bool, fast: bool) -> Dual {
        self.guards = guards;
        self.fast = fast;
        self.hypot_in_range = None;
        let mut regs: Vec<Dual> = vec![Dual::value(ZERO); self.tape.registers()];
        for (axis, input) in inputs.into_iter().enumerate() {
            let mut d = [ZERO; 3];
            if self.gradients {
                d[axis] = Const(1.0);
            }
            regs[axis] = Dual {
                v: Vector(input),
                d,
            };
        }
        for (k, &c) in self.tape.constants().iter().enumerate() {
            regs[self.tape.inputs() + k] = Dual::value(Const(c));
        }
        for ins in self.tape.instrs() {
            let a = regs[ins.a.index()];
            let b = match ins.op.arity() {
                Arity::Binary => regs[ins.b.index()],
                _ => Dual::value(ZERO),
            };
            regs[ins.out.index()] = if self.gradients {
                self.grad(ins.op, a, b)
            } else {
                Dual::value(self.value(ins.op, a.v, b.v))
            };
        }
        regs[self.tape.outputs()[0].index()]
    }

    /// Value and partials as vectors.
    fn components(&mut self, r: Dual) -> [Value; 4] {
        [r.v, r.d[0], r.d[1], r.d[2]].map(|x| self.vector(x))
    }

    /// Stores a pair's values and gradients: each point's ValueGrad is [v dx] [dy dz], the
    /// low lanes first, then the high lanes.
    fn store_grads(&mut self, [v, dx, dy, dz]: [Value; 4], base: Value, flags: MemFlagsData) {
        let stores = [
            (v, dx, LOW_LOW, 0),
            (dy, dz, LOW_LOW, 16),
            (v, dx, HIGH_HIGH, 32),
            (dy, dz, HIGH_HIGH, 48),
        ];
        for (a, b, lanes, offset) in stores {
            let x = self.shuffle(a, b, lanes);
            self.b.ins().store(flags, x, base, offset);
        }
    }

    /// [a's lane, b's lane], each lane 0 or 1 as `lanes` says.
    fn shuffle(&mut self, a: Value, b: Value, lanes: [u8; 2]) -> Value {
        // Cranelift shuffles bytes: 0–15 name a's, 16–31 b's.
        let mut bytes = [0u8; 16];
        for (i, byte) in bytes.iter_mut().enumerate() {
            let (from_b, lane) = (i / 8, lanes[i / 8]);
            *byte = from_b as u8 * 16 + lane * 8 + (i % 8) as u8;
        }
        let mask = self
            .b
            .func
            .dfg
            .immediates
            .push(ConstantData::from(&bytes[..]));
        let lanes = MemFlagsData::new().with_endianness(Endianness::Little);
        let (a, b) = (
            self.b.ins().bitcast(I8X16, lanes, a),
            self.b.ins().bitcast(I8X16, lanes, b),
        );
        let x = self.b.ins().shuffle(a, b, mask);
        self.b.ins().bitcast(F64X2, lanes, x)
    }

    /// The lanes as a vector.
    fn vector(&mut self, x: Lanes) -> Value {
        match x {
            Vector(v) => v,
            Const(c) => *self.splats.entry(c.to_bits()).or_insert_with(|| {
                let s = self.b.ins().f64const(c);
                self.b.ins().splat(F64X2, s)
            }),
        }
    }

    /// `op a, b` on values: folded when both are known, inline for the arithmetic, through
    /// `ops::value` otherwise.
    fn value(&mut self, op: Op, a: Lanes, b: Lanes) -> Lanes {
        let unary = op.arity() == Arity::Unary;
        match (a, b) {
            (Const(x), _) if unary => return Const(ops::value(op, x, 0.0)),
            (Const(x), Const(y)) => return Const(ops::value(op, x, y)),
            _ => {}
        }
        let va = self.vector(a);
        let vb = if unary { va } else { self.vector(b) };
        Vector(match op {
            // Flipping the sign bit with a shared constant: one instruction, where `fneg`
            // builds its mask each time.
            Op::Neg => {
                let sign = self.vector(Const(-0.0));
                self.b.ins().bxor(va, sign)
            }
            Op::Square => self.b.ins().fmul(va, va),
            Op::Sqrt => self.b.ins().sqrt(va),
            Op::Hypot if self.fast => self.hypot(va, vb),
            Op::Abs => self.b.ins().fabs(va),
            Op::Add => self.b.ins().fadd(va, vb),
            Op::Sub => self.b.ins().fsub(va, vb),
            Op::Mul => self.b.ins().fmul(va, vb),
            Op::Div => self.b.ins().fdiv(va, vb),
            Op::Recip => {
                let one = self.vector(Const(1.0));
                self.b.ins().fdiv(one, va)
            }
            Op::Min | Op::Max => {
                // ops::min_value: NaN if either is; else b where b < a (b > a for max),
                // else a.
                let cc = if op == Op::Min {
                    FloatCC::LessThan
                } else {
                    FloatCC::GreaterThan
                };
                let pick_b = self.mask(cc, vb, va);
                let chosen = self.b.ins().bitselect(pick_b, vb, va);
                let nan = self.mask(FloatCC::Unordered, va, vb);
                let nan_value = self.vector(Const(f64::NAN));
                self.b.ins().bitselect(nan, nan_value, chosen)
            }
            _ => return self.call_back(op, Dual::value(a), Dual::value(b), false).v,
        })
    }

    /// `values::hypot`'s first form, √(a·a + b·b), with the lanes where a·a + b·b is normal
    /// and finite added to `hypot_in_range` (elsewhere the pair runs again, see `pair`).
    fn hypot(&mut self, a: Value, b: Value) -> Value {
        let aa = self.b.ins().fmul(a, a);
        let bb = self.b.ins().fmul(b, b);
        let s = self.b.ins().fadd(aa, bb);
        let (smallest, infinity) = (
            self.vector(Const(f64::MIN_POSITIVE)),
            self.vector(Const(f64::INFINITY)),
        );
        let normal = self.mask(FloatCC::GreaterThanOrEqual, s, smallest);
        let finite = self.mask(FloatCC::LessThan, s, infinity);
        let mut in_range = self.b.ins().band(normal, finite);
        if let Some(before) = self.hypot_in_range {
            in_range = self.b.ins().band(before, in_range);
        }
        self.hypot_in_range = Some(in_range);
        self.b.ins().sqrt(s)
    }

    /// A lane mask (all ones where `x cc y`) typed as f64x2 for `bitselect` and `band`.
    fn mask(&mut self, cc: FloatCC, x: Value, y: Value) -> Value {
        let m = self.b.ins().fcmp(cc, x, y);
        self.b.ins().bitcast(F64X2, MemFlagsData::new(), m)
    }

    /// `ops::term`: k·d, where a zero d gives 0 whatever k is (also ∞ or NaN).
    fn term(&mut self, k: Lanes, d: Lanes) -> Lanes {
        if d.is_zero() {
            return ZERO;
        }
        // A non-zero constant d: k·d is the term. A finite constant k: k·d differs from the
        // term at most in the sign of a zero.
        if !self.guards || matches!(d, Const(_)) || matches!(k, Const(c) if c.is_finite()) {
            return self.value(Op::Mul, k, d);
        }
        let p = self.value(Op::Mul, k, d);
        let (p, d) = (self.vector(p), self.vector(d));
        let zero = self.vector(ZERO);
        let keep = self.mask(FloatCC::NotEqual, d, zero);
        Vector(self.b.ins().band(p, keep))
    }

    /// `op a, b` on dual numbers, with the batch VM's sparse rules for the arithmetic and
    /// `ops::grad` (dense) for the rest.
    fn grad(&mut self, op: Op, a: Dual, b: Dual) -> Dual {
        let binary = op.arity() == Arity::Binary;
        let sparse = matches!(
            op,
            Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Neg | Op::Square
        );
        let chained = self.fast
            && matches!(
                op,
                Op::Min | Op::Max | Op::Abs | Op::Sqrt | Op::Recip | Op::Hypot
            );
        if chained {
            return self.chained(op, a, b);
        }
        if !sparse {
            return self.call_back(op, a, b, true);
        }
        let v = self.value(op, a.v, b.v);
        let mut d = [ZERO; 3];
        for (k, out) in d.iter_mut().enumerate() {
            let (ad, bd) = (a.d[k], if binary { b.d[k] } else { ZERO });
            let (ha, hb) = (!ad.is_zero(), !bd.is_zero());
            *out = match (op, ha, hb) {
                (_, false, false) => ZERO,
                (Op::Add, true, true) => self.value(Op::Add, ad, bd),
                (Op::Add | Op::Sub, true, false) => ad,
                (Op::Add, false, true) => bd,
                (Op::Sub, true, true) => self.value(Op::Sub, ad, bd),
                (Op::Sub, false, true) => self.value(Op::Neg, bd, bd),
                (Op::Mul, _, _) => {
                    let ta = if ha { self.term(b.v, ad) } else { ZERO };
                    let tb = if hb { self.term(a.v, bd) } else { ZERO };
                    self.sum(ha, ta, hb, tb)
                }
                (Op::Div, _, _) => {
                    let r = self.value(Op::Div, Const(1.0), b.v);
                    let ta = if ha { self.term(r, ad) } else { ZERO };
                    let tb = if hb {
                        let nv = self.value(Op::Neg, v, v);
                        let k = self.value(Op::Mul, nv, r);
                        self.term(k, bd)
                    } else {
                        ZERO
                    };
                    self.sum(ha, ta, hb, tb)
                }
                (Op::Neg, _, _) => self.value(Op::Neg, ad, ad),
                (Op::Square, _, _) => {
                    let twice = self.value(Op::Mul, Const(2.0), a.v);
                    self.term(twice, ad)
                }
                _ => ZERO,
            };
        }
        Dual { v, d }
    }

    /// `op a, b` for the fast copy, as `ops::grad` computes it: the value, and the partials
    /// k·a′ + m·b′ with ops' coefficients k and m, selected lane by lane. Where a coefficient
    /// is NaN (an operand NaN) the output's partials are NaN and the pair runs again with the
    /// call back (see `pair`), as it does where an inlined `hypot` flags a lane; elsewhere the
    /// terms differ from ops' at most in the sign of a zero, as the sparse rules do.
    fn chained(&mut self, op: Op, a: Dual, b: Dual) -> Dual {
        let binary = op.arity() == Arity::Binary;
        let v = self.value(op, a.v, b.v);
        let has = |d: &[Lanes; 3]| d.iter().any(|x| !x.is_zero());
        if !(has(&a.d) || binary && has(&b.d)) {
            return Dual::value(v);
        }
        let [zero, one, nan] = [0.0, 1.0, f64::NAN].map(|c| self.vector(Const(c)));
        let va = self.vector(a.v);
        let (k, m) = match op {
            Op::Hypot => {
                // a/v, b/v (v > 0 where inlined: a² + b² is normal; elsewhere the lane's flag
                // runs the pair again).
                let inv = self.value(Op::Div, Const(1.0), v);
                let (k, m) = (self.value(Op::Mul, a.v, inv), self.value(Op::Mul, b.v, inv));
                (self.vector(k), self.vector(m))
            }
            Op::Sqrt => {
                // 0.5/v, and 0 where v = 0.
                let vv = self.vector(v);
                let half = self.value(Op::Div, Const(0.5), Vector(vv));
                let half = self.vector(half);
                let at_zero = self.mask(FloatCC::Equal, vv, zero);
                (self.b.ins().bitselect(at_zero, zero, half), zero)
            }
            Op::Recip => {
                // −v·v
                let nv = self.value(Op::Neg, v, v);
                let k = self.value(Op::Mul, nv, v);
                (self.vector(k), zero)
            }
            Op::Abs => {
                // The sign of a: 1, −1, 0 at ±0, NaN at NaN.
                let minus_one = self.vector(Const(-1.0));
                let positive = self.mask(FloatCC::GreaterThan, va, zero);
                let negative = self.mask(FloatCC::LessThan, va, zero);
                let at_zero = self.mask(FloatCC::Equal, va, zero);
                let s = self.b.ins().bitselect(at_zero, zero, nan);
                let s = self.b.ins().bitselect(negative, minus_one, s);
                (self.b.ins().bitselect(positive, one, s), zero)
            }
            _ => {
                // min, max: NaN if either is; the mean on a tie; else the chosen operand's.
                let vb = self.vector(b.v);
                let cc = if op == Op::Min {
                    FloatCC::LessThan
                } else {
                    FloatCC::GreaterThan
                };
                let half = self.vector(Const(0.5));
                let pick_b = self.mask(cc, vb, va);
                let tie = self.mask(FloatCC::Equal, va, vb);
                let either_nan = self.mask(FloatCC::Unordered, va, vb);
                let mut coefficient = |if_b: Value, if_a: Value| {
                    let c = self.b.ins().bitselect(pick_b, if_b, if_a);
                    let c = self.b.ins().bitselect(tie, half, c);
                    self.b.ins().bitselect(either_nan, nan, c)
                };
                (coefficient(zero, one), coefficient(one, zero))
            }
        };
        let mut d = [ZERO; 3];
        for (i, out) in d.iter_mut().enumerate() {
            let (ad, bd) = (a.d[i], if binary { b.d[i] } else { ZERO });
            let (ha, hb) = (!ad.is_zero(), !bd.is_zero());
            let ta = if ha { self.term(Vector(k), ad) } else { ZERO };
            let tb = if hb { self.term(Vector(m), bd) } else { ZERO };
            *out = self.sum(ha, ta, hb, tb);
        }
        Dual { v, d }
    }

    /// The VM's `x + y` of two terms, or the one term present.
    fn sum(&mut self, hx: bool, x: Lanes, hy: bool, y: Lanes) -> Lanes {
        match (hx, hy) {
            (true, true) => self.value(Op::Add, x, y),
            (true, false) => x,
            _ => y,
        }
    }

    /// `op a, b` through `ops` for each lane: `ops::grad` when computing gradients, else
    /// `ops::value`. Partials that are zero in both operands stay zero (a dense rule gives
    /// k·0 + m·0 = 0 there).
    fn call_back(&mut self, op: Op, a: Dual, b: Dual, gradients: bool) -> Dual {
        let (slot, sig) = match self.scratch {
            Some(made) => made,
            None => {
                let bytes = SCRATCH_DUALS as u32 * DUAL_BYTES as u32;
                let slot = self.b.create_sized_stack_slot(StackSlotData::new(
                    StackSlotKind::ExplicitSlot,
                    bytes,
                    4,
                ));
                let mut sig = Signature::new(self.b.func.signature.call_conv);
                sig.params
                    .extend([AbiParam::new(I32), AbiParam::new(self.pointer)]);
                let sig = self.b.import_signature(sig);
                self.scratch = Some((slot, sig));
                (slot, sig)
            }
        };
        let parts = if gradients { 4 } else { 1 };
        for (n, dual) in [a, b].into_iter().enumerate() {
            let components = [dual.v, dual.d[0], dual.d[1], dual.d[2]];
            for (c, x) in components.into_iter().take(parts).enumerate() {
                let x = self.vector(x);
                let offset = n as i32 * DUAL_BYTES + c as i32 * 16;
                self.b.ins().stack_store(self.pointer, x, slot, offset);
            }
        }
        let callee: extern "C" fn(u32, *mut Scratch) =
            if gradients { grad_call } else { value_call };
        let callee = self.b.ins().iconst(self.pointer, callee as usize as i64);
        let code = Op::ALL.iter().position(|&o| o == op).unwrap_or(usize::MAX) as i64;
        let code = self.b.ins().iconst(I32, code);
        let addr = self.b.ins().stack_addr(self.pointer, slot, 0);
        self.b.ins().call_indirect(sig, callee, &[code, addr]);
        let mut load = |c: usize| {
            let offset = 2 * DUAL_BYTES + c as i32 * 16;
            Vector(self.b.ins().stack_load(self.pointer, F64X2, slot, offset))
        };
        let v = load(0);
        let mut d = [ZERO; 3];
        if gradients {
            for (k, dk) in d.iter_mut().enumerate() {
                if !(a.d[k].is_zero() && b.d[k].is_zero()) {
                    *dk = load(k + 1);
                }
            }
        }
        Dual { v, d }
    }
}

impl Dual {
    fn value(v: Lanes) -> Dual {
        Dual { v, d: [ZERO; 3] }
    }
}

/// The scratch of a call back: `[a, b, out]`, each `[v, ∂x, ∂y, ∂z]` of two lanes.
type Scratch = [f64; 24];

fn lane_dual(s: &Scratch, n: usize, lane: usize) -> Grad {
    let at = |c: usize| s[n * 8 + c * 2 + lane];
    Grad::new(at(0), at(1), at(2), at(3))
}

fn op_of(code: u32) -> Op {
    Op::ALL.get(code as usize).copied().unwrap_or(Op::Dist)
}

/// `ops::value` for both lanes of a call back.
extern "C" fn value_call(code: u32, scratch: *mut Scratch) {
    // SAFETY: the generated code passes its own 16-aligned scratch slot of 24 f64s.
    let s = unsafe { &mut *scratch };
    let op = op_of(code);
    for lane in 0..WIDTH {
        s[16 + lane] = ops::value(op, s[lane], s[8 + lane]);
    }
}

/// `ops::grad` for both lanes of a call back.
extern "C" fn grad_call(code: u32, scratch: *mut Scratch) {
    // SAFETY: as in `value_call`.
    let s = unsafe { &mut *scratch };
    let op = op_of(code);
    for lane in 0..WIDTH {
        let g = ops::grad(op, lane_dual(s, 0, lane), lane_dual(s, 1, lane));
        for (c, x) in [g.v, g.dx, g.dy, g.dz].into_iter().enumerate() {
            s[16 + c * 2 + lane] = x;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x·y + c.
    fn tape(c: f64) -> Tape {
        let names = ["x", "y", "z"].map(String::from).to_vec();
        let instrs = vec![
            Instr {
                op: Op::Mul,
                out: Reg(4),
                a: Reg(0),
                b: Reg(1),
            },
            Instr {
                op: Op::Add,
                out: Reg(5),
                a: Reg(4),
                b: Reg(3),
            },
        ];
        Tape::new(names, vec![c], instrs, vec![Reg(5)], 6, 0).unwrap()
    }

    /// One tape's code is compiled once while it is held, a tape differing in one
    /// constant's bits has its own, and code nobody holds is freed.
    #[test]
    fn a_tape_held_is_compiled_once() {
        let Ok(first) = NativeTape::shared(&tape(0.5)) else {
            return; // A host Cranelift does not support: nothing is compiled.
        };
        let again = NativeTape::shared(&tape(0.5)).unwrap();
        assert!(Rc::ptr_eq(&first, &again));
        for other in [0.5f64.next_up(), -0.5] {
            let code = NativeTape::shared(&tape(other)).unwrap();
            assert!(!Rc::ptr_eq(&first, &code));
            let p = DVec3::new(3.0, 2.0, 1.0);
            assert_eq!(code.value_grad_at(p).value, 6.0 + other);
        }
        assert_eq!(first.value_grad_at(DVec3::new(3.0, 2.0, 1.0)).value, 6.5);
        let held = Rc::downgrade(&first);
        drop((first, again));
        assert!(
            held.upgrade().is_none(),
            "the code outlived its last holder"
        );
    }
}
