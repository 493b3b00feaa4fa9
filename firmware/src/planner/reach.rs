//! Reachability: which cells the robot may stand on (inflation), the path distance to every one
//! of them (Dijkstra), and goals with their paths down that distance field.

use super::{Goal, Planner, Viewpoint, HEADINGS};
use crate::capacity::{GRID_AREA, GRID_CELLS, MAX_INFLATION_OFFSETS, MAX_PATH_WAYPOINTS};
use crate::config::MAX_ROBOT_RADIUS_M;
use crate::grid::{Cell, LidarGrid, Line, PackedGrid};
use fixed_point::{atan2, BinaryAngle, Meters, Pose2};

/// Path-distance cost of a straight step (one unit = 0.02 m at 0.10 m cells).
pub const STEP_STRAIGHT: u16 = 5;
/// Path-distance cost of a diagonal step.
pub const STEP_DIAGONAL: u16 = 7;
/// Distance value of an unreachable cell.
pub const UNREACHABLE: u16 = u16::MAX;
/// Distance-field marker of a cell within `lethal_radius_m` of an occupied cell, stamped before
/// Dijkstra; [`Planner::distance`] reports it as [`UNREACHABLE`].
const LETHAL: u16 = UNREACHABLE - 1;
/// A step onto a cell of the narrow band (farther than `lethal_radius_m` from every occupied cell
/// but within `robot_radius_m` of one) costs this many times a step onto an open cell.
pub const NARROW_STEP_FACTOR: u16 = 5;
/// Longest straight segment between two path waypoints, cells (3 m).
pub const MAX_SEGMENT_CELLS: i32 = 30;

#[inline]
pub(super) fn idx(x: i32, y: i32) -> usize {
    y as usize * GRID_CELLS + x as usize
}

/// Bit `k` of `NOT_FREE[b]` is set when cell `k` of packed byte `b` (bits `2k..2k+2`, see
/// [`PackedGrid::as_bytes`]) is not [`Cell::Free`].
const NOT_FREE: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        let mut k = 0;
        while k < 4 {
            if (b >> (2 * k)) & 3 != Cell::Free as usize {
                t[b] |= 1 << k;
            }
            k += 1;
        }
        b += 1;
    }
    t
};

impl Planner {
    /// Path distance (units of 0.02 m) from the robot to `(x, y)` as of the last step.
    #[inline]
    pub fn distance(&self, x: i32, y: i32) -> u16 {
        if PackedGrid::in_bounds(x, y) && self.dist[idx(x, y)] < LETHAL {
            self.dist[idx(x, y)]
        } else {
            UNREACHABLE
        }
    }

    /// True if the last step considered `(x, y)` open: free and farther than `robot_radius_m`
    /// from every occupied cell (or the robot's way out of that clearance).
    pub fn traversable(&self, x: i32, y: i32) -> bool {
        PackedGrid::in_bounds(x, y) && !self.blocked.get(x, y)
    }

    /// Whether the robot may step onto `(x, y)` after [`Planner::inflate`], `bytes` being the
    /// LiDAR grid's ([`PackedGrid::as_bytes`]): 1 open, 2 a free cell of the narrow band between
    /// `lethal_radius_m` and `robot_radius_m` (at [`NARROW_STEP_FACTOR`] times the cost), 0 not
    /// at all (lethal, not free, outside the grid).
    #[inline]
    fn step_kind(&self, bytes: &[u8], x: i32, y: i32) -> u8 {
        let Some(i) = PackedGrid::index(x, y) else {
            return 0;
        };
        if !self.blocked.at(i) {
            1
        } else if self.dist[i] != LETHAL && Cell::from_bits(bytes[i >> 2] >> ((i & 3) * 2)) == Cell::Free {
            2
        } else {
            0
        }
    }

    /// The blocked bits of the 3 × 3 cells around cell index `i` (not on the grid's edge), each
    /// row's three in bits 0–2, 8–10 and 16–18: zero when none is blocked.
    #[inline(always)]
    fn blocked_around(&self, i: usize) -> u32 {
        let words = self.blocked.words();
        let row = |j: usize| {
            let (w, s) = (j >> 5, j & 31);
            let v = words[w] >> s;
            (if s > 29 { v | words[w + 1] << (32 - s) } else { v }) & 7
        };
        row(i - GRID_CELLS - 1) | row(i - 1) << 8 | row(i + GRID_CELLS - 1) << 16
    }

    /// True if the last step reached `(x, y)` through the narrow band's cost: a reachable cell
    /// within `robot_radius_m` of an occupied cell.
    pub fn narrow(&self, x: i32, y: i32) -> bool {
        self.reach_kind(x, y) == 2
    }

    /// As of the last step: 0 unreachable, 1 reachable and open (the robot's own cell, where it
    /// stands whatever the cell is, included), 2 reachable through the narrow band
    /// ([`Planner::narrow`]).
    #[inline]
    pub(super) fn reach_kind(&self, x: i32, y: i32) -> u8 {
        match PackedGrid::index(x, y) {
            Some(i) if self.dist[i] == 0 => 1,
            Some(i) if self.dist[i] < LETHAL => 1 + self.blocked.at(i) as u8,
            _ => 0,
        }
    }

    /// Step 1: which cells the robot may stand on. Cells within `radius` of an occupied cell are
    /// blocked (not open); those within `lethal` (at most `radius`) are marked [`LETHAL`] in the
    /// distance field, which this resets, and the rest of the blocked cells are the narrow band.
    pub(super) fn inflate(&mut self, lidar: &LidarGrid, radius: Meters, lethal: Meters, robot: (i32, i32)) -> u32 {
        let mut offsets: heapless::Vec<(i8, i8, bool), MAX_INFLATION_OFFSETS> = heapless::Vec::new();
        // Cells whose centre lies within `radius` of an occupied cell's centre: the squared
        // distance in cells, exact (0.35 m → ≤ 12.25 cells², not a radius rounded to 4 cells,
        // which would leave a 1 m doorway only two cells wide). A radius beyond the largest a
        // valid configuration has ([`MAX_ROBOT_RADIUS_M`], the capacity of `offsets`) is taken
        // as that one.
        let radius = radius.clamp(Meters::ZERO, MAX_ROBOT_RADIUS_M);
        let r_q16 = radius.to_bits() as i64 * crate::capacity::CELLS_PER_METER;
        let r2 = ((r_q16 * r_q16) >> 32) as i32;
        let r = ((r_q16 + 0xFFFF) >> 16) as i32;
        let l_q16 = lethal.clamp(Meters::ZERO, radius).to_bits() as i64 * crate::capacity::CELLS_PER_METER;
        let l2 = ((l_q16 * l_q16) >> 32) as i32;
        for dy in -r..=r {
            for dx in -r..=r {
                let d2 = dx * dx + dy * dy;
                if d2 <= r2 {
                    let _ = offsets.push((dx as i8, dy as i8, d2 <= l2));
                }
            }
        }
        self.dist.fill(UNREACHABLE);
        // Every cell not free is blocked: 32 cells (8 packed bytes) a word.
        let bytes = lidar.grid.as_bytes();
        for (w, word) in self.blocked.words_mut().iter_mut().enumerate() {
            *word = (0..8).fold(0, |v, j| v | (NOT_FREE[bytes[w * 8 + j] as usize] as u32) << (4 * j));
        }
        let mut work = GRID_AREA as u32;
        // The disc around every occupied cell, in row-major order (bytes without one skipped).
        for (k, &b) in bytes.iter().enumerate() {
            let occupied = b & 0b1010_1010 & !(b << 1);
            if occupied == 0 {
                continue;
            }
            for slot in 0..4 {
                if occupied & (0b10 << (2 * slot)) != 0 {
                    let i = k * 4 + slot;
                    let (x, y) = ((i % GRID_CELLS) as i32, (i / GRID_CELLS) as i32);
                    for &(dx, dy, lethal) in offsets.iter() {
                        let (cx, cy) = (x + dx as i32, y + dy as i32);
                        self.blocked.put(cx, cy, true);
                        if lethal && PackedGrid::in_bounds(cx, cy) {
                            self.dist[idx(cx, cy)] = LETHAL;
                        }
                    }
                    work += offsets.len() as u32;
                }
            }
        }
        // A robot inside the inflation (it drifted close to something, or came upon furniture
        // the LiDAR had not seen) may leave it, but only by moving away: the free cells around
        // it that are farther from every occupied cell than the robot's own cell. Clearing the
        // whole disc instead lets the path run along the obstacle, and a base that is already
        // touching it is then blocked on every goal. Where no neighbour is farther (the robot
        // stands on the middle line of a passage narrower than the inflation), cells as far as
        // its own are allowed too, so it can walk along that line.
        let mut clearance = |x: i32, y: i32| {
            work += offsets.len() as u32;
            offsets
                .iter()
                .filter(|&&(dx, dy, _)| lidar.get(x + dx as i32, y + dy as i32) == Cell::Occupied)
                .map(|&(dx, dy, _)| dx as i32 * dx as i32 + dy as i32 * dy as i32)
                .min()
                .unwrap_or(i32::MAX)
        };
        let own = clearance(robot.0, robot.1);
        let mut escape = false;
        for pass in 0..2 {
            for &(dx, dy, _) in offsets.iter() {
                let (x, y) = (robot.0 + dx as i32, robot.1 + dy as i32);
                let neighbour = (dx, dy) != (0, 0) && dx.abs() <= 1 && dy.abs() <= 1;
                if lidar.get(x, y) != Cell::Free {
                    continue;
                }
                if !self.blocked.get(x, y) {
                    escape |= neighbour;
                    continue;
                }
                let c = clearance(x, y);
                if (dx, dy) == (0, 0) || c > own || (pass == 1 && c == own) {
                    self.blocked.put(x, y, false);
                    self.dist[idx(x, y)] = UNREACHABLE;
                    escape |= neighbour;
                }
            }
            if escape || own == i32::MAX {
                break;
            }
        }
        work
    }

    /// Step 2: Dijkstra from the robot's cell over passable cells, on the field
    /// [`Planner::inflate`] reset (lethal cells marked): a step onto a cell of the narrow band
    /// costs [`NARROW_STEP_FACTOR`] times its length.
    pub(super) fn distances(&mut self, lidar: &LidarGrid, robot: (i32, i32)) -> u32 {
        self.heap.clear();
        let mut work = 0;
        if !PackedGrid::in_bounds(robot.0, robot.1) {
            return work;
        }
        self.dist[idx(robot.0, robot.1)] = 0;
        let _ = self.heap.push(idx(robot.0, robot.1) as u64);
        const N8: [(i32, i32, u16); 8] = [
            (1, 0, STEP_STRAIGHT),
            (-1, 0, STEP_STRAIGHT),
            (0, 1, STEP_STRAIGHT),
            (0, -1, STEP_STRAIGHT),
            (1, 1, STEP_DIAGONAL),
            (1, -1, STEP_DIAGONAL),
            (-1, 1, STEP_DIAGONAL),
            (-1, -1, STEP_DIAGONAL),
        ];
        // The orthogonal neighbours (indices into `N8`) each diagonal one passes.
        const CORNERS: [(usize, usize); 4] = [(0, 2), (0, 3), (1, 2), (1, 3)];
        let bytes = lidar.grid.as_bytes();
        while let Some(e) = self.heap.pop() {
            let d = (e >> 32) as u16;
            let i = (e & 0xFFFF_FFFF) as usize;
            if d > self.dist[i] {
                continue;
            }
            work += 1;
            self.stats.reachable_cells += 1;
            let (x, y) = ((i % GRID_CELLS) as i32, (i / GRID_CELLS) as i32);
            // Away from the grid's edge, a cell none of whose neighbours is blocked (most of a
            // room) has all eight open, at their plain cost: three reads of the blocked bits
            // tell, and the steps below are those of the general case with every kind 1.
            let inside = x > 0 && y > 0 && x < GRID_CELLS as i32 - 1 && y < GRID_CELLS as i32 - 1;
            if inside && self.blocked_around(i) == 0 {
                // By offset from `i`: 1.5 M instructions a known-map step fewer on the
                // Cortex-M than `idx(x + dx, y + dy)`, the same cell.
                for &(dx, dy, cost) in N8.iter() {
                    self.relax(d.saturating_add(cost), (i as isize + dx as isize + dy as isize * GRID_CELLS as isize) as usize);
                }
                work += 8;
                continue;
            }
            // Each neighbour's kind once (the diagonals' corner test reads the orthogonal ones):
            // 0 not passable, 1 open, 2 narrow.
            let kinds = N8.map(|(dx, dy, _)| self.step_kind(bytes, x + dx, y + dy));
            for (k, &(dx, dy, cost)) in N8.iter().enumerate() {
                if kinds[k] == 0 {
                    continue;
                }
                // No corner cutting: a diagonal step needs both orthogonal cells it passes.
                if k >= 4 && (kinds[CORNERS[k - 4].0] == 0 || kinds[CORNERS[k - 4].1] == 0) {
                    continue;
                }
                let cost = if kinds[k] == 2 { cost * NARROW_STEP_FACTOR } else { cost };
                self.relax(d.saturating_add(cost), idx(x + dx, y + dy));
            }
            work += 8;
        }
        work
    }

    /// Dijkstra's relaxation: cell `ni` at path distance `nd` if that is shorter than it has.
    #[inline(always)]
    fn relax(&mut self, nd: u16, ni: usize) {
        if nd < LETHAL && nd < self.dist[ni] {
            self.dist[ni] = nd;
            if self.heap.push(((nd as u64) << 32) | ni as u64).is_err() {
                self.stats.heap_overflows += 1;
            }
        }
    }

    /// One step down the distance field from `(x, y)`, or `None` at the robot / a dead end.
    #[inline]
    pub(super) fn descend(&self, x: i32, y: i32) -> Option<(i32, i32)> {
        let here = self.distance(x, y);
        if here == 0 || here == UNREACHABLE {
            return None;
        }
        let mut best = (here, None);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let d = self.distance(x + dx, y + dy);
                if d < best.0 {
                    best = (d, Some((x + dx, y + dy)));
                }
            }
        }
        best.1
    }

    /// Where a frontier's (or frontier point's) viewpoint stands: [`Planner::reachable_near`],
    /// with its work added to `work` and a miss counted in `unreachable`.
    pub(super) fn snap_site(&self, at: (i32, i32), snap: i32, work: &mut u32, unreachable: &mut u32) -> Option<(i32, i32)> {
        *work += ((2 * snap + 1) * (2 * snap + 1)) as u32;
        let c = self.reachable_near(at, snap);
        *unreachable += c.is_none() as u32;
        c
    }

    /// The nearest reachable cell to `c` within `radius` cells (Euclidean), `c` itself first;
    /// an open cell before any of the narrow band (a viewpoint keeps `robot_radius_m` where it
    /// can).
    pub(super) fn reachable_near(&self, c: (i32, i32), radius: i32) -> Option<(i32, i32)> {
        let here = self.reach_kind(c.0, c.1);
        if here == 1 {
            return Some(c);
        }
        // (squared distance, cell) of the nearest open and the nearest narrow cell.
        let mut open: Option<(i64, (i32, i32))> = None;
        let mut narrow: Option<(i64, (i32, i32))> = None;
        for dy in -radius..=radius {
            for dx in -radius..=radius {
                let d2 = (dx * dx + dy * dy) as i64;
                let (x, y) = (c.0 + dx, c.1 + dy);
                let kind = if d2 > (radius * radius) as i64 { 0 } else { self.reach_kind(x, y) };
                if kind == 0 {
                    continue;
                }
                let best = if kind == 2 { &mut narrow } else { &mut open };
                if best.is_none_or(|(bd, _)| d2 < bd) {
                    *best = Some((d2, (x, y)));
                }
            }
        }
        match open {
            Some((_, o)) => Some(o),
            None if here != 0 => Some(c),
            None => narrow.map(|b| b.1),
        }
    }

    /// True if every cell on the straight line between `a` and `b` is reachable and at most
    /// `narrow` of them are in the narrow band.
    pub(super) fn line_clear(&self, a: (i32, i32), b: (i32, i32), narrow: u32) -> bool {
        let mut left = narrow;
        Line::new(a.0, a.1, b.0, b.1).all(|(x, y)| match self.reach_kind(x, y) {
            0 => false,
            1 => true,
            _ => {
                left = left.wrapping_sub(1);
                left != u32::MAX
            }
        })
    }

    /// For `nearest`: the quarter-turn heading closest to the direction of travel into `site`.
    pub(super) fn travel_heading(&self, site: (i32, i32), pose: &Pose2) -> BinaryAngle {
        let mut back = site;
        for _ in 0..5 {
            match self.descend(back.0, back.1) {
                Some(c) => back = c,
                None => break,
            }
        }
        let a = if back == site { pose.theta } else { atan2(site.1 - back.1, site.0 - back.0) };
        // Round to the nearest quarter turn.
        HEADINGS[((((a.0 as u32).wrapping_add(1 << 29)) >> 30) & 3) as usize]
    }

    /// The goal for `vp`, with its path pulled taut: walking down the distance field from the
    /// goal, a waypoint is emitted where the straight line from the previous waypoint would leave
    /// reachable cells or cross more cells of the narrow band than the walk did since that
    /// waypoint, or every [`MAX_SEGMENT_CELLS`], so the base can drive straight between
    /// consecutive waypoints. The path starts at the first waypoint after the robot's cell.
    pub(super) fn goal_for(&self, lidar: &LidarGrid, vp: Viewpoint) -> Goal {
        let mut rev: heapless::Vec<(i32, i32), MAX_PATH_WAYPOINTS> = heapless::Vec::new();
        let _ = rev.push(vp.cell);
        let mut anchor = vp.cell;
        let mut prev = vp.cell;
        let mut steps = 0usize;
        // Narrow cells the walk has passed since `anchor`, both ends included.
        let narrow_at = |c: (i32, i32)| self.narrow(c.0, c.1) as u32;
        let mut walked_narrow = narrow_at(anchor);
        let mut cur = self.descend(vp.cell.0, vp.cell.1);
        while let Some(c) = cur {
            steps += 1;
            if steps > GRID_AREA {
                break;
            }
            let long = (c.0 - anchor.0).abs().max((c.1 - anchor.1).abs()) > MAX_SEGMENT_CELLS;
            if (long || !self.line_clear(anchor, c, walked_narrow + narrow_at(c))) && prev != anchor {
                if rev.push(prev).is_err() {
                    break;
                }
                anchor = prev;
                walked_narrow = narrow_at(anchor);
            }
            walked_narrow += narrow_at(c);
            prev = c;
            cur = self.descend(c.0, c.1);
        }
        // `prev` is now the robot's own cell. Its centre is not a waypoint: the robot stands
        // up to half a cell from it, and a base pressed against something would have to walk
        // back into it (the line from there to the first waypoint is clear, as checked above).
        let mut path = heapless::Vec::new();
        for &(x, y) in rev.iter().rev() {
            let _ = path.push(lidar.geom.center_of(x, y));
        }
        let (gx, gy) = lidar.geom.center_of(vp.cell.0, vp.cell.1);
        Goal { pose: Pose2::new(gx, gy, vp.heading), viewpoint: vp, path, path_length_m: vp.path_length_m() }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::boxed::Box;

    /// The three-word read of a cell's 3 × 3 blocked bits agrees with the bits one by one,
    /// across the words' edges (columns 0, 1, 30, 31, 32, 33 of a word) and on random masks.
    #[test]
    fn blocked_around_reads_exactly_the_nine_cells() {
        let mut p = Box::new(Planner::new());
        let mut rng = fixed_point::SplitMix64(3);
        // Half, a quarter and a sixty-fourth of the cells blocked: the last leaves many
        // neighbourhoods all clear.
        for (round, density) in [(0, 0), (1, 1), (2, 2)] {
            for w in p.blocked.words_mut() {
                let r = rng.next_u64();
                let (a, b) = (r as u32, (r >> 32) as u32);
                *w = match density {
                    0 => a,
                    1 => a & b,
                    _ => a & b & 0x1111_1111 & (a >> 7) & (b >> 13),
                };
            }
            let (mut clear, mut checked) = (0, 0);
            for y in 1..GRID_CELLS as i32 - 1 {
                for x in 1..GRID_CELLS as i32 - 1 {
                    if (x + y) % 7 != 0 && !matches!(x % 32, 0 | 1 | 30 | 31) {
                        continue;
                    }
                    let mut expected = 0;
                    for (r, dy) in (-1..=1).enumerate() {
                        for (c, dx) in (-1..=1).enumerate() {
                            expected |= (p.blocked.get(x + dx, y + dy) as u32) << (8 * r + c);
                        }
                    }
                    assert_eq!(p.blocked_around(idx(x, y)), expected, "round {round} at ({x}, {y})");
                    clear += (expected == 0) as u32;
                    checked += 1;
                }
            }
            assert!(checked > 50_000);
            if round == 2 {
                assert!(clear > 1000, "{clear} clear neighbourhoods: the all-open case is not tested");
            }
        }
    }
}
