//! The two global search maps of LIVES: the [`LidarGrid`] (what the 360° LiDAR has swept) and the
//! [`VisualGrid`] (what the narrow camera has actually looked at).
//!
//! Both are [`GRID_CELLS`]² occupancy grids packed at 2 bits a cell (64 KiB each), indexed by
//! integer cell coordinates; the LiDAR grid's cells are the view of a 4-bit log-odds evidence
//! grid (128 KiB) that every scan updates with hits and misses ([`LidarGrid`]); [`GridGeometry`] converts between metres and cells with exact integer
//! arithmetic. Rays are traversed with Bresenham's integer line algorithm ([`Line`]).
//!
//! This module owns the cell states and their update rules; it does not decide where to go.

use crate::capacity::{BEAMS, CELLS_PER_METER, GRID_AREA, GRID_CELLS, MAX_CAMERA_RAYS};

mod bits;
mod rays;
use crate::scan::{BeamScan, RANGE_INVALID};
pub use bits::BitGrid;
use fixed_point::{cos, sin, BinaryAngle, Meters, Pose2};
pub use rays::{grazing, is_return, no_return_bounds, veiling, GRAZING_STEP_PER_MILLE, MAX_BOUND_SPAN, NO_BOUND, VEIL_STEP_PER_MILLE};

/// The state of one cell. In the ROS convention: −1 unknown, 0 free, 100 occupied. Its two
/// bits in a packed grid are its discriminant: 0, 1, 2 in declaration order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Cell {
    /// Never observed (for the visual grid: never seen by the camera).
    Unknown,
    /// Observed free (visual grid: seen by the camera, and free).
    Free,
    /// Observed occupied (visual grid: an occupied cell the camera has looked at).
    Occupied,
}

impl Cell {
    /// The cell whose packed bits (its discriminant) are `b & 3`; 3 reads as unknown.
    #[inline]
    pub(crate) const fn from_bits(b: u8) -> Cell {
        match b & 3 {
            1 => Cell::Free,
            2 => Cell::Occupied,
            _ => Cell::Unknown,
        }
    }

    /// The ROS `nav_msgs/OccupancyGrid` value: −1, 0 or 100.
    pub const fn to_ros(self) -> i8 {
        match self {
            Cell::Unknown => -1,
            Cell::Free => 0,
            Cell::Occupied => 100,
        }
    }
}

/// A [`GRID_CELLS`]² grid of [`Cell`]s, 4 cells per byte. Out-of-bounds reads are `Unknown`,
/// out-of-bounds writes are ignored.
#[derive(Clone)]
pub struct PackedGrid {
    bytes: [u8; GRID_AREA / 4],
}

/// `n` cells' flags spread two bits a cell, as [`PackedGrid::occupied_span`] gives them: bit `2k`
/// set if `occupied(k)`.
#[inline]
pub fn spread_span(n: usize, occupied: impl Fn(i32) -> bool) -> u32 {
    (0..n as i32).filter(|&k| occupied(k)).fold(0, |m, k| m | 1 << (2 * k))
}

impl PackedGrid {
    /// All unknown.
    pub const fn new() -> Self {
        Self { bytes: [0; GRID_AREA / 4] }
    }

    /// True if `(x, y)` is inside the grid.
    #[inline]
    pub const fn in_bounds(x: i32, y: i32) -> bool {
        (x as u32) < GRID_CELLS as u32 && (y as u32) < GRID_CELLS as u32
    }

    /// The row-major index `y·W + x` of `(x, y)` in any grid of [`GRID_CELLS`]², `None` out of
    /// bounds.
    #[inline]
    pub const fn index(x: i32, y: i32) -> Option<usize> {
        if Self::in_bounds(x, y) {
            Some(y as usize * GRID_CELLS + x as usize)
        } else {
            None
        }
    }

    /// The cell at `(x, y)`.
    #[inline]
    pub fn get(&self, x: i32, y: i32) -> Cell {
        let Some(i) = Self::index(x, y) else {
            return Cell::Unknown;
        };
        Cell::from_bits(self.bytes[i >> 2] >> ((i & 3) * 2))
    }

    /// Which of the `N` cells `(x + k, y)`, `k` in `0..N` (at most 12), are occupied: bit `2k` set
    /// if cell `(x + k, y)` is, odd bits clear. Read from the packed bytes in one word where
    /// the run lies inside the grid; out-of-bounds cells are not occupied.
    #[inline]
    pub fn occupied_span<const N: usize>(&self, x: i32, y: i32) -> u32 {
        const { assert!(N >= 1 && N <= 12) };
        let even = 0x5555_5555u32 & ((1u64 << (2 * N)) - 1) as u32;
        if let (Some(i), true) = (Self::index(x, y), x.checked_add(N as i32 - 1).is_some_and(|e| (e as usize) < GRID_CELLS)) {
            // Cells i .. i + N: 2N bits after at most 6 from byte i / 4, within 4 bytes.
            let b = i >> 2;
            let mut word = [0u8; 4];
            let end = (b + 4).min(self.bytes.len());
            word[..end - b].copy_from_slice(&self.bytes[b..end]);
            let codes = u32::from_le_bytes(word) >> ((i & 3) * 2);
            // Occupied is code 2: high bit set, low bit clear.
            return (codes >> 1) & !codes & even;
        }
        spread_span(N, |k| self.get(x.saturating_add(k), y) == Cell::Occupied)
    }

    /// Sets the cell at `(x, y)`; returns false when out of bounds.
    #[inline]
    pub fn set(&mut self, x: i32, y: i32, c: Cell) -> bool {
        let Some(i) = Self::index(x, y) else {
            return false;
        };
        let shift = (i & 3) * 2;
        let b = &mut self.bytes[i >> 2];
        *b = (*b & !(3 << shift)) | ((c as u8) << shift);
        true
    }

    /// Number of cells in state `c`.
    pub fn count(&self, c: Cell) -> u32 {
        let mut n = 0;
        for &b in self.bytes.iter() {
            for k in 0..4 {
                if Cell::from_bits(b >> (k * 2)) == c {
                    n += 1;
                }
            }
        }
        n
    }

    /// The packed bytes (cell `i = y·W + x` in bits `2·(i mod 4)` of byte `i / 4`).
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        self.bytes.fill(0);
    }

    /// Moves the window by `(sx, sy)` cells: the new cell `(x, y)` is the old `(x + sx, y + sy)`,
    /// cells with no old counterpart are unknown. `sx` must be a multiple of 4 (a byte).
    pub(crate) fn shift(&mut self, sx: i32, sy: i32) {
        debug_assert!(sx % 4 == 0);
        shift_2d(&mut self.bytes, GRID_CELLS / 4, sx as i64 / 4, sy as i64, 0);
    }
}

/// Moves a row-major 2-D array (rows of `row_len` elements) so that the new element `(i, r)` is
/// the old `(i + di, r + dr)`; elements with no old counterpart become `fill`. Every element is
/// written once (`copy_within` and `fill` over rows), so the work is the array's length whatever
/// the shift; no allocation.
pub(crate) fn shift_2d<T: Copy>(a: &mut [T], row_len: usize, di: i64, dr: i64, fill: T) {
    let rows = (a.len() / row_len) as i64;
    let rl = row_len as i64;
    // Destination columns `lo..hi` have a source column in the row.
    let lo = (-di).clamp(0, rl) as usize;
    let hi = (rl - di).clamp(lo as i64, rl) as usize;
    let row = |a: &mut [T], y: i64| {
        let base = y as usize * row_len;
        let src = y.saturating_add(dr);
        if src < 0 || src >= rows || lo == hi {
            a[base..base + row_len].fill(fill);
            return;
        }
        let s0 = (src * rl + lo as i64 + di) as usize;
        a.copy_within(s0..s0 + (hi - lo), base + lo);
        a[base..base + lo].fill(fill);
        a[base + hi..base + row_len].fill(fill);
    };
    // Rows are written in the order that reads every source row before it is overwritten.
    if dr >= 0 {
        (0..rows).for_each(|y| row(a, y));
    } else {
        (0..rows).rev().for_each(|y| row(a, y));
    }
}

impl Default for PackedGrid {
    fn default() -> Self {
        Self::new()
    }
}

/// Where the grid sits in the world: the world coordinates of cell (0, 0)'s lower-left corner,
/// and [`CELLS_PER_METER`] cells a metre.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridGeometry {
    /// World x of the grid's lower-left corner.
    pub origin_x: Meters,
    /// World y of the grid's lower-left corner.
    pub origin_y: Meters,
}

impl GridGeometry {
    /// The cell containing world point `(x, y)` (possibly out of bounds), by exact integer floor.
    #[inline]
    pub fn cell_of(&self, x: Meters, y: Meters) -> (i32, i32) {
        let cx = ((x.to_bits() as i64 - self.origin_x.to_bits() as i64) * CELLS_PER_METER).div_euclid(1 << 16);
        let cy = ((y.to_bits() as i64 - self.origin_y.to_bits() as i64) * CELLS_PER_METER).div_euclid(1 << 16);
        (cx.clamp(i32::MIN as i64, i32::MAX as i64) as i32, cy.clamp(i32::MIN as i64, i32::MAX as i64) as i32)
    }

    /// The world coordinates of the centre of cell `(cx, cy)`.
    #[inline]
    pub fn center_of(&self, cx: i32, cy: i32) -> (Meters, Meters) {
        let half_cells = |c: i32| ((2 * c as i64 + 1) << 16) / (2 * CELLS_PER_METER);
        (
            Meters::from_bits((self.origin_x.to_bits() as i64 + half_cells(cx)) as i32),
            Meters::from_bits((self.origin_y.to_bits() as i64 + half_cells(cy)) as i32),
        )
    }

    /// A length in metres as a whole number of cells, rounded to nearest.
    #[inline]
    pub fn cells(len: Meters) -> i32 {
        ((len.to_bits() as i64 * CELLS_PER_METER + (1 << 15)) >> 16) as i32
    }
}

/// Bresenham's line from one cell to another, both ends included.
#[derive(Clone, Debug)]
pub struct Line {
    x: i32,
    y: i32,
    x1: i32,
    y1: i32,
    dx: i32,
    dy: i32,
    sx: i32,
    sy: i32,
    err: i32,
    done: bool,
}

impl Line {
    /// The cells from `(x0, y0)` to `(x1, y1)`.
    pub fn new(x0: i32, y0: i32, x1: i32, y1: i32) -> Self {
        let dx = (x1 as i64 - x0 as i64).abs().min(i32::MAX as i64 / 2) as i32;
        let dy = -((y1 as i64 - y0 as i64).abs().min(i32::MAX as i64 / 2) as i32);
        Line { x: x0, y: y0, x1, y1, dx, dy, sx: if x0 < x1 { 1 } else { -1 }, sy: if y0 < y1 { 1 } else { -1 }, err: dx + dy, done: false }
    }
}

impl Iterator for Line {
    type Item = (i32, i32);
    #[inline]
    fn next(&mut self) -> Option<(i32, i32)> {
        if self.done {
            return None;
        }
        let out = (self.x, self.y);
        if self.x == self.x1 && self.y == self.y1 {
            self.done = true;
        } else {
            let e2 = 2 * self.err;
            if e2 >= self.dy {
                self.err += self.dy;
                self.x += self.sx;
            }
            if e2 <= self.dx {
                self.err += self.dx;
                self.y += self.sy;
            }
        }
        Some(out)
    }
}

/// The angle of beam `b` of the core's beam grid in the sensor frame: −π + b·2π/[`BEAMS`], exactly.
#[inline]
pub fn beam_angle(b: usize) -> BinaryAngle {
    BinaryAngle::HALF + BinaryAngle::from_fraction(b as i64, BEAMS as i64)
}

/// The cell at distance `len` along heading `a` from world point `(x, y)`.
#[inline]
pub fn ray_end(geom: &GridGeometry, x: Meters, y: Meters, a: BinaryAngle, len: Meters) -> (i32, i32) {
    let ex = x.saturating_add(fixed_point::mul_unit(len, cos(a)));
    let ey = y.saturating_add(fixed_point::mul_unit(len, sin(a)));
    geom.cell_of(ex, ey)
}

/// Meters from a range in millimetres.
#[inline]
pub fn mm_to_meters(mm: u16) -> Meters {
    Meters::from_bits(((mm as i64 * 65_536 + 500) / 1000) as i32)
}

/// What the rolling window ([`crate::rolling`]) has done: kept with the LiDAR grid it moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WindowStats {
    /// Shifts so far.
    pub shifts: u32,
    /// The window's total movement in cells (x, y) since it was placed.
    pub moved_cells: (i32, i32),
    /// The last shift, cells (x, y).
    pub last_shift: (i32, i32),
    /// Work of the last shift (cells and entries touched).
    pub last_work: u32,
    /// Stored cell coordinates dropped for falling outside the window (blacklist entries,
    /// candidates, frontiers, `rrt` nodes and points, the goal); non-map points dropped are
    /// counted in [`crate::nonmap::NonMapStats::dropped_outside`].
    pub dropped: u32,
    /// Shifts refused because the origin would leave the fixed-point range
    /// ([`crate::config::MAX_ORIGIN_M`]).
    pub refused: u32,
}

impl WindowStats {
    /// Nothing yet.
    pub const fn new() -> Self {
        Self { shifts: 0, moved_cells: (0, 0), last_shift: (0, 0), last_work: 0, dropped: 0, refused: 0 }
    }
}

/// Occupancy evidence of one cell in the [`LidarGrid`]: a saturating log-odds count in 4 bits.
///
/// The unit is about 0.41 nats (OctoMap's miss, `logit(0.4)`); a hit adds [`EVIDENCE_HIT`] (≈ 0.85,
/// OctoMap's `logit(0.7)`), a miss adds [`EVIDENCE_MISS`], and the sum is clamped to
/// [[`EVIDENCE_MIN`], [`EVIDENCE_MAX`]] (p ≈ 0.16 and 0.92; OctoMap clamps at 0.12 / 0.97,
/// Cartographer at 0.1 / 0.9), so that a cell is never so sure that a few scans cannot change it:
/// a person who walks away leaves free cells behind within
/// `(EVIDENCE_MAX − EVIDENCE_MIN_OCCUPIED) / −EVIDENCE_MISS + 1` = 6 scans. Stored as `L + 8`
/// (1 ..= 15); 0 means never observed.
pub type Evidence = i8;
/// A hit: the beam ended in the cell.
pub const EVIDENCE_HIT: Evidence = 2;
/// A miss: the beam passed through the cell.
pub const EVIDENCE_MISS: Evidence = -1;
/// Lowest evidence (most certainly free).
pub const EVIDENCE_MIN: Evidence = -4;
/// Highest evidence (most certainly occupied).
pub const EVIDENCE_MAX: Evidence = 6;
/// A cell with at least this evidence is occupied; below it, free (a cell whose hits and misses
/// balance, evidence 0, is free: a wall must out-vote the rays that pass through it).
pub const EVIDENCE_MIN_OCCUPIED: Evidence = 1;

/// How far behind the measured surface a return's cell is taken, millimetres: a return marks the
/// cell `HIT_DEPTH_MM` beyond its range, and the ray frees the cells before that one.
///
/// Why: a wall's face is rarely in the middle of a cell. When it lies near a cell boundary, range
/// noise puts half the returns in the cell in front of the face and half in the wall's own, and
/// with evidence (unlike a last-writer-wins grid) the front cell's hits are not undone by the rays
/// that pass through it: walls grow a cell thicker towards the robot and 0.9 m doorways shrink by
/// 0.2 m — which is what closed doorways in the simulator when a 4-bit evidence count was first
/// tried. The surface is there and the solid is behind it, so the hit belongs one noise width
/// deeper: with 40 mm, a face within 40 mm of a boundary puts its returns (σ ≈ 10 mm) in the cell
/// behind it, and a face elsewhere in its own cell, as before.
pub const HIT_DEPTH_MM: i64 = 40;

/// A [`GRID_CELLS`]² grid of [`Evidence`], two cells per byte. Out-of-bounds reads are "never
/// observed", out-of-bounds writes are ignored.
#[derive(Clone)]
pub struct EvidenceGrid {
    nibbles: [u8; GRID_AREA / 2],
}

impl EvidenceGrid {
    /// Never observed anywhere.
    pub const fn new() -> Self {
        Self { nibbles: [0; GRID_AREA / 2] }
    }

    /// The evidence at `(x, y)`, `None` if never observed (or out of bounds).
    #[inline]
    pub fn get(&self, x: i32, y: i32) -> Option<Evidence> {
        let i = PackedGrid::index(x, y)?;
        let v = (self.nibbles[i >> 1] >> ((i & 1) * 4)) & 15;
        (v != 0).then_some(v as Evidence - 8)
    }

    /// Adds `delta` to the evidence at `(x, y)` (an unobserved cell starts at 0), clamped;
    /// returns the new evidence, or `None` out of bounds.
    #[inline]
    pub fn add(&mut self, x: i32, y: i32, delta: Evidence) -> Option<Evidence> {
        let i = PackedGrid::index(x, y)?;
        let shift = (i & 1) * 4;
        let b = &mut self.nibbles[i >> 1];
        let v = (*b >> shift) & 15;
        let old = if v == 0 { 0 } else { v as Evidence - 8 };
        let new = (old + delta).clamp(EVIDENCE_MIN, EVIDENCE_MAX);
        *b = (*b & !(15 << shift)) | (((new + 8) as u8) << shift);
        Some(new)
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        self.nibbles.fill(0);
    }

    /// Moves the window by `(sx, sy)` cells (see [`PackedGrid::shift`]); new cells are never
    /// observed. `sx` must be even.
    pub(crate) fn shift(&mut self, sx: i32, sy: i32) {
        debug_assert!(sx % 2 == 0);
        shift_2d(&mut self.nibbles, GRID_CELLS / 2, sx as i64 / 2, sy as i64, 0);
    }
}

impl Default for EvidenceGrid {
    fn default() -> Self {
        Self::new()
    }
}

/// The [`Cell`] a cell's evidence stands for.
#[inline]
pub const fn cell_of_evidence(e: Option<Evidence>) -> Cell {
    match e {
        None => Cell::Unknown,
        Some(l) if l >= EVIDENCE_MIN_OCCUPIED => Cell::Occupied,
        Some(_) => Cell::Free,
    }
}

/// What one integrated scan did, for the stage's cost and the tests.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntegrateStats {
    /// Cells visited along rays, plus hit cells (the stage's work).
    pub work: u32,
    /// Hit updates applied (once per cell per scan).
    pub hits: u32,
    /// Miss updates applied (once per cell per scan).
    pub misses: u32,
}

/// The LiDAR search map: an occupancy evidence grid ([`EvidenceGrid`]) and its ternary view
/// ([`LidarGrid::grid`], what the planner, the camera model and the pictures read).
///
/// Each scan, in this order (Cartographer's rule: one update per cell per scan, hits first):
/// 1. every return marks its hit cell ([`HIT_DEPTH_MM`] behind the surface), once per cell,
///    but a mixed pixel ([`veiling`]: between a nearer and a farther neighbour) marks none;
/// 2. every beam frees the cells before its hit cell, once per cell, skipping cells hit in this
///    scan. A return beyond the clearing range, and a "no return" beam (nothing within the
///    scan's `range_max`), frees cells out to the nearer of `range_max` and the clearing range and
///    marks nothing, and stops at the first cell with wall evidence: nothing seen is not a reason
///    to erase a wall, nor past a surface its neighbouring returns span ([`no_return_bounds`]:
///    glass, dark paint and walls met edge-on return nothing too). A beam that grazes its
///    surface ([`grazing`]) frees no occupied cell either (a wall seen edge-on runs through the
///    wall's own cells for many cells before its hit);
/// 3. the hits are applied.
///
/// The marks of steps 1–2 live in a bit per cell ([`BitGrid`]), cleared after each scan.
#[derive(Clone)]
pub struct LidarGrid {
    /// The ternary view of the evidence (kept in step with it by every update).
    pub grid: PackedGrid,
    /// The evidence.
    pub evidence: EvidenceGrid,
    /// Where the grid is: placed by the configuration, then moved by the rolling window
    /// ([`crate::rolling`]) when the robot nears an edge.
    pub geom: GridGeometry,
    /// What the rolling window has done since the last [`LidarGrid::clear`].
    pub window: WindowStats,
    /// Work of window shifts not yet reported: added to the next scan's [`IntegrateStats::work`]
    /// (the LiDAR stage of the same tick whenever the pose comes with its scan).
    pub(crate) pending_work: u32,
    hits: [(i32, i32); BEAMS],
    /// A scan's no-return bounds ([`no_return_bounds`]), millimetres.
    bounds: [u16; BEAMS],
    marks: BitGrid,
}

impl LidarGrid {
    /// An all-unknown grid at `geom`.
    pub const fn new(geom: GridGeometry) -> Self {
        Self {
            grid: PackedGrid::new(),
            evidence: EvidenceGrid::new(),
            geom,
            window: WindowStats::new(),
            pending_work: 0,
            hits: [(0, 0); BEAMS],
            bounds: [NO_BOUND; BEAMS],
            marks: BitGrid::new(),
        }
    }

    /// The cell at `(x, y)`.
    #[inline]
    pub fn get(&self, x: i32, y: i32) -> Cell {
        self.grid.get(x, y)
    }

    /// Forgets everything but where the window is (a new search starts where the robot is; a
    /// new configured origin is set by [`crate::Controller::set_config`]).
    pub fn clear(&mut self) {
        self.grid.clear();
        self.evidence.clear();
        self.marks.clear();
        self.window = WindowStats::new();
        self.pending_work = 0;
    }

    /// Moves the window by `(sx, sy)` cells: the cells, the evidence and the origin. `sx` must be
    /// even (see [`crate::rolling::shift`], which moves everything else with it).
    pub(crate) fn shift(&mut self, sx: i32, sy: i32, geom: GridGeometry) {
        self.grid.shift(sx, sy);
        self.evidence.shift(sx, sy);
        self.marks.clear();
        self.geom = geom;
    }

    #[inline]
    fn update(&mut self, x: i32, y: i32, delta: Evidence) {
        if let Some(e) = self.evidence.add(x, y, delta) {
            self.grid.set(x, y, cell_of_evidence(Some(e)));
        }
    }

    /// Gives a cell the LiDAR has never observed the evidence `e` (a prior map's,
    /// [`crate::knownmap::PriorMap::seed`]); an observed cell keeps its own.
    pub fn seed(&mut self, x: i32, y: i32, e: Evidence) {
        if PackedGrid::in_bounds(x, y) && self.evidence.get(x, y).is_none() {
            self.update(x, y, e);
        }
    }

    /// Integrates one resampled scan taken at `pose` (see the type's docs). `clear_range` is the
    /// clearing range (the configuration's `lidar_max_range_m`): returns beyond it mark nothing.
    pub fn integrate(&mut self, pose: &Pose2, scan: &BeamScan, clear_range: Meters) -> IntegrateStats {
        let (rx, ry) = self.geom.cell_of(pose.x, pose.y);
        let no_return_len = mm_to_meters(scan.range_max_mm).min(clear_range);
        let depth = Meters::from_bits(((HIT_DEPTH_MM << 16) / 1000) as i32);
        let mut st = IntegrateStats::default();
        // 1. Hit cells, once each.
        let mut nhits = 0usize;
        for b in 0..BEAMS {
            let r = scan.ranges_mm[b];
            if !is_return(r, clear_range) || veiling(scan, b) {
                continue;
            }
            let a = pose.theta + beam_angle(b);
            let (ex, ey) = ray_end(&self.geom, pose.x, pose.y, a, mm_to_meters(r).saturating_add(depth));
            if PackedGrid::in_bounds(ex, ey) && !self.marks.get(ex, ey) {
                self.marks.put(ex, ey, true);
                self.hits[nhits] = (ex, ey);
                nhits += 1;
            }
        }
        // 2. Misses along every ray, once per cell, never on a cell hit in this scan; a ray without
        // a return stops short of the surface its neighbours' returns span.
        st.work += no_return_bounds(scan, clear_range, &mut self.bounds);
        for b in 0..BEAMS {
            let r = scan.ranges_mm[b];
            if r == RANGE_INVALID {
                continue;
            }
            let a = pose.theta + beam_angle(b);
            let no_return = !is_return(r, clear_range);
            let (ex, ey) = if no_return {
                let len = match self.bounds[b] {
                    NO_BOUND => no_return_len,
                    mm => mm_to_meters(mm).min(no_return_len),
                };
                ray_end(&self.geom, pose.x, pose.y, a, len)
            } else {
                ray_end(&self.geom, pose.x, pose.y, a, mm_to_meters(r).saturating_add(depth))
            };
            let grazing = !no_return && grazing(scan, b);
            for (x, y) in Line::new(rx, ry, ex, ey) {
                if !PackedGrid::in_bounds(x, y) {
                    break;
                }
                st.work += 1;
                if !no_return && x == ex && y == ey {
                    break;
                }
                let occupied = self.grid.get(x, y) == Cell::Occupied;
                if no_return && occupied {
                    break;
                }
                if (grazing && occupied) || self.marks.get(x, y) {
                    continue;
                }
                self.marks.put(x, y, true);
                self.update(x, y, EVIDENCE_MISS);
                st.misses += 1;
            }
        }
        // 3. The hits.
        for i in 0..nhits {
            let (x, y) = self.hits[i];
            self.update(x, y, EVIDENCE_HIT);
        }
        st.hits = nhits as u32;
        st.work += nhits as u32;
        st.work = st.work.saturating_add(core::mem::take(&mut self.pending_work));
        self.marks.clear();
        st
    }
}

/// Rays needed so that neighbouring rays are at most half a cell apart at `range_cells`.
pub fn camera_rays(fov: BinaryAngle, range_cells: i32) -> usize {
    // arc length in cells = fov_rad · range; 2π in Q16 is 411 775.
    let fov_units = fov.0 as u32 as u64;
    let arc_q16 = (fov_units * 411_775) >> 32; // fov in radians, Q16
    let rays = ((arc_q16 * range_cells.max(1) as u64 * 2) >> 16) + 2;
    (rays as usize).min(MAX_CAMERA_RAYS)
}

/// What a camera at a candidate viewpoint would see (see [`VisualGrid::unseen_in_cone`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ConeView {
    /// Estimated camera-unseen cells in the cone.
    pub unseen_cells: u32,
    /// Rays that end on a camera-unseen LiDAR-occupied cell.
    pub unseen_surface_rays: u32,
    /// Cells visited.
    pub work: u32,
}

/// The visual search map: cells the camera has looked at. `Free` = seen and free, `Occupied` = an
/// occupied cell the camera has looked at, `Unknown` = never seen by the camera.
#[derive(Clone)]
pub struct VisualGrid {
    /// The cells.
    pub grid: PackedGrid,
}

impl VisualGrid {
    /// All unseen.
    pub const fn new() -> Self {
        Self { grid: PackedGrid::new() }
    }

    /// The cell at `(x, y)`.
    #[inline]
    pub fn get(&self, x: i32, y: i32) -> Cell {
        self.grid.get(x, y)
    }

    /// True once the camera has looked at the cell.
    #[inline]
    pub fn seen(&self, x: i32, y: i32) -> bool {
        self.grid.get(x, y) != Cell::Unknown
    }

    /// Marks what the camera at `pose` (looking along its heading) sees: rays across `fov` out to
    /// `range`, each stopping at (and including) the first cell the LiDAR map knows is occupied.
    /// Returns cells touched.
    pub fn integrate(&mut self, lidar: &LidarGrid, pose: &Pose2, fov: BinaryAngle, range: Meters) -> u32 {
        self.integrate_noting(lidar, pose, fov, range, |_, _| {})
    }

    /// [`VisualGrid::integrate`], calling `first_seen` with each cell the camera sees for the
    /// first time (LIVE's search map counts them, [`crate::searchmap`]).
    pub fn integrate_noting(
        &mut self,
        lidar: &LidarGrid,
        pose: &Pose2,
        fov: BinaryAngle,
        range: Meters,
        mut first_seen: impl FnMut(i32, i32),
    ) -> u32 {
        let (rx, ry) = lidar.geom.cell_of(pose.x, pose.y);
        let rays = camera_rays(fov, GridGeometry::cells(range));
        let start = pose.theta - BinaryAngle((fov.0 as u32 / 2) as i32);
        let mut work = 0;
        for j in 0..rays {
            let off = ((fov.0 as u32 as u64 * j as u64) / (rays as u64 - 1)) as u32;
            let a = start + BinaryAngle(off as i32);
            let (ex, ey) = ray_end(&lidar.geom, pose.x, pose.y, a, range);
            for (x, y) in Line::new(rx, ry, ex, ey) {
                if !PackedGrid::in_bounds(x, y) {
                    break;
                }
                work += 1;
                let c = lidar.get(x, y);
                if c != Cell::Unknown && self.grid.get(x, y) == Cell::Unknown {
                    first_seen(x, y);
                }
                match c {
                    Cell::Occupied => {
                        self.grid.set(x, y, Cell::Occupied);
                        break;
                    }
                    // Unknown to the LiDAR: a wall it has not mapped yet may stand here.
                    Cell::Unknown => break,
                    Cell::Free => {
                        self.grid.set(x, y, Cell::Free);
                    }
                }
            }
        }
        work
    }

    /// Estimated number of cells not yet seen by the camera that a camera at cell `(cx, cy)`
    /// looking along `heading` would see: `rays` rays across `fov`, occluded by LiDAR-occupied
    /// cells; a cell at step `d` along a ray stands for `d·Δθ` cells of the cone's area.
    /// Also counts the rays that end on a LiDAR-occupied cell the camera has not seen: unseen
    /// surfaces, where an object (the target) can be. A cell unknown to the LiDAR as well counts
    /// `unknown_eighths / 8` of a cell (8: all unseen cells alike, as in the paper).
    #[allow(clippy::too_many_arguments)]
    pub fn unseen_in_cone(
        &self,
        lidar: &LidarGrid,
        cx: i32,
        cy: i32,
        heading: BinaryAngle,
        fov: BinaryAngle,
        range_cells: i32,
        rays: usize,
        unknown_eighths: u8,
    ) -> ConeView {
        let rays = rays.max(2);
        let mut surface_rays = 0u32;
        let start = heading - BinaryAngle((fov.0 as u32 / 2) as i32);
        let mut weighted: u64 = 0;
        let mut work = 0u32;
        for j in 0..rays {
            let off = ((fov.0 as u32 as u64 * j as u64) / (rays as u64 - 1)) as u32;
            let a = start + BinaryAngle(off as i32);
            let ex = cx + ((range_cells as i64 * cos(a).to_bits() as i64 + (1 << 29)) >> 30) as i32;
            let ey = cy + ((range_cells as i64 * sin(a).to_bits() as i64 + (1 << 29)) >> 30) as i32;
            for (d, (x, y)) in Line::new(cx, cy, ex, ey).enumerate() {
                if !PackedGrid::in_bounds(x, y) {
                    break;
                }
                work += 1;
                let l = lidar.get(x, y);
                if !self.seen(x, y) {
                    // Cells the LiDAR has not seen either count `unknown_eighths`/8 of a cell.
                    weighted += if l == Cell::Unknown { d as u64 * unknown_eighths as u64 } else { d as u64 * 8 };
                }
                if l == Cell::Occupied {
                    if !self.seen(x, y) {
                        surface_rays += 1;
                    }
                    break;
                }
            }
        }
        // Δθ = fov / rays in radians (Q16): fov_units · 2π / 2³² / rays.
        let dtheta_q16 = ((fov.0 as u32 as u64 * 411_775) >> 32) / rays as u64;
        ConeView { unseen_cells: ((weighted * dtheta_q16) >> 19) as u32, unseen_surface_rays: surface_rays, work }
    }
}

impl Default for VisualGrid {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests;
