//! A sampling-based explorer in the spirit of RRT exploration (Umari & Mukhopadhyay, IROS 2017):
//! a baseline for `lives eval`, not part of LIVES.
//!
//! **What it does.** Two rapidly-exploring random trees grow over the LiDAR map's free cells: a
//! *global* tree rooted where the search started, which persists, and a *local* tree rooted at the
//! robot, which is reset to the robot's cell every time it finds a frontier point. Each growth
//! iteration draws a cell uniformly over the grid, takes the tree's nearest node, and steers
//! [`ETA_CELLS`] towards the sample. The edge is walked cell by cell over the LiDAR map:
//! - an occupied cell: the edge is dropped;
//! - an unknown cell: that cell is a **LiDAR frontier point** (the edge is not added);
//! - otherwise the node is added, and if the edge leaves camera-seen space into free space the
//!   camera has not seen, the first such cell is a **camera frontier point** (a visual search needs
//!   the camera's frontier too; the original explores the LiDAR map only).
//!
//! Frontier points within [`CLUSTER_CELLS`] of a kept point of the same map are merged into it
//! (the original clusters with mean shift); a point whose *information gain* — unknown cells of
//! its map within [`INFO_RADIUS_CELLS`] — falls below [`MIN_INFO_CELLS`] is dropped (the
//! original's filter node). The planner scores each point with the original assigner's
//! *revenue*: `INFO_MULTIPLIER · gain_area_m² · (HYSTERESIS_GAIN if within HYSTERESIS_RADIUS) −
//! euclidean_distance_m`, LiDAR points first and camera points once no LiDAR point is reachable,
//! as `nearest` does, and the controller keeps a goal until it is reached or fails (the
//! original's assigner only gives an idle robot a new goal).
//!
//! **Determinism.** Samples come from a xorshift32 generator with a fixed seed ([`RRT_SEED`]),
//! reseeded by [`RrtExplorer::clear`]: the same inputs give the same trees, bit for bit. Runs
//! still differ between trials because the simulator's seed moves the start, the target, the
//! people and the sensor noise.
//!
//! **Memory.** [`RRT_GLOBAL_NODES`] + [`RRT_LOCAL_NODES`] nodes of two `i16`s and
//! [`RRT_POINTS`] frontier points, all inline; a full global tree stops growing (frontier
//! detection continues from its nodes), a full point list drops its oldest point.

use crate::capacity::GRID_CELLS;
use crate::frontier::FrontierSource;
use crate::grid::{Cell, LidarGrid, Line, VisualGrid};

/// Advances a xorshift32 generator (Marsaglia 2003) and returns its new state: the core's one
/// deterministic source of pseudo-random numbers (the sampler here; the target's self-tests).
/// A state of 0 stays 0.
#[inline]
pub fn xorshift32(state: &mut u32) -> u32 {
    let mut x = *state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *state = x;
    x
}

/// Capacity of the global tree.
pub const RRT_GLOBAL_NODES: usize = 2048;
/// Capacity of the local tree.
pub const RRT_LOCAL_NODES: usize = 512;
/// Frontier points kept.
pub const RRT_POINTS: usize = 128;
/// Growth iterations of each tree per planning step.
pub const RRT_ITERATIONS: u32 = 300;
/// Steering step: 1.0 m (the original's `eta`).
pub const ETA_CELLS: i32 = 10;
/// Information-gain radius: 1.0 m (the original's `info_radius`).
pub const INFO_RADIUS_CELLS: i32 = 10;
/// Points with fewer unknown cells than this within the radius are dropped (0.2 m²).
pub const MIN_INFO_CELLS: u32 = 20;
/// Frontier points closer than this (0.3 m) to a kept point are merged into it.
pub const CLUSTER_CELLS: i32 = 3;
/// Revenue weight of the information gain (the original's `info_multiplier`).
pub const INFO_MULTIPLIER: i64 = 3;
/// Gain multiplier for points within [`HYSTERESIS_RADIUS_CELLS`] of the robot.
pub const HYSTERESIS_GAIN: i64 = 2;
/// 3.0 m (the original's `hysteresis_radius`).
pub const HYSTERESIS_RADIUS_CELLS: i32 = 30;
/// The sampler's seed.
pub const RRT_SEED: u32 = 0x9E37_79B9;

/// A frontier point found by a tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RrtPoint {
    /// Cell.
    pub cell: (i32, i32),
    /// The map whose frontier it is.
    pub source: FrontierSource,
}

/// Counters of the explorer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RrtStats {
    /// Nodes in the global tree.
    pub global_nodes: u32,
    /// Frontier points found in total (before merging).
    pub found: u32,
    /// Points dropped by the information-gain filter.
    pub filtered: u32,
}

struct Tree<const N: usize> {
    nodes: heapless::Vec<(i16, i16), N>,
}

impl<const N: usize> Tree<N> {
    const fn new() -> Self {
        Self { nodes: heapless::Vec::new() }
    }

    fn reset(&mut self, root: (i32, i32)) {
        self.nodes.clear();
        let _ = self.nodes.push((root.0 as i16, root.1 as i16));
    }

    /// The node nearest `s` (squared Euclidean, first wins ties).
    fn nearest(&self, s: (i32, i32)) -> Option<(i32, i32)> {
        let mut best: Option<(i64, (i32, i32))> = None;
        for &(x, y) in self.nodes.iter() {
            let (dx, dy) = ((x as i32 - s.0) as i64, (y as i32 - s.1) as i64);
            let d2 = dx * dx + dy * dy;
            if best.is_none_or(|(b, _)| d2 < b) {
                best = Some((d2, (x as i32, y as i32)));
            }
        }
        best.map(|b| b.1)
    }
}

/// What one edge met.
enum Edge {
    /// Hit an occupied cell.
    Blocked,
    /// Reached a LiDAR-unknown cell here.
    LidarFrontier((i32, i32)),
    /// Free all the way; `Some` where it first entered camera-unseen free space from seen space.
    Free(Option<(i32, i32)>),
}

/// The explorer's state: trees, frontier points and the sampler.
pub struct RrtExplorer {
    global: Tree<RRT_GLOBAL_NODES>,
    local: Tree<RRT_LOCAL_NODES>,
    points: heapless::Deque<RrtPoint, RRT_POINTS>,
    rng: u32,
    /// Counters.
    pub stats: RrtStats,
}

impl RrtExplorer {
    /// Empty trees (rooted at the first [`RrtExplorer::grow`]).
    pub const fn new() -> Self {
        Self {
            global: Tree::new(),
            local: Tree::new(),
            points: heapless::Deque::new(),
            rng: RRT_SEED,
            stats: RrtStats { global_nodes: 0, found: 0, filtered: 0 },
        }
    }

    /// Forgets the trees and points and reseeds the sampler.
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Moves the window by `(sx, sy)` cells ([`crate::rolling::shift`]): every node and point is
    /// translated and those that fall outside the window are dropped (a tree is a set of nodes
    /// with no parent links, so dropping nodes leaves a valid tree; an emptied tree is re-rooted
    /// at the robot by the next [`RrtExplorer::grow`]). Returns the work (entries touched) and
    /// the entries dropped.
    pub(crate) fn shift(&mut self, sx: i32, sy: i32) -> (u32, u32) {
        let inside = |x: i32, y: i32| (x as u32) < GRID_CELLS as u32 && (y as u32) < GRID_CELLS as u32;
        let work = (self.global.nodes.len() + self.local.nodes.len() + self.points.len()) as u32;
        let before = work;
        let mv = |n: &mut (i16, i16)| {
            let (x, y) = (n.0 as i32 - sx, n.1 as i32 - sy);
            *n = (x as i16, y as i16);
            inside(x, y)
        };
        self.global.nodes.retain_mut(mv);
        self.local.nodes.retain_mut(mv);
        self.points.retain_mut(|p| {
            p.cell = (p.cell.0 - sx, p.cell.1 - sy);
            inside(p.cell.0, p.cell.1)
        });
        self.stats.global_nodes = self.global.nodes.len() as u32;
        let after = (self.global.nodes.len() + self.local.nodes.len() + self.points.len()) as u32;
        (work, before - after)
    }

    /// The frontier points kept (oldest first).
    pub fn points(&self) -> impl Iterator<Item = &RrtPoint> {
        self.points.iter()
    }

    fn next(&mut self) -> u32 {
        xorshift32(&mut self.rng)
    }

    fn sample(&mut self) -> (i32, i32) {
        let x = (self.next() % GRID_CELLS as u32) as i32;
        let y = (self.next() % GRID_CELLS as u32) as i32;
        (x, y)
    }

    /// Grows both trees by [`RRT_ITERATIONS`] iterations each, then filters the points.
    /// Returns the work (cells visited).
    pub fn grow(&mut self, lidar: &LidarGrid, visual: &VisualGrid, robot: (i32, i32)) -> u32 {
        if self.global.nodes.is_empty() {
            self.global.reset(robot);
        }
        if self.local.nodes.is_empty() {
            self.local.reset(robot);
        }
        let mut work = 0;
        for _ in 0..RRT_ITERATIONS {
            let s = self.sample();
            work += self.extend_global(lidar, visual, s);
            let s = self.sample();
            work += self.extend_local(lidar, visual, s, robot);
        }
        self.stats.global_nodes = self.global.nodes.len() as u32;
        work + self.filter(lidar, visual)
    }

    fn extend_global(&mut self, lidar: &LidarGrid, visual: &VisualGrid, s: (i32, i32)) -> u32 {
        let Some(from) = self.global.nearest(s) else { return 0 };
        let to = steer(from, s);
        let (edge, work) = walk(lidar, visual, from, to);
        match edge {
            Edge::Blocked => {}
            Edge::LidarFrontier(c) => self.found(c, FrontierSource::Lidar),
            Edge::Free(visual_point) => {
                if let Some(c) = visual_point {
                    self.found(c, FrontierSource::Visual);
                }
                if to != from {
                    let _ = self.global.nodes.push((to.0 as i16, to.1 as i16));
                }
            }
        }
        work + self.global.nodes.len() as u32
    }

    fn extend_local(&mut self, lidar: &LidarGrid, visual: &VisualGrid, s: (i32, i32), robot: (i32, i32)) -> u32 {
        let Some(from) = self.local.nearest(s) else { return 0 };
        let to = steer(from, s);
        let (edge, work) = walk(lidar, visual, from, to);
        match edge {
            Edge::Blocked => {}
            Edge::LidarFrontier(c) => {
                self.found(c, FrontierSource::Lidar);
                self.local.reset(robot);
            }
            Edge::Free(visual_point) => {
                if let Some(c) = visual_point {
                    self.found(c, FrontierSource::Visual);
                    self.local.reset(robot);
                } else if to != from && self.local.nodes.push((to.0 as i16, to.1 as i16)).is_err() {
                    self.local.reset(robot);
                }
            }
        }
        work + self.local.nodes.len() as u32
    }

    fn found(&mut self, cell: (i32, i32), source: FrontierSource) {
        self.stats.found += 1;
        let r2 = (CLUSTER_CELLS * CLUSTER_CELLS) as i64;
        let near = self.points.iter().any(|p| p.source == source && dist2(p.cell, cell) <= r2);
        if near {
            return;
        }
        if self.points.is_full() {
            self.points.pop_front();
        }
        let _ = self.points.push_back(RrtPoint { cell, source });
    }

    /// Drops points whose information gain fell below [`MIN_INFO_CELLS`].
    fn filter(&mut self, lidar: &LidarGrid, visual: &VisualGrid) -> u32 {
        let n = self.points.len();
        let mut work = 0;
        for _ in 0..n {
            let Some(p) = self.points.pop_front() else { break };
            work += ((2 * INFO_RADIUS_CELLS + 1) * (2 * INFO_RADIUS_CELLS + 1)) as u32;
            if info_gain(lidar, visual, p) >= MIN_INFO_CELLS {
                let _ = self.points.push_back(p);
            } else {
                self.stats.filtered += 1;
            }
        }
        work
    }
}

impl Default for RrtExplorer {
    fn default() -> Self {
        Self::new()
    }
}

/// Unknown cells of the point's map within [`INFO_RADIUS_CELLS`] (for the camera map: LiDAR-free
/// cells the camera has not seen — floor where a target could stand).
pub fn info_gain(lidar: &LidarGrid, visual: &VisualGrid, p: RrtPoint) -> u32 {
    let r = INFO_RADIUS_CELLS;
    let mut n = 0;
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy > r * r {
                continue;
            }
            let (x, y) = (p.cell.0 + dx, p.cell.1 + dy);
            let unknown = match p.source {
                FrontierSource::Lidar => lidar.get(x, y) == Cell::Unknown,
                FrontierSource::Visual => lidar.get(x, y) == Cell::Free && !visual.seen(x, y),
            };
            n += unknown as u32;
        }
    }
    n
}

/// The assigner's revenue of `p` seen from `robot`, Q16.16 utility bits:
/// `INFO_MULTIPLIER · gain_m² · hysteresis − distance_m`.
pub fn revenue(lidar: &LidarGrid, visual: &VisualGrid, p: RrtPoint, robot: (i32, i32)) -> i64 {
    let gain_bits = info_gain(lidar, visual, p) as i64 * 65_536 / 100; // cells of 0.01 m²
    let d2 = dist2(p.cell, robot);
    let h = if d2 <= (HYSTERESIS_RADIUS_CELLS * HYSTERESIS_RADIUS_CELLS) as i64 { HYSTERESIS_GAIN } else { 1 };
    let dist_bits = fixed_point::isqrt_u64((d2 as u64) << 32) as i64 / 10; // cells · 2¹⁶ → metres
    INFO_MULTIPLIER * gain_bits * h - dist_bits
}

fn dist2(a: (i32, i32), b: (i32, i32)) -> i64 {
    let (dx, dy) = ((a.0 - b.0) as i64, (a.1 - b.1) as i64);
    dx * dx + dy * dy
}

/// At most [`ETA_CELLS`] from `from` towards `s`.
fn steer(from: (i32, i32), s: (i32, i32)) -> (i32, i32) {
    let d2 = dist2(from, s);
    let eta2 = (ETA_CELLS * ETA_CELLS) as i64;
    if d2 <= eta2 {
        return s;
    }
    let d = fixed_point::isqrt_u64(d2 as u64) as i64;
    let (dx, dy) = ((s.0 - from.0) as i64, (s.1 - from.1) as i64);
    (from.0 + (dx * ETA_CELLS as i64 / d) as i32, from.1 + (dy * ETA_CELLS as i64 / d) as i32)
}

fn walk(lidar: &LidarGrid, visual: &VisualGrid, from: (i32, i32), to: (i32, i32)) -> (Edge, u32) {
    let mut work = 0;
    let mut prev_seen = visual.seen(from.0, from.1);
    let mut visual_point = None;
    for (x, y) in Line::new(from.0, from.1, to.0, to.1) {
        work += 1;
        match lidar.get(x, y) {
            Cell::Occupied => return (Edge::Blocked, work),
            Cell::Unknown => return (Edge::LidarFrontier((x, y)), work),
            Cell::Free => {
                let seen = visual.seen(x, y);
                if prev_seen && !seen && visual_point.is_none() {
                    visual_point = Some((x, y));
                }
                prev_seen = seen;
            }
        }
    }
    (Edge::Free(visual_point), work)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GridGeometry;

    fn room() -> (LidarGrid, VisualGrid) {
        // A 10 × 10 m free room (cells 100..200) with walls, unknown outside; an opening on the
        // east wall at y 140..160 leads into unknown space.
        let mut lidar = LidarGrid::new(GridGeometry { origin_x: fixed_point::Meters::ZERO, origin_y: fixed_point::Meters::ZERO });
        for y in 100..=200 {
            for x in 100..=200 {
                let wall = x == 100 || x == 200 || y == 100 || y == 200;
                let door = x == 200 && (140..160).contains(&y);
                lidar.grid.set(x, y, if wall && !door { Cell::Occupied } else { Cell::Free });
            }
        }
        (lidar, VisualGrid::new())
    }

    /// The camera has seen the room's inside at columns `xs`.
    fn seen(visual: &mut VisualGrid, xs: core::ops::Range<i32>) {
        for y in 101..200 {
            for x in xs.clone() {
                visual.grid.set(x, y, Cell::Free);
            }
        }
    }

    /// A new explorer after `steps` growth steps with the robot at `robot`.
    fn grown(lidar: &LidarGrid, visual: &VisualGrid, robot: (i32, i32), steps: u32) -> RrtExplorer {
        let mut rrt = RrtExplorer::new();
        for _ in 0..steps {
            rrt.grow(lidar, visual, robot);
        }
        rrt
    }

    #[test]
    fn the_trees_find_the_doorway_and_nothing_through_walls() {
        let (lidar, mut visual) = room();
        // The camera has seen the whole room: only the doorway is a frontier.
        seen(&mut visual, 101..200);
        let rrt = grown(&lidar, &visual, (150, 150), 10);
        let pts: heapless::Vec<RrtPoint, RRT_POINTS> = rrt.points().copied().collect();
        assert!(!pts.is_empty(), "the doorway is found");
        for p in &pts {
            assert_eq!(p.source, FrontierSource::Lidar);
            assert!(p.cell.0 >= 200 && (138..=161).contains(&p.cell.1), "a point outside the doorway: {p:?}");
        }
        assert!(rrt.stats.global_nodes > 100, "the global tree grows over the room");
    }

    #[test]
    fn camera_frontier_points_appear_where_the_camera_has_not_looked_and_go_when_it_has() {
        let (lidar, mut visual) = room();
        // The camera has seen the west half only; the doorway is closed off.
        let mut lidar = lidar;
        for y in 140..160 {
            lidar.grid.set(200, y, Cell::Occupied);
        }
        seen(&mut visual, 101..150);
        let mut rrt = grown(&lidar, &visual, (120, 150), 5);
        assert!(rrt.points().any(|p| p.source == FrontierSource::Visual && (148..=152).contains(&p.cell.0)));
        assert!(rrt.points().all(|p| p.source == FrontierSource::Visual));
        // The camera looks at everything: every point loses its gain and is dropped.
        seen(&mut visual, 101..200);
        rrt.grow(&lidar, &visual, (120, 150));
        assert_eq!(rrt.points().count(), 0);
        assert!(rrt.stats.filtered > 0);
    }

    #[test]
    fn growth_is_deterministic_and_clear_restarts_it() {
        let (lidar, visual) = room();
        let run = |rrt: &mut RrtExplorer| {
            for _ in 0..3 {
                rrt.grow(&lidar, &visual, (150, 150));
            }
            let pts: heapless::Vec<RrtPoint, RRT_POINTS> = rrt.points().copied().collect();
            (pts, rrt.stats)
        };
        let mut a = RrtExplorer::new();
        let first = run(&mut a);
        a.clear();
        assert_eq!(run(&mut a), first);
        assert_eq!(run(&mut RrtExplorer::new()), first);
    }

    #[test]
    fn revenue_trades_gain_against_distance_with_hysteresis() {
        let (lidar, visual) = room();
        let p = RrtPoint { cell: (201, 150), source: FrontierSource::Lidar };
        let gain = info_gain(&lidar, &visual, p);
        assert!(gain >= MIN_INFO_CELLS);
        let near = revenue(&lidar, &visual, p, (181, 150)); // 2 m: hysteresis applies
        let far = revenue(&lidar, &visual, p, (151, 150)); // 5 m
        let g = gain as i64 * 65_536 / 100;
        assert_eq!(near, 3 * g * 2 - 2 * 65_536);
        assert_eq!(far, 3 * g - 5 * 65_536);
    }
}
