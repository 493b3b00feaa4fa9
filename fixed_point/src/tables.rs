//! Lookup tables for sin and atan, computed at compile time with 128-bit integer arithmetic only,
//! so every target and every build host gets the same bits.

/// π in Q62 (π · 2⁶²), rounded.
pub(crate) const PI_Q62: i128 = 14_488_038_916_154_245_685;
const ONE_Q62: i128 = 1 << 62;

/// Segments in each table; `TABLE_BITS` index bits.
pub(crate) const TABLE_BITS: u32 = 10;
pub(crate) const TABLE_SEGMENTS: usize = 1 << TABLE_BITS;

/// `SIN_Q30[k] = round(sin(k · (π/2) / 1024) · 2³⁰)`, k = 0..=1024.
pub(crate) static SIN_Q30: [i32; TABLE_SEGMENTS + 1] = sin_table();

/// `ATAN_UNITS[k] = round(atan(k / 1024) · 2³¹ / π)` in binary-angle units, k = 0..=1024.
pub(crate) static ATAN_UNITS: [i32; TABLE_SEGMENTS + 1] = atan_table();

const fn mul_q62(a: i128, b: i128) -> i128 {
    // Both operands are below 2⁶⁴ in magnitude here, so the product fits in i128.
    (a * b) >> 62
}

/// sin(x) for x in [0, π/2], both Q62, by its Taylor series.
const fn sin_q62(x: i128) -> i128 {
    let x2 = mul_q62(x, x);
    let mut term = x;
    let mut sum = x;
    let mut n: i128 = 1;
    while n < 40 {
        term = -mul_q62(term, x2) / ((2 * n) * (2 * n + 1));
        if term == 0 {
            break;
        }
        sum += term;
        n += 1;
    }
    sum
}

/// atan(t) for t in [0, 1], both Q62, by Euler's series
/// atan t = Σₙ (2ⁿ n!)² / (2n+1)! · t^(2n+1) / (1+t²)^(n+1), whose ratio is ≤ ½ on [0, 1].
const fn atan_q62(t: i128) -> i128 {
    let t2 = mul_q62(t, t);
    let y = (t2 << 62) / (ONE_Q62 + t2); // t²/(1+t²) in Q62
    let mut term = (t << 62) / (ONE_Q62 + t2); // t/(1+t²)
    let mut sum = term;
    let mut n: i128 = 1;
    while n < 200 {
        term = mul_q62(term, y) * (2 * n) / (2 * n + 1);
        if term == 0 {
            break;
        }
        sum += term;
        n += 1;
    }
    sum
}

const fn round_shift(v: i128, s: u32) -> i128 {
    (v + (1 << (s - 1))) >> s
}

const fn sin_table() -> [i32; TABLE_SEGMENTS + 1] {
    let mut t = [0i32; TABLE_SEGMENTS + 1];
    let mut k = 0;
    while k <= TABLE_SEGMENTS {
        let x = (k as i128 * PI_Q62) / (2 * TABLE_SEGMENTS as i128);
        t[k] = round_shift(sin_q62(x), 32) as i32;
        k += 1;
    }
    t
}

const fn atan_table() -> [i32; TABLE_SEGMENTS + 1] {
    let mut t = [0i32; TABLE_SEGMENTS + 1];
    let mut k = 0;
    while k <= TABLE_SEGMENTS {
        let x = (k as i128) << (62 - TABLE_BITS);
        let rad = atan_q62(x);
        // units = rad · 2³¹ / π, rounded.
        let num = rad << 31;
        t[k] = ((num + PI_Q62 / 2) / PI_Q62) as i32;
        k += 1;
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_match_f64() {
        for (k, &v) in SIN_Q30.iter().enumerate() {
            let exact = (k as f64 * core::f64::consts::FRAC_PI_2 / 1024.0).sin() * (1u64 << 30) as f64;
            assert!((v as f64 - exact).abs() <= 0.5 + 1e-6, "sin[{k}] = {v}, f64 {exact}");
        }
        for (k, &v) in ATAN_UNITS.iter().enumerate() {
            let exact = (k as f64 / 1024.0).atan() * (1u64 << 31) as f64 / core::f64::consts::PI;
            assert!((v as f64 - exact).abs() <= 0.5 + 1e-6, "atan[{k}] = {v}, f64 {exact}");
        }
        assert_eq!(SIN_Q30[1024], 1 << 30);
        assert_eq!(ATAN_UNITS[1024], 1 << 29);
    }
}
