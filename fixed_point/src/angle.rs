//! Binary angles: one full turn is 2³² units of an `i32`, so addition wraps exactly like angles do
//! and a beam index maps to an angle by exact integer arithmetic ([`BinaryAngle::from_fraction`]).

use crate::round_f64_to_i64;

/// An angle as a binary angular measurement: `2³²` units per turn, stored in an `i32` that wraps.
/// `0` is the x axis, positive is counter-clockwise (REP-103). `i32::MIN` is ±180°.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct BinaryAngle(pub i32);

impl BinaryAngle {
    /// Zero.
    pub const ZERO: Self = Self(0);
    /// A quarter turn (90°).
    pub const QUARTER: Self = Self(1 << 30);
    /// A half turn (180°, also −180°).
    pub const HALF: Self = Self(i32::MIN);
    /// Units per radian, 2³¹ / π.
    pub const UNITS_PER_RAD: f64 = 683_565_275.576_431_6;

    /// `num / den` of a full turn, floored, by exact integer arithmetic: beam `i` of `n` beams over
    /// a full circle is `from_fraction(i, n)`. `den == 0` gives zero.
    pub const fn from_fraction(num: i64, den: i64) -> Self {
        if den == 0 {
            return Self(0);
        }
        let units = (num as i128 * (1i128 << 32)).div_euclid(den as i128);
        Self(units as u32 as i32)
    }

    /// `num / den` of a full turn, rounded to nearest (ties up).
    pub const fn from_fraction_rounded(num: i64, den: i64) -> Self {
        if den == 0 {
            return Self(0);
        }
        let n = num as i128 * (1i128 << 33) + den as i128;
        Self((n.div_euclid(2 * den as i128)) as u32 as i32)
    }

    /// Whole degrees (exact when 360 divides `deg·2³²`, otherwise floored).
    pub const fn from_degrees(deg: i32) -> Self {
        Self::from_fraction(deg as i64, 360)
    }

    /// From radians, rounded to nearest; `None` for NaN or ±inf. Boundary conversion only.
    pub fn from_radians(rad: f64) -> Option<Self> {
        if !rad.is_finite() {
            return None;
        }
        // Reduce to one turn first so the product stays exact in an f64 mantissa.
        let turns = rad / core::f64::consts::TAU;
        let frac = turns - (turns as i64) as f64;
        let units = round_f64_to_i64(frac * 4_294_967_296.0);
        Some(Self(units as u32 as i32))
    }

    /// To radians in (−π, π]. Boundary conversion only (rendering, logs).
    pub fn to_radians(self) -> f64 {
        self.0 as f64 / Self::UNITS_PER_RAD
    }

    /// Wrapping sum.
    #[inline]
    pub const fn add(self, o: Self) -> Self {
        Self(self.0.wrapping_add(o.0))
    }

    /// Wrapping difference, i.e. the signed shortest rotation from `o` to `self`.
    #[inline]
    pub const fn sub(self, o: Self) -> Self {
        Self(self.0.wrapping_sub(o.0))
    }

    /// Wrapping negation.
    #[inline]
    pub const fn neg(self) -> Self {
        Self(self.0.wrapping_neg())
    }

    /// Absolute value of the shortest rotation, as an unsigned number of units (≤ 2³¹).
    #[inline]
    pub const fn unsigned_abs(self) -> u32 {
        self.0.unsigned_abs()
    }
}

impl core::ops::Add for BinaryAngle {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        BinaryAngle::add(self, o)
    }
}

impl core::ops::Sub for BinaryAngle {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        BinaryAngle::sub(self, o)
    }
}

impl core::ops::Neg for BinaryAngle {
    type Output = Self;
    fn neg(self) -> Self {
        BinaryAngle::neg(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beam_index_maps_exactly() {
        // 897 beams over a full turn: beam 897 would be exactly one turn, i.e. angle 0 again.
        assert_eq!(BinaryAngle::from_fraction(897, 897), BinaryAngle(0));
        assert_eq!(BinaryAngle::from_fraction(0, 897), BinaryAngle(0));
        let step = BinaryAngle::from_fraction(1, 897).0 as i64;
        assert_eq!(step, (1i64 << 32) / 897);
        assert_eq!(BinaryAngle::from_degrees(90), BinaryAngle::QUARTER);
        assert_eq!(BinaryAngle::from_degrees(180), BinaryAngle::HALF);
        assert_eq!(BinaryAngle::from_degrees(-90).0, -(1 << 30));
    }

    #[test]
    fn wraps_like_an_angle() {
        let a = BinaryAngle::from_degrees(170);
        let b = BinaryAngle::from_degrees(20);
        let s = a + b; // 190° == -170°
        assert!((s.to_radians() + 170f64.to_radians()).abs() < 1e-8);
        assert_eq!((b - a).unsigned_abs(), BinaryAngle::from_degrees(150).unsigned_abs());
    }

    #[test]
    fn radians_round_trip() {
        for i in -1000..1000 {
            let r = i as f64 * 0.0123;
            let a = BinaryAngle::from_radians(r).unwrap();
            let back = a.to_radians();
            let d = (back - r).rem_euclid(core::f64::consts::TAU);
            let d = if d > core::f64::consts::PI { d - core::f64::consts::TAU } else { d };
            assert!(d.abs() < 2e-9, "{r} -> {back}");
        }
        assert_eq!(BinaryAngle::from_radians(f64::NAN), None);
    }
}
