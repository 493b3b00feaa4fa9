//! Coarse reachability: which places a disc-shaped robot can drive to from the start.
//!
//! A 0.1 m grid over the world; a cell is free when a disc of the robot's radius at its centre
//! touches no wall and no obstacle (targets and people are ignored: targets are what we want to
//! reach, people move). Free cells are flooded 4-connected from the start. Used by the tests of
//! the built-in worlds and by the procedural generator; it is a check, not a planner.

use std::collections::VecDeque;

use super::geometry::dist;
use super::{World, P2};

/// Grid resolution of the reachability check.
pub const REACH_RESOLUTION_M: f64 = 0.1;

/// A target counts as reachable when the robot can stand (clear of it) within this distance of
/// its centre.
pub const REACH_STANDOFF_M: f64 = 1.0;

/// [`ReachMap`]'s step count of a cell the flood did not reach.
const UNREACHED: u32 = u32::MAX;

/// The flood fill's result.
pub struct ReachMap {
    origin: P2,
    nx: usize,
    ny: usize,
    /// 4-connected steps from the start cell; [`UNREACHED`] where the flood did not reach.
    steps: Vec<u32>,
}

impl ReachMap {
    /// Flood the free cells of `world` from `from` for a robot of radius `robot_radius_m`.
    pub fn new(world: &World, from: P2, robot_radius_m: f64) -> ReachMap {
        let res = REACH_RESOLUTION_M;
        let scene = world.static_scene(&[]);
        let (origin, nx, ny) = world.grid_over_bounds(res);
        let center = |x: usize, y: usize| [origin[0] + (x as f64 + 0.5) * res, origin[1] + (y as f64 + 0.5) * res];
        let mut map = ReachMap { origin, nx, ny, steps: vec![UNREACHED; nx * ny] };
        let Some(s) = map.index(from) else {
            return map;
        };
        // 0 unknown, 1 free, 2 blocked: free-ness is computed lazily, only for cells the flood
        // touches.
        let mut state = vec![0u8; nx * ny];
        let free = |i: usize, state: &mut Vec<u8>| {
            if state[i] == 0 {
                let c = center(i % nx, i / nx);
                state[i] = if scene.disc_collides(c, robot_radius_m) { 2 } else { 1 };
            }
            state[i] == 1
        };
        if !free(s, &mut state) {
            return map;
        }
        let mut queue = VecDeque::new();
        map.steps[s] = 0;
        queue.push_back(s);
        while let Some(i) = queue.pop_front() {
            let (x, y) = (i % nx, i / nx);
            let next = map.steps[i] + 1;
            let mut visit = |j: usize, map: &mut ReachMap, state: &mut Vec<u8>| {
                if map.steps[j] == UNREACHED && free(j, state) {
                    map.steps[j] = next;
                    queue.push_back(j);
                }
            };
            if x > 0 {
                visit(i - 1, &mut map, &mut state);
            }
            if x + 1 < nx {
                visit(i + 1, &mut map, &mut state);
            }
            if y > 0 {
                visit(i - nx, &mut map, &mut state);
            }
            if y + 1 < ny {
                visit(i + nx, &mut map, &mut state);
            }
        }
        map
    }

    fn index(&self, p: P2) -> Option<usize> {
        let x = ((p[0] - self.origin[0]) / REACH_RESOLUTION_M).floor();
        let y = ((p[1] - self.origin[1]) / REACH_RESOLUTION_M).floor();
        if x >= 0.0 && y >= 0.0 && (x as usize) < self.nx && (y as usize) < self.ny {
            Some(y as usize * self.nx + x as usize)
        } else {
            None
        }
    }

    fn center(&self, i: usize) -> P2 {
        [
            self.origin[0] + ((i % self.nx) as f64 + 0.5) * REACH_RESOLUTION_M,
            self.origin[1] + ((i / self.nx) as f64 + 0.5) * REACH_RESOLUTION_M,
        ]
    }

    fn reached(&self, i: usize) -> bool {
        self.steps[i] != UNREACHED
    }

    /// Was the cell containing `p` reached?
    pub fn is_reached(&self, p: P2) -> bool {
        self.index(p).is_some_and(|i| self.reached(i))
    }

    /// Centres of the reached cells within `radius` of `p`.
    pub fn reached_near(&self, p: P2, radius: f64) -> Vec<P2> {
        let mut out = Vec::new();
        let r = (radius / REACH_RESOLUTION_M).ceil() as isize + 1;
        let cx = ((p[0] - self.origin[0]) / REACH_RESOLUTION_M).floor() as isize;
        let cy = ((p[1] - self.origin[1]) / REACH_RESOLUTION_M).floor() as isize;
        for y in (cy - r).max(0)..=(cy + r).min(self.ny as isize - 1) {
            for x in (cx - r).max(0)..=(cx + r).min(self.nx as isize - 1) {
                let i = y as usize * self.nx + x as usize;
                if self.reached(i) {
                    let c = self.center(i);
                    if dist(c, p) <= radius {
                        out.push(c);
                    }
                }
            }
        }
        out
    }

    /// Length of the shortest 4-connected path from the start to the cell containing `p`, in
    /// metres (an overestimate of the true shortest path by at most a factor of √2), or `None`
    /// where the flood did not reach.
    pub fn path_m(&self, p: P2) -> Option<f64> {
        self.index(p).filter(|&i| self.reached(i)).map(|i| self.steps[i] as f64 * REACH_RESOLUTION_M)
    }

    /// Centres of all reached cells whose [`ReachMap::path_m`] lies in `lo..=hi`, in cell order.
    pub fn reached_within(&self, lo: f64, hi: f64) -> Vec<(P2, f64)> {
        (0..self.steps.len())
            .filter(|&i| self.reached(i))
            .map(|i| (self.center(i), self.steps[i] as f64 * REACH_RESOLUTION_M))
            .filter(|&(_, d)| d >= lo && d <= hi)
            .collect()
    }

    /// Number of reached cells.
    pub fn reached_count(&self) -> usize {
        self.steps.iter().filter(|&&s| s != UNREACHED).count()
    }

    /// Is any cell inside the axis-aligned box `[min, max]` reached?
    pub fn any_reached_in(&self, bb: [P2; 2]) -> bool {
        let x0 = ((bb[0][0] - self.origin[0]) / REACH_RESOLUTION_M).floor().max(0.0) as usize;
        let y0 = ((bb[0][1] - self.origin[1]) / REACH_RESOLUTION_M).floor().max(0.0) as usize;
        let x1 = (((bb[1][0] - self.origin[0]) / REACH_RESOLUTION_M).floor().max(0.0) as usize).min(self.nx - 1);
        let y1 = (((bb[1][1] - self.origin[1]) / REACH_RESOLUTION_M).floor().max(0.0) as usize).min(self.ny - 1);
        (y0..=y1).any(|y| (x0..=x1).any(|x| self.reached(y * self.nx + x)))
    }
}

impl World {
    /// Target positions the robot cannot get near from the nominal start: `(target index,
    /// position)` for each one where no reachable, target-clear spot lies within
    /// [`REACH_STANDOFF_M`] of it. Empty means every target position is reachable.
    pub fn unreachable_targets(&self, robot_radius_m: f64) -> Vec<(usize, P2)> {
        let map = ReachMap::new(self, [self.start.pose[0], self.start.pose[1]], robot_radius_m);
        let mut out = Vec::new();
        for (i, t) in self.targets.iter().enumerate() {
            for p in t.positions() {
                let shape = t.shape_at(p);
                let ok = map.reached_near(p, REACH_STANDOFF_M).into_iter().any(|c| shape.distance_to(c) >= robot_radius_m);
                if !ok {
                    out.push((i, p));
                }
            }
        }
        out
    }
}
