//! Value types shared by the stages: intervals and interval gradients (the bounds of the
//! component search and the crease survey), f and ∇f at a point, and the surface oracle's
//! trait that every numerical stage asks, and the one `hypot` every evaluator computes.
//! Imports nothing of the crate, so any stage may use it without an import running back up
//! the data flow (docs/ARCHITECTURE.md).

pub mod interval;
pub mod interval_grad;
pub mod oracle;

pub use interval::Interval;
pub use interval_grad::IntervalGrad;
pub use oracle::{Fault, Surface, ValueGrad};

/// `x.floor() as i64` (saturating, NaN to 0) without the call to libm's `floor` that
/// x86-64's baseline makes of it (`roundsd` is SSE4.1): truncate, then step down where that
/// rounded up. The cells of the front's spatial hash (six a query) and of the point queries' pruned spines.
pub fn floor(x: f64) -> i64 {
    let t = x as i64;
    t.saturating_sub(i64::from(x < t as f64))
}

/// √(a² + b²), the one `hypot` of the language: the constant folder, the VM, the native code
/// (which has it in vector form, `eval::native`) and the interval bounds all compute this.
/// Where a² + b² is a normal finite number it is `(a·a + b·b).sqrt()` — four correctly
/// rounded operations, within about an ulp of the exact value, the same bits in scalar and
/// vector code and on any libm; elsewhere (overflow, underflow, ∞, NaN) the host's
/// `f64::hypot`, which scales, so hypot(1e200, 1) is 1e200 and hypot(∞, NaN) is ∞. The first
/// form is non-decreasing in |a| and |b| (each rounded operation is) and both lie within two
/// ulps of the exact value, so an interval's endpoints widened by two ulps enclose it.
#[inline(always)]
pub fn hypot(a: f64, b: f64) -> f64 {
    let s = a * a + b * b;
    if (f64::MIN_POSITIVE..f64::INFINITY).contains(&s) {
        s.sqrt()
    } else {
        a.hypot(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_is_the_floor_cast() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1.0 - f64::EPSILON,
            2.0f64.powi(52) + 0.5,
            -(2.0f64.powi(52)) - 0.5,
            2.0f64.powi(63),
            -(2.0f64.powi(63)),
            -(2.0f64.powi(63)) - 4096.0,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        values.extend((0..2000).map(|i| (i as f64 - 1000.0) * 0.0137));
        for x in values {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
        }
    }
}
