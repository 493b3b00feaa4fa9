//! Differential tests of the crate's trig and roots: ≥ 10⁵ inputs each against `f64`, and against
//! the `cordic` crate / the `fixed` crate where they compute the same function. The bounds asserted
//! here are the ones stated in the crate docs.

use fixed_point::fixed::types::{I16F16, I4F28};
use fixed_point::{atan2, cos, hypot, isqrt_u64, sin, sqrt, BinaryAngle, Meters, Pose2};
use std::f64::consts::PI;

const N: usize = 200_000;

/// SplitMix64: a fixed, seedable input stream so the tests see the same inputs every run.
use fixed_point::SplitMix64 as Inputs;

fn wrap_pi(a: f64) -> f64 {
    let r = (a + PI).rem_euclid(2.0 * PI) - PI;
    if r <= -PI {
        r + 2.0 * PI
    } else {
        r
    }
}

#[test]
fn sin_cos_within_bound_of_f64_and_agree_with_cordic() {
    let mut rng = Inputs(1);
    let (mut worst, mut worst_cordic_gap) = (0f64, 0f64);
    for i in 0..N {
        // Every 7th input is a "nice" angle (multiples of 1°) to cover the table knots.
        let a = if i % 7 == 0 { BinaryAngle::from_fraction((i / 7) as i64 % 360, 360) } else { BinaryAngle(rng.next_u64() as i32) };
        let r = a.to_radians();
        let (s, c) = (sin(a).to_num::<f64>(), cos(a).to_num::<f64>());
        worst = worst.max((s - r.sin()).abs()).max((c - r.cos()).abs());
        let (cs, cc) = cordic::sin_cos(I4F28::from_num(r));
        worst_cordic_gap = worst_cordic_gap.max((s - cs.to_num::<f64>()).abs()).max((c - cc.to_num::<f64>()).abs());
    }
    assert!(worst <= 4e-7, "sin/cos max error {worst:e}");
    // cordic's own error is ~1.2e-4 (CRATES.md); we must agree to within that.
    assert!(worst_cordic_gap <= 2e-4, "sin/cos vs cordic {worst_cordic_gap:e}");
}

#[test]
fn atan2_within_bound_of_f64_and_agree_with_cordic() {
    let mut rng = Inputs(2);
    let (mut worst, mut worst_cordic_gap) = (0f64, 0f64);
    for i in 0..N {
        let (y, x) = match i % 4 {
            // full i32 range
            0 => (rng.next_u64() as i32, rng.next_u64() as i32),
            // metres-sized vectors in Q16.16 (±40 m)
            1 => (((rng.next_u64() % 5_242_880) as i32) - 2_621_440, ((rng.next_u64() % 5_242_880) as i32) - 2_621_440),
            // tiny vectors (a few LSBs): worst case for ratio precision
            2 => ((rng.next_u64() % 64) as i32 - 32, (rng.next_u64() % 64) as i32 - 32),
            // axis-aligned and diagonals
            _ => {
                let k = (rng.next_u64() % 5) as i32 - 2;
                let m = (rng.next_u64() % 1000) as i32 + 1;
                [(0, m), (m, 0), (m * k, m), (-m, m * k)][(rng.next_u64() % 4) as usize]
            }
        };
        if x == 0 && y == 0 {
            assert_eq!(atan2(0, 0), BinaryAngle::ZERO);
            continue;
        }
        let got = atan2(y, x).to_radians();
        let want = (y as f64).atan2(x as f64);
        worst = worst.max(wrap_pi(got - want).abs());
        // cordic's CORDIC gain overflows Q16.16 for long vectors: compare within ±4 m.
        if i % 4 == 1 && x.unsigned_abs() < 4 << 16 && y.unsigned_abs() < 4 << 16 {
            let c = cordic::atan2(I16F16::from_bits(y), I16F16::from_bits(x)).to_num::<f64>();
            worst_cordic_gap = worst_cordic_gap.max(wrap_pi(got - c).abs());
        }
    }
    assert!(worst <= 2e-7, "atan2 max error {worst:e} rad");
    assert!(worst_cordic_gap <= 1e-3, "atan2 vs cordic {worst_cordic_gap:e}");
}

#[test]
fn sqrt_is_exact_floor_and_matches_fixed() {
    let mut rng = Inputs(3);
    for i in 0..N {
        let bits = if i % 3 == 0 { (rng.next_u64() % 1_000_000) as i32 } else { (rng.next_u64() >> 33) as i32 };
        let v = Meters::from_bits(bits);
        let got = sqrt(v);
        assert_eq!(got, v.sqrt(), "sqrt({v}) differs from fixed's");
        let exact = v.to_num::<f64>().sqrt();
        let err = got.to_num::<f64>() - exact;
        assert!(err <= 1e-12 && err > -1.0 / 65_536.0, "sqrt({v}) = {got}, f64 {exact}");
    }
    assert_eq!(sqrt(Meters::from_num(-4)), Meters::ZERO);
}

#[test]
fn isqrt_is_exact() {
    let mut rng = Inputs(4);
    for _ in 0..N {
        let n = rng.next_u64() >> (rng.next_u64() % 64);
        let r = isqrt_u64(n);
        assert!((r as u128) * (r as u128) <= n as u128 && ((r + 1) as u128) * ((r + 1) as u128) > n as u128, "isqrt({n}) = {r}");
    }
    assert_eq!(isqrt_u64(u64::MAX), u32::MAX as u64);
}

#[test]
fn hypot_is_floor_of_f64() {
    let mut rng = Inputs(5);
    for _ in 0..N {
        let dx = Meters::from_bits(rng.next_u64() as i32 >> 4);
        let dy = Meters::from_bits(rng.next_u64() as i32 >> 4);
        let got = hypot(dx, dy).to_num::<f64>();
        let want = dx.to_num::<f64>().hypot(dy.to_num::<f64>());
        let err = got - want;
        assert!(err <= 1e-9 && err > -1.0 / 65_536.0 - 1e-9, "hypot({dx},{dy}) = {got}, f64 {want}");
    }
}

#[test]
fn pose_compose_inverse_transform_match_f64() {
    let mut rng = Inputs(6);
    let mut worst = 0f64;
    for _ in 0..N / 2 {
        let mut p = || {
            let x = (rng.next_u64() % 6_000_000) as f64 / 100_000.0 - 30.0;
            let y = (rng.next_u64() % 6_000_000) as f64 / 100_000.0 - 30.0;
            let t = (rng.next_u64() % 6_283_185) as f64 / 1e6 - PI;
            Pose2::from_f64(x, y, t).unwrap()
        };
        let (a, b) = (p(), p());
        let (ax, ay, at) = a.to_f64();
        let (bx, by, bt) = b.to_f64();
        let c = a.compose(&b);
        let (cx, cy, ct) = c.to_f64();
        let ex = ax + at.cos() * bx - at.sin() * by;
        let ey = ay + at.sin() * bx + at.cos() * by;
        worst = worst.max((cx - ex).abs()).max((cy - ey).abs());
        assert!(wrap_pi(ct - (at + bt)).abs() < 1e-8);
        // a ∘ a⁻¹ = identity, to a few LSBs of Q16.16 plus the trig error × |t|.
        let id = a.compose(&a.inverse());
        let (ix, iy, it) = id.to_f64();
        assert!(ix.abs() < 5e-5 && iy.abs() < 5e-5 && it.abs() < 1e-9, "{id:?}");
    }
    // |error| ≤ |p|·4e-7·2 + 3 LSB ≈ 2.4e-5 + 4.6e-5 for |p| ≤ 42 m
    assert!(worst < 1e-4, "compose error {worst:e} m");
}

#[test]
fn beam_angles_are_exact_fractions_of_a_turn() {
    // The classifier's beam grid: beam i of 897 at -π + i·2π/897.
    for i in 0..897i64 {
        let a = BinaryAngle::HALF + BinaryAngle::from_fraction(i, 897);
        let want = -PI + i as f64 * 2.0 * PI / 897.0;
        assert!(wrap_pi(a.to_radians() - want).abs() < 2e-9);
    }
}
