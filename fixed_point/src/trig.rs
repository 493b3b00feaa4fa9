//! sin, cos, atan2, sqrt and hypot on fixed-point numbers (see the crate docs for error bounds).

use crate::tables::{ATAN_UNITS, SIN_Q30, TABLE_BITS};
use crate::{BinaryAngle, Meters, Unit};

/// Fraction bits left below the table index in a quarter-turn angle (32 − 2 − 10 = 20).
const SIN_FRAC_BITS: u32 = 30 - TABLE_BITS;

/// sin of a quarter-turn offset `q` in [0, 2³⁰], Q30.
#[inline]
fn sin_quarter(q: u32) -> i32 {
    let idx = (q >> SIN_FRAC_BITS) as usize;
    let frac = (q & ((1 << SIN_FRAC_BITS) - 1)) as i64;
    if idx >= SIN_Q30.len() - 1 {
        return SIN_Q30[SIN_Q30.len() - 1];
    }
    let a = SIN_Q30[idx] as i64;
    let b = SIN_Q30[idx + 1] as i64;
    (a + (((b - a) * frac + (1 << (SIN_FRAC_BITS - 1))) >> SIN_FRAC_BITS)) as i32
}

/// Sine of a binary angle, |error| ≤ 4 × 10⁻⁷.
#[inline]
pub fn sin(a: BinaryAngle) -> Unit {
    let u = a.0 as u32;
    let quadrant = u >> 30;
    let q = u & ((1 << 30) - 1);
    let v = match quadrant {
        0 => sin_quarter(q),
        1 => sin_quarter((1 << 30) - q),
        2 => -sin_quarter(q),
        _ => -sin_quarter((1 << 30) - q),
    };
    Unit::from_bits(v)
}

/// Cosine of a binary angle, |error| ≤ 4 × 10⁻⁷.
#[inline]
pub fn cos(a: BinaryAngle) -> Unit {
    sin(a + BinaryAngle::QUARTER)
}

/// `(sin a, cos a)`.
#[inline]
pub fn sin_cos(a: BinaryAngle) -> (Unit, Unit) {
    (sin(a), cos(a))
}

/// atan of `num/den` for 0 ≤ num ≤ den, den > 0, in binary-angle units (0 ..= 2²⁹).
#[inline]
fn atan_unit_ratio(num: u64, den: u64) -> i32 {
    // t in Q(TABLE_BITS + 20) so the index and a 20-bit interpolation fraction fall out.
    const FRAC: u32 = 20;
    let t = ((num as u128) << (TABLE_BITS + FRAC)) / den as u128; // ≤ 2^30
    let t = t as u64;
    let idx = (t >> FRAC) as usize;
    if idx >= ATAN_UNITS.len() - 1 {
        return ATAN_UNITS[ATAN_UNITS.len() - 1];
    }
    let frac = (t & ((1 << FRAC) - 1)) as i64;
    let a = ATAN_UNITS[idx] as i64;
    let b = ATAN_UNITS[idx + 1] as i64;
    (a + (((b - a) * frac + (1 << (FRAC - 1))) >> FRAC)) as i32
}

/// atan2(y, x) as a binary angle, for any two numbers in the same fixed-point unit (only their
/// ratio matters). |error| ≤ 2 × 10⁻⁷ rad. `atan2(0, 0)` is 0 (as in C's `atan2`).
pub fn atan2(y: i32, x: i32) -> BinaryAngle {
    let ax = (x as i64).unsigned_abs();
    let ay = (y as i64).unsigned_abs();
    if ax == 0 && ay == 0 {
        return BinaryAngle::ZERO;
    }
    // First-octant angle in [0, 45°], then unfold.
    let base = if ay <= ax { atan_unit_ratio(ay, ax) } else { (1 << 30) - atan_unit_ratio(ax, ay) };
    let first_quadrant = base; // [0, 90°]
    let a = if x >= 0 {
        first_quadrant
    } else {
        // 180° − angle, wrapping: i32::MIN is 180°.
        (i32::MIN).wrapping_sub(first_quadrant)
    };
    BinaryAngle(if y < 0 { a.wrapping_neg() } else { a })
}

/// Floor of the square root of a `u64`, exact (integer Newton iteration).
pub fn isqrt_u64(n: u64) -> u64 {
    if n < 2 {
        return n;
    }
    // Initial guess above the root: 2^ceil(bits/2).
    let bits = 64 - n.leading_zeros();
    let mut x = 1u64 << bits.div_ceil(2);
    loop {
        let y = (x + n / x) >> 1;
        if y >= x {
            return x;
        }
        x = y;
    }
}

/// Square root of non-negative metres² expressed as metres (`sqrt(v)` for `v` in Q16.16), floored:
/// −2⁻¹⁶ < error ≤ 0. Negative input gives zero.
pub fn sqrt(v: Meters) -> Meters {
    let b = v.to_bits();
    if b <= 0 {
        return Meters::ZERO;
    }
    Meters::from_bits(isqrt_u64((b as u64) << 16) as i32)
}

/// `sqrt(dx² + dy²)` in metres without overflow for any Q16.16 inputs (saturates at `Meters::MAX`),
/// floored: −2⁻¹⁶ < error ≤ 0.
pub fn hypot(dx: Meters, dy: Meters) -> Meters {
    let x = (dx.to_bits() as i64).unsigned_abs() as u128;
    let y = (dy.to_bits() as i64).unsigned_abs() as u128;
    let s = x * x + y * y; // Q32.32, < 2^63
    let r = isqrt_u64(s as u64);
    Meters::from_bits(r.min(i32::MAX as u64) as i32)
}
