//! The geometric classifier: per-beam shape features of the newest scan and a small int8 MLP.
//!
//! `LabelPoseNet` (the paper's network, [`super::Classifier`]) sees each beam through one 9 × 9
//! convolution channel, too narrow to tell the front of a wardrobe from the wall behind it: in
//! the built-in buildings it stays below "always map" (docs/model-card.md). This model gives the
//! network the shape of the scan around each beam instead, at scales from 2 to 128 beams, and
//! classifies each beam on its own, from the newest scan and, as the paper's label encoder does,
//! its own earlier outputs for the same direction ([`history_features`]).
//!
//! ## Features (all int8, scale 1/127, integer arithmetic only)
//! For beam `b` with a return, `r` its range:
//! - for each width `w` in [`GEO_WIDTHS`]: the chord through the returns of beams `b − w` and
//!   `b + w` (circular), and where beam `b`'s ray meets it, at range `t`: the protrusion
//!   `(t − r) / r` clamped to ±1 (positive: the point stands in front of the chord), and a flag
//!   (127) that the chord exists (both ends have returns, it is not parallel to the ray, `t > 0`);
//! - on each side: the run of beams without a depth jump (consecutive returns differ by more than
//!   0.1 m + 3 % of the range) or a missing return, as an arc length `n · r · 2π / 897` over 6 m
//!   (capped at 1; runs of 300 beams or more count as 300 with no end), the jump's direction (+127:
//!   the next surface is farther, −127: nearer, 0: no jump) and a flag for a missing return;
//! - the inverse range `min(1, 0.5 m / r)`;
//! - the label history ([`history_features`]): the model's own output one step earlier for the
//!   same direction, and the weighted average of its 8 earlier outputs (zero when the model was
//!   trained without them: their weights are then zero).
//!
//! ## Network
//! `GEO_FEATURES → GEO_HIDDEN` (int8 weights per output channel, int32 bias and accumulator,
//! requantised by a fixed-point multiplier into a 256-entry tanh table) `→ 1` (int16 weights; the
//! sign of the int32 accumulator plus bias is the label: ≥ 0 map, < 0 non-map).
//!
//! ## Blob (`GEO_MAGIC`, little-endian; docs/model-format.md)
//! | offset | bytes | field |
//! |---|---|---|
//! | 0 | 4 | magic `LVGM` |
//! | 4 | 2 | version (2; 1 had 21 features and int8 output weights) |
//! | 6 | 2 | header length (32) |
//! | 8 | 2 | features (23) |
//! | 10 | 2 | hidden units (48) |
//! | 12 | 4 | payload length (bytes after the header) |
//! | 16 | 4 | CRC-32/ISO-HDLC of bytes 0–15 and 20–end |
//! | 20 | 12 | reserved, zero |
//! | 32 | 12 × hidden | per hidden unit: bias `i32`, multiplier `i32`, shift `i32` |
//! | … | 12 | output: bias `i32`, multiplier `i32`, shift `i32` (accumulator → int8 output, for display) |
//! | … | 256 | tanh table, `i8`, indexed by pre-activation + 128 |
//! | … | hidden × features | hidden weights, `i8`, row-major |
//! | … | 2 × hidden | output weights, `i16` (int8 at one scale left the small ones a few steps) |

use super::model::ModelError;
use crate::capacity::BEAMS;
use crate::grid::beam_angle;
use crate::scan::{RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::{requantize_i8, sin_cos, QuantizedMultiplier};

/// Chord half-widths, beams.
pub const GEO_WIDTHS: [usize; 7] = [2, 4, 8, 16, 32, 64, 128];
/// Shape features per beam (from the newest scan).
pub const SCAN_FEATURES: usize = 2 * GEO_WIDTHS.len() + 7;
/// Features per beam: the shape features and the two label-history features.
pub const GEO_FEATURES: usize = SCAN_FEATURES + 2;
/// Hidden units.
pub const GEO_HIDDEN: usize = 48;
/// First four bytes of a geometric model blob.
pub const GEO_MAGIC: [u8; 4] = *b"LVGM";
/// The blob format version this firmware reads.
pub const GEO_VERSION: u16 = 2;
/// Header bytes.
pub const GEO_HEADER_LEN: usize = 32;
/// Bytes of one bias / multiplier / shift record.
const RECORD: usize = 12;
/// Offset of the output record.
const OUT_RECORD: usize = GEO_HEADER_LEN + GEO_HIDDEN * RECORD;
/// Offset of the tanh table.
const TANH: usize = OUT_RECORD + RECORD;
/// Offset of the hidden weights.
const W1: usize = TANH + 256;
/// Offset of the output weights.
const W2: usize = W1 + GEO_HIDDEN * GEO_FEATURES;
/// Total blob length.
pub const GEO_BLOB_LEN: usize = W2 + 2 * GEO_HIDDEN;
/// Multiply-accumulates per scan.
pub const WORK_PER_GEO_CLASSIFY: u32 = (BEAMS * (GEO_FEATURES * GEO_HIDDEN + GEO_HIDDEN)) as u32;

/// Longest run of beams the side features count.
const RUN_CAP: u32 = 300;

/// The CRC-32 a geometric blob stores: bytes 0–15 and 20–end. `None` if shorter than the header.
pub fn geo_checksum(blob: &[u8]) -> Option<u32> {
    const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
    let head = blob.get(..16)?;
    let tail = blob.get(20..)?;
    let mut d = CRC32.digest();
    d.update(head);
    d.update(tail);
    Some(d.finalize())
}

fn u16_at(b: &[u8], off: usize) -> u16 {
    u16::from_le_bytes([b[off], b[off + 1]])
}

#[inline(always)]
fn i32_at(b: &[u8], off: usize) -> i32 {
    i32::from_le_bytes([b[off], b[off + 1], b[off + 2], b[off + 3]])
}

/// A bias and requantisation multiplier record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeoChannel {
    /// Bias at the accumulator's scale.
    pub bias: i32,
    /// Accumulator → int8.
    pub multiplier: QuantizedMultiplier,
}

/// A checked view of a geometric model blob (borrowed, not copied).
#[derive(Clone, Copy, Debug)]
pub struct GeoView<'a> {
    bytes: &'a [u8],
}

impl<'a> GeoView<'a> {
    /// True if `bytes` starts with [`GEO_MAGIC`] (then [`GeoView::parse`] is the parser to use).
    pub fn is_geo(bytes: &[u8]) -> bool {
        bytes.get(..4) == Some(&GEO_MAGIC[..])
    }

    /// Checks the blob: magic, version, header length, shapes, reserved bytes, length, CRC and
    /// every multiplier, in that order.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, ModelError> {
        if !Self::is_geo(bytes) {
            return Err(ModelError::BadMagic);
        }
        if bytes.len() < GEO_HEADER_LEN {
            return Err(ModelError::Truncated { needed: GEO_HEADER_LEN, got: bytes.len() });
        }
        let version = u16_at(bytes, 4);
        if version != GEO_VERSION {
            return Err(ModelError::UnsupportedVersion(version));
        }
        let header = u16_at(bytes, 6);
        if header as usize != GEO_HEADER_LEN {
            return Err(ModelError::BadHeaderLength(header));
        }
        for (off, field, expected) in [(8, super::ShapeField::GeoFeatures, GEO_FEATURES), (10, super::ShapeField::GeoHidden, GEO_HIDDEN)] {
            let found = u16_at(bytes, off) as u32;
            if found != expected as u32 {
                return Err(ModelError::ShapeMismatch { field, expected: expected as u32, found });
            }
        }
        if bytes[20..GEO_HEADER_LEN].iter().any(|&b| b != 0) {
            return Err(ModelError::ReservedNotZero);
        }
        let payload = i32_at(bytes, 12) as u32;
        let expected = (GEO_BLOB_LEN - GEO_HEADER_LEN) as u32;
        if payload != expected {
            return Err(ModelError::PayloadLength { expected, found: payload });
        }
        if bytes.len() < GEO_BLOB_LEN {
            return Err(ModelError::Truncated { needed: GEO_BLOB_LEN, got: bytes.len() });
        }
        if bytes.len() > GEO_BLOB_LEN {
            return Err(ModelError::TrailingBytes { extra: bytes.len() - GEO_BLOB_LEN });
        }
        let stored = i32_at(bytes, 16) as u32;
        let computed = geo_checksum(bytes).unwrap_or(0);
        if stored != computed {
            return Err(ModelError::ChecksumMismatch { stored, computed });
        }
        let view = GeoView { bytes };
        for c in 0..=GEO_HIDDEN {
            let off = if c < GEO_HIDDEN { GEO_HEADER_LEN + c * RECORD } else { OUT_RECORD };
            let shift = i32_at(bytes, off + 8);
            let q = QuantizedMultiplier::from_raw(i32_at(bytes, off + 4), shift.clamp(-128, 127) as i8);
            let shift_ok = (QuantizedMultiplier::MIN_SHIFT as i32..=QuantizedMultiplier::MAX_SHIFT as i32).contains(&shift);
            if !shift_ok || !q.is_normalised() {
                return Err(ModelError::BadGeoMultiplier { channel: c as u16 });
            }
        }
        Ok(view)
    }

    /// The blob.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// The stored CRC-32.
    pub fn crc(&self) -> u32 {
        i32_at(self.bytes, 16) as u32
    }

    /// The record at `off` (one bounds check for its 12 bytes: it is read per hidden unit, per
    /// beam, every scan).
    #[inline(always)]
    fn record(&self, off: usize) -> GeoChannel {
        let r = &self.bytes[off..off + RECORD];
        GeoChannel { bias: i32_at(r, 0), multiplier: QuantizedMultiplier::from_raw(i32_at(r, 4), i32_at(r, 8) as i8) }
    }

    /// Hidden unit `j`'s bias and multiplier.
    #[inline]
    pub fn hidden(&self, j: usize) -> GeoChannel {
        self.record(GEO_HEADER_LEN + j * RECORD)
    }

    /// The output's bias and multiplier.
    pub fn output(&self) -> GeoChannel {
        self.record(OUT_RECORD)
    }

    /// The tanh table.
    pub fn tanh_table(&self) -> &'a [u8] {
        &self.bytes[TANH..TANH + 256]
    }

    /// Hidden unit `j`'s weights.
    #[inline]
    pub fn hidden_weights(&self, j: usize) -> &'a [u8; GEO_FEATURES] {
        // A fixed-size row: the dot product over it unrolls and vectorises.
        &self.bytes[W1..W2].as_chunks::<GEO_FEATURES>().0[j]
    }

    /// The output weights, `i16` little-endian.
    pub fn output_weights(&self) -> &'a [u8] {
        &self.bytes[W2..W2 + 2 * GEO_HIDDEN]
    }
}

/// Writes a geometric blob: header, records, table and weights, then the CRC.
pub fn write_geo_blob(
    hidden: &[GeoChannel; GEO_HIDDEN],
    output: GeoChannel,
    tanh: &[i8; 256],
    w1: &[[i8; GEO_FEATURES]; GEO_HIDDEN],
    w2: &[i16; GEO_HIDDEN],
    out: &mut [u8; GEO_BLOB_LEN],
) {
    out.fill(0);
    out[..4].copy_from_slice(&GEO_MAGIC);
    out[4..6].copy_from_slice(&GEO_VERSION.to_le_bytes());
    out[6..8].copy_from_slice(&(GEO_HEADER_LEN as u16).to_le_bytes());
    out[8..10].copy_from_slice(&(GEO_FEATURES as u16).to_le_bytes());
    out[10..12].copy_from_slice(&(GEO_HIDDEN as u16).to_le_bytes());
    out[12..16].copy_from_slice(&((GEO_BLOB_LEN - GEO_HEADER_LEN) as u32).to_le_bytes());
    let mut put = |off: usize, c: &GeoChannel| {
        out[off..off + 4].copy_from_slice(&c.bias.to_le_bytes());
        out[off + 4..off + 8].copy_from_slice(&c.multiplier.multiplier.to_le_bytes());
        out[off + 8..off + 12].copy_from_slice(&(c.multiplier.shift as i32).to_le_bytes());
    };
    for (j, c) in hidden.iter().enumerate() {
        put(GEO_HEADER_LEN + j * RECORD, c);
    }
    put(OUT_RECORD, &output);
    for (i, &v) in tanh.iter().enumerate() {
        out[TANH + i] = v as u8;
    }
    for (j, row) in w1.iter().enumerate() {
        for (i, &v) in row.iter().enumerate() {
            out[W1 + j * GEO_FEATURES + i] = v as u8;
        }
    }
    for (j, &v) in w2.iter().enumerate() {
        out[W2 + 2 * j..W2 + 2 * j + 2].copy_from_slice(&v.to_le_bytes());
    }
    let crc = geo_checksum(&out[..]).unwrap_or(0);
    out[16..20].copy_from_slice(&crc.to_le_bytes());
}

#[inline]
fn has_return(r: u16) -> bool {
    r != RANGE_INVALID && r != RANGE_NO_RETURN
}

/// Scratch for the features: beam directions, return points and runs of the last scan given to
/// [`GeoScratch::prepare`] (fixed arrays, about 21 KiB, reused every scan).
#[derive(Clone)]
pub struct GeoScratch {
    /// Beam directions in Q14, robot frame: the same every scan, computed by the first
    /// [`GeoScratch::prepare`] (`sin_cos` of 897 angles costs about 1.4 M instructions on the
    /// Cortex-M4, more than the rest of the features).
    dirs: [(i32, i32); BEAMS],
    /// Whether `dirs` holds the directions yet.
    dirs_ready: bool,
    /// Return points, 1/16 mm, robot frame.
    points: [(i32, i32); BEAMS],
    /// Left runs: count (saturating) and end kind (0 none, 1 farther, 2 nearer, 3 no return).
    left: [(u16, u8); BEAMS],
    /// Right runs.
    right: [(u16, u8); BEAMS],
}

impl GeoScratch {
    /// Zeroed (`const`, so it can live in a `static`).
    pub const fn new() -> Self {
        GeoScratch { dirs: [(0, 0); BEAMS], dirs_ready: false, points: [(0, 0); BEAMS], left: [(0, 0); BEAMS], right: [(0, 0); BEAMS] }
    }

    /// Computes the points and runs of a scan; then [`GeoScratch::features`] gives each beam's
    /// features. Returns the work done (beams visited).
    pub fn prepare(&mut self, ranges_mm: &[u16; BEAMS]) -> u32 {
        if !self.dirs_ready {
            for (b, dir) in self.dirs.iter_mut().enumerate() {
                let (sn, c) = sin_cos(beam_angle(b));
                *dir = (c.to_bits() >> 16, sn.to_bits() >> 16);
            }
            self.dirs_ready = true;
        }
        for (&range, (&(c, sn), point)) in ranges_mm.iter().zip(self.dirs.iter().zip(self.points.iter_mut())) {
            let r = range as i64 * 16;
            *point = (((r * c as i64) >> 14) as i32, ((r * sn as i64) >> 14) as i32);
        }
        // Two laps around the circle, so every run that ends within the scan is counted from its
        // end; a run with no end saturates and is capped with no end kind.
        let mut prev: (u16, u8) = (u16::MAX, 0);
        for lap in 0..2 * BEAMS {
            let b = lap % BEAMS;
            let k = break_kind(ranges_mm[b], ranges_mm[(b + BEAMS - 1) % BEAMS]);
            prev = if k != 0 { (0, k) } else { (prev.0.saturating_add(1), prev.1) };
            self.left[b] = prev;
        }
        let mut prev: (u16, u8) = (u16::MAX, 0);
        for lap in 0..2 * BEAMS {
            let b = BEAMS - 1 - lap % BEAMS;
            let k = break_kind(ranges_mm[b], ranges_mm[(b + 1) % BEAMS]);
            prev = if k != 0 { (0, k) } else { (prev.0.saturating_add(1), prev.1) };
            self.right[b] = prev;
        }
        5 * BEAMS as u32
    }

    /// Beam `b`'s features (zeros for a beam without a return), from the scan last given to
    /// [`GeoScratch::prepare`] (`ranges_mm` must be that scan). Integer arithmetic only.
    pub fn features(&self, ranges_mm: &[u16; BEAMS], b: usize) -> [i8; GEO_FEATURES] {
        let mut f = [0i8; GEO_FEATURES];
        let rb = ranges_mm[b];
        if !has_return(rb) {
            return f;
        }
        let r16 = rb as i64 * 16;
        let (dx, dy) = (self.dirs[b].0 as i64, self.dirs[b].1 as i64);
        for (k, &w) in GEO_WIDTHS.iter().enumerate() {
            let (l, h) = ((b + BEAMS - w) % BEAMS, (b + w) % BEAMS);
            if !has_return(ranges_mm[l]) || !has_return(ranges_mm[h]) {
                continue;
            }
            let (p, q) = (self.points[l], self.points[h]);
            let (px, py) = (p.0 as i64, p.1 as i64);
            let (ex, ey) = (q.0 as i64 - px, q.1 as i64 - py);
            // Where the ray meets the chord: t = (p × e) / (d × e), d in Q14.
            if let Some(v) = chord_protrusion((px * ey - py * ex) << 14, dx * ey - dy * ex, r16) {
                f[2 * k] = v;
                f[2 * k + 1] = 127;
            }
        }
        let base = 2 * GEO_WIDTHS.len();
        for (side, run) in [self.left[b], self.right[b]].into_iter().enumerate() {
            let (n, kind) = if run.0 as u32 >= RUN_CAP { (RUN_CAP, 0) } else { (run.0 as u32, run.1) };
            // n · r · 2π / 897 over 6 m, in 1/127: 2π · 127 ≈ 797 964 / 1000.
            f[base + 3 * side] = (n as i64 * rb as i64 * 797_964 / 5_382_000_000).min(127) as i8;
            f[base + 3 * side + 1] = match kind {
                1 => 127,
                2 => -127,
                _ => 0,
            };
            f[base + 3 * side + 2] = if kind == 3 { 127 } else { 0 };
        }
        f[SCAN_FEATURES - 1] = (500 * 127 / rb as i32).min(127) as i8;
        f
    }
}

/// A chord's protrusion feature: with `t = num / den` truncated (where the beam meets the
/// chord, 1/16 mm) and `r16` the beam's range (1/16 mm, `0 < r16 < 2²⁰`), `None` when
/// `den = 0` or `t ≤ 0`, else `clamp((t − r16) · 127 / r16, ±127)` truncated: exactly
/// [`chord_protrusion_reference`], with fewer 64-bit divisions (a library call on the
/// Cortex-M, about 80 instructions). `|num| < 2⁵⁷` and `|den| < 2³⁶` for points within 65.5 m.
/// With `den > 0` (both negated otherwise: the same truncated quotient), `t ≤ 0` exactly when
/// `num < den`, and `t ≥ 2·r16` (the feature clamps to 127) exactly when `num ≥ 2·r16·den`;
/// below that `|t − r16| · 127 < 2²⁷` fits an `i32` (a hardware divide).
#[inline]
fn chord_protrusion(num: i64, den: i64, r16: i64) -> Option<i8> {
    let (num, den) = match den {
        0 => return None,
        d if d < 0 => (-num, -den),
        _ => (num, den),
    };
    if num < den {
        return None;
    }
    if num >= 2 * r16 * den {
        return Some(127);
    }
    let d = num / den - r16;
    Some(((d as i32 * 127) / r16 as i32).clamp(-127, 127) as i8)
}

/// [`chord_protrusion`] the plain way, in 64 bits: its specification.
#[cfg(test)]
fn chord_protrusion_reference(num: i64, den: i64, r16: i64) -> Option<i8> {
    if den == 0 {
        return None;
    }
    let t = num / den;
    (t > 0).then(|| ((t - r16) * 127 / r16).clamp(-127, 127) as i8)
}

impl Default for GeoScratch {
    fn default() -> Self {
        Self::new()
    }
}

/// The break between consecutive beams `a` → `b` (walking from `a`): 0 none, 1 the next surface
/// is farther, 2 nearer (by more than 0.1 m + 3 % of `a`'s range), 3 `b` has no return.
#[inline]
fn break_kind(ra: u16, rb: u16) -> u8 {
    if !has_return(rb) {
        return 3;
    }
    let (a, b) = (ra as i64, rb as i64);
    if (b - a).abs() * 100 > 10_000 + 3 * a {
        if b > a {
            1
        } else {
            2
        }
    } else {
        0
    }
}

/// The label-history features of beam `b` (indices [`SCAN_FEATURES`] and [`SCAN_FEATURES`] + 1):
/// the model's output for the same direction one step earlier, and the linear-weighted average
/// of its 8 earlier outputs (row i of 1…8 weighted i/36, newest heaviest: the paper's label-average
/// row). `h` holds the current scan's pose as its newest row and the earlier outputs as its label
/// rows; each earlier row is read at the beam that pointed the same way then (the robot's turn
/// since, rounded to a beam; its travel, ≤ 0.1 m a step, is ignored). Unfilled rows count zero.
pub fn history_features(h: &super::ScanHistory, b: usize) -> [i8; 2] {
    HistoryReader::new(h).features(b)
}

/// [`history_features`] for every beam of one scan: the turn of each earlier row, read once per
/// scan instead of once per beam (the same values, bit for bit).
pub struct HistoryReader<'h> {
    history: &'h super::ScanHistory,
    /// Per label row: `Some(beams turned since)`, or `None` for an unfilled row (all `None`
    /// before the first scan, which gives zero features).
    shifts: [Option<usize>; super::LABEL_ROWS],
}

impl<'h> HistoryReader<'h> {
    /// Reads the poses of `h`'s rows.
    pub fn new(h: &'h super::ScanHistory) -> Self {
        let mut shifts = [None; super::LABEL_ROWS];
        if let Some(now) = h.pose(super::HISTORY - 1) {
            for (r, s) in shifts.iter_mut().enumerate() {
                let Some(p) = h.pose(r) else { continue };
                // Beams turned since row r: (θ_now − θ_r) · 897 / 2³², rounded half away from zero.
                let d = (now.theta - p.theta).0 as i64 * BEAMS as i64;
                let shift = if d >= 0 { (d + (1 << 31)) >> 32 } else { -((-d + (1 << 31)) >> 32) };
                *s = Some(shift.rem_euclid(BEAMS as i64) as usize);
            }
        }
        HistoryReader { history: h, shifts }
    }

    /// Beam `b`'s two label-history features (`b < BEAMS`).
    #[inline]
    pub fn features(&self, b: usize) -> [i8; 2] {
        let mut last = 0i8;
        let mut sum = 0i32;
        for (r, s) in self.shifts.iter().enumerate() {
            let Some(s) = *s else { continue };
            let at = if b + s >= BEAMS { b + s - BEAMS } else { b + s };
            let v = self.history.label_row(r)[at];
            // |Σ| ≤ 36 · 128: no overflow.
            sum += (r as i32 + 1) * v as i32;
            if r == super::LABEL_ROWS - 1 {
                last = v;
            }
        }
        let w = super::LABEL_WEIGHT_SUM;
        let avg = if sum >= 0 { (2 * sum + w) / (2 * w) } else { -((-2 * sum + w) / (2 * w)) };
        [last, avg.clamp(-127, 127) as i8]
    }
}

/// The network on one beam's features: `(score, output)`, the int32 score (≥ 0 map) and its
/// int8 requantisation.
#[inline]
pub fn geo_forward(m: &GeoView<'_>, x: &[i8; GEO_FEATURES]) -> (i32, i8) {
    let table = m.tanh_table();
    let w2 = m.output_weights();
    let xin = GeoInput::new(x);
    let mut acc2: i32 = 0;
    for (j, v2) in w2.chunks_exact(2).enumerate() {
        let v2 = i16::from_le_bytes([v2[0], v2[1]]) as i32;
        let acc = xin.dot(m.hidden_weights(j));
        let c = m.hidden(j);
        let pre = requantize_i8(acc.saturating_add(c.bias), c.multiplier);
        let h = table[(pre as i32 + 128) as usize] as i8;
        // |Σ| ≤ 48 · 32 768 · 128 < 2³¹.
        acc2 = acc2.wrapping_add(v2 * h as i32);
    }
    let o = m.output();
    let score = acc2.saturating_add(o.bias);
    (score, requantize_i8(score, o.multiplier))
}

/// One beam's features, prepared for the 48 dot products of the hidden layer.
///
/// On a Cortex-M with the DSP extension (`lives_dsp`) the first 20 features are also packed as
/// int16 pairs `[x0, x2], [x1, x3]` per 4, so that `SXTB16` of a word of 4 weights and of the
/// word rotated by 8 meet them in two `SMLAD` (the technique of `kernels::dot`, for rows of 23
/// bytes rather than 897): 7 instructions per 4 multiply-accumulates instead of about 12. The
/// last 3 features go the plain way. Elsewhere it is the plain loop. Both give the exact sum
/// (`|Σ| ≤ 23 · 128 · 128 < 2³¹`).
struct GeoInput<'a> {
    x: &'a [i8; GEO_FEATURES],
    #[cfg(lives_dsp)]
    pairs: [[u32; 2]; DSP_GROUPS],
}

/// Groups of 4 features the DSP path takes.
#[cfg(lives_dsp)]
const DSP_GROUPS: usize = GEO_FEATURES / 4;

impl<'a> GeoInput<'a> {
    #[inline(always)]
    fn new(x: &'a [i8; GEO_FEATURES]) -> Self {
        #[cfg(lives_dsp)]
        {
            let pack = |lo: i8, hi: i8| (lo as i16 as u16 as u32) | ((hi as i16 as u16 as u32) << 16);
            let pairs = core::array::from_fn(|g| {
                let q = &x[4 * g..4 * g + 4];
                [pack(q[0], q[2]), pack(q[1], q[3])]
            });
            GeoInput { x, pairs }
        }
        #[cfg(not(lives_dsp))]
        GeoInput { x }
    }

    /// `Σ w[i] · x[i]` over the 23 features (weights as raw bytes).
    #[inline(always)]
    #[allow(unsafe_code)]
    fn dot(&self, w: &[u8; GEO_FEATURES]) -> i32 {
        #[cfg(lives_dsp)]
        {
            let mut acc: i32 = 0;
            for (g, &[xa, xb]) in self.pairs.iter().enumerate() {
                let word = u32::from_le_bytes([w[4 * g], w[4 * g + 1], w[4 * g + 2], w[4 * g + 3]]);
                // SAFETY: register-only arithmetic on the declared operands; no memory, no stack.
                unsafe {
                    core::arch::asm!(
                        "sxtb16 {t}, {w}",
                        "sxtb16 {w}, {w}, ror #8",
                        "smlad {acc}, {t}, {xa}, {acc}",
                        "smlad {acc}, {w}, {xb}, {acc}",
                        w = inout(reg) word => _,
                        t = out(reg) _,
                        xa = in(reg) xa,
                        xb = in(reg) xb,
                        acc = inout(reg) acc,
                        options(pure, nomem, nostack),
                    );
                }
            }
            let done = 4 * DSP_GROUPS;
            w[done..].iter().zip(self.x[done..].iter()).fold(acc, |a, (&wi, &xi)| a.wrapping_add(wi as i8 as i32 * xi as i32))
        }
        // |Σ| ≤ 23 · 128 · 128 < 2³¹, so wrapping adds give the checked sum, and let the
        // compiler vectorise the dot product (the checked one cannot be).
        #[cfg(not(lives_dsp))]
        w.iter().zip(self.x.iter()).fold(0i32, |a, (&wi, &xi)| a.wrapping_add(wi as i8 as i32 * xi as i32))
    }
}

/// Checks the hidden layer's dot product (the DSP path on a Cortex-M) against the plain sum on
/// `rounds` random rows and inputs, then on the extremes (every weight and input −128 or 127,
/// mixed): returns `(cases, mismatches)`. For the target's self-test (`mcu-selftest geo`).
#[doc(hidden)]
pub fn geo_dot_selfcheck(rounds: u32) -> (u32, u32) {
    let mut seed = 0x9E37_79B9u32;
    let mut next = move || crate::rrt::xorshift32(&mut seed);
    let (mut cases, mut bad) = (0, 0);
    for round in 0..rounds + 3 {
        let mut w = [0u8; GEO_FEATURES];
        let mut x = [0i8; GEO_FEATURES];
        for (wi, xi) in w.iter_mut().zip(x.iter_mut()) {
            let r = next();
            (*wi, *xi) = match round.checked_sub(rounds) {
                None => (r as u8, (r >> 8) as i8),
                Some(0) => (0x80, -128),
                Some(1) => (0x7F, -128),
                _ => (if r & 1 == 0 { 0x80 } else { 0x7F }, if r & 2 == 0 { 127 } else { -128 }),
            };
        }
        let plain = w.iter().zip(x.iter()).map(|(&wi, &xi)| wi as i8 as i32 * xi as i32).sum::<i32>();
        cases += 1;
        bad += (GeoInput::new(&x).dot(&w) != plain) as u32;
    }
    (cases, bad)
}

/// A synthetic scan for cross-target checks (integer only): the robot 1–3 m off the centre of a
/// 10 m square room, a box in front of one wall, a person-sized post, a dropout every 97 beams.
#[doc(hidden)]
pub fn synthetic_scan(seed: u32) -> [u16; BEAMS] {
    let off = 1000 + (seed as i64 % 3) * 1000;
    core::array::from_fn(|b| {
        if b % 97 == seed as usize % 97 {
            return RANGE_INVALID;
        }
        let (sn, c) = sin_cos(beam_angle(b));
        let (c, sn) = (c.to_bits() as i64, sn.to_bits() as i64);
        // Walls at x = ±5 m, y = ±5 m around a robot at (off, 0): the nearest along the ray.
        let mut r = i64::MAX;
        for (d, w) in [(c, 5000 - off), (-c, 5000 + off), (sn, 5000), (-sn, 5000)] {
            if d > 0 {
                r = r.min((w << 30) / d);
            }
        }
        // A box face 1.2 m wide at x = 3.5 m (world), and a post at y = -2 m.
        if c > 0 {
            let t = ((3500 - off) << 30) / c;
            let y = (t * sn) >> 30;
            if (-600..=600).contains(&y) && t > 0 && t < r {
                r = t;
            }
        }
        if sn < 0 {
            let t = (2000i64 << 30) / -sn;
            let x = off + ((t * c) >> 30);
            if (-250..=250).contains(&x) && t < r {
                r = t;
            }
        }
        r.clamp(1, 60_000) as u16
    })
}

/// Labels `n` synthetic scans ([`synthetic_scan`]) with `cls` (a geometric model installed) and
/// returns an FNV-1a digest of every score and the non-map count: the same on every target.
#[doc(hidden)]
pub fn synthetic_digest(cls: &mut super::Classifier<'_>, n: u32) -> (u32, u32) {
    let (digest, nonmap, _) = synthetic_digest_timed(cls, n, || 0);
    (digest, nonmap)
}

/// [`synthetic_digest`], also summing `clock()`'s advance over the classifier calls alone (the
/// scans' synthesis and the digest are left out: on the Cortex-M they cost 2.6 M instructions a
/// scan, which the selftest once counted as the classifier's).
#[doc(hidden)]
pub fn synthetic_digest_timed(cls: &mut super::Classifier<'_>, n: u32, mut clock: impl FnMut() -> u64) -> (u32, u32, u64) {
    let mut digest: u32 = 0x811c_9dc5;
    let mut nonmap = 0;
    let mut elapsed = 0u64;
    let mut out = [crate::scan::BeamLabel::Unlabelled; BEAMS];
    for seed in 0..n {
        let scan = synthetic_scan(seed);
        let t0 = clock();
        cls.classify_ranges(&fixed_point::Pose2::default(), &scan, &mut out);
        elapsed += clock().wrapping_sub(t0);
        for (&s, &l) in cls.scores().iter().zip(out.iter()) {
            for byte in s.to_le_bytes() {
                digest = (digest ^ byte as u32).wrapping_mul(0x0100_0193);
            }
            nonmap += (l == crate::scan::BeamLabel::NonMap) as u32;
        }
    }
    (digest, nonmap, elapsed)
}

#[cfg(test)]
mod tests;
