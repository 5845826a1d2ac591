//! Numbers as text for the text formats (OBJ, OFF, MSH), fast: floats through `ryu` in
//! exactly the text of Rust's `{:?}` (shortest round-trip; docs/cli.md), integers through
//! `itoa`, and long lists formatted in chunks on the threads of the rayon pool and written in
//! order, so the bytes are the same for any number of threads.

use std::io::{self, Write};

use rayon::prelude::*;

/// Items per chunk formatted on one thread (≈ 2–4 MB of text).
const CHUNK: usize = 1 << 16;

/// A growing line buffer with the number formatters.
pub(super) struct Text {
    pub bytes: Vec<u8>,
    float: ryu::Buffer,
    int: itoa::Buffer,
}

impl Text {
    pub fn with_capacity(n: usize) -> Text {
        Text {
            bytes: Vec::with_capacity(n),
            float: ryu::Buffer::new(),
            int: itoa::Buffer::new(),
        }
    }

    pub fn str(&mut self, s: &str) {
        self.bytes.extend_from_slice(s.as_bytes());
    }

    pub fn int(&mut self, v: u64) {
        self.bytes.extend_from_slice(self.int.format(v).as_bytes());
    }

    /// `x` as `format!("{x:?}")` writes it.
    pub fn float(&mut self, x: f64) {
        if may_tie(x) {
            use std::fmt::Write as _;
            let mut s = String::new();
            let _ = write!(s, "{x:?}");
            self.bytes.extend_from_slice(s.as_bytes());
            return;
        }
        let text = self.float.format(x);
        // The one range where the two disagree: ryu writes 1e-5 ≤ |x| < 1e-4 as
        // `0.0000ddd`, Rust as `d.dde-5` (the same shortest digits).
        let abs = x.abs();
        if (1e-5..1e-4).contains(&abs) {
            if x.is_sign_negative() {
                self.bytes.push(b'-');
            }
            let digits = text.trim_start_matches('-').trim_start_matches("0.0000");
            let (first, rest) = digits.split_at(1);
            self.bytes.extend_from_slice(first.as_bytes());
            if !rest.is_empty() {
                self.bytes.push(b'.');
                self.bytes.extend_from_slice(rest.as_bytes());
            }
            self.bytes.extend_from_slice(b"e-5");
        } else {
            self.bytes.extend_from_slice(text.as_bytes());
        }
    }
}

/// Whether two shortest round-trip texts of `x` may exist (a tie between the last digits,
/// which ryu and Rust break differently): only where the exact decimal value of `x` has 17
/// or 18 significant digits (its last digit 5), or at 1e16 and above. A tie at L digits puts
/// x halfway between two L-digit neighbours, each within the rounding interval of x, whose
/// half-width is at most 2⁻⁵³·|x|: half a unit of the L-th digit is at least |x|·10^−L / 2,
/// so 10^L ≥ 2⁵², L ≥ 16, and x has L + 1 digits. With fewer, its exact decimal is its one
/// shortest text (a CAD part's faces at 1.5 or 0.25), which ryu writes. A binary fraction
/// m·2^e (m odd, e < 0) has exactly −e digits after the point, so that is where it has 17 or
/// 18 of them. Mesh coordinates from Newton steps almost never do; those go to `{:?}`.
fn may_tie(x: f64) -> bool {
    if !x.is_finite() || x == 0.0 {
        return false;
    }
    let abs = x.abs();
    if abs >= 1e16 {
        return true;
    }
    let (biased, e) = exponents(abs);
    // An integer below 1e16 is exact in at most 16 digits: one shortest text.
    if e >= 0 {
        return false;
    }
    // Digits before the point: at least ⌊log10 2^k⌋ + 1 for abs ≥ 2^k, less one for the
    // rounding of the log10 below: ⌊k·log10 2⌋, with log10 2 taken low for k ≥ 0 and high
    // below (1233/4096 < log10 2 < 1234/4096). Coordinates from Newton steps have ~50
    // binary digits after the point: decided here, without the log10 (a fifth of an OBJ's
    // float formatting).
    let k = if biased == 0 { -1074 } else { biased - 1023 };
    let at_least = (k * if k >= 0 { 1233 } else { 1234 }) >> 12;
    if at_least - e > 19 {
        return false;
    }
    // Digits before the point, give or take one (the margin covers log10's rounding).
    let whole = abs.log10().floor() as i64 + 1;
    (16..=19).contains(&(whole - e))
}

/// The biased exponent field of `abs` (> 0, finite) and the power of two of its lowest set
/// bit: abs = m·2^e with m odd.
fn exponents(abs: f64) -> (i64, i64) {
    let bits = abs.to_bits();
    let (biased, fraction) = ((bits >> 52) as i64, bits & ((1u64 << 52) - 1));
    let (m, e) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1u64 << 52), biased - 1075)
    };
    (biased, e + i64::from(m.trailing_zeros()))
}

/// Writes one line per item of `items`, made by `line`, in order; the lines are formatted in
/// chunks on the pool's threads.
pub(super) fn write_lines<T: Sync>(
    out: &mut dyn Write,
    items: &[T],
    line: impl Fn(&mut Text, &T) + Sync,
) -> io::Result<()> {
    let chunks: Vec<Vec<u8>> = items
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut text = Text::with_capacity(chunk.len() * 64);
            for item in chunk {
                line(&mut text, item);
            }
            text.bytes
        })
        .collect();
    for chunk in chunks {
        out.write_all(&chunk)?;
    }
    Ok(())
}

/// Three floats separated by spaces, after `prefix`, and a newline.
pub(super) fn xyz(text: &mut Text, prefix: &str, [x, y, z]: [f64; 3]) {
    text.str(prefix);
    text.float(x);
    text.bytes.push(b' ');
    text.float(y);
    text.bytes.push(b' ');
    text.float(z);
    text.bytes.push(b'\n');
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ours(x: f64) -> String {
        let mut t = Text::with_capacity(32);
        t.float(x);
        String::from_utf8(t.bytes).expect("ASCII")
    }

    /// Every float the same text as `{:?}`: the edges of each notation's range, and random
    /// bit patterns (all exponents) and random values in the ranges coordinates take.
    #[test]
    fn floats_read_as_rust_debug_writes_them() {
        let mut edges = vec![
            0.0,
            -0.0,
            1.0,
            2.0,
            0.1,
            1e-4,
            1e-5,
            9.999999999999999e-5,
            1.5e-5,
            -1.2345e-5,
            1144061379383392.2,
            -1144061379383392.2,
            9.99999e-6,
            1e-6,
            1e16,
            9.999999999999998e15,
            1.5e16,
            1e15,
            123456789.0,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut state = 0x853c_49e6_748f_ea9bu64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..100_000 {
            edges.push(f64::from_bits(next()));
            let unit = (next() >> 11) as f64 / (1u64 << 53) as f64;
            let scale = 10f64.powi((next() % 24) as i32 - 12);
            edges.push((2.0 * unit - 1.0) * scale);
            // Short binary fractions of every size: where ties between two shortest texts are.
            let k = (next() >> (11 + next() % 40)) as f64;
            edges.push(k * 2f64.powi(-((next() % 60) as i32)));
        }
        // Binary fractions whose exact decimals have 14 to 20 digits, around the bound of
        // `may_tie`: m/2ⁿ = m·5ⁿ/10ⁿ (m odd) has the digits of m·5ⁿ.
        for n in 1..=22u32 {
            for digits in 14..=20u32 {
                let low = 10u128.pow(digits - 1) / 5u128.pow(n);
                for _ in 0..40 {
                    let m = (low + u128::from(next()) % low.max(1)) | 1;
                    if m < 1 << 53 {
                        let x = m as f64 / 2f64.powi(n as i32);
                        edges.extend([x, -x]);
                    }
                }
            }
        }
        for x in edges {
            assert_eq!(ours(x), format!("{x:?}"), "{:#x}", x.to_bits());
            assert_eq!(may_tie(x), may_tie_by_log10(x), "{:#x}", x.to_bits());
        }
    }

    /// `may_tie` without its shortcut: the digits before the point from log10 alone.
    fn may_tie_by_log10(x: f64) -> bool {
        if !x.is_finite() || x == 0.0 {
            return false;
        }
        let abs = x.abs();
        if abs >= 1e16 {
            return true;
        }
        let e = exponents(abs).1;
        e < 0 && (16..=19).contains(&(abs.log10().floor() as i64 + 1 - e))
    }

    #[test]
    fn lines_come_in_order_whatever_the_chunks() {
        let items: Vec<u64> = (0..(3 * CHUNK as u64 + 17)).collect();
        let mut out = Vec::new();
        write_lines(&mut out, &items, |t, &v| {
            t.int(v);
            t.str("\n");
        })
        .expect("a Vec takes every write");
        let expected: String = items.iter().map(|v| format!("{v}\n")).collect();
        assert_eq!(String::from_utf8(out).expect("ASCII"), expected);
    }
}
