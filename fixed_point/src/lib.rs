//! # `fixed_point` — the numbers the LIVES controller decides with
//!
//! Every value on a path that decides one of the controller's outputs (a goal, a path, a stop) is
//! an integer or a fixed-point number from this crate, so the core gives bit-identical answers on
//! x86_64 and on a Cortex-M. Floats appear only at the boundary (`from_f64` / `to_f64`), where a
//! host turns sensor data into the core's units once.
//!
//! | type | representation | range | resolution |
//! |---|---|---|---|
//! | [`Meters`] | `fixed::types::I16F16` (Q16.16) | ±32 768 m | 15.26 µm |
//! | [`Unit`] | `fixed::types::I2F30` (Q2.30), results of sin/cos | [−2, 2) | 9.3 × 10⁻¹⁰ |
//! | [`BinaryAngle`] | `i32`, one turn = 2³², wraps | one turn | 1.46 × 10⁻⁹ rad |
//! | [`Pose2`] | x, y in [`Meters`], θ a [`BinaryAngle`] | | |
//!
//! ## Functions and their error bounds (tested against `f64` on ≥ 10⁵ inputs each)
//! | function | method | bound (absolute) |
//! |---|---|---|
//! | [`sin`], [`cos`] | quarter-wave table, 1 025 entries, linear interpolation | ≤ 4 × 10⁻⁷ |
//! | [`atan2`] | octant reduction + atan table on [0, 1], 1 025 entries, interpolation | ≤ 2 × 10⁻⁷ rad |
//! | [`sqrt`] | exact integer square root of the Q32.32 square | floor: −2⁻¹⁶ < err ≤ 0 |
//! | [`hypot`] | exact integer square root of dx² + dy² | floor: −2⁻¹⁶ < err ≤ 0 |
//!
//! The tables are computed at compile time by `const fn`s with 128-bit integer arithmetic only
//! (series for sin and atan), so they are the same bits on every target and every build host.
//! Our own implementations are differentially tested against the `cordic` crate (the well-kept
//! fixed-point reference that builds on the same `fixed` types) and against `f64`.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod angle;
mod pose;
mod quant;
mod splitmix;
mod tables;
mod trig;

pub use angle::BinaryAngle;
pub use fixed;
pub use pose::Pose2;
pub use quant::*;
pub use splitmix::SplitMix64;
pub use trig::{atan2, cos, hypot, isqrt_u64, sin, sin_cos, sqrt};

/// Metres, as a Q16.16 fixed-point number (range ±32 768 m, resolution 2⁻¹⁶ m ≈ 15 µm).
pub type Meters = fixed::types::I16F16;

/// A dimensionless value in [−2, 2) with 30 fractional bits: what [`sin`] and [`cos`] return.
pub type Unit = fixed::types::I2F30;

/// Multiplies metres by a unit value (e.g. a cosine), rounding half up, saturating on overflow.
#[inline]
pub fn mul_unit(m: Meters, u: Unit) -> Meters {
    let p = (m.to_bits() as i64) * (u.to_bits() as i64);
    let r = (p + (1 << 29)) >> 30;
    Meters::from_bits(r.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
}

/// Converts an `f64` number of metres to [`Meters`], rounding to nearest; `None` for NaN, ±inf or
/// a value outside ±32 767 m. This is the boundary where floats enter the core.
pub fn meters_from_f64(v: f64) -> Option<Meters> {
    if !v.is_finite() || v.abs() > 32_767.0 {
        return None;
    }
    Some(Meters::from_bits(round_f64_to_i64(v * 65_536.0) as i32))
}

/// Rounds half away from zero without `std` (`f64::round` is not in `core` on every toolchain).
#[inline]
pub(crate) fn round_f64_to_i64(v: f64) -> i64 {
    if v >= 0.0 {
        (v + 0.5) as i64
    } else {
        (v - 0.5) as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mul_unit_rounds_and_saturates() {
        let half = Unit::from_num(0.5);
        assert_eq!(mul_unit(Meters::from_num(3), half), Meters::from_num(1.5));
        assert_eq!(mul_unit(Meters::from_num(-3), half), Meters::from_num(-1.5));
        let big = Meters::MAX;
        assert_eq!(mul_unit(big, Unit::from_num(1.9)), Meters::MAX);
        assert_eq!(mul_unit(Meters::MIN, Unit::from_num(1.9)), Meters::MIN);
    }

    #[test]
    fn meters_boundary_rejects_non_finite() {
        assert_eq!(meters_from_f64(f64::NAN), None);
        assert_eq!(meters_from_f64(f64::INFINITY), None);
        assert_eq!(meters_from_f64(-1e9), None);
        assert_eq!(meters_from_f64(1.25), Some(Meters::from_num(1.25)));
        assert_eq!(meters_from_f64(-0.1).unwrap().to_bits(), -6554);
    }
}
