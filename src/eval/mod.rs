//! Evaluator: runs a verified tape for value, and for value + gradient by forward-mode
//! automatic differentiation (dual numbers: a value and three partials per register), at one
//! point or over a batch of points.
//!
//! The registers live in the [`Vm`] and are reused, so an evaluation allocates nothing. The
//! batch path keeps the instruction dispatch outside the point loop: it runs each instruction
//! over [`LANES`] points at a time (structure-of-arrays registers), which lets the compiler
//! vectorise the arithmetic (in an AVX-512 or AVX2 copy where the CPU has it), and computes
//! only the partials that can be non-zero (per-instruction masks). While a block computes,
//! the next block's points and output slots are hinted into the cache a few lines per
//! instruction, so the memory streams overlap the arithmetic. `dist` instructions call the
//! tape's child surfaces.
//!
//! That is the interpreter. By default a surface tape runs as native code instead, at single
//! points and in batches ([`native`], compiled at the first evaluation); the interpreter is
//! the other [`Engine`], the reference the native code is tested against, and the fallback.
//! `docs/compiler.md` has the measurements behind these choices.

pub mod interval;
pub mod interval_grad;
pub mod native;

use glam::DVec3;

pub use crate::compile::ops::{self, Grad};
pub use crate::compile::tape::VmError;
use crate::compile::tape::{Arity, Op, Reg, Tape};
pub use crate::values::{Interval, IntervalGrad};
use crate::values::{Surface, ValueGrad};

/// Points per block of the gradient batch path. Measured on the genus-3 and blend benches
/// (32 to 1024 points; with the prefetch hints and AVX-512, 64, 128, 256 and 512): long lane
/// loops amortise each instruction's dispatch and its per-partial branches; at 128 a register
/// is 4 KiB, and a gallery tape's ~14 registers (56 KiB) stay between L1 and L2.
pub const LANES: usize = 128;

/// Points per block of the value-only batch path (a register is 1 KiB).
pub const VALUE_LANES: usize = 128;

type Lanes = [f64; VALUE_LANES];

/// One register over a block of points, with gradients: structure of arrays.
#[derive(Clone, Copy)]
struct GradLanes {
    v: [f64; LANES],
    dx: [f64; LANES],
    dy: [f64; LANES],
    dz: [f64; LANES],
}

impl GradLanes {
    const ZERO: GradLanes = GradLanes {
        v: [0.0; LANES],
        dx: [0.0; LANES],
        dy: [0.0; LANES],
        dz: [0.0; LANES],
    };

    fn splat(g: Grad) -> GradLanes {
        GradLanes {
            v: [g.v; LANES],
            dx: [g.dx; LANES],
            dy: [g.dy; LANES],
            dz: [g.dz; LANES],
        }
    }

    #[inline(always)]
    fn partial(&self, k: usize) -> &[f64; LANES] {
        match k {
            0 => &self.dx,
            1 => &self.dy,
            _ => &self.dz,
        }
    }

    #[inline(always)]
    fn partial_mut(&mut self, k: usize) -> &mut [f64; LANES] {
        match k {
            0 => &mut self.dx,
            1 => &mut self.dy,
            _ => &mut self.dz,
        }
    }

    /// Sets the partials whose bit is not in `mask` to 0.
    fn zero_partials_outside(&mut self, mask: u8) {
        for k in 0..3 {
            if mask & (1 << k) == 0 {
                self.partial_mut(k).fill(0.0);
            }
        }
    }

    #[inline(always)]
    fn get(&self, i: usize) -> Grad {
        Grad::new(self.v[i], self.dx[i], self.dy[i], self.dz[i])
    }

    #[inline(always)]
    fn set(&mut self, i: usize, g: Grad) {
        self.v[i] = g.v;
        self.dx[i] = g.dx;
        self.dy[i] = g.dy;
        self.dz[i] = g.dz;
    }
}

/// A tape with its child surfaces and its registers.
pub struct Vm {
    tape: Tape,
    children: Vec<Box<dyn Surface>>,
    values: Vec<f64>,
    grads: Vec<Grad>,
    lane_values: Vec<Lanes>,
    lane_grads: Vec<GradLanes>,
    /// The registers of an interval evaluation.
    intervals: Vec<Interval>,
    /// The registers of an interval-gradient evaluation.
    interval_grads: Vec<IntervalGrad>,
    /// The widest vector instructions the CPU has (checked once): the block loops run in a
    /// copy compiled for them. Results are bit-identical (Rust never contracts a·b + c into
    /// a fused multiply-add).
    simd: Simd,
    /// Per instruction: which partials (bit k: ∂/∂ input k) can be non-zero in its output and
    /// its two operands. The gradient batch computes only those.
    masks: Vec<[u8; 3]>,
    /// The same for the first output register.
    output_mask: u8,
    /// Which engine evaluates.
    engine: Engine,
    /// The tape's native code, compiled at the first evaluation that wants it.
    native: Native,
}

/// The engine that evaluates a surface tape, at single points and in batches. Both give the
/// same values bit for bit and the same partials up to the sign of zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Engine {
    /// The tape compiled to native code (`native.rs`), where it can be (surface tapes without
    /// `dist` children, on a host Cranelift supports); else the interpreter.
    #[default]
    Native,
    /// The interpreter: dense dual numbers at single points (the reference of both engines),
    /// block loops over batches.
    Interpreter,
}

/// The state of a VM's native code.
#[derive(Debug)]
enum Native {
    NotTried,
    Ready(std::rc::Rc<native::NativeTape>),
    Unavailable(native::NativeError),
}

/// Which partials of each instruction's output and operands can be non-zero: an input has its
/// own, a constant none, `dist` all three, an operation the union of its operands'.
fn partial_masks(tape: &Tape) -> (Vec<[u8; 3]>, u8) {
    let mut reg = vec![0u8; tape.registers()];
    for (i, m) in reg.iter_mut().enumerate().take(tape.inputs().min(3)) {
        *m = 1 << i;
    }
    let mut masks = Vec::with_capacity(tape.instrs().len());
    for ins in tape.instrs() {
        let get = |r: Reg| reg.get(r.index()).copied().unwrap_or(0b111);
        let (a, b) = match ins.op.arity() {
            Arity::Child => (0, 0),
            Arity::Unary => (get(ins.a), 0),
            Arity::Binary => (get(ins.a), get(ins.b)),
        };
        let out = if ins.op == Op::Dist { 0b111 } else { a | b };
        if let Some(m) = reg.get_mut(ins.out.index()) {
            *m = out;
        }
        masks.push([out, a, b]);
    }
    let output = reg.get(tape.outputs()[0].index()).copied().unwrap_or(0b111);
    (masks, output)
}

impl std::fmt::Debug for Vm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Vm")
            .field("tape", &self.tape)
            .field("children", &self.children.len())
            .finish_non_exhaustive()
    }
}

/// Out, a, b of a block instruction as disjoint borrows (the verifier guarantees that an
/// instruction never writes one of its operands).
#[inline(always)]
fn split3<T>(regs: &mut [T], o: usize, a: usize, b: usize) -> Option<(&mut T, &T, &T)> {
    if o == a || o == b {
        return None;
    }
    let (lo, rest) = regs.split_at_mut(o);
    let (out, hi) = rest.split_first_mut()?;
    let (lo, hi): (&[T], &[T]) = (lo, hi);
    let pick = |r: usize| {
        if r < o { lo.get(r) } else { hi.get(r - o - 1) }
    };
    Some((out, pick(a)?, pick(b)?))
}

/// Register `r` of a single-point register file, without a bounds check: the single-point
/// loop is what the marcher calls, once per Newton step.
///
/// # Safety
/// `r.index() < regs.len()`. Holds for every register an instruction of a `Vm`'s tape names:
/// the verifier (`Tape::new`) checked each against `tape.registers()`, and `Vm::new` sizes
/// both single-point register files to exactly `tape.registers()`.
#[inline(always)]
unsafe fn read<T: Copy>(regs: &[T], r: Reg) -> T {
    debug_assert!(r.index() < regs.len());
    // SAFETY: the caller's contract.
    unsafe { *regs.get_unchecked(r.index()) }
}

/// Writes register `r`; the safety contract of [`read`].
#[inline(always)]
unsafe fn write<T>(regs: &mut [T], r: Reg, v: T) {
    debug_assert!(r.index() < regs.len());
    // SAFETY: the caller's contract.
    unsafe { *regs.get_unchecked_mut(r.index()) = v };
}

/// The point a `dist` instruction measures from: the first three inputs.
fn point_of(inputs: &[f64]) -> DVec3 {
    let c = |i: usize| inputs.get(i).copied().unwrap_or(0.0);
    DVec3::new(c(0), c(1), c(2))
}

/// Runs `$run!(op)` with `op` a constant, so each arm inlines `ops::value`/`ops::grad` for
/// one opcode and the lane loop around it is specialised (and vectorised).
macro_rules! per_opcode {
    ($op:expr, $run:ident) => {
        match $op {
            Op::Neg => $run!(Op::Neg),
            Op::Square => $run!(Op::Square),
            Op::Recip => $run!(Op::Recip),
            Op::Sqrt => $run!(Op::Sqrt),
            Op::Abs => $run!(Op::Abs),
            Op::Exp => $run!(Op::Exp),
            Op::Ln => $run!(Op::Ln),
            Op::Sin => $run!(Op::Sin),
            Op::Cos => $run!(Op::Cos),
            Op::Tan => $run!(Op::Tan),
            Op::Asin => $run!(Op::Asin),
            Op::Acos => $run!(Op::Acos),
            Op::Atan => $run!(Op::Atan),
            Op::Sinh => $run!(Op::Sinh),
            Op::Cosh => $run!(Op::Cosh),
            Op::Tanh => $run!(Op::Tanh),
            Op::Add => $run!(Op::Add),
            Op::Sub => $run!(Op::Sub),
            Op::Mul => $run!(Op::Mul),
            Op::Div => $run!(Op::Div),
            Op::Pow => $run!(Op::Pow),
            Op::Atan2 => $run!(Op::Atan2),
            Op::Min => $run!(Op::Min),
            Op::Max => $run!(Op::Max),
            Op::Hypot => $run!(Op::Hypot),
            Op::Dist => {}
        }
    };
}

#[inline(always)]
fn value_lanes(op: Op, o: &mut Lanes, a: &Lanes, b: &Lanes) {
    macro_rules! run {
        ($k:expr) => {
            for i in 0..VALUE_LANES {
                o[i] = ops::value($k, a[i], b[i]);
            }
        };
    }
    per_opcode!(op, run)
}

#[inline(always)]
fn grad_lanes(op: Op, o: &mut GradLanes, a: &GradLanes, b: &GradLanes) {
    macro_rules! run {
        ($k:expr) => {
            for i in 0..LANES {
                o.set(i, ops::grad($k, a.get(i), b.get(i)));
            }
        };
    }
    per_opcode!(op, run)
}

impl Vm {
    /// A VM for `tape`; `children[k]` is the surface of its `dist #k`.
    pub fn new(tape: Tape, children: Vec<Box<dyn Surface>>) -> Result<Vm, VmError> {
        if children.len() != tape.children() {
            return Err(VmError::ChildCount {
                expected: tape.children(),
                found: children.len(),
            });
        }
        let (masks, output_mask) = partial_masks(&tape);
        let mut values = vec![0.0; tape.registers()];
        let mut grads = vec![Grad::default(); tape.registers()];
        for (i, &c) in tape.constants().iter().enumerate() {
            values[tape.inputs() + i] = c;
            grads[tape.inputs() + i] = Grad::constant(c);
        }
        Ok(Vm {
            tape,
            children,
            values,
            grads,
            lane_values: Vec::new(),
            lane_grads: Vec::new(),
            intervals: Vec::new(),
            interval_grads: Vec::new(),
            simd: Simd::detect(),
            masks,
            output_mask,
            engine: Engine::default(),
            native: Native::NotTried,
        })
    }

    pub fn tape(&self) -> &Tape {
        &self.tape
    }

    /// Chooses the engine.
    pub fn set_engine(&mut self, engine: Engine) {
        self.engine = engine;
    }

    /// The tape's native code, compiled at the first call; None if the engine is the
    /// interpreter or the tape cannot have native code ([`Vm::native_error`] says why).
    fn native(&mut self) -> Option<&native::NativeTape> {
        if self.engine != Engine::Native {
            return None;
        }
        if let Native::NotTried = self.native {
            self.native = match native::NativeTape::shared(&self.tape) {
                Ok(code) => Native::Ready(code),
                Err(e) => Native::Unavailable(e),
            };
        }
        match &self.native {
            Native::Ready(code) => Some(code),
            _ => None,
        }
    }

    /// The first fault of a `dist` child (a foot point not found), if any.
    pub fn fault(&self) -> Option<crate::values::Fault> {
        self.children.iter().find_map(|c| c.fault())
    }

    /// Does the tape call `dist` children? Their foot-point searches start warm from the last
    /// query, so what they give may depend on the order of the points asked.
    pub fn has_children(&self) -> bool {
        !self.children.is_empty()
    }

    /// Why the interpreter evaluates although the engine is `Native`, once an evaluation has
    /// tried to compile the tape.
    pub fn native_error(&self) -> Option<&native::NativeError> {
        match &self.native {
            Native::Unavailable(e) => Some(e),
            _ => None,
        }
    }

    fn run_values(&mut self, inputs: &[f64]) {
        let Vm {
            tape,
            children,
            values,
            ..
        } = self;
        for (i, r) in values.iter_mut().enumerate().take(tape.inputs()) {
            *r = inputs.get(i).copied().unwrap_or(0.0);
        }
        for ins in tape.instrs() {
            let v = match ins.op {
                Op::Dist => match children.get_mut(ins.child().index()) {
                    Some(child) => child.value(point_of(inputs)),
                    None => f64::NAN,
                },
                // SAFETY: see `read`.
                op => unsafe { ops::value(op, read(values, ins.a), read(values, ins.b)) },
            };
            // SAFETY: see `read`.
            unsafe { write(values, ins.out, v) };
        }
    }

    fn run_grads(&mut self, inputs: &[f64]) {
        let Vm {
            tape,
            children,
            grads,
            ..
        } = self;
        for (axis, r) in grads.iter_mut().enumerate().take(tape.inputs()) {
            *r = Grad::input(inputs.get(axis).copied().unwrap_or(0.0), axis);
        }
        for ins in tape.instrs() {
            let g = match ins.op {
                Op::Dist => match children.get_mut(ins.child().index()) {
                    Some(child) => {
                        let vg = child.value_gradient(point_of(inputs));
                        let d = vg.gradient;
                        Grad::new(vg.value, d.x, d.y, d.z)
                    }
                    None => Grad::constant(f64::NAN),
                },
                // SAFETY: see `read`.
                op => unsafe { ops::grad(op, read(grads, ins.a), read(grads, ins.b)) },
            };
            // SAFETY: see `read`.
            unsafe { write(grads, ins.out, g) };
        }
    }

    /// The first output at one point (`inputs`: x, y, z or u, v; missing ones read as 0).
    pub fn value(&mut self, inputs: &[f64]) -> f64 {
        if let Some(code) = self.native() {
            return code.value_at(point_of(inputs));
        }
        self.run_values(inputs);
        self.values[self.tape.outputs()[0].index()]
    }

    /// The first output with its partial derivatives by the inputs.
    pub fn value_grad(&mut self, inputs: &[f64]) -> Grad {
        if let Some(code) = self.native() {
            let vg = code.value_grad_at(point_of(inputs));
            let d = vg.gradient;
            return Grad::new(vg.value, d.x, d.y, d.z);
        }
        self.run_grads(inputs);
        self.grads[self.tape.outputs()[0].index()]
    }

    /// An interval holding the first output's value at every point of the box `lo .. hi`
    /// (its defined values: see [`interval`]). Interpreted, one interval per register; a
    /// `dist` child gives its own bound ([`Surface::bound`]), or the whole line if it has
    /// none. Inputs beyond the third read as [0, 0].
    pub fn interval(&mut self, lo: DVec3, hi: DVec3) -> Interval {
        let Vm {
            tape,
            children,
            intervals: regs,
            ..
        } = self;
        regs.clear();
        regs.resize(tape.registers(), Interval::ENTIRE);
        for (axis, r) in regs.iter_mut().enumerate().take(tape.inputs()) {
            *r = if axis < 3 {
                Interval::new(lo[axis], hi[axis])
            } else {
                Interval::point(0.0)
            };
        }
        for (i, &c) in tape.constants().iter().enumerate() {
            regs[tape.inputs() + i] = Interval::point(c);
        }
        let get = |regs: &[Interval], r: Reg| regs.get(r.index()).copied();
        for ins in tape.instrs() {
            let v = match ins.op {
                Op::Dist => children
                    .get_mut(ins.child().index())
                    .and_then(|child| child.bound(lo, hi))
                    .unwrap_or(Interval::ENTIRE),
                op => match (get(regs, ins.a), get(regs, ins.b)) {
                    (Some(a), Some(b)) => interval::interval(op, a, b),
                    _ => Interval::ENTIRE,
                },
            };
            if let Some(slot) = regs.get_mut(ins.out.index()) {
                *slot = v;
            }
        }
        get(regs, tape.outputs()[0]).unwrap_or(Interval::ENTIRE)
    }

    /// [`Vm::interval`] with interval partials ([`interval_grad`]): the first output's value
    /// and its derivatives by the inputs `axes` asks for over the box `lo .. hi` (the others
    /// are not computed and come back as the whole line). A `dist` child gives its value
    /// bound and unknown partials (the whole line).
    pub fn interval_grad(&mut self, lo: DVec3, hi: DVec3, axes: [bool; 3]) -> IntervalGrad {
        let Vm {
            tape,
            children,
            interval_grads: regs,
            ..
        } = self;
        let unknown = IntervalGrad::unknown_slope(Interval::ENTIRE);
        regs.clear();
        regs.resize(tape.registers(), unknown);
        for (axis, r) in regs.iter_mut().enumerate().take(tape.inputs()) {
            *r = if axis < 3 && axes[axis] {
                IntervalGrad::input(Interval::new(lo[axis], hi[axis]), axis)
            } else if axis < 3 {
                // An input whose partial is not asked for: a constant to the chain rule,
                // which then skips that partial's work throughout.
                IntervalGrad::constant(Interval::new(lo[axis], hi[axis]))
            } else {
                IntervalGrad::constant(Interval::point(0.0))
            };
        }
        for (i, &c) in tape.constants().iter().enumerate() {
            regs[tape.inputs() + i] = IntervalGrad::constant(Interval::point(c));
        }
        let get = |regs: &[IntervalGrad], r: Reg| regs.get(r.index()).copied();
        for ins in tape.instrs() {
            let v = match ins.op {
                Op::Dist => IntervalGrad::unknown_slope(
                    children
                        .get_mut(ins.child().index())
                        .and_then(|child| child.bound(lo, hi))
                        .unwrap_or(Interval::ENTIRE),
                ),
                op => match (get(regs, ins.a), get(regs, ins.b)) {
                    (Some(a), Some(b)) => interval_grad::interval_grad(op, a, b),
                    _ => unknown,
                },
            };
            if let Some(slot) = regs.get_mut(ins.out.index()) {
                *slot = v;
            }
        }
        let mut out = get(regs, tape.outputs()[0]).unwrap_or(unknown);
        for (d, asked) in out.d.iter_mut().zip(axes) {
            if !asked {
                *d = Interval::ENTIRE;
            }
        }
        out
    }

    /// Every output with its partials, into `out` (as many as fit). Interpreted (patch tapes
    /// have no native code).
    pub fn grad_outputs(&mut self, inputs: &[f64], out: &mut [Grad]) {
        self.run_grads(inputs);
        for (o, r) in out.iter_mut().zip(self.tape.outputs()) {
            *o = self.grads[r.index()];
        }
    }

    fn init_lanes(&mut self) {
        if self.lane_values.len() == self.tape.registers() {
            return;
        }
        let n = self.tape.registers();
        self.lane_values = vec![[0.0; VALUE_LANES]; n];
        self.lane_grads = vec![GradLanes::ZERO; n];
        for (i, &c) in self.tape.constants().iter().enumerate() {
            let r = self.tape.inputs() + i;
            self.lane_values[r] = [c; VALUE_LANES];
            self.lane_grads[r] = GradLanes::splat(Grad::constant(c));
        }
        // The partials of the inputs are the same at every point: set them once.
        for axis in 0..self.tape.inputs() {
            self.lane_grads[axis] = GradLanes::splat(Grad::input(0.0, axis));
        }
    }

    /// f at each point of a surface tape: `out[i] = f(points[i])` for i below the shorter
    /// length.
    pub fn value_batch(&mut self, points: &[DVec3], out: &mut [f64]) {
        if let Some(code) = self.native() {
            code.values(points, out);
            return;
        }
        self.init_lanes();
        let output = self.tape.outputs()[0].index();
        let (points_addr, out_addr, out_len) = (points.as_ptr(), out.as_ptr(), out.len());
        let blocks = points.chunks(VALUE_LANES).zip(out.chunks_mut(VALUE_LANES));
        for (block, (pts, outs)) in blocks.enumerate() {
            let n = pts.len().min(outs.len());
            let mut hints = Prefetch::new(
                (points_addr, points.len()),
                (out_addr, out_len),
                (block + 1) * VALUE_LANES,
                VALUE_LANES,
                self.tape.instrs().len(),
            );
            let Vm {
                tape,
                children,
                lane_values: regs,
                simd,
                ..
            } = self;
            for (i, p) in pts.iter().enumerate() {
                for (axis, c) in [p.x, p.y, p.z].into_iter().enumerate().take(tape.inputs()) {
                    regs[axis][i] = c;
                }
            }
            run_block(
                *simd,
                Block::Values(regs),
                tape,
                &[],
                children,
                n,
                &mut hints,
            );
            hints.finish();
            outs[..n].copy_from_slice(&regs[output][..n]);
        }
    }

    /// f and ∇f at each point of a surface tape, for i below the shorter length.
    pub fn value_grad_batch(&mut self, points: &[DVec3], out: &mut [ValueGrad]) {
        if let Some(code) = self.native() {
            code.value_grads(points, out);
            return;
        }
        self.init_lanes();
        let output = self.tape.outputs()[0].index();
        // Addresses only (never dereferenced), for the prefetch hints.
        let (points_addr, out_addr, out_len) = (points.as_ptr(), out.as_ptr(), out.len());
        for (block, (pts, outs)) in points.chunks(LANES).zip(out.chunks_mut(LANES)).enumerate() {
            let n = pts.len().min(outs.len());
            let mut hints = Prefetch::new(
                (points_addr, points.len()),
                (out_addr, out_len),
                (block + 1) * LANES,
                LANES,
                self.tape.instrs().len(),
            );
            let Vm {
                tape,
                children,
                lane_grads: regs,
                simd,
                masks,
                ..
            } = self;
            match (tape.inputs(), &mut regs[..]) {
                (3, [xs, ys, zs, ..]) => {
                    let lanes = xs.v.iter_mut().zip(ys.v.iter_mut()).zip(zs.v.iter_mut());
                    for (((x, y), z), p) in lanes.zip(pts) {
                        (*x, *y, *z) = (p.x, p.y, p.z);
                    }
                }
                _ => {
                    for (i, p) in pts.iter().enumerate() {
                        for (axis, c) in [p.x, p.y, p.z].into_iter().enumerate().take(tape.inputs())
                        {
                            regs[axis].v[i] = c;
                        }
                    }
                }
            }
            run_block(
                *simd,
                Block::Grads(regs),
                tape,
                masks,
                children,
                n,
                &mut hints,
            );
            hints.finish();
            let r = &mut regs[output];
            r.zero_partials_outside(self.output_mask);
            let lanes = r.v.iter().zip(&r.dx).zip(&r.dy).zip(&r.dz);
            for (slot, (((&v, &dx), &dy), &dz)) in outs[..n].iter_mut().zip(lanes) {
                *slot = ValueGrad {
                    value: v,
                    gradient: DVec3::new(dx, dy, dz),
                };
            }
        }
    }
}

/// Cache hints for the next block's points and output slots, issued a few lines after each
/// instruction of the current block: the memory streams keep flowing while the block
/// computes, instead of stalling the block's input and output loops (a burst of all the
/// hints at once stalls on the CPU's fill buffers). Hints only: no effect on results.
struct Prefetch {
    /// Start and length in bytes of each range still to hint.
    ranges: [(*const i8, usize); 2],
    /// Cache lines hinted after each instruction.
    per_step: usize,
}

/// Bytes a cache line.
const CACHE_LINE: usize = 64;

impl Prefetch {
    /// Items `from..from + n` of each slice (given by address and length; clipped to it),
    /// spread over `steps` steps.
    fn new<A, B>(
        a: (*const A, usize),
        b: (*const B, usize),
        from: usize,
        n: usize,
        steps: usize,
    ) -> Prefetch {
        fn range<T>((base, len): (*const T, usize), from: usize, n: usize) -> (*const i8, usize) {
            let size = std::mem::size_of::<T>();
            let bytes = len.saturating_sub(from).min(n) * size;
            (base.cast::<i8>().wrapping_add(from.min(len) * size), bytes)
        }
        let ranges = [range(a, from, n), range(b, from, n)];
        let lines = (ranges[0].1 + ranges[1].1).div_ceil(CACHE_LINE);
        Prefetch {
            ranges,
            per_step: lines.div_ceil(steps.max(1)),
        }
    }

    /// Hints the next `per_step` lines.
    #[inline(always)]
    fn step(&mut self) {
        self.hint(self.per_step);
    }

    /// Hints the lines not hinted yet.
    fn finish(&mut self) {
        self.hint(usize::MAX);
    }

    #[inline(always)]
    fn hint(&mut self, mut lines: usize) {
        for (p, bytes) in &mut self.ranges {
            while lines > 0 && *bytes > 0 {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: SSE is part of x86_64; a prefetch only hints the cache and never
                // faults (the address stays inside the slice anyway).
                unsafe {
                    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
                    _mm_prefetch::<_MM_HINT_T0>(*p)
                };
                let s = (*bytes).min(CACHE_LINE);
                *p = p.wrapping_add(s);
                *bytes -= s;
                lines -= 1;
            }
        }
    }
}

/// The opcodes with a sparse gradient rule in the batch evaluator: the arithmetic of
/// polynomials, the bulk of every gallery surface.
#[inline(always)]
fn is_sparse(op: Op) -> bool {
    matches!(
        op,
        Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Neg | Op::Square
    )
}

/// A sparse opcode over a block: the values, then each partial that can be non-zero (bit k
/// of `mask[0]`), reading an operand's partial only where it can be non-zero. Partials
/// outside the output's mask are left stale; readers treat them as 0. Agrees with `ops::grad`
/// up to the sign of zero (a missing `+ 0`), since `ops::term` keeps zero partials zero.
#[inline(always)]
fn sparse_grad_lanes(op: Op, mask: [u8; 3], o: &mut GradLanes, a: &GradLanes, b: &GradLanes) {
    use ops::term;
    let (av, bv) = (&a.v, &b.v);
    let GradLanes {
        v: ov,
        dx: odx,
        dy: ody,
        dz: odz,
    } = o;
    match op {
        Op::Add => (0..LANES).for_each(|i| ov[i] = av[i] + bv[i]),
        Op::Sub => (0..LANES).for_each(|i| ov[i] = av[i] - bv[i]),
        Op::Mul => (0..LANES).for_each(|i| ov[i] = av[i] * bv[i]),
        Op::Div => (0..LANES).for_each(|i| ov[i] = av[i] / bv[i]),
        Op::Neg => (0..LANES).for_each(|i| ov[i] = -av[i]),
        Op::Square => (0..LANES).for_each(|i| ov[i] = av[i] * av[i]),
        _ => {}
    }
    let v: &[f64; LANES] = ov;
    let binary = op.arity() == Arity::Binary;
    for k in 0..3 {
        let bit = 1u8 << k;
        let (ha, hb) = (mask[1] & bit != 0, binary && mask[2] & bit != 0);
        if !ha && !hb {
            continue;
        }
        let (ad, bd) = (a.partial(k), b.partial(k));
        let od: &mut [f64; LANES] = match k {
            0 => &mut *odx,
            1 => &mut *ody,
            _ => &mut *odz,
        };
        match (op, ha, hb) {
            (Op::Add, true, true) => (0..LANES).for_each(|i| od[i] = ad[i] + bd[i]),
            (Op::Add, true, false) => *od = *ad,
            (Op::Add, false, true) => *od = *bd,
            (Op::Sub, true, true) => (0..LANES).for_each(|i| od[i] = ad[i] - bd[i]),
            (Op::Sub, true, false) => *od = *ad,
            (Op::Sub, false, true) => (0..LANES).for_each(|i| od[i] = -bd[i]),
            (Op::Mul, true, true) => {
                (0..LANES).for_each(|i| od[i] = term(bv[i], ad[i]) + term(av[i], bd[i]))
            }
            (Op::Mul, true, false) => (0..LANES).for_each(|i| od[i] = term(bv[i], ad[i])),
            (Op::Mul, false, true) => (0..LANES).for_each(|i| od[i] = term(av[i], bd[i])),
            (Op::Div, true, true) => (0..LANES).for_each(|i| {
                let r = 1.0 / bv[i];
                od[i] = term(r, ad[i]) + term(-v[i] * r, bd[i]);
            }),
            (Op::Div, true, false) => (0..LANES).for_each(|i| od[i] = term(1.0 / bv[i], ad[i])),
            (Op::Div, false, true) => (0..LANES).for_each(|i| {
                let r = 1.0 / bv[i];
                od[i] = term(-v[i] * r, bd[i]);
            }),
            (Op::Neg, _, _) => (0..LANES).for_each(|i| od[i] = -ad[i]),
            (Op::Square, _, _) => (0..LANES).for_each(|i| od[i] = term(2.0 * av[i], ad[i])),
            _ => {}
        }
    }
}

/// Which compiled copy of the block loops runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Simd {
    /// The target's baseline (SSE2 on x86_64): two lanes a vector.
    Baseline,
    /// Four lanes a vector.
    Avx2,
    /// Eight lanes a vector. Measured (docs/compiler.md): value + gradient ~25% faster than
    /// the AVX2 copy on the benches' AMD EPYC.
    Avx512,
}

impl Simd {
    fn detect() -> Simd {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Simd::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Simd::Avx2;
            }
        }
        Simd::Baseline
    }
}

/// The registers of one block of points.
enum Block<'r> {
    Values(&'r mut [Lanes]),
    Grads(&'r mut [GradLanes]),
}

/// Runs the tape over one block of points whose first `n` lanes are real (the others hold
/// stale values; only `dist` looks at `n`, to call its child no more than needed).
fn run_block(
    simd: Simd,
    regs: Block<'_>,
    tape: &Tape,
    masks: &[[u8; 3]],
    children: &mut [Box<dyn Surface>],
    n: usize,
    hints: &mut Prefetch,
) {
    #[cfg(target_arch = "x86_64")]
    match simd {
        // SAFETY: `Simd::detect` found the feature on this CPU when the Vm was built.
        Simd::Avx512 => unsafe { run_block_avx512(regs, tape, masks, children, n, hints) },
        // SAFETY: as above.
        Simd::Avx2 => unsafe { run_block_avx2(regs, tape, masks, children, n, hints) },
        Simd::Baseline => run_block_generic(regs, tape, masks, children, n, hints),
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = simd;
        run_block_generic(regs, tape, masks, children, n, hints);
    }
}

/// `run_block_generic` compiled for AVX-512.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn run_block_avx512(
    regs: Block<'_>,
    tape: &Tape,
    masks: &[[u8; 3]],
    children: &mut [Box<dyn Surface>],
    n: usize,
    hints: &mut Prefetch,
) {
    run_block_generic(regs, tape, masks, children, n, hints);
}

/// `run_block_generic` compiled for AVX2.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_block_avx2(
    regs: Block<'_>,
    tape: &Tape,
    masks: &[[u8; 3]],
    children: &mut [Box<dyn Surface>],
    n: usize,
    hints: &mut Prefetch,
) {
    run_block_generic(regs, tape, masks, children, n, hints);
}

#[inline(always)]
fn run_block_generic(
    regs: Block<'_>,
    tape: &Tape,
    masks: &[[u8; 3]],
    children: &mut [Box<dyn Surface>],
    n: usize,
    hints: &mut Prefetch,
) {
    match regs {
        Block::Values(regs) => {
            for ins in tape.instrs() {
                hints.step();
                let o = ins.out.index();
                if ins.op == Op::Dist {
                    let (Some(child), Some((lo, hi))) = (
                        children.get_mut(ins.child().index()),
                        split_inputs(regs, o, tape.inputs()),
                    ) else {
                        continue;
                    };
                    for (i, slot) in hi.iter_mut().enumerate().take(n) {
                        *slot = child.value(DVec3::new(lo[0][i], lo[1][i], lo[2][i]));
                    }
                    continue;
                }
                if let Some((out, a, b)) = split3(regs, o, ins.a.index(), ins.b.index()) {
                    value_lanes(ins.op, out, a, b);
                }
            }
        }
        Block::Grads(regs) => {
            for (ins, &mask) in tape.instrs().iter().zip(masks) {
                let o = ins.out.index();
                if ins.op == Op::Dist {
                    let (Some(child), Some((lo, hi))) = (
                        children.get_mut(ins.child().index()),
                        split_inputs(regs, o, tape.inputs()),
                    ) else {
                        continue;
                    };
                    for i in 0..n {
                        let p = DVec3::new(lo[0].v[i], lo[1].v[i], lo[2].v[i]);
                        let vg = child.value_gradient(p);
                        let d = vg.gradient;
                        hi.set(i, Grad::new(vg.value, d.x, d.y, d.z));
                    }
                    continue;
                }
                hints.step();
                if !is_sparse(ins.op) {
                    // The dense rule reads every partial: make the structurally zero ones 0.
                    let binary = ins.op.arity() == Arity::Binary;
                    let operands = [Some((ins.a, mask[1])), binary.then_some((ins.b, mask[2]))];
                    for (r, m) in operands.into_iter().flatten() {
                        if let Some(reg) = regs.get_mut(r.index()) {
                            reg.zero_partials_outside(m);
                        }
                    }
                }
                if let Some((out, a, b)) = split3(regs, o, ins.a.index(), ins.b.index()) {
                    if is_sparse(ins.op) {
                        sparse_grad_lanes(ins.op, mask, out, a, b);
                    } else {
                        grad_lanes(ins.op, out, a, b);
                    }
                }
            }
        }
    }
}

/// The three input registers (read) and register `o` (written) of a `dist` instruction;
/// None unless the tape has three inputs below `o`.
fn split_inputs<T>(regs: &mut [T], o: usize, inputs: usize) -> Option<(&[T], &mut T)> {
    if inputs != 3 || o < 3 {
        return None;
    }
    let (lo, rest) = regs.split_at_mut(o);
    Some((&lo[..3], rest.first_mut()?))
}
