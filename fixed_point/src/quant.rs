//! Quantised-integer arithmetic for int8 neural-network inference (TFLite / CMSIS-NN conventions).
//!
//! A real value `r` is stored as an integer `q` with a scale: `r = scale · q` (zero point 0, i.e.
//! symmetric quantisation everywhere). A layer accumulates `Σ w·x` in an `i32` whose scale is
//! `s_w · s_x`; to hand the result to the next layer at scale `s_y` it multiplies the accumulator by
//! the real factor `M = s_w · s_x / s_y`. That factor is represented without floats as a
//! [`QuantizedMultiplier`]: a Q0.31 mantissa in [2³⁰, 2³¹) (i.e. [0.5, 1)) and a power-of-two
//! exponent, `M ≈ multiplier · 2^(shift − 31)`.
//!
//! [`requantize`] is TFLite's `MultiplyByQuantizedMultiplier`, bit-exact:
//!
//! 1. a left shift by `max(shift, 0)` (saturating here, where C++ has undefined behaviour),
//! 2. `SaturatingRoundingDoublingHighMul` — the high 32 bits of `2·a·b`, rounded to nearest with
//!    ties toward +∞ ([`saturating_rounding_doubling_high_mul`]),
//! 3. `RoundingDivideByPOT` by `max(−shift, 0)` — division by a power of two, rounded to nearest
//!    with ties away from zero ([`rounding_divide_by_pot`]).
//!
//! This is the one rounding mode of the whole int8 pipeline; the firmware's classifier and the
//! host's quantiser both go through these functions, so their results are the same bits on every
//! target. The result differs from the exact real product `acc · M` by at most 1 (two roundings to
//! nearest, each ≤ ½), which the tests check on 10⁵ random cases.
//!
//! Floats appear only in [`QuantizedMultiplier::from_f64`] and [`QuantizedMultiplier::to_f64`],
//! used offline by the quantiser; inference is integer-only.

/// A real multiplier `M ≈ multiplier · 2^(shift − 31)` (TFLite's `quantized_multiplier`, `shift`).
///
/// Normalised values (what [`QuantizedMultiplier::from_f64`] returns) have `multiplier` in
/// [2³⁰, 2³¹) or exactly 0, and `shift` in [−31, 30]. [`requantize`] accepts any value of either
/// field without panicking.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct QuantizedMultiplier {
    /// Q0.31 mantissa (in [2³⁰, 2³¹) when normalised; 0 for a zero multiplier).
    pub multiplier: i32,
    /// Power-of-two exponent: positive shifts left before the multiply, negative shifts right after.
    pub shift: i8,
}

impl QuantizedMultiplier {
    /// The zero multiplier (every input requantises to 0).
    pub const ZERO: Self = Self { multiplier: 0, shift: 0 };
    /// The smallest shift a normalised multiplier has.
    pub const MIN_SHIFT: i8 = -31;
    /// The largest shift a normalised multiplier has.
    pub const MAX_SHIFT: i8 = 30;

    /// From raw parts (as read from a model blob), no checks.
    pub const fn from_raw(multiplier: i32, shift: i8) -> Self {
        Self { multiplier, shift }
    }

    /// True when the parts are normalised: `multiplier` in [2³⁰, 2³¹) (or the zero multiplier
    /// `0, 0`) and `shift` in [[`Self::MIN_SHIFT`], [`Self::MAX_SHIFT`]].
    pub const fn is_normalised(&self) -> bool {
        if self.multiplier == 0 {
            return self.shift == 0;
        }
        self.multiplier >= (1 << 30) && self.shift >= Self::MIN_SHIFT && self.shift <= Self::MAX_SHIFT
    }

    /// TFLite's `QuantizeMultiplier` for a non-negative real multiplier: `real = q · 2^shift` with
    /// `q` in [0.5, 1), `multiplier = round(q · 2³¹)` (ties away from zero). Multipliers below
    /// 2⁻³¹·½ become [`Self::ZERO`]; multipliers of 2³⁰ or more saturate to the largest
    /// representable one. `None` for NaN, ±inf or a negative value. Offline use only.
    pub fn from_f64(real: f64) -> Option<Self> {
        if !real.is_finite() || real < 0.0 {
            return None;
        }
        if real == 0.0 {
            return Some(Self::ZERO);
        }
        // frexp without libm: scaling by powers of two is exact in binary floating point.
        let mut q = real;
        let mut shift: i32 = 0;
        while q >= 1.0 {
            q *= 0.5;
            shift += 1;
        }
        while q < 0.5 {
            q *= 2.0;
            shift -= 1;
        }
        let mut q_fixed = crate::round_f64_to_i64(q * 2_147_483_648.0);
        if q_fixed == 1 << 31 {
            q_fixed /= 2;
            shift += 1;
        }
        if shift < Self::MIN_SHIFT as i32 {
            return Some(Self::ZERO);
        }
        if shift > Self::MAX_SHIFT as i32 {
            return Some(Self { multiplier: i32::MAX, shift: Self::MAX_SHIFT });
        }
        Some(Self { multiplier: q_fixed as i32, shift: shift as i8 })
    }

    /// The real value this multiplier represents exactly, `multiplier · 2^(shift − 31)`.
    pub fn to_f64(&self) -> f64 {
        let mut v = self.multiplier as f64 / 2_147_483_648.0;
        let mut s = self.shift as i32;
        while s > 0 {
            v *= 2.0;
            s -= 1;
        }
        while s < 0 {
            v *= 0.5;
            s += 1;
        }
        v
    }
}

/// gemmlowp's `SaturatingRoundingDoublingHighMul`: `a · b / 2³¹` rounded to nearest with ties
/// toward +∞ (the nudge is `2³⁰` for a non-negative product and `1 − 2³⁰` for a negative one, then
/// the division truncates toward zero), saturating the one overflowing case `a = b = i32::MIN` to
/// `i32::MAX`.
#[inline]
pub const fn saturating_rounding_doubling_high_mul(a: i32, b: i32) -> i32 {
    if a == i32::MIN && b == i32::MIN {
        return i32::MAX;
    }
    let ab = a as i64 * b as i64;
    let nudge: i64 = if ab >= 0 { 1 << 30 } else { 1 - (1 << 30) };
    // `/` truncates toward zero, as C++ integer division does.
    ((ab + nudge) / (1i64 << 31)) as i32
}

/// gemmlowp's `RoundingDivideByPOT`: `x / 2^exponent` rounded to nearest, ties away from zero.
/// `exponent ≤ 0` returns `x`; `exponent ≥ 32` returns 0 (|x| / 2³² < ½ for every `i32`).
#[inline]
pub const fn rounding_divide_by_pot(x: i32, exponent: i32) -> i32 {
    if exponent <= 0 {
        return x;
    }
    if exponent >= 32 {
        return 0;
    }
    // gemmlowp's int32 form: for 1 ≤ exponent ≤ 31 the mask (at most 2³¹ − 1), the threshold
    // (at most 2³⁰) and the result (|x >> exponent| + 1 ≤ 2³⁰ + 1) all fit an `i32`, so no
    // 64-bit arithmetic is needed (on a 32-bit core it doubled the instructions of this step).
    let mask = ((1u32 << exponent) - 1) as i32;
    let remainder = x & mask;
    let threshold = (mask >> 1) + (x < 0) as i32;
    (x >> exponent) + (remainder > threshold) as i32
}

/// `$x`, of the wider integer type `$wide`, saturated into the narrower `$t` (its `MIN` or `MAX`
/// when out of range). A macro so that each use compares in its own wide type, in a `const fn`.
macro_rules! saturate {
    ($x:ident: $wide:ty => $t:ty) => {{
        let x: $wide = $x;
        if x > <$t>::MAX as $wide {
            <$t>::MAX
        } else if x < <$t>::MIN as $wide {
            <$t>::MIN
        } else {
            x as $t
        }
    }};
}

/// TFLite's `MultiplyByQuantizedMultiplier`: `acc · M` in the pipeline's one rounding mode (see the
/// module docs). The left shift for `shift > 0` saturates instead of overflowing.
#[inline]
pub const fn requantize(acc: i32, m: QuantizedMultiplier) -> i32 {
    let shift = m.shift as i32;
    let x = if shift > 0 {
        let wide = (acc as i64) << if shift > 32 { 32 } else { shift };
        saturate!(wide: i64 => i32)
    } else {
        acc
    };
    rounding_divide_by_pot(saturating_rounding_doubling_high_mul(x, m.multiplier), -shift)
}

/// Clamps an `i32` into `i8` (TFLite's activation clamp to [−128, 127]).
#[inline]
pub const fn saturate_i8(x: i32) -> i8 {
    saturate!(x: i32 => i8)
}

/// [`requantize`] followed by [`saturate_i8`]: an int8 activation from an `i32` accumulator.
#[inline]
pub const fn requantize_i8(acc: i32, m: QuantizedMultiplier) -> i8 {
    saturate_i8(requantize(acc, m))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// splitmix64: the randomized tests' inputs.
    use crate::SplitMix64 as Rng;

    /// `rounding_divide_by_pot` in 64 bits, as gemmlowp states it: the specification of the int32
    /// form.
    fn rounding_divide_by_pot_i64(x: i32, exponent: i32) -> i32 {
        if exponent <= 0 {
            return x;
        }
        if exponent >= 32 {
            return 0;
        }
        let x = x as i64;
        let mask = (1i64 << exponent) - 1;
        let threshold = (mask >> 1) + (x < 0) as i64;
        ((x >> exponent) + ((x & mask) > threshold) as i64) as i32
    }

    #[test]
    fn rounding_divide_by_pot_in_32_bits_is_the_64_bit_one() {
        let mut rng = Rng(3);
        for exponent in -2..=40 {
            let edges = [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX - 1, i32::MAX];
            // Ties and their neighbours at this exponent: ±(k · 2^e ± 2^(e−1) ± 1).
            let ties = (1..=31).contains(&exponent).then(|| {
                let half = 1i64 << (exponent - 1);
                [half - 1, half, half + 1, 3 * half, 3 * half + 1].map(|v| v.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
            });
            let random = (0..2000).map(|_| rng.next_u64() as i32);
            for x in edges.into_iter().chain(ties.into_iter().flatten().flat_map(|t| [t, -t])).chain(random) {
                assert_eq!(rounding_divide_by_pot(x, exponent), rounding_divide_by_pot_i64(x, exponent), "{x} / 2^{exponent}");
            }
        }
    }

    #[test]
    fn golden_multipliers() {
        // 0.5 = 2^30 · 2^(0−31).
        assert_eq!(QuantizedMultiplier::from_f64(0.5), Some(QuantizedMultiplier::from_raw(1 << 30, 0)));
        // 1.0 = 0.5 · 2^1.
        assert_eq!(QuantizedMultiplier::from_f64(1.0), Some(QuantizedMultiplier::from_raw(1 << 30, 1)));
        // 0.75 = 0.75 · 2^0 → 0.75 · 2^31 = 1 610 612 736.
        assert_eq!(QuantizedMultiplier::from_f64(0.75), Some(QuantizedMultiplier::from_raw(1_610_612_736, 0)));
        // 1/127 = 0.5039… · 2^−6; round(2^37 / 127) = 1 082 196 484 (2^37/127 = 1 082 196 484.03).
        assert_eq!(QuantizedMultiplier::from_f64(1.0 / 127.0), Some(QuantizedMultiplier::from_raw(1_082_196_484, -6)));
        // 3.0 = 0.75 · 2^2.
        assert_eq!(QuantizedMultiplier::from_f64(3.0), Some(QuantizedMultiplier::from_raw(1_610_612_736, 2)));
        // A mantissa that rounds up to 2^31 renormalises: (1 − 2^−40) → 0.5 · 2^1.
        assert_eq!(QuantizedMultiplier::from_f64(1.0 - 1e-12), Some(QuantizedMultiplier::from_raw(1 << 30, 1)));
        assert_eq!(QuantizedMultiplier::from_f64(0.0), Some(QuantizedMultiplier::ZERO));
        assert_eq!(QuantizedMultiplier::from_f64(1e-12), Some(QuantizedMultiplier::ZERO));
        assert_eq!(QuantizedMultiplier::from_f64(1e12), Some(QuantizedMultiplier::from_raw(i32::MAX, 30)));
        assert_eq!(QuantizedMultiplier::from_f64(-1.0), None);
        assert_eq!(QuantizedMultiplier::from_f64(f64::NAN), None);
        assert_eq!(QuantizedMultiplier::from_f64(f64::INFINITY), None);
        assert!(QuantizedMultiplier::from_f64(0.3).unwrap().is_normalised());
        assert!(!QuantizedMultiplier::from_raw(5, 0).is_normalised());
        assert!(!QuantizedMultiplier::from_raw(1 << 30, 31).is_normalised());
    }

    #[test]
    fn golden_requantize() {
        let half = QuantizedMultiplier::from_raw(1 << 30, 0);
        // SRDHM breaks ties upward (toward +∞): 3·0.5 = 1.5 → 2, −3·0.5 = −1.5 → −1, 2.5 → 3,
        // −2.5 → −2.
        assert_eq!(requantize(3, half), 2);
        assert_eq!(requantize(-3, half), -1);
        assert_eq!(requantize(5, half), 3);
        assert_eq!(requantize(-5, half), -2);
        assert_eq!(requantize(4, half), 2);
        // 0.25 = 0.5 · 2^−1: SRDHM(6, 2^30) = 3, RDBPOT(3, 1) = round(1.5) = 2 (RDBPOT breaks ties
        // away from zero, so −6 → SRDHM −3 → −2).
        let quarter = QuantizedMultiplier::from_raw(1 << 30, -1);
        assert_eq!(requantize(6, quarter), 2);
        assert_eq!(requantize(-6, quarter), -2);
        // Double rounding: 7·0.25 = 1.75: SRDHM(7, 2^30) = round(3.5) = 4, RDBPOT(4, 1) = 2.
        assert_eq!(requantize(7, quarter), 2);
        // 1/127 on a product of two full-scale int8: 127·127/127 = 127. Double rounding shows at
        // 63/127 ≈ 0.496: SRDHM(63, m) = round(31.75) = 32, then RDBPOT(32, 6) = round(0.5) = 1.
        // 62/127 ≈ 0.488: SRDHM = round(31.24) = 31, RDBPOT(31, 6) = round(0.484) = 0.
        let inv127 = QuantizedMultiplier::from_f64(1.0 / 127.0).unwrap();
        assert_eq!(requantize(127 * 127, inv127), 127);
        assert_eq!(requantize(62, inv127), 0);
        assert_eq!(requantize(63, inv127), 1);
        assert_eq!(requantize(-63, inv127), -1);
        assert_eq!(requantize(64, inv127), 1);
        assert_eq!(requantize(-64, inv127), -1);
        // 3.0 shifts left by 2 first: 1000·3 = 3000.
        let three = QuantizedMultiplier::from_f64(3.0).unwrap();
        assert_eq!(requantize(1000, three), 3000);
        // The left shift saturates.
        assert_eq!(requantize(i32::MAX, three), saturating_rounding_doubling_high_mul(i32::MAX, three.multiplier));
        assert_eq!(requantize(i32::MIN, QuantizedMultiplier::from_raw(i32::MIN, 0)), i32::MAX);
        assert_eq!(saturate_i8(300), 127);
        assert_eq!(saturate_i8(-300), -128);
        assert_eq!(saturate_i8(-5), -5);
        assert_eq!(requantize_i8(1000, half), 127);
    }

    #[test]
    fn primitives_match_gemmlowp() {
        assert_eq!(saturating_rounding_doubling_high_mul(i32::MIN, i32::MIN), i32::MAX);
        assert_eq!(saturating_rounding_doubling_high_mul(1 << 30, 1 << 30), 1 << 29);
        // (2^31 − 1)·1 / 2^31 = 0.99999… → 1.
        assert_eq!(saturating_rounding_doubling_high_mul(i32::MAX, 1), 1);
        assert_eq!(saturating_rounding_doubling_high_mul(i32::MIN, 1), -1);
        assert_eq!(rounding_divide_by_pot(5, 1), 3);
        assert_eq!(rounding_divide_by_pot(-5, 1), -3);
        assert_eq!(rounding_divide_by_pot(-4, 1), -2);
        assert_eq!(rounding_divide_by_pot(i32::MIN, 31), -1);
        assert_eq!(rounding_divide_by_pot(i32::MAX, 31), 1);
        assert_eq!(rounding_divide_by_pot(i32::MAX, 40), 0);
        assert_eq!(rounding_divide_by_pot(7, 0), 7);
    }

    #[test]
    fn never_panics_on_any_shift() {
        for shift in i8::MIN..=i8::MAX {
            for &acc in &[i32::MIN, -1, 0, 1, i32::MAX, 123_456] {
                for &mult in &[i32::MIN, -1, 0, 1, 1 << 30, i32::MAX] {
                    let _ = requantize(acc, QuantizedMultiplier::from_raw(mult, shift));
                }
            }
        }
    }

    #[test]
    fn within_one_lsb_of_the_real_product() {
        let mut rng = Rng(0x5EED_0001);
        let mut worst_repr = 0.0f64;
        let mut worst_real = 0.0f64;
        for _ in 0..200_000 {
            // Multipliers log-uniform in [2^−24, 2^4), accumulators up to 2^24 in magnitude, sized
            // so no result leaves i32.
            let real = (2.0f64).powf(rng.unit() * 28.0 - 24.0);
            let m = QuantizedMultiplier::from_f64(real).unwrap();
            assert!(m.is_normalised(), "{real} -> {m:?}");
            let mag = (rng.unit() * (1u64 << 24) as f64) as i64;
            let acc = if rng.next_u64() & 1 == 0 { mag } else { -mag } as i32;
            let got = requantize(acc, m) as f64;
            // Against the multiplier's exact value, and against the real number it came from.
            let e_repr = (got - acc as f64 * m.to_f64()).abs();
            let e_real = (got - acc as f64 * real).abs();
            assert!(e_repr <= 1.0, "acc {acc} real {real} {m:?}: got {got}, err {e_repr}");
            assert!(e_real <= 1.0, "acc {acc} real {real} {m:?}: got {got}, err {e_real}");
            worst_repr = worst_repr.max(e_repr);
            worst_real = worst_real.max(e_real);
        }
        assert!(worst_repr > 0.5, "double rounding should show up somewhere: {worst_repr}");
        let _ = worst_real;
    }

    #[test]
    fn to_f64_round_trips_the_real_within_half_an_ulp_of_q31() {
        let mut rng = Rng(7);
        for _ in 0..100_000 {
            let real = (2.0f64).powf(rng.unit() * 50.0 - 30.0);
            let m = QuantizedMultiplier::from_f64(real).unwrap();
            let rel = (m.to_f64() - real).abs() / real;
            assert!(rel <= 1.0 / (1u64 << 31) as f64, "{real}: {m:?} rel {rel}");
        }
    }
}
