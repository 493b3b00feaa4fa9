//! The classifier's memory of the last k steps ([`ScanHistory`]) and the integer input
//! normalisation that turns millimetres and Q16.16 poses into the network's int8 inputs.
//!
//! Rows are numbered oldest first: row `K − 1` is the newest scan. Every ring starts full of zeros,
//! which is the paper's bootstrap ("zero-value poses, scans and labels for the first k steps"):
//! the first k calls see zero rows where no scan has arrived yet.
//!
//! Normalisation (all integer, rounding half away from zero; `docs/model-format.md` has the table):
//! - range `r` mm, [`RangeEncoding::Linear`]: `0` (invalid) → 0; `65 535` (no return) → 127;
//!   otherwise `round(127 · min(r, range_max_mm) / range_max_mm)`, so 0 .. 30 m → 0 .. 127;
//!   [`RangeEncoding::Inverse`]: no return → 0; otherwise `min(127, round(127 · range_max_mm / r))`;
//!   an invalid beam takes the value of the nearest valid beam before it (wrapping), 0 if none;
//! - pose of row `t`: `rel = newest⁻¹ ∘ pose_t` (the older pose in the newest pose's frame), then
//!   `x, y → round(127 · metres · 1000 / pose_scale_mm)` clamped to ±127 and
//!   `θ → round(127 · θ / π)` with θ wrapped into [−π, π), clamped to ±127;
//!   rows not filled yet are `[0, 0, 0]`;
//! - labels are the network's own int8 outputs (scale 1/127), or their signs (±127), see
//!   [`super::LabelFeedback`]; the extra label row is their linear-weighted average.

use super::model::{Normalisation, RangeEncoding};
use super::{HISTORY, POSE_FEATURES};
use crate::capacity::BEAMS;
use crate::scan::{RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::Pose2;

/// Label rows kept: k − 1.
pub const LABEL_ROWS: usize = HISTORY - 1;
/// Sum of the label-average weights 1 + 2 + … + (k − 1) = 36.
pub const LABEL_WEIGHT_SUM: i32 = (LABEL_ROWS * (LABEL_ROWS + 1) / 2) as i32;

/// `n / d` rounded to nearest, ties away from zero (`d > 0`).
#[inline]
pub(crate) const fn div_round(n: i64, d: i64) -> i64 {
    if n >= 0 {
        (n + d / 2) / d
    } else {
        -((-n + d / 2) / d)
    }
}

/// One range in millimetres → int8 (scale 1/127). Linear: `min(r, range_max_mm) /
/// range_max_mm`. Inverse: `min(1, range_max_mm / r)`, and an invalid range gives −1, which no
/// valid range does ([`normalise_scan`] replaces it).
#[inline]
pub fn normalise_range(r_mm: u16, norm: &Normalisation) -> i8 {
    let max = norm.range_max_mm.max(1) as i64;
    match (norm.range_encoding, r_mm) {
        (RangeEncoding::Linear, RANGE_INVALID) => 0,
        (RangeEncoding::Linear, RANGE_NO_RETURN) => 127,
        (RangeEncoding::Linear, r) => div_round(127 * (r as i64).min(max), max) as i8,
        (RangeEncoding::Inverse, RANGE_INVALID) => INVALID_MARK,
        (RangeEncoding::Inverse, RANGE_NO_RETURN) => 0,
        (RangeEncoding::Inverse, r) => div_round(127 * max, r as i64).min(127) as i8,
    }
}

/// [`normalise_range`]'s mark for an invalid beam in the inverse encoding.
const INVALID_MARK: i8 = -1;

/// A whole scan → int8 inputs: [`normalise_range`] per beam; in the inverse encoding each invalid
/// beam then takes the value of the nearest valid beam before it (beam 0 looks back from beam
/// 896), or 0 when no beam is valid.
pub fn normalise_scan(ranges_mm: &[u16; BEAMS], norm: &Normalisation, row: &mut [i8; BEAMS]) {
    for (q, &r) in row.iter_mut().zip(ranges_mm.iter()) {
        *q = normalise_range(r, norm);
    }
    if norm.range_encoding == RangeEncoding::Inverse {
        let mut carry = row.iter().rev().copied().find(|&q| q != INVALID_MARK).unwrap_or(0);
        for q in row.iter_mut() {
            if *q == INVALID_MARK {
                *q = carry;
            } else {
                carry = *q;
            }
        }
    }
}

/// A Q16.16 distance → int8 (scale 1/127 of `pose_scale_mm`), clamped to ±127.
#[inline]
pub fn normalise_distance(bits: i32, norm: &Normalisation) -> i8 {
    // metres · 1000 / scale_mm = bits · 1000 / (65 536 · scale_mm).
    let d = 65_536 * norm.pose_scale_mm.max(1) as i64;
    div_round(127 * 1000 * bits as i64, d).clamp(-127, 127) as i8
}

/// A binary angle → int8 (scale π/127), clamped to ±127 (−π maps to −127).
#[inline]
pub fn normalise_angle(a: fixed_point::BinaryAngle) -> i8 {
    div_round(127 * a.0 as i64, 1 << 31).clamp(-127, 127) as i8
}

/// Scans, poses and labels of the last k steps, in fixed-size rings.
#[derive(Clone)]
pub struct ScanHistory {
    scans: [[i8; BEAMS]; HISTORY],
    labels: [[i8; BEAMS]; LABEL_ROWS],
    poses: [Pose2; HISTORY],
    /// Physical index of the oldest scan row (also of the oldest pose).
    scan_head: usize,
    /// Physical index of the oldest label row.
    label_head: usize,
    /// Scans pushed since the last clear, saturating at k.
    filled: usize,
}

impl ScanHistory {
    /// An empty history: all rows zero (the bootstrap state).
    pub const fn new() -> Self {
        Self {
            scans: [[0; BEAMS]; HISTORY],
            labels: [[0; BEAMS]; LABEL_ROWS],
            poses: [Pose2::IDENTITY; HISTORY],
            scan_head: 0,
            label_head: 0,
            filled: 0,
        }
    }

    /// Back to the bootstrap state.
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Scans pushed since the last clear, at most k.
    pub fn len(&self) -> usize {
        self.filled
    }

    /// True before the first scan.
    pub fn is_empty(&self) -> bool {
        self.filled == 0
    }

    /// Appends a scan taken at `pose`, normalised; the oldest row falls out.
    pub fn push_scan(&mut self, pose: &Pose2, ranges_mm: &[u16; BEAMS], norm: &Normalisation) {
        normalise_scan(ranges_mm, norm, &mut self.scans[self.scan_head]);
        self.poses[self.scan_head] = *pose;
        self.scan_head = (self.scan_head + 1) % HISTORY;
        self.filled = (self.filled + 1).min(HISTORY);
    }

    /// Appends a label row (int8, scale 1/127: +127 map, −127 non-map); the oldest falls out.
    pub fn push_labels(&mut self, row: &[i8; BEAMS]) {
        self.labels[self.label_head] = *row;
        self.label_head = (self.label_head + 1) % LABEL_ROWS;
    }

    /// Scan row `r` (0 oldest … k − 1 newest), normalised; `r` is taken modulo k.
    pub fn scan_row(&self, r: usize) -> &[i8; BEAMS] {
        &self.scans[(self.scan_head + r) % HISTORY]
    }

    /// Label row `r` (0 oldest … k − 2 newest); `r` is taken modulo k − 1.
    pub fn label_row(&self, r: usize) -> &[i8; BEAMS] {
        &self.labels[(self.label_head + r) % LABEL_ROWS]
    }

    /// The raw pose of scan row `r` (`None` for a row not filled yet).
    pub fn pose(&self, r: usize) -> Option<&Pose2> {
        let r = r % HISTORY;
        (r >= HISTORY - self.filled).then(|| &self.poses[(self.scan_head + r) % HISTORY])
    }

    /// The linear-weighted average of the label rows: row `i` (1 oldest … k − 1 newest) weighted
    /// `i / 36`, rounded half away from zero.
    pub fn label_average(&self, out: &mut [i8; BEAMS]) {
        for (b, o) in out.iter_mut().enumerate() {
            let mut s = 0i32;
            for r in 0..LABEL_ROWS {
                s += (r as i32 + 1) * self.label_row(r)[b] as i32;
            }
            *o = div_round(s as i64, LABEL_WEIGHT_SUM as i64) as i8;
        }
    }

    /// The pose input `[k][x, y, θ]`: each filled row relative to the newest pose, normalised;
    /// unfilled rows zero.
    pub fn pose_input(&self, norm: &Normalisation) -> [[i8; POSE_FEATURES]; HISTORY] {
        let mut out = [[0i8; POSE_FEATURES]; HISTORY];
        let Some(newest) = self.pose(HISTORY - 1) else {
            return out;
        };
        let inv = newest.inverse();
        for (r, o) in out.iter_mut().enumerate() {
            if let Some(p) = self.pose(r) {
                let rel = inv.compose(p);
                *o = [
                    normalise_distance(rel.x.to_bits(), norm),
                    normalise_distance(rel.y.to_bits(), norm),
                    normalise_angle(p.theta - newest.theta),
                ];
            }
        }
        out
    }
}

impl Default for ScanHistory {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fixed_point::{BinaryAngle, Meters};

    #[test]
    fn range_normalisation() {
        let n = Normalisation::DEFAULT;
        assert_eq!(normalise_range(RANGE_INVALID, &n), 0);
        assert_eq!(normalise_range(RANGE_NO_RETURN, &n), 127);
        assert_eq!(normalise_range(30_000, &n), 127);
        assert_eq!(normalise_range(60_000, &n), 127);
        assert_eq!(normalise_range(15_000, &n), 64); // 63.5 rounds up
        assert_eq!(normalise_range(1, &n), 0);
        assert_eq!(normalise_range(118, &n), 0); // 0.4995
        assert_eq!(normalise_range(119, &n), 1); // 0.5037
        assert_eq!(normalise_range(10_000, &n), 42); // 42.33
    }

    #[test]
    fn inverse_range_normalisation_fills_dropouts() {
        let n = Normalisation { range_max_mm: 500, range_encoding: RangeEncoding::Inverse, ..Normalisation::DEFAULT };
        assert_eq!(normalise_range(RANGE_NO_RETURN, &n), 0);
        assert_eq!(normalise_range(100, &n), 127); // closer than the reference range: clamped
        assert_eq!(normalise_range(500, &n), 127);
        assert_eq!(normalise_range(1_000, &n), 64); // 63.5
        assert_eq!(normalise_range(2_000, &n), 32); // 31.75
        assert_eq!(normalise_range(65_534, &n), 1);
        let mut ranges = [2_000u16; BEAMS];
        ranges[0] = RANGE_INVALID; // looks back to beam 896
        ranges[BEAMS - 1] = 1_000;
        ranges[10] = 500;
        ranges[11] = RANGE_INVALID;
        ranges[12] = RANGE_INVALID;
        ranges[13] = RANGE_NO_RETURN;
        let mut row = [0i8; BEAMS];
        normalise_scan(&ranges, &n, &mut row);
        assert_eq!(&row[..3], &[64, 32, 32]);
        assert_eq!(&row[10..15], &[127, 127, 127, 0, 32]);
        normalise_scan(&[RANGE_INVALID; BEAMS], &n, &mut row);
        assert!(row.iter().all(|&q| q == 0), "no valid beam: zeros");
        // The linear encoding is per beam, as before.
        normalise_scan(&ranges, &Normalisation::DEFAULT, &mut row);
        assert_eq!(&row[10..14], &[2, 0, 0, 127]);
    }

    #[test]
    fn pose_normalisation() {
        let n = Normalisation::DEFAULT; // 5 m
        assert_eq!(normalise_distance(Meters::from_num(5).to_bits(), &n), 127);
        assert_eq!(normalise_distance(Meters::from_num(-5).to_bits(), &n), -127);
        assert_eq!(normalise_distance(Meters::from_num(-50).to_bits(), &n), -127);
        assert_eq!(normalise_distance(Meters::from_num(1).to_bits(), &n), 25); // 25.4
        assert_eq!(normalise_distance(Meters::from_num(-1).to_bits(), &n), -25);
        assert_eq!(normalise_angle(BinaryAngle::QUARTER), 64); // 63.5
        assert_eq!(normalise_angle(BinaryAngle::ZERO - BinaryAngle::QUARTER), -64);
        assert_eq!(normalise_angle(BinaryAngle::HALF), -127);
        assert_eq!(normalise_angle(BinaryAngle(i32::MAX)), 127);
    }

    #[test]
    fn rings_bootstrap_with_zeros_and_order_oldest_first() {
        let n = Normalisation::DEFAULT;
        let mut h = ScanHistory::new();
        assert!(h.is_empty());
        assert_eq!(h.pose_input(&n), [[0; 3]; HISTORY]);
        for step in 0..12u16 {
            let ranges = [1000 * (step + 1); BEAMS];
            let pose = Pose2::new(Meters::from_num(step as i32), Meters::ZERO, BinaryAngle::ZERO);
            h.push_scan(&pose, &ranges, &n);
            h.push_labels(&[step as i8; BEAMS]);
            if step == 2 {
                // Three scans: rows 0..6 still zero, the newest last.
                assert_eq!(h.len(), 3);
                assert_eq!(h.scan_row(5)[0], 0);
                assert_eq!(h.scan_row(8)[0], normalise_range(3000, &n));
                let p = h.pose_input(&n);
                assert_eq!(p[5], [0, 0, 0]);
                assert_eq!(p[6], [-51, 0, 0]); // −2 m / 5 m · 127 = −50.8
                assert_eq!(p[8], [0, 0, 0]);
            }
        }
        assert_eq!(h.len(), HISTORY);
        for r in 0..HISTORY {
            assert_eq!(h.scan_row(r)[100], normalise_range(1000 * (4 + r as u16), &n));
        }
        for r in 0..LABEL_ROWS {
            assert_eq!(h.label_row(r)[7], 4 + r as i8);
        }
        // Average: Σ i·(3 + i) / 36 for i = 1..8 = (36·3 + 204) / 36 = 8.67 → 9.
        let mut avg = [0; BEAMS];
        h.label_average(&mut avg);
        assert_eq!(avg[0], 9);
        h.clear();
        assert!(h.is_empty());
        assert_eq!(h.scan_row(8)[0], 0);
    }

    #[test]
    fn label_average_weights_the_newest_most() {
        let mut h = ScanHistory::new();
        for r in 0..LABEL_ROWS {
            // Only the newest row says map (+127), all others non-map (−127).
            h.push_labels(&[if r == LABEL_ROWS - 1 { 127 } else { -127 }; BEAMS]);
        }
        let mut avg = [0; BEAMS];
        h.label_average(&mut avg);
        // 127 · (8 − 28) / 36 = −70.56 → −71.
        assert_eq!(avg[3], -71);
        // Saturated histories stay within int8.
        let mut h = ScanHistory::new();
        for _ in 0..LABEL_ROWS {
            h.push_labels(&[-128; BEAMS]);
        }
        h.label_average(&mut avg);
        assert_eq!(avg[0], -128);
    }

    #[test]
    fn poses_are_relative_to_the_newest() {
        let n = Normalisation::DEFAULT;
        let mut h = ScanHistory::new();
        let ranges = [2000; BEAMS];
        // The robot at (10, 10) facing +y; one second earlier it was 1 m behind, facing +x.
        let old = Pose2::new(Meters::from_num(10), Meters::from_num(9), BinaryAngle::ZERO);
        let new = Pose2::new(Meters::from_num(10), Meters::from_num(10), BinaryAngle::QUARTER);
        h.push_scan(&old, &ranges, &n);
        h.push_scan(&new, &ranges, &n);
        let p = h.pose_input(&n);
        // In the newest frame (x along world +y) the old pose is 1 m behind: x = −1 m, y = 0,
        // θ = −90°.
        assert_eq!(p[7], [-25, 0, -64]);
        assert_eq!(p[8], [0, 0, 0]);
    }
}
