//! LIVE's known-map classification (issue 32; METHOD.md §2, the paper's rule): with a prior map
//! of the building, each scan's points are labelled online as
//!
//! * **LTF** (long-term feature, *map*): within [`LTF_GATE_MM`] of an occupied cell of the prior
//!   map — the paper's `exp(−d(p, L)² / Σs) > τ` is exactly a distance gate (`τ = exp(−d_max² /
//!   Σs)`, as the host's labeller says); here `L` is the prior's occupied cells near `p` rather
//!   than the one line the beam is expected to hit (a grid has no lines), so a point near *any*
//!   mapped wall is an LTF;
//! * **STF** (short-term feature: static, not on the map): a non-LTF point within
//!   [`STF_MATCH_MM`] of a non-LTF point of one of the last [`STF_HISTORY`] scans (the same
//!   distance-gate reading of `exp(−‖p − q‖² / Σs) > τ`);
//! * **DF** (dynamic feature): the other non-LTF points;
//!
//! and *map* = LTF, *non-map* = STF, as [`BeamLabel`] (DFs are ignored, as the paper does).
//!
//! The prior map ([`PriorMap`]) is a bit per 0.1 m cell over its own fixed 51.2 m window (its
//! lower-left corner is the map's, not the rolling LiDAR grid's), filled a row segment at a time
//! ([`PriorMap::set_row_bits`], how the host sends it over the link in chunks). Everything is
//! integer (millimetres) and in static buffers: 32 KiB of map bits and
//! `(STF_HISTORY + 1) × BEAMS` points of history (57 KiB).
//!
//! [`crate::Controller`] labels every scan with it once a prior map is loaded
//! ([`crate::Controller::prior_map_row`]), seeds its LiDAR grid from the prior's occupied and
//! free cells ([`PriorMap::seed`]) and keeps LIVE's search map over the prior's free space
//! ([`crate::searchmap`]). The STF points go to the non-map store, whose filters are LIVE's
//! inspection-region filters (pooling, removal where the camera looked, and removal near LTFs
//! when `nonmap_wall_clearance_m` is not 0, its default).

use crate::capacity::{BEAMS, CELL_MM, GRID_CELLS};
use crate::grid::{BitGrid, GridGeometry, LidarGrid};
use crate::nonmap::hit_point;
use crate::scan::{BeamLabel, BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::{Meters, Pose2};

/// The LTF gate: a point this close to an occupied prior cell's centre is on the map, mm. The
/// host labeller's point-to-line gate is 100 mm; a cell centre is up to half a cell's diagonal
/// (71 mm) from the wall line through it, hence the larger gate.
pub const LTF_GATE_MM: i64 = 150;

/// The STF match: a point this close to a non-LTF point of a recent scan is static, mm (the host
/// labeller's 0.25 m).
pub const STF_MATCH_MM: i64 = 250;

/// Scans of non-LTF points kept for the STF test (the host labeller's history).
pub const STF_HISTORY: usize = 3;

/// A point's class.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Feature {
    /// No return, or the beam was not read.
    #[default]
    None,
    /// On the prior map.
    Ltf,
    /// Static, not on the map.
    Stf,
    /// Moving, not on the map.
    Df,
}

impl Feature {
    /// As the planner's label: map = LTF, non-map = STF; DFs stay unlabelled (ignored, as in
    /// the paper: they never become inspection regions).
    pub fn label(self) -> BeamLabel {
        match self {
            Feature::None => BeamLabel::Unlabelled,
            Feature::Ltf => BeamLabel::Map,
            Feature::Stf => BeamLabel::NonMap,
            // The paper ignores DFs: a point seen once, or moving, is no place to look.
            Feature::Df => BeamLabel::Unlabelled,
        }
    }
}

/// Why a row segment of the prior map was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PriorError {
    /// The row is outside the map's window.
    RowOutside,
    /// The segment runs past the window's right edge.
    SegmentTooLong,
}

/// The prior map: occupied and free cells over a fixed window with its own lower-left corner
/// (a cell that is neither is unknown: outside the building, or never mapped).
pub struct PriorMap {
    geom: GridGeometry,
    occupied: BitGrid,
    free: BitGrid,
    rows: u32,
}

impl PriorMap {
    /// Empty, its window's lower-left corner at the origin.
    pub const fn new() -> Self {
        PriorMap {
            geom: GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO },
            occupied: BitGrid::new(),
            free: BitGrid::new(),
            rows: 0,
        }
    }

    /// Forgets the map; the window's lower-left corner becomes `(x, y)`.
    pub fn reset(&mut self, x: Meters, y: Meters) {
        self.geom = GridGeometry { origin_x: x, origin_y: y };
        self.occupied.clear();
        self.free.clear();
        self.rows = 0;
    }

    /// Row `y`'s cells from column `x0` on: bit `i` of `bits` (least significant first) is cell
    /// `x0 + i`, 1 occupied; `n` cells.
    pub fn set_row_bits(&mut self, y: usize, x0: usize, bits: &[u8], n: usize) -> Result<(), PriorError> {
        Self::put_row(&mut self.occupied, y, x0, bits, n)?;
        self.rows = self.rows.saturating_add(1);
        Ok(())
    }

    /// As [`PriorMap::set_row_bits`] for the free cells (1 free): the known free space, which
    /// seeds the LiDAR grid and is what the search map covers ([`SearchMap`]).
    pub fn set_free_row_bits(&mut self, y: usize, x0: usize, bits: &[u8], n: usize) -> Result<(), PriorError> {
        Self::put_row(&mut self.free, y, x0, bits, n)
    }

    fn put_row(plane: &mut BitGrid, y: usize, x0: usize, bits: &[u8], n: usize) -> Result<(), PriorError> {
        if y >= GRID_CELLS {
            return Err(PriorError::RowOutside);
        }
        if x0.checked_add(n).is_none_or(|end| end > GRID_CELLS) || n > bits.len() * 8 {
            return Err(PriorError::SegmentTooLong);
        }
        for i in 0..n {
            plane.put((x0 + i) as i32, y as i32, bits[i / 8] >> (i % 8) & 1 != 0);
        }
        Ok(())
    }

    /// The prior's cell under cell `(x, y)` of a grid at `geom` (both grids have 0.1 m cells).
    #[inline]
    pub fn cell_under(&self, geom: &GridGeometry, x: i32, y: i32) -> (i32, i32) {
        let (wx, wy) = geom.center_of(x, y);
        self.geom.cell_of(wx, wy)
    }

    /// Whether the prior marks cell `(x, y)` of its own window free.
    #[inline]
    pub fn free_cell(&self, x: i32, y: i32) -> bool {
        self.free.get(x, y)
    }

    /// Whether the prior marks cell `(x, y)` of its own window occupied.
    #[inline]
    pub fn occupied_cell(&self, x: i32, y: i32) -> bool {
        self.occupied.get(x, y)
    }

    /// Row segments received since the last reset (0: no map).
    pub fn rows_received(&self) -> u32 {
        self.rows
    }

    /// Whether the prior map's cell holding world point `(x, y)` is occupied.
    pub fn occupied_at(&self, x: Meters, y: Meters) -> bool {
        let (cx, cy) = self.geom.cell_of(x, y);
        self.occupied.get(cx, cy)
    }

    /// Whether an occupied prior cell's centre lies within `gate_mm` of world point `(x, y)`.
    pub fn near_occupied(&self, x: Meters, y: Meters, gate_mm: i64) -> bool {
        let (cx, cy) = self.geom.cell_of(x, y);
        let r = (gate_mm + CELL_MM - 1) / CELL_MM;
        let (px, py) = (mm(x), mm(y));
        for dy in -r..=r {
            for dx in -r..=r {
                let (qx, qy) = (cx + dx as i32, cy + dy as i32);
                if !self.occupied.get(qx, qy) {
                    continue;
                }
                let (mx, my) = self.geom.center_of(qx, qy);
                let (ex, ey) = (mm(mx) - px, mm(my) - py);
                if ex * ex + ey * ey <= gate_mm * gate_mm {
                    return true;
                }
            }
        }
        false
    }
}

/// The evidence a prior-free cell starts with: two misses' worth, so a scan or two of an object
/// that stands there now (the target) outweigh the map.
pub const SEED_FREE: crate::grid::Evidence = 2 * crate::grid::EVIDENCE_MISS;
/// The evidence a prior-occupied cell starts with: one hit's worth, so a door the map has closed
/// opens after a few scans through it.
pub const SEED_OCCUPIED: crate::grid::Evidence = crate::grid::EVIDENCE_HIT;

impl PriorMap {
    /// Seeds the cells of `lidar` it has never observed with the prior: occupied ones with
    /// [`SEED_OCCUPIED`], free ones with [`SEED_FREE`] (unknown ones stay unknown). Cells the
    /// LiDAR has already observed keep their evidence. Returns the work charged: the grid's
    /// cells, the most it visits ([`PriorMap::for_each_marked`] passes over the unmarked runs).
    pub fn seed(&self, lidar: &mut LidarGrid) -> u32 {
        let geom = lidar.geom;
        self.for_each_marked(&geom, |x, y, px, py| {
            let e = if self.occupied_cell(px, py) { SEED_OCCUPIED } else { SEED_FREE };
            lidar.seed(x, y, e);
        });
        (GRID_CELLS * GRID_CELLS) as u32
    }

    /// Calls `f(x, y, px, py)` for every cell `(x, y)` of a grid at `geom` whose prior cell
    /// `(px, py)` ([`PriorMap::cell_under`]) is occupied or free, in row-major order. A row
    /// whose prior row is outside the window, and a run of 32 cells whose prior cells are all
    /// unknown, are passed over whole: the prior cell's column grows with the cell's (the
    /// lattices differ by a translation), so the run's prior cells lie between those of its
    /// ends. (A run whose ends are out of order, as a coordinate wrapping past the fixed-point
    /// range would make them, is visited cell by cell.)
    pub(crate) fn for_each_marked(&self, geom: &GridGeometry, mut f: impl FnMut(i32, i32, i32, i32)) {
        const RUN: i32 = 32;
        let n = GRID_CELLS as i32;
        let marked = |px: i32, py: i32| self.occupied_cell(px, py) || self.free_cell(px, py);
        // The prior's column under each column (the same in every row): computed once, as
        // the 64-bit divisions of `cell_under` are dear on the Cortex-M.
        let mut columns = [0i32; GRID_CELLS];
        for (x, c) in columns.iter_mut().enumerate() {
            *c = self.cell_under(geom, x as i32, 0).0;
        }
        for y in 0..n {
            let py = self.cell_under(geom, 0, y).1;
            if !(0..n).contains(&py) {
                continue;
            }
            for x0 in (0..n).step_by(RUN as usize) {
                let (pa, pb) = (columns[x0 as usize], columns[(x0 + RUN - 1) as usize]);
                if pa <= pb && (pb < 0 || pa >= n || self.row_unknown(py, pa.max(0), pb.min(n - 1))) {
                    continue;
                }
                for x in x0..x0 + RUN {
                    let px = columns[x as usize];
                    if marked(px, py) {
                        f(x, y, px, py);
                    }
                }
            }
        }
    }

    /// True if cells `a..=b` of the window's row `py` (all within it) are neither occupied nor
    /// free, a word of the planes at a time.
    fn row_unknown(&self, py: i32, a: i32, b: i32) -> bool {
        let base = py as usize * GRID_CELLS;
        let (first, last) = (base + a as usize, base + b as usize);
        let (occ, free) = (self.occupied.words(), self.free.words());
        (first / 32..=last / 32).all(|w| {
            let lo = if w == first / 32 { first % 32 } else { 0 };
            let hi = if w == last / 32 { last % 32 } else { 31 };
            let mask = (u32::MAX >> (31 - hi)) & (u32::MAX << lo);
            (occ[w] | free[w]) & mask == 0
        })
    }
}

impl Default for PriorMap {
    fn default() -> Self {
        Self::new()
    }
}

/// Millimetres of a fixed-point length (rounded down).
fn mm(v: Meters) -> i64 {
    (v.to_bits() as i64 * 1000) >> 16
}

/// A non-LTF point of a recent scan: its bucket key (a [`STF_MATCH_MM`] square) and position, mm.
#[derive(Clone, Copy, Default)]
struct Kept {
    key: i64,
    x: i32,
    y: i32,
}

/// The history's slots: the last [`STF_HISTORY`] scans and the one being classified.
const SLOTS: usize = STF_HISTORY + 1;

/// The classifier: the prior map and the recent non-LTF points.
pub struct KnownMap {
    /// The building's map.
    pub prior: PriorMap,
    /// The last scan's classes, beam by beam.
    pub features: [Feature; BEAMS],
    /// How many of each class so far: `[LTF, STF, DF]`.
    pub counts: [u32; 3],
    /// The last [`STF_HISTORY`] scans' non-LTF points, each scan's sorted by key.
    history: [[Kept; BEAMS]; SLOTS],
    lens: [usize; SLOTS],
    /// The slot the next scan's points go to.
    next: usize,
}

fn bucket(v: i64) -> i64 {
    v.div_euclid(STF_MATCH_MM)
}

/// The key of bucket `(bx, by)`.
fn key(bx: i64, by: i64) -> i64 {
    (bx << 32) ^ (by & 0xffff_ffff)
}

impl KnownMap {
    /// No map, no history.
    pub const fn new() -> Self {
        KnownMap {
            prior: PriorMap::new(),
            features: [Feature::None; BEAMS],
            counts: [0; 3],
            history: [[Kept { key: 0, x: 0, y: 0 }; BEAMS]; SLOTS],
            lens: [0; SLOTS],
            next: 0,
        }
    }

    /// Forgets the recent scans (a new mission; the map stays).
    pub fn forget_history(&mut self) {
        self.lens = [0; SLOTS];
        self.next = 0;
    }

    /// Classifies the scan `beams` taken from `pose` (the laser's, in the map's frame) into
    /// [`KnownMap::features`] and the scan's labels (map = LTF, non-map = STF ∪ DF), and keeps its
    /// non-LTF points for the [`STF_HISTORY`] scans after it. Returns this scan's counts
    /// `[LTF, STF, DF]`.
    pub fn classify(&mut self, pose: &Pose2, beams: &mut BeamScan) -> [u32; 3] {
        // The slot of the scan `STF_HISTORY + 1` ago takes this one's points: the others are
        // the history searched.
        let slot = self.next;
        self.lens[slot] = 0;
        let mut counts = [0u32; 3];
        let mut kept = 0;
        let BeamScan { ranges_mm, labels, .. } = beams;
        for (b, ((&r, o), l)) in ranges_mm.iter().zip(self.features.iter_mut()).zip(labels.iter_mut()).enumerate() {
            let f = if r == RANGE_INVALID || r == RANGE_NO_RETURN {
                Feature::None
            } else {
                let (x, y) = hit_point(pose, b, r);
                if self.prior.near_occupied(x, y, LTF_GATE_MM) {
                    Feature::Ltf
                } else {
                    let (px, py) = (mm(x), mm(y));
                    let f = if matches_history(&self.history, &self.lens, px, py) { Feature::Stf } else { Feature::Df };
                    self.history[slot][kept] = Kept { key: key(bucket(px), bucket(py)), x: px as i32, y: py as i32 };
                    kept += 1;
                    f
                }
            };
            match f {
                Feature::None => {}
                Feature::Ltf => counts[0] += 1,
                Feature::Stf => counts[1] += 1,
                Feature::Df => counts[2] += 1,
            }
            *o = f;
            *l = f.label();
        }
        self.history[slot][..kept].sort_unstable_by_key(|p| (p.key, p.x, p.y));
        self.lens[slot] = kept;
        self.next = (slot + 1) % SLOTS;
        for (total, c) in self.counts.iter_mut().zip(counts) {
            *total = total.saturating_add(c);
        }
        counts
    }
}

/// Whether `(x, y)` (mm) is within [`STF_MATCH_MM`] of a kept point.
fn matches_history(history: &[[Kept; BEAMS]; SLOTS], lens: &[usize; SLOTS], x: i64, y: i64) -> bool {
    let (bx, by) = (bucket(x), bucket(y));
    for (scan, &len) in history.iter().zip(lens) {
        let pts = &scan[..len];
        for dy in -1..=1 {
            for dx in -1..=1 {
                let k = key(bx + dx, by + dy);
                let start = pts.partition_point(|p| p.key < k);
                for p in pts[start..].iter().take_while(|p| p.key == k) {
                    let (ex, ey) = (p.x as i64 - x, p.y as i64 - y);
                    if ex * ex + ey * ey <= STF_MATCH_MM * STF_MATCH_MM {
                        return true;
                    }
                }
            }
        }
    }
    false
}

impl Default for KnownMap {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::grid::beam_angle;
    use std::boxed::Box;

    /// The runs [`PriorMap::for_each_marked`] passes over hold no marked cell: it visits exactly
    /// the cells a cell-by-cell pass finds, in the same order, whatever the two windows' offset
    /// (whole cells, fractions of a cell, the prior partly or wholly outside the grid).
    #[test]
    fn for_each_marked_visits_exactly_the_cells_a_full_pass_finds() {
        let mut prior = Box::new(PriorMap::new());
        let mut rng = fixed_point::SplitMix64(2);
        // A building of 300 × 200 cells from (40, 100) of the prior's window: rows of random
        // occupied and free runs, and a few stray cells elsewhere (at the window's edges too).
        prior.reset(Meters::ZERO, Meters::ZERO);
        for y in 100..300 {
            let (occ, free): (std::vec::Vec<u8>, std::vec::Vec<u8>) = (0..38)
                .map(|_| {
                    let r = rng.next_u64();
                    let o = (r & (r >> 8) & (r >> 16)) as u8;
                    (o, (r >> 24) as u8 & !o)
                })
                .unzip();
            prior.set_row_bits(y, 40, &occ, 300).unwrap();
            prior.set_free_row_bits(y, 40, &free, 300).unwrap();
        }
        for (x, y) in [(0, 0), (511, 511), (0, 511), (511, 0), (31, 7), (32, 7), (480, 450)] {
            prior.set_free_row_bits(y, x, &[1], 1).unwrap();
        }
        let mm = |v: i32| Meters::from_bits(((v as i64) << 16).div_euclid(1000) as i32);
        for (ox, oy) in [(0, 0), (1_000, -2_000), (37, 51), (-4_963, 7_777), (-30_000, 12_345), (51_150, 0), (-60_000, -60_000)] {
            let geom = GridGeometry { origin_x: mm(ox), origin_y: mm(oy) };
            let mut visited = std::vec::Vec::new();
            prior.for_each_marked(&geom, |x, y, px, py| visited.push((x, y, px, py)));
            let mut full = std::vec::Vec::new();
            for y in 0..GRID_CELLS as i32 {
                for x in 0..GRID_CELLS as i32 {
                    let (px, py) = prior.cell_under(&geom, x, y);
                    if prior.occupied_cell(px, py) || prior.free_cell(px, py) {
                        full.push((x, y, px, py));
                    }
                }
            }
            assert!(visited == full, "origin ({ox}, {oy}) mm: {} cells visited, {} found cell by cell", visited.len(), full.len());
            if (ox, oy) == (0, 0) {
                assert!(full.len() > 20_000, "{} marked cells", full.len());
            }
        }
    }

    /// A prior map with a wall along x = 5 m (cells of column 50), window at the origin.
    fn walled() -> Box<KnownMap> {
        let mut k = Box::new(KnownMap::new());
        k.prior.reset(Meters::ZERO, Meters::ZERO);
        let bits = [0u8; 64];
        for y in 0..GRID_CELLS {
            let mut row = bits;
            row[50 / 8] |= 1 << (50 % 8);
            k.prior.set_row_bits(y, 0, &row, GRID_CELLS).unwrap();
        }
        k
    }

    /// A scan from `(2, 10)` facing +x with one return per beam in `hits` (beam, range mm).
    fn scan(hits: &[(usize, u16)]) -> BeamScan {
        let mut s = BeamScan::new();
        for &(b, r) in hits {
            s.ranges_mm[b] = r;
        }
        s
    }

    fn ahead() -> usize {
        // The beam pointing along the pose's heading (beam 0 is at −π).
        (0..BEAMS).min_by_key(|&b| (beam_angle(b).0 as i64).abs()).unwrap()
    }

    #[test]
    fn points_on_the_mapped_wall_are_ltf_and_the_rest_stf_or_df() {
        let mut k = walled();
        let pose = Pose2::from_f64(2.0, 10.0, 0.0).unwrap();
        let b = ahead();
        // The wall is 3 m ahead (x = 5.0–5.1 m: the cell's centre 5.05 m): LTF; a box at 1.5 m: not.
        let c = k.classify(&pose, &mut scan(&[(b, 3_040), (b + 5, 1_500)]));
        let out = k.features;
        assert_eq!(out[b], Feature::Ltf);
        assert_eq!(out[b + 5], Feature::Df, "a first sighting of an unmapped object moves, as far as one scan knows");
        assert_eq!(c, [1, 0, 1]);
        // Seen again, it is static.
        let c = k.classify(&pose, &mut scan(&[(b, 3_040), (b + 5, 1_510)]));
        let out = k.features;
        assert_eq!(out[b + 5], Feature::Stf);
        assert_eq!(c, [1, 1, 0]);
        assert_eq!(Feature::Stf.label(), BeamLabel::NonMap);
        assert_eq!(Feature::Ltf.label(), BeamLabel::Map);
    }

    #[test]
    fn a_point_past_the_gate_is_not_on_the_map_and_history_ages_out() {
        let mut k = walled();
        let pose = Pose2::from_f64(2.0, 10.0, 0.0).unwrap();
        let b = ahead();
        // 0.3 m short of the wall: beyond the 0.15 m gate.
        k.classify(&pose, &mut scan(&[(b, 2_700)]));
        assert_eq!(k.features[b], Feature::Df);
        // STF_HISTORY empty scans push it out of the history.
        for _ in 0..STF_HISTORY {
            k.classify(&pose, &mut scan(&[]));
        }
        let mut s = scan(&[(b, 2_700)]);
        k.classify(&pose, &mut s);
        assert_eq!(k.features[b], Feature::Df);
        assert_eq!(s.labels[b], BeamLabel::Unlabelled, "a DF is ignored");
        // No returns: nothing.
        k.classify(&pose, &mut scan(&[]));
        assert!(k.features.iter().all(|f| *f == Feature::None));
        assert_eq!(k.counts, [0, 0, 2]);
    }

    #[test]
    fn bad_row_segments_are_refused() {
        let mut p = PriorMap::new();
        assert_eq!(p.set_row_bits(GRID_CELLS, 0, &[0xff], 8), Err(PriorError::RowOutside));
        assert_eq!(p.set_row_bits(0, GRID_CELLS - 4, &[0xff], 8), Err(PriorError::SegmentTooLong));
        assert_eq!(p.set_row_bits(0, 0, &[0xff], 9), Err(PriorError::SegmentTooLong));
        assert_eq!(p.set_row_bits(0, usize::MAX, &[0xff], 8), Err(PriorError::SegmentTooLong));
        assert_eq!(p.rows_received(), 0);
        p.set_row_bits(3, 8, &[0b101], 3).unwrap();
        assert!(p.occupied_at(Meters::from_num(0.85), Meters::from_num(0.35)));
        assert!(!p.occupied_at(Meters::from_num(0.95), Meters::from_num(0.35)));
        assert!(p.occupied_at(Meters::from_num(1.05), Meters::from_num(0.35)));
        assert_eq!(p.rows_received(), 1);
    }
}
