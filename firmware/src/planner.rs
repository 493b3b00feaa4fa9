//! Viewpoint selection: the LIVES utility over four candidate viewpoints per frontier.
//!
//! Each planning step:
//! 1. **Traversable cells**: LiDAR-free cells farther than `robot_radius_m` from every occupied
//!    cell (unknown cells are never traversable). A robot within that radius of something may
//!    still leave, but only away from it: the free cells near it that are farther from every
//!    occupied cell than its own cell stay traversable (see [`Planner::inflate`]).
//! 2. **Path distance** from the robot to every traversable cell: Dijkstra on the 8-connected grid
//!    with integer step costs 5 (straight) and 7 (diagonal) — one unit is 0.02 m, 7/5 ≈ √2 — and
//!    no corner cutting. The open list is a fixed-capacity binary heap ([`DIJKSTRA_HEAP`]); an
//!    overflow is counted in [`PlanStats::heap_overflows`].
//! 3. **Candidates**: at each frontier's anchor cell (or the nearest reachable cell within
//!    `viewpoint_snap_radius_m`), four viewpoints facing 0°, 90°, 180°, 270°. Unreachable and
//!    blacklisted candidates are dropped.
//! 4. **Utility** (Q16.16 fixed point), the paper's weighted sum:
//!    `U = − w_dist·path_m + w_unknown·unseen_cells + w_frontier·frontier_cells_near_path
//!         + w_nonmap·nonmap_points_in_cone`.
//!    `unseen_cells` is estimated by casting rays across the camera cone from the viewpoint
//!    (occluded by LiDAR-occupied cells); `frontier_cells_near_path` counts the frontier cells of
//!    either map in the 8 × 8-cell blocks within `frontier_near_path_blocks` of the path, each
//!    block once; `nonmap_points_in_cone` counts stored non-map points within camera range and
//!    field of view with an unoccluded line of sight.
//! 5. **Argmax** (ties: the first candidate in frontier order wins) → a [`Goal`]: the viewpoint
//!    pose and a path of at most [`MAX_PATH_WAYPOINTS`] waypoints down the distance field.
//!
//! `nearest` (Yamauchi) replaces 4–5 with the reachable LiDAR frontier of shortest path (camera
//! frontiers once the LiDAR map has none), facing the direction of travel.
//!
//! The two other baselines of `lives eval` also face the direction of travel:
//! - `explore-lite` (after ROS `explore_lite`): the frontier of least
//!   `EXPLORE_LITE_POTENTIAL_SCALE · d − EXPLORE_LITE_GAIN_SCALE · cells`, `d` the Euclidean
//!   distance in metres from the robot to the frontier's anchor cell and `cells` the frontier's
//!   size (its defaults 3 and 1; explore_lite multiplies both terms by the costmap resolution,
//!   which does not change the order). LiDAR frontiers first, camera frontiers once the LiDAR map
//!   has none (as `nearest`; explore_lite itself stops there). Simplified: frontiers are the
//!   pieces of at most [`crate::frontier::SPLIT_CELLS`] cells, not whole groups.
//! - `rrt`: frontier points from [`crate::rrt::RrtExplorer`], scored by its revenue.

use crate::capacity::{
    BLOCKS, BLOCK_CELLS, DIJKSTRA_HEAP, GRID_AREA, GRID_CELLS, MAX_BLACKLIST, MAX_FRONTIERS_PER_GRID, MAX_INFLATION_OFFSETS,
    MAX_NONMAP_POINTS, MAX_NONMAP_SITES, MAX_PATH_WAYPOINTS, MAX_VIEWPOINTS,
};
use crate::config::{Config, PlannerKind, Weight, MAX_ROBOT_RADIUS_M};
use crate::frontier::{FrontierSet, FrontierSource};
use crate::grid::{BitGrid, Cell, GridGeometry, LidarGrid, Line, PackedGrid, VisualGrid};
use crate::nonmap::NonMapStore;
use crate::rrt::{self, RrtExplorer};
use fixed_point::{atan2, BinaryAngle, Meters, Pose2};
use heapless::binary_heap::{BinaryHeap, Min};

/// Path-distance cost of a straight step (one unit = 0.02 m at 0.10 m cells).
pub const STEP_STRAIGHT: u16 = 5;
/// Path-distance cost of a diagonal step.
pub const STEP_DIAGONAL: u16 = 7;
/// Distance value of an unreachable cell.
pub const UNREACHABLE: u16 = u16::MAX;
/// Longest straight segment between two path waypoints, cells (3 m).
pub const MAX_SEGMENT_CELLS: i32 = 30;
/// Rays cast across the camera cone when scoring a viewpoint's unseen cells.
pub const SCORE_RAYS: usize = 24;
/// Headings the gaze is chosen from (every 22.5°).
pub const GAZE_HEADINGS: usize = 16;
/// Within this distance of its goal the robot stops choosing a gaze and turns to the goal's
/// heading (the viewpoint's own view).
pub const GAZE_HANDOVER_M: Meters = Meters::from_bits(1 << 16);

/// One entry of a step's site list: where, what kind, a fixed heading if the site has one, and a
/// baseline's own score of it.
type SiteEntry = ((i32, i32), Site, Option<BinaryAngle>, i64);

/// Capacity of one step's site list: frontier pieces of both maps, non-map clusters, the
/// current goal, and the `rrt` baseline's points.
const SITES: usize = 2 * MAX_FRONTIERS_PER_GRID + MAX_NONMAP_SITES + 1 + rrt::RRT_POINTS;

/// `explore-lite`: cost per metre of distance (explore_lite's `potential_scale` default).
pub const EXPLORE_LITE_POTENTIAL_SCALE: i64 = 3;
/// `explore-lite`: gain per frontier cell (explore_lite's `gain_scale` default).
pub const EXPLORE_LITE_GAIN_SCALE: i64 = 1;

/// The four viewpoint headings.
pub const HEADINGS: [BinaryAngle; 4] = [BinaryAngle::ZERO, BinaryAngle::QUARTER, BinaryAngle::HALF, BinaryAngle(-(1 << 30))];

/// What produced a candidate viewpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Site {
    /// A frontier of the LiDAR map (four headings).
    LidarFrontier,
    /// A frontier of the visual map (four headings).
    VisualFrontier,
    /// A cluster of non-map points, looked at from `nonmap_standoff_m` (`lives` only).
    NonMapCluster,
    /// The robot's own cell: turning in place to look (`look_around_here`).
    Here,
    /// The goal being pursued, re-scored for hysteresis (never a new goal itself).
    Current,
}

impl Site {
    /// The site kind of a frontier of `source`'s map.
    pub const fn frontier(source: FrontierSource) -> Site {
        match source {
            FrontierSource::Lidar => Site::LidarFrontier,
            FrontierSource::Visual => Site::VisualFrontier,
        }
    }
}

/// A scored candidate viewpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Viewpoint {
    /// Cell where the robot would stand.
    pub cell: (i32, i32),
    /// Which way the camera faces: one of [`HEADINGS`] at a frontier, the bearing of the
    /// cluster at a non-map site.
    pub heading: BinaryAngle,
    /// What produced it.
    pub source: Site,
    /// Utility, Q16.16 bits.
    pub utility: i64,
    /// Path distance in units of 0.02 m.
    pub path_units: u16,
    /// Estimated camera-unseen cells in its cone.
    pub unseen: u32,
    /// Rays of its cone ending on an unseen surface (LiDAR-occupied, camera-unseen).
    pub surface: u32,
    /// Frontier cells near the path.
    pub frontier_near_path: u32,
    /// Non-map points in its cone.
    pub nonmap: u32,
}

impl Viewpoint {
    /// The path distance in metres (Q16.16, truncated).
    pub fn path_length_m(&self) -> Meters {
        let path_mm = self.path_units as i64 * (crate::capacity::CELL_MM / STEP_STRAIGHT as i64);
        Meters::from_bits(((path_mm << 16) / 1000) as i32)
    }
}

/// A goal for the base: a viewpoint pose and how to get there.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Goal {
    /// Where to stand and which way to look.
    pub pose: Pose2,
    /// The viewpoint it came from.
    pub viewpoint: Viewpoint,
    /// Waypoints from (near) the robot to the goal, the last one the goal position.
    pub path: heapless::Vec<(Meters, Meters), MAX_PATH_WAYPOINTS>,
    /// Path length.
    pub path_length_m: Meters,
}

impl Goal {
    /// The same goal in another frame: `t` maps this goal's frame into it (pose and waypoints;
    /// the viewpoint's grid cell stays as it was).
    pub fn transformed(&self, t: &Pose2) -> Goal {
        let mut path = heapless::Vec::new();
        for &(x, y) in self.path.iter() {
            // Cannot fail: the same capacity.
            let _ = path.push(t.transform_point(x, y));
        }
        Goal { pose: t.compose(&self.pose), viewpoint: self.viewpoint, path, path_length_m: self.path_length_m }
    }
}

/// Counters of the last planning step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlanStats {
    /// Viewpoints scored.
    pub candidates: u32,
    /// Frontiers with no reachable cell near their anchor.
    pub unreachable: u32,
    /// Frontiers dropped for being near a blacklisted goal.
    pub blacklisted: u32,
    /// Dijkstra pushes refused because the open list was full.
    pub heap_overflows: u32,
    /// Candidates skipped because the robot already stands there facing that way.
    pub already_there: u32,
    /// Cells reached by the path-distance search.
    pub reachable_cells: u32,
    /// Work units spent.
    pub work: u32,
}

/// The planner's working memory and its blacklist.
pub struct Planner {
    blocked: BitGrid,
    dist: [u16; GRID_AREA],
    heap: BinaryHeap<u64, Min, DIJKSTRA_HEAP>,
    block_stamp: [u16; BLOCKS * BLOCKS],
    stamp: u16,
    blacklist: heapless::Deque<(i32, i32), MAX_BLACKLIST>,
    visible: heapless::Vec<(BinaryAngle, u32), MAX_NONMAP_POINTS>,
    /// The candidates scored in the last step (for logs and pictures).
    pub candidates: heapless::Vec<Viewpoint, MAX_VIEWPOINTS>,
    /// Counters of the last step.
    pub stats: PlanStats,
    robot_cell: (i32, i32),
    /// The `rrt` baseline's trees and frontier points (idle under the other planners).
    pub rrt: RrtExplorer,
}

#[inline]
fn idx(x: i32, y: i32) -> usize {
    y as usize * GRID_CELLS + x as usize
}

impl Planner {
    /// Empty, no blacklist.
    pub const fn new() -> Self {
        Self {
            blocked: BitGrid::new(),
            dist: [UNREACHABLE; GRID_AREA],
            heap: BinaryHeap::new(),
            block_stamp: [0; BLOCKS * BLOCKS],
            stamp: 0,
            blacklist: heapless::Deque::new(),
            visible: heapless::Vec::new(),
            candidates: heapless::Vec::new(),
            stats: PlanStats {
                candidates: 0,
                unreachable: 0,
                blacklisted: 0,
                heap_overflows: 0,
                already_there: 0,
                reachable_cells: 0,
                work: 0,
            },
            robot_cell: (0, 0),
            rrt: RrtExplorer::new(),
        }
    }

    /// Forgets the blacklist and the last step.
    pub fn clear(&mut self) {
        self.blacklist.clear();
        self.candidates.clear();
        self.rrt.clear();
        self.dist.fill(UNREACHABLE);
        self.stats = PlanStats::default();
    }

    /// Moves the window by `(sx, sy)` cells ([`crate::rolling::shift`]): the distance field and
    /// traversability mask move with the cells (new cells unreachable and blocked), blacklist
    /// entries, the last step's candidates and the `rrt` trees are translated, and whatever falls
    /// outside the window is dropped (counted in the return's second value). Returns the work
    /// (cells and entries touched) and the entries dropped.
    pub(crate) fn shift(&mut self, sx: i32, sy: i32) -> (u32, u32) {
        self.blocked.shift(sx, sy, true);
        crate::grid::shift_2d(&mut self.dist, GRID_CELLS, sx as i64, sy as i64, UNREACHABLE);
        let mut work = 2 * GRID_AREA as u32;
        let mut dropped = 0;
        let n = self.blacklist.len() + self.candidates.len();
        self.blacklist.retain_mut(|c| {
            *c = (c.0 - sx, c.1 - sy);
            PackedGrid::in_bounds(c.0, c.1) || {
                dropped += 1;
                false
            }
        });
        self.candidates.retain_mut(|v| {
            v.cell = (v.cell.0 - sx, v.cell.1 - sy);
            PackedGrid::in_bounds(v.cell.0, v.cell.1) || {
                dropped += 1;
                false
            }
        });
        self.robot_cell = (self.robot_cell.0 - sx, self.robot_cell.1 - sy);
        work += n as u32;
        let (w, d) = self.rrt.shift(sx, sy);
        (work + w, dropped + d)
    }

    /// Path distance (units of 0.02 m) from the robot to `(x, y)` as of the last step.
    #[inline]
    pub fn distance(&self, x: i32, y: i32) -> u16 {
        if PackedGrid::in_bounds(x, y) {
            self.dist[idx(x, y)]
        } else {
            UNREACHABLE
        }
    }

    /// True if the last step considered `(x, y)` traversable.
    pub fn traversable(&self, x: i32, y: i32) -> bool {
        PackedGrid::in_bounds(x, y) && !self.blocked.get(x, y)
    }

    /// Remembers a failed goal; candidates near it are dropped from now on.
    pub fn blacklist(&mut self, cell: (i32, i32)) {
        if self.blacklist.is_full() {
            self.blacklist.pop_front();
        }
        let _ = self.blacklist.push_back(cell);
    }

    /// Goals blacklisted so far (oldest first).
    pub fn blacklisted(&self) -> impl Iterator<Item = &(i32, i32)> {
        self.blacklist.iter()
    }

    fn is_blacklisted(&self, c: (i32, i32), radius_cells: i32) -> bool {
        let r2 = radius_cells as i64 * radius_cells as i64;
        self.blacklist.iter().any(|b| ((b.0 - c.0) as i64).pow(2) + ((b.1 - c.1) as i64).pow(2) <= r2)
    }

    /// Step 1: which cells the robot may stand on.
    fn inflate(&mut self, lidar: &LidarGrid, radius: Meters, robot: (i32, i32)) -> u32 {
        let mut offsets: heapless::Vec<(i8, i8), MAX_INFLATION_OFFSETS> = heapless::Vec::new();
        // Cells whose centre lies within `radius` of an occupied cell's centre: the squared
        // distance in cells, exact (0.35 m → ≤ 12.25 cells², not a radius rounded to 4 cells,
        // which would leave a 1 m doorway only two cells wide). A radius beyond the largest a
        // valid configuration has ([`MAX_ROBOT_RADIUS_M`], the capacity of `offsets`) is taken
        // as that one.
        let radius = radius.clamp(Meters::ZERO, MAX_ROBOT_RADIUS_M);
        let r_q16 = radius.to_bits() as i64 * crate::capacity::CELLS_PER_METER;
        let r2 = ((r_q16 * r_q16) >> 32) as i32;
        let r = ((r_q16 + 0xFFFF) >> 16) as i32;
        for dy in -r..=r {
            for dx in -r..=r {
                if dx * dx + dy * dy <= r2 {
                    let _ = offsets.push((dx as i8, dy as i8));
                }
            }
        }
        let mut work = 0;
        for y in 0..GRID_CELLS as i32 {
            for x in 0..GRID_CELLS as i32 {
                let c = lidar.get(x, y);
                self.blocked.put(x, y, c != Cell::Free);
                work += 1;
            }
        }
        for y in 0..GRID_CELLS as i32 {
            for x in 0..GRID_CELLS as i32 {
                if lidar.get(x, y) == Cell::Occupied {
                    for &(dx, dy) in offsets.iter() {
                        self.blocked.put(x + dx as i32, y + dy as i32, true);
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
                .filter(|&&(dx, dy)| lidar.get(x + dx as i32, y + dy as i32) == Cell::Occupied)
                .map(|&(dx, dy)| dx as i32 * dx as i32 + dy as i32 * dy as i32)
                .min()
                .unwrap_or(i32::MAX)
        };
        let own = clearance(robot.0, robot.1);
        let mut escape = false;
        for pass in 0..2 {
            for &(dx, dy) in offsets.iter() {
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
                    escape |= neighbour;
                }
            }
            if escape || own == i32::MAX {
                break;
            }
        }
        work
    }

    /// Step 2: Dijkstra from the robot's cell over traversable cells.
    fn distances(&mut self, robot: (i32, i32)) -> u32 {
        self.dist.fill(UNREACHABLE);
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
        while let Some(e) = self.heap.pop() {
            let d = (e >> 32) as u16;
            let i = (e & 0xFFFF_FFFF) as usize;
            if d > self.dist[i] {
                continue;
            }
            work += 1;
            self.stats.reachable_cells += 1;
            let (x, y) = ((i % GRID_CELLS) as i32, (i / GRID_CELLS) as i32);
            for &(dx, dy, cost) in N8.iter() {
                let (nx, ny) = (x + dx, y + dy);
                if !self.traversable(nx, ny) {
                    continue;
                }
                if dx != 0 && dy != 0 && (!self.traversable(x + dx, y) || !self.traversable(x, y + dy)) {
                    continue;
                }
                let nd = d.saturating_add(cost);
                let ni = idx(nx, ny);
                if nd < self.dist[ni] {
                    self.dist[ni] = nd;
                    if self.heap.push(((nd as u64) << 32) | ni as u64).is_err() {
                        self.stats.heap_overflows += 1;
                    }
                }
            }
            work += 8;
        }
        work
    }

    /// One step down the distance field from `(x, y)`, or `None` at the robot / a dead end.
    #[inline]
    fn descend(&self, x: i32, y: i32) -> Option<(i32, i32)> {
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

    /// Frontier cells in blocks near the path from the robot to `(x, y)`, each block once.
    fn frontier_near_path(&mut self, frontiers: &FrontierSet, x: i32, y: i32, reach: i32) -> (u32, u32) {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.block_stamp.fill(0);
            self.stamp = 1;
        }
        let mut total = 0u32;
        let mut work = 0u32;
        let mut cur = Some((x, y));
        let mut last_block = (-1, -1);
        let mut steps = 0usize;
        while let Some((cx, cy)) = cur {
            let b = (cx / BLOCK_CELLS as i32, cy / BLOCK_CELLS as i32);
            if b != last_block {
                last_block = b;
                for by in b.1 - reach..=b.1 + reach {
                    for bx in b.0 - reach..=b.0 + reach {
                        if (bx as u32) < BLOCKS as u32 && (by as u32) < BLOCKS as u32 {
                            let k = by as usize * BLOCKS + bx as usize;
                            if self.block_stamp[k] != self.stamp {
                                self.block_stamp[k] = self.stamp;
                                total += frontiers.block_count(bx, by) as u32;
                            }
                        }
                        work += 1;
                    }
                }
            }
            steps += 1;
            if steps > GRID_AREA {
                break;
            }
            cur = self.descend(cx, cy);
            work += 9;
        }
        (total, work)
    }

    /// Where a frontier's (or frontier point's) viewpoint stands: [`Planner::reachable_near`],
    /// with its work added to `work` and a miss counted in `unreachable`.
    fn snap_site(&self, at: (i32, i32), snap: i32, work: &mut u32, unreachable: &mut u32) -> Option<(i32, i32)> {
        *work += ((2 * snap + 1) * (2 * snap + 1)) as u32;
        let c = self.reachable_near(at, snap);
        *unreachable += c.is_none() as u32;
        c
    }

    /// The nearest reachable cell to `c` within `radius` cells (Euclidean), `c` itself first.
    fn reachable_near(&self, c: (i32, i32), radius: i32) -> Option<(i32, i32)> {
        if self.distance(c.0, c.1) != UNREACHABLE {
            return Some(c);
        }
        let mut best: Option<(i64, (i32, i32))> = None;
        for dy in -radius..=radius {
            for dx in -radius..=radius {
                let d2 = (dx * dx + dy * dy) as i64;
                if d2 > (radius * radius) as i64 || self.distance(c.0 + dx, c.1 + dy) == UNREACHABLE {
                    continue;
                }
                if best.is_none_or(|(bd, _)| d2 < bd) {
                    best = Some((d2, (c.0 + dx, c.1 + dy)));
                }
            }
        }
        best.map(|b| b.1)
    }

    /// Collects the bearings of the non-map points visible (range + line of sight) from `c`.
    fn visible_nonmap(&mut self, lidar: &LidarGrid, nonmap: &NonMapStore, c: (i32, i32), range_cells: i32) -> u32 {
        self.visible.clear();
        let mut work = 0;
        let r2 = range_cells as i64 * range_cells as i64;
        for p in nonmap.points() {
            work += 1;
            let (px, py) = lidar.geom.cell_of(p.x, p.y);
            if !PackedGrid::in_bounds(px, py) {
                continue;
            }
            let (dx, dy) = ((px - c.0) as i64, (py - c.1) as i64);
            if dx * dx + dy * dy > r2 {
                continue;
            }
            let mut clear = true;
            for (x, y) in Line::new(c.0, c.1, px, py) {
                work += 1;
                if (x - px).abs() <= 1 && (y - py).abs() <= 1 {
                    break;
                }
                if lidar.get(x, y) == Cell::Occupied {
                    clear = false;
                    break;
                }
            }
            if clear {
                let block = (py as u32 / BLOCK_CELLS as u32) * BLOCKS as u32 + px as u32 / BLOCK_CELLS as u32;
                let _ = self.visible.push((atan2(dy as i32, dx as i32), block));
            }
        }
        work
    }

    /// Non-map clusters: points bucketed by block, as (centroid cell, points), at most
    /// [`MAX_NONMAP_SITES`], blocks in raster order of first appearance.
    fn nonmap_clusters(&self, lidar: &LidarGrid, nonmap: &NonMapStore) -> heapless::Vec<((i32, i32), u32), MAX_NONMAP_SITES> {
        let mut sums: heapless::Vec<(u32, i64, i64, u32), MAX_NONMAP_SITES> = heapless::Vec::new();
        for p in nonmap.points() {
            let (x, y) = lidar.geom.cell_of(p.x, p.y);
            if !PackedGrid::in_bounds(x, y) {
                continue;
            }
            let block = (y as u32 / BLOCK_CELLS as u32) * BLOCKS as u32 + x as u32 / BLOCK_CELLS as u32;
            match sums.iter_mut().find(|e| e.0 == block) {
                Some(e) => {
                    e.1 += x as i64;
                    e.2 += y as i64;
                    e.3 += 1;
                }
                None => {
                    let _ = sums.push((block, x as i64, y as i64, 1));
                }
            }
        }
        sums.iter().map(|e| (((e.1 / e.3 as i64) as i32, (e.2 / e.3 as i64) as i32), e.3)).collect()
    }

    /// Where to stand to look at a non-map cluster at `p`: on the line from `p` towards the robot,
    /// `standoff` cells from `p` (or at the robot if it is nearer), then snapped to a reachable
    /// cell. Returns the cell and the exact bearing from it to `p`.
    fn nonmap_viewpoint(&self, p: (i32, i32), standoff: i32, snap: i32) -> Option<((i32, i32), BinaryAngle)> {
        let r = self.robot_cell;
        let (dx, dy) = ((r.0 - p.0) as i64, (r.1 - p.1) as i64);
        let d = fixed_point::isqrt_u64((dx * dx + dy * dy) as u64) as i64;
        let v = if d <= standoff as i64 || d == 0 {
            r
        } else {
            ((p.0 as i64 + dx * standoff as i64 / d) as i32, (p.1 as i64 + dy * standoff as i64 / d) as i32)
        };
        let v = self.reachable_near(v, snap)?;
        if v == p {
            return None;
        }
        Some((v, atan2(p.1 - v.1, p.0 - v.0)))
    }

    /// One planning step. `current` is the goal being pursued (cell and heading), re-scored with
    /// the same terms so the caller can apply hysteresis; returns `(best, current_utility)`.
    #[allow(clippy::too_many_arguments)]
    pub fn plan(
        &mut self,
        cfg: &Config,
        lidar: &LidarGrid,
        visual: &VisualGrid,
        frontiers: &FrontierSet,
        nonmap: &NonMapStore,
        pose: &Pose2,
        current: Option<((i32, i32), BinaryAngle)>,
    ) -> (Option<Goal>, Option<i64>) {
        self.stats = PlanStats::default();
        self.candidates.clear();
        let robot = lidar.geom.cell_of(pose.x, pose.y);
        self.robot_cell = robot;
        let mut work = self.inflate(lidar, cfg.robot_radius_m, robot);
        work += self.distances(robot);
        let snap = GridGeometry::cells(cfg.viewpoint_snap_radius_m);
        let bl = GridGeometry::cells(cfg.blacklist_radius_m);
        let range_cells = GridGeometry::cells(cfg.camera_range_m);
        let w_nonmap = cfg.effective_w_nonmap();
        let nearest = cfg.planner == PlannerKind::Nearest;
        let explore_lite = cfg.planner == PlannerKind::ExploreLite;
        let use_rrt = cfg.planner == PlannerKind::Rrt;
        // The baselines score sites by their own rules and face the direction of travel.
        let baseline = cfg.planner.is_baseline();
        let lidar_frontiers_reachable = (nearest || explore_lite)
            && frontiers.frontiers().iter().any(|f| f.source == FrontierSource::Lidar && self.reachable_near(f.anchor, snap).is_some());
        if use_rrt {
            work += self.rrt.grow(lidar, visual, robot);
        }

        // Sites: frontier anchors; for `lives`, viewpoints aimed at non-map clusters; last, the
        // current goal (re-scored for hysteresis, never a candidate itself).
        // The fourth field is a baseline's own score of the site (`explore-lite`, `rrt`).
        let mut sites: heapless::Vec<SiteEntry, { SITES }> = heapless::Vec::new();
        let euclid_bits = |c: (i32, i32)| {
            let d2 = ((c.0 - robot.0) as i64).pow(2) + ((c.1 - robot.1) as i64).pow(2);
            // Q16.16 metres: sqrt(d2 · 2³²) is the distance in cells · 2¹⁶.
            fixed_point::isqrt_u64((d2 as u64) << 32) as i64 / crate::capacity::CELLS_PER_METER
        };
        let mut unreachable = 0;
        for f in frontiers.frontiers() {
            if use_rrt || ((nearest || explore_lite) && lidar_frontiers_reachable && f.source != FrontierSource::Lidar) {
                continue;
            }
            let Some(c) = self.snap_site(f.anchor, snap, &mut work, &mut unreachable) else { continue };
            let kind = Site::frontier(f.source);
            let own = if explore_lite {
                EXPLORE_LITE_GAIN_SCALE * f.cells as i64 * 65_536 - EXPLORE_LITE_POTENTIAL_SCALE * euclid_bits(f.anchor)
            } else {
                0
            };
            let _ = sites.push((c, kind, None, own));
        }
        if use_rrt {
            let lidar_points = self.rrt.points().any(|p| p.source == FrontierSource::Lidar && self.reachable_near(p.cell, snap).is_some());
            for &p in self.rrt.points() {
                if lidar_points && p.source != FrontierSource::Lidar {
                    continue;
                }
                let Some(c) = self.snap_site(p.cell, snap, &mut work, &mut unreachable) else { continue };
                let _ = sites.push((c, Site::frontier(p.source), None, rrt::revenue(lidar, visual, p, robot)));
            }
        }
        self.stats.unreachable += unreachable;
        if cfg.planner == PlannerKind::Lives && cfg.nonmap_viewpoints {
            let standoff = GridGeometry::cells(cfg.nonmap_standoff_m);
            for (p, _) in self.nonmap_clusters(lidar, nonmap) {
                work += ((2 * snap + 1) * (2 * snap + 1)) as u32;
                match self.nonmap_viewpoint(p, standoff, snap) {
                    Some((c, h)) => {
                        let _ = sites.push((c, Site::NonMapCluster, Some(h), 0));
                    }
                    None => self.stats.unreachable += 1,
                }
            }
        }
        if !baseline && cfg.look_around_here && PackedGrid::in_bounds(robot.0, robot.1) {
            // Turning in place is an action too: the four headings at the robot's own cell.
            let _ = sites.push((robot, Site::Here, None, 0));
        }
        // The current goal is re-scored for hysteresis, except under `explore-lite` (which
        // switches to any better frontier) and `rrt` (which keeps a goal until it is reached or
        // fails; see `Controller`).
        if let (Some((c, h)), false) = (current, explore_lite || use_rrt) {
            if self.distance(c.0, c.1) != UNREACHABLE {
                let _ = sites.push((c, Site::Current, Some(h), 0));
            }
        }

        let mut best: Option<Viewpoint> = None;
        let mut current_utility = None;
        let here = GridGeometry::cells(cfg.goal_tolerance_m) as i64 * STEP_STRAIGHT as i64;
        let already_there = |cell: (i32, i32), h: BinaryAngle, d: u16| {
            (cell == robot || (d as i64) <= here) && (h - pose.theta).unsigned_abs() <= cfg.goal_heading_tolerance.unsigned_abs()
        };
        for &(site, kind, fixed_heading, own_score) in sites.iter() {
            if kind != Site::Current && self.is_blacklisted(site, bl) {
                self.stats.blacklisted += 1;
                continue;
            }
            let path_units = self.distance(site.0, site.1);
            let path_mm = path_units as i64 * (crate::capacity::CELL_MM / STEP_STRAIGHT as i64);
            let dist_term = (cfg.w_dist_per_m.to_bits() as i64 * path_mm) / 1000;
            if baseline {
                let heading = fixed_heading.unwrap_or_else(|| self.travel_heading(site, pose));
                let vp = Viewpoint {
                    cell: site,
                    heading,
                    source: kind,
                    utility: if nearest { -dist_term } else { own_score },
                    path_units,
                    unseen: 0,
                    surface: 0,
                    frontier_near_path: 0,
                    nonmap: 0,
                };
                let at = already_there(site, heading, path_units);
                self.offer(vp, &mut best, &mut current_utility, at);
                continue;
            }
            let (near, w) = self.frontier_near_path(frontiers, site.0, site.1, cfg.frontier_near_path_blocks as i32);
            work += w;
            work += if w_nonmap != Weight::ZERO { self.visible_nonmap(lidar, nonmap, site, range_cells) } else { 0 };
            let headings: &[BinaryAngle] = match &fixed_heading {
                Some(h) => core::slice::from_ref(h),
                None => &HEADINGS,
            };
            for &heading in headings {
                let view = visual.unseen_in_cone(
                    lidar,
                    site.0,
                    site.1,
                    heading,
                    cfg.camera_fov,
                    range_cells,
                    SCORE_RAYS,
                    cfg.unseen_unknown_eighths,
                );
                work += view.work;
                let unseen = view.unseen_cells;
                let nm = if w_nonmap != Weight::ZERO { self.in_cone(cfg, heading) } else { 0 };
                let gain = cfg.w_unknown_per_cell.to_bits() as i64 * unseen as i64
                    + cfg.w_surface_per_ray.to_bits() as i64 * view.unseen_surface_rays as i64
                    + cfg.w_frontier_per_cell.to_bits() as i64 * near as i64
                    + w_nonmap.to_bits() as i64 * nm as i64;
                let utility = gain - dist_term;
                let vp = Viewpoint {
                    cell: site,
                    heading,
                    source: kind,
                    utility,
                    path_units,
                    unseen,
                    surface: view.unseen_surface_rays,
                    frontier_near_path: near,
                    nonmap: nm,
                };
                let at = already_there(site, heading, path_units);
                self.offer(vp, &mut best, &mut current_utility, at);
            }
        }
        self.stats.work = work;
        let goal = best.map(|vp| self.goal_for(lidar, vp));
        (goal, current_utility)
    }

    /// Where the camera should look from the robot's own cell while the base walks its path
    /// (the base is holonomic: Spot can walk one way and face another). Each of
    /// [`GAZE_HEADINGS`] headings is scored with the utility's view terms — camera-unseen cells
    /// and, for `lives`, non-map points in the cone — and the best is returned with its score
    /// (Q16.16 utility bits), or `None` when no heading offers at least `cfg.gaze_min_gain`.
    /// `current` is the heading returned on the last tick: it is kept while it offers at least
    /// half of `gaze_min_gain` and no heading beats it by `gaze_min_gain` (hysteresis).
    /// Reads the grids, writes only scratch; its work units are returned too.
    pub fn gaze(
        &mut self,
        cfg: &Config,
        lidar: &LidarGrid,
        visual: &VisualGrid,
        nonmap: &NonMapStore,
        pose: &Pose2,
        current: Option<BinaryAngle>,
    ) -> (Option<(BinaryAngle, i64)>, u32) {
        let robot = lidar.geom.cell_of(pose.x, pose.y);
        if !PackedGrid::in_bounds(robot.0, robot.1) {
            return (None, 0);
        }
        let range_cells = GridGeometry::cells(cfg.camera_range_m);
        let w_nonmap = cfg.effective_w_nonmap();
        let mut work = if w_nonmap != Weight::ZERO { self.visible_nonmap(lidar, nonmap, robot, range_cells) } else { 0 };
        let mut best: Option<(BinaryAngle, i64)> = None;
        let mut kept: Option<(BinaryAngle, i64)> = None;
        for i in 0..GAZE_HEADINGS {
            let heading = BinaryAngle((i as u32).wrapping_mul(u32::MAX / GAZE_HEADINGS as u32 + 1) as i32);
            let view = visual.unseen_in_cone(
                lidar,
                robot.0,
                robot.1,
                heading,
                cfg.camera_fov,
                range_cells,
                SCORE_RAYS,
                cfg.unseen_unknown_eighths,
            );
            work += view.work;
            let nm = if w_nonmap != Weight::ZERO { self.in_cone(cfg, heading) } else { 0 };
            let gain = cfg.w_unknown_per_cell.to_bits() as i64 * view.unseen_cells as i64
                + cfg.w_surface_per_ray.to_bits() as i64 * view.unseen_surface_rays as i64
                + w_nonmap.to_bits() as i64 * nm as i64;
            if current == Some(heading) {
                kept = Some((heading, gain));
            }
            if best.is_none_or(|(_, g)| gain > g) {
                best = Some((heading, gain));
            }
        }
        // Hysteresis (the base turns at a finite rate, and a heading re-chosen every tick among
        // near-equal scores is never reached): the last tick's heading stays while it offers at
        // least half the least gain and no heading beats it by the least gain.
        let min_gain = cfg.gaze_min_gain.to_bits() as i64;
        if let (Some(k), Some(b)) = (kept, best) {
            if 2 * k.1 >= min_gain && b.1 < k.1 + min_gain {
                return (Some(k), work);
            }
        }
        (best.filter(|&(_, g)| g >= min_gain), work)
    }

    /// Visible non-map points (from the last [`Planner::visible_nonmap`]) within the camera cone
    /// facing `heading`, at most `cfg.nonmap_view_cap` of them (0 = no cap).
    fn in_cone(&self, cfg: &Config, heading: BinaryAngle) -> u32 {
        let n = self.in_cone_per_block(heading, cfg.camera_fov, cfg.nonmap_block_cap);
        match cfg.nonmap_view_cap {
            0 => n,
            cap => n.min(cap as u32),
        }
    }

    /// The points within the cone; with `cap > 0`, at most `cap` count per 0.8 m block (a scaled
    /// count: several distinct objects outweigh one large piece of furniture).
    fn in_cone_per_block(&self, heading: BinaryAngle, fov: BinaryAngle, cap: u8) -> u32 {
        let half = fov.0 as u32 / 2;
        let in_view = self.visible.iter().filter(|(a, _)| (*a - heading).unsigned_abs() <= half);
        if cap == 0 {
            return in_view.count() as u32;
        }
        let mut per_block: heapless::Vec<(u32, u8), MAX_NONMAP_SITES> = heapless::Vec::new();
        let mut total = 0;
        for &(_, block) in in_view {
            match per_block.iter_mut().find(|e| e.0 == block) {
                Some(e) if e.1 >= cap => {}
                Some(e) => {
                    e.1 += 1;
                    total += 1;
                }
                None => {
                    // Blocks beyond the scratch capacity still count their first point.
                    let _ = per_block.push((block, 1));
                    total += 1;
                }
            }
        }
        total
    }

    fn offer(&mut self, vp: Viewpoint, best: &mut Option<Viewpoint>, current_utility: &mut Option<i64>, already_there: bool) {
        if vp.source == Site::Current {
            *current_utility = Some(vp.utility);
            return;
        }
        if already_there {
            // The robot stands there looking that way: the camera already shows what it offers.
            self.stats.already_there += 1;
            return;
        }
        self.stats.candidates += 1;
        let _ = self.candidates.push(vp);
        if best.is_none_or(|b| vp.utility > b.utility) {
            *best = Some(vp);
        }
    }

    /// For `nearest`: the quarter-turn heading closest to the direction of travel into `site`.
    fn travel_heading(&self, site: (i32, i32), pose: &Pose2) -> BinaryAngle {
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

    /// True if every cell on the straight line between `a` and `b` is reachable.
    fn line_clear(&self, a: (i32, i32), b: (i32, i32)) -> bool {
        Line::new(a.0, a.1, b.0, b.1).all(|(x, y)| self.distance(x, y) != UNREACHABLE)
    }

    /// The goal for `vp`, with its path pulled taut: walking down the distance field from the
    /// goal, a waypoint is emitted where the straight line from the previous waypoint would leave
    /// reachable cells, or every [`MAX_SEGMENT_CELLS`], so the base can drive straight between
    /// consecutive waypoints. The path starts at the first waypoint after the robot's cell.
    fn goal_for(&self, lidar: &LidarGrid, vp: Viewpoint) -> Goal {
        let mut rev: heapless::Vec<(i32, i32), MAX_PATH_WAYPOINTS> = heapless::Vec::new();
        let _ = rev.push(vp.cell);
        let mut anchor = vp.cell;
        let mut prev = vp.cell;
        let mut steps = 0usize;
        let mut cur = self.descend(vp.cell.0, vp.cell.1);
        while let Some(c) = cur {
            steps += 1;
            if steps > GRID_AREA {
                break;
            }
            let long = (c.0 - anchor.0).abs().max((c.1 - anchor.1).abs()) > MAX_SEGMENT_CELLS;
            if (long || !self.line_clear(anchor, c)) && prev != anchor {
                if rev.push(prev).is_err() {
                    break;
                }
                anchor = prev;
            }
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

impl Default for Planner {
    fn default() -> Self {
        Self::new()
    }
}
