//! Tests of the parent module (`geo.rs`).

#![allow(clippy::needless_range_loop)] // the reference is index loops on purpose
extern crate std;
use super::super::testing::Rng;
use super::*;
use std::vec::Vec;

/// A valid blob with random weights, biases and multipliers and a steep odd table.
fn random_geo_blob(seed: u64) -> [u8; GEO_BLOB_LEN] {
    let mut rng = Rng(seed);
    let mut mult = |shift: i8| QuantizedMultiplier::from_raw((1 << 30) + (rng.next() % (1 << 30)) as i32, shift);
    let hidden: [GeoChannel; GEO_HIDDEN] = core::array::from_fn(|_| GeoChannel { bias: 0, multiplier: mult(-8) });
    let output = GeoChannel { bias: 0, multiplier: mult(-9) };
    let mut rng = Rng(seed ^ 0xABCD);
    let mut hidden = hidden;
    for h in hidden.iter_mut() {
        h.bias = (rng.next() % 8001) as i32 - 4000;
    }
    let output = GeoChannel { bias: (rng.next() % 20001) as i32 - 10_000, ..output };
    let tanh: [i8; 256] = core::array::from_fn(|q| ((q as i32 - 128) * 2).clamp(-127, 127) as i8);
    let w1: [[i8; GEO_FEATURES]; GEO_HIDDEN] = core::array::from_fn(|_| core::array::from_fn(|_| rng.next() as i8));
    let w2: [i16; GEO_HIDDEN] = core::array::from_fn(|_| rng.next() as i16);
    let mut blob = [0u8; GEO_BLOB_LEN];
    write_geo_blob(&hidden, output, &tanh, &w1, &w2, &mut blob);
    blob
}

/// A room-like scan: a smooth range profile with steps (objects), dropouts and no-returns.
fn random_scan(rng: &mut Rng) -> [u16; BEAMS] {
    let mut r = 1000 + (rng.next() % 8000) as i64;
    core::array::from_fn(|_| {
        match rng.next() % 40 {
            0 => return RANGE_INVALID,
            1 => return RANGE_NO_RETURN,
            2 => r = 300 + (rng.next() % 20_000) as i64,
            // The far end of the range (the features' 64-bit bounds): up to 65.5 m.
            3 => r = 60_000 + (rng.next() % 5_500) as i64,
            _ => r = (r + (rng.next() % 41) as i64 - 20).clamp(150, 65_500),
        }
        r as u16
    })
}

/// The features written out the long way: walks for the runs (no laps), index loops.
fn reference_features(r: &[u16; BEAMS], b: usize) -> Vec<i8> {
    let mut f = std::vec![0i8; GEO_FEATURES];
    let ok = |x: u16| x != RANGE_INVALID && x != RANGE_NO_RETURN;
    if !ok(r[b]) {
        return f;
    }
    let dir = |k: usize| {
        let (s, c) = sin_cos(beam_angle(k));
        ((c.to_bits() >> 16) as i64, (s.to_bits() >> 16) as i64)
    };
    let pt = |k: usize| {
        let (c, s) = dir(k);
        let rr = r[k] as i64 * 16;
        ((rr * c) >> 14, (rr * s) >> 14)
    };
    let (dx, dy) = dir(b);
    let r16 = r[b] as i64 * 16;
    for k in 0..GEO_WIDTHS.len() {
        let w = GEO_WIDTHS[k] as i64;
        let l = (b as i64 - w).rem_euclid(BEAMS as i64) as usize;
        let h = (b as i64 + w).rem_euclid(BEAMS as i64) as usize;
        if !ok(r[l]) || !ok(r[h]) {
            continue;
        }
        let (p, q) = (pt(l), pt(h));
        let (ex, ey) = (q.0 - p.0, q.1 - p.1);
        let den = dx * ey - dy * ex;
        if den == 0 {
            continue;
        }
        let t = (p.0 * ey - p.1 * ex) * 16384 / den;
        if t > 0 {
            f[2 * k] = ((t - r16) * 127 / r16).clamp(-127, 127) as i8;
            f[2 * k + 1] = 127;
        }
    }
    for (side, step) in [(0usize, -1i64), (1, 1)] {
        let (mut n, mut kind, mut prev, mut cur) = (0i64, 0u8, r[b] as i64, b as i64);
        while n < 300 {
            cur += step;
            let x = r[cur.rem_euclid(BEAMS as i64) as usize];
            if !ok(x) {
                kind = 3;
                break;
            }
            let x = x as i64;
            if (x - prev).abs() * 100 > 10_000 + 3 * prev {
                kind = if x > prev { 1 } else { 2 };
                break;
            }
            prev = x;
            n += 1;
        }
        let base = 2 * GEO_WIDTHS.len() + 3 * side;
        f[base] = (n * r[b] as i64 * 797_964 / 5_382_000_000).min(127) as i8;
        f[base + 1] = [0, 127, -127, 0][kind as usize];
        f[base + 2] = if kind == 3 { 127 } else { 0 };
    }
    f[SCAN_FEATURES - 1] = (63_500 / r[b] as i64).min(127) as i8;
    f
}

fn reference_forward(m: &GeoView<'_>, x: &[i8]) -> i64 {
    let b = m.bytes();
    let mut acc2 = 0i64;
    for j in 0..GEO_HIDDEN {
        let mut acc = 0i64;
        for i in 0..GEO_FEATURES {
            acc += b[W1 + j * GEO_FEATURES + i] as i8 as i64 * x[i] as i64;
        }
        let c = m.hidden(j);
        let pre = requantize_i8((acc + c.bias as i64) as i32, c.multiplier);
        let v2 = i16::from_le_bytes([b[W2 + 2 * j], b[W2 + 2 * j + 1]]) as i64;
        acc2 += v2 * b[TANH + (pre as i32 + 128) as usize] as i8 as i64;
    }
    acc2 + m.output().bias as i64
}

#[test]
fn the_chord_feature_matches_its_64_bit_specification_at_every_boundary() {
    let mut rng = Rng(11);
    for _ in 0..20_000 {
        let r16 = 16 * (1 + (rng.next() % 65_534) as i64);
        let den = (rng.next() % (1 << 36)) as i64 * if rng.next() & 1 == 0 { 1 } else { -1 };
        let sign = den.signum().max(1);
        // Around the edges the fast paths decide on: t = 0 / 1 (num ≈ den), t = 2·r16
        // (num ≈ 2·r16·den), then anywhere in range, each ±1 and with both signs flipped.
        let base = match rng.next() % 4 {
            0 => den,
            1 => 2 * r16 * den,
            2 => (r16 + (rng.next() % r16 as u64) as i64) * den,
            _ => (rng.next() % (1 << 56)) as i64 * sign,
        };
        for num in [base - 1, base, base + 1, -(base - 1), -base, -(base + 1)] {
            assert_eq!(chord_protrusion(num, den, r16), chord_protrusion_reference(num, den, r16), "{num} / {den}, r16 {r16}");
        }
    }
    assert_eq!(chord_protrusion(5, 0, 16), None);
}

#[test]
fn features_and_network_match_an_independent_reference_on_random_scans() {
    let mut rng = Rng(7);
    let mut s = GeoScratch::new();
    for seed in 0..6 {
        let blob = random_geo_blob(seed);
        let m = GeoView::parse(&blob).unwrap();
        for _ in 0..4 {
            let r = random_scan(&mut rng);
            s.prepare(&r);
            for b in 0..BEAMS {
                let f = s.features(&r, b);
                assert_eq!(&f[..], &reference_features(&r, b)[..], "beam {b}");
                assert_eq!(geo_forward(&m, &f).0 as i64, reference_forward(&m, &f), "beam {b}");
            }
        }
    }
}

#[test]
fn a_straight_wall_has_no_protrusion_and_a_box_in_front_of_it_does() {
    // A wall 3 m ahead across beams 400..=500 (beam 448 looks straight ahead), a box at 2 m
    // on beams 440..=456.
    let mut r = [RANGE_NO_RETURN; BEAMS];
    // Range to a line `d` mm ahead along beam `b`: d / cos(angle off beam 448).
    let to_line = |b: usize, d: i64| (d << 30) / fixed_point::cos(beam_angle(b) - beam_angle(448)).to_bits() as i64;
    for b in 380..=520 {
        r[b] = to_line(b, 3000) as u16;
    }
    let wall = r;
    for b in 440..=456 {
        r[b] = to_line(b, 2000) as u16;
    }
    let mut s = GeoScratch::new();
    s.prepare(&wall);
    let f = s.features(&wall, 448);
    for k in 0..5 {
        assert!(f[2 * k].abs() <= 1 && f[2 * k + 1] == 127, "width {}: {f:?}", GEO_WIDTHS[k]);
    }
    s.prepare(&r);
    let f = s.features(&r, 448);
    // The chords 16 and 32 beams wide span the box and meet the wall behind it: +50 %.
    assert!(f[6] > 55 && f[8] > 55, "{f:?}");
    // Depth jumps to a farther surface on both sides, 8 beams away.
    let base = 2 * GEO_WIDTHS.len();
    assert_eq!((f[base + 1], f[base + 4]), (127, 127));
    assert_eq!((f[base + 2], f[base + 5]), (0, 0));
    // Beams without a return have no features.
    assert_eq!(s.features(&r, 0), [0; GEO_FEATURES]);
}

#[test]
fn the_label_history_is_read_where_each_direction_was_then() {
    use super::super::{ScanHistory, LABEL_ROWS};
    use fixed_point::{BinaryAngle, Pose2};
    let mut h = ScanHistory::new();
    let scan = [1000u16; BEAMS];
    // Before any scan, and on the first scan (no earlier outputs): zeros.
    assert_eq!(history_features(&h, 10), [0, 0]);
    h.push_scan(&Pose2::IDENTITY, &scan, &super::super::Normalisation::DEFAULT);
    assert_eq!(history_features(&h, 10), [0, 0]);
    // Output of that step: +127 at beam 100 only, −127 elsewhere.
    let mut row = [-127i8; BEAMS];
    row[100] = 127;
    h.push_labels(&row);
    // The robot then turns left by 10 beams' worth: the direction beam 100 saw is now beam 90.
    let turn = BinaryAngle::from_fraction(10, BEAMS as i64);
    h.push_scan(&Pose2 { theta: turn, ..Pose2::IDENTITY }, &scan, &super::super::Normalisation::DEFAULT);
    let [last, avg] = history_features(&h, 90);
    assert_eq!(last, 127);
    // One filled label row of weight 8/36 (the newest): 127 · 8 / 36 = 28.2 → 28.
    assert_eq!(avg, 28);
    assert_eq!(history_features(&h, 100), [-127, -28]);
    // Wrap-around: beam 0 now reads beam 10 then.
    assert_eq!(history_features(&h, 0)[0], -127);
    // A full history of +127: the average is +127.
    let mut h = ScanHistory::new();
    for _ in 0..=LABEL_ROWS {
        h.push_scan(&Pose2::IDENTITY, &scan, &super::super::Normalisation::DEFAULT);
        h.push_labels(&[127; BEAMS]);
    }
    h.push_scan(&Pose2::IDENTITY, &scan, &super::super::Normalisation::DEFAULT);
    assert_eq!(history_features(&h, 400), [127, 127]);
}

#[test]
fn a_bad_blob_is_refused_with_its_reason_and_never_panics() {
    let blob = random_geo_blob(1);
    assert!(GeoView::parse(&blob).is_ok());
    let mut b = blob;
    b[GEO_BLOB_LEN - 1] ^= 1;
    assert!(matches!(GeoView::parse(&b), Err(ModelError::ChecksumMismatch { .. })));
    assert_eq!(GeoView::parse(&blob[..100]).unwrap_err(), ModelError::Truncated { needed: GEO_BLOB_LEN, got: 100 });
    assert_eq!(GeoView::parse(&blob[..20]).unwrap_err(), ModelError::Truncated { needed: GEO_HEADER_LEN, got: 20 });
    let mut long = blob.to_vec();
    long.push(0);
    assert_eq!(GeoView::parse(&long).unwrap_err(), ModelError::TrailingBytes { extra: 1 });
    let mut b = blob;
    b[4] = 1;
    assert_eq!(GeoView::parse(&b).unwrap_err(), ModelError::UnsupportedVersion(1));
    let mut b = blob;
    b[8] = 20;
    assert_eq!(
        GeoView::parse(&b).unwrap_err(),
        ModelError::ShapeMismatch { field: super::super::ShapeField::GeoFeatures, expected: GEO_FEATURES as u32, found: 20 }
    );
    let mut b = blob;
    b[25] = 1;
    assert_eq!(GeoView::parse(&b).unwrap_err(), ModelError::ReservedNotZero);
    // A multiplier that is not normalised, with a valid CRC.
    let mut b = blob;
    b[GEO_HEADER_LEN + 4..GEO_HEADER_LEN + 8].copy_from_slice(&5i32.to_le_bytes());
    let crc = geo_checksum(&b).unwrap();
    b[16..20].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(GeoView::parse(&b).unwrap_err(), ModelError::BadGeoMultiplier { channel: 0 });
    assert_eq!(GeoView::parse(b"LVG").unwrap_err(), ModelError::BadMagic);
    // Random corruption: an error or a blob, never a panic.
    let mut rng = Rng(9);
    for _ in 0..2000 {
        let mut b = blob;
        let n = (rng.next() % 4 + 1) as usize;
        for _ in 0..n {
            let i = (rng.next() as usize) % GEO_BLOB_LEN;
            b[i] = rng.next() as u8;
        }
        let cut = (rng.next() as usize) % (GEO_BLOB_LEN + 1);
        let _ = GeoView::parse(&b[..cut]);
        let _ = GeoView::parse(&b);
    }
}
