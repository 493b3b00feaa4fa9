//! The non-map store: where the target may be.
//!
//! Every LiDAR point labelled non-map enters here in world coordinates, pooled (a point within
//! `nonmap_pool_radius_m` of a kept point is merged into it), and filtered by the paper's two
//! rules: points near map (wall) points are dropped (they come from localisation drift or a
//! mislabelled wall), and points the camera has already looked at are dropped (the detector saw
//! nothing there). A third rule is ours: a point whose place the LiDAR has since seen empty is
//! dropped ([`NonMapStore::vacated`]): whatever stood there (a person walking by) has moved on,
//! and without the rule a walking person leaves a trail of points that draws the planner to
//! where the person was. Capacity is [`MAX_NONMAP_POINTS`]; when full, new points are refused
//! and counted.
//!
//! This module owns the points and the wall-point mask; it reads the grids, never writes them.

use crate::capacity::{BEAMS, MAX_NONMAP_POINTS};
use crate::grid::{beam_angle, mm_to_meters, BitGrid, Cell, GridGeometry, LidarGrid, VisualGrid};
use crate::scan::{BeamLabel, BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::{cos, mul_unit, sin, Meters, Pose2};
use heapless::index_map::FnvIndexMap;

/// A pooled non-map point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NonMapPoint {
    /// World x.
    pub x: Meters,
    /// World y.
    pub y: Meters,
    /// LiDAR points merged into this one (saturating).
    pub hits: u16,
}

/// Counters of what the store did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NonMapStats {
    /// Points inserted as new entries.
    pub inserted: u32,
    /// Points merged into an existing entry.
    pub pooled: u32,
    /// Points dropped because they were near a wall point.
    pub dropped_near_wall: u32,
    /// Points dropped because the camera had seen their cell.
    pub dropped_seen: u32,
    /// Points dropped because the LiDAR has since seen their place empty ([`NonMapStore::vacated`]).
    pub dropped_vacated: u32,
    /// Points refused because the store was full.
    pub dropped_full: u32,
    /// Points outside the search area (the grid).
    pub dropped_outside: u32,
}

/// The fixed-capacity set of non-map points, with a hash index over pooling cells.
pub struct NonMapStore {
    points: heapless::Vec<NonMapPoint, MAX_NONMAP_POINTS>,
    index: FnvIndexMap<u32, u16, { MAX_NONMAP_POINTS * 2 }>,
    /// Cells where a map-labelled (wall) point has landed.
    pub walls: BitGrid,
    /// Counters.
    pub stats: NonMapStats,
}

impl NonMapStore {
    /// Empty.
    pub const fn new() -> Self {
        Self {
            points: heapless::Vec::new(),
            index: FnvIndexMap::new(),
            walls: BitGrid::new(),
            stats: NonMapStats {
                inserted: 0,
                pooled: 0,
                dropped_near_wall: 0,
                dropped_seen: 0,
                dropped_vacated: 0,
                dropped_full: 0,
                dropped_outside: 0,
            },
        }
    }

    /// The kept points.
    pub fn points(&self) -> &[NonMapPoint] {
        &self.points
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        self.points.clear();
        self.index.clear();
        self.walls.clear();
        self.stats = NonMapStats::default();
    }

    /// Moves the window ([`crate::rolling::shift`]) by `(sx, sy)` cells to `geom`: the wall mask
    /// moves with the cells, points now outside the window are dropped (counted in
    /// [`NonMapStats::dropped_outside`]: nothing there can be looked at), and the pooling index,
    /// whose cells count from the window's origin, is rebuilt. `sx` must be a multiple of 32.
    /// Returns the work (cells and points touched).
    pub(crate) fn shift(&mut self, sx: i32, sy: i32, geom: &GridGeometry, pool_radius: Meters) -> u32 {
        self.walls.shift(sx, sy, false);
        let work = crate::capacity::GRID_AREA as u32 + 2 * self.points.len() as u32;
        self.index.clear();
        let mut i = 0;
        while i < self.points.len() {
            let p = self.points[i];
            let (cx, cy) = geom.cell_of(p.x, p.y);
            let key = Self::key(Self::pool_cell(geom, p.x, p.y, pool_radius));
            // Kept points are more than the pooling radius apart and a pooling cell's diagonal is
            // shorter than that, so no two share a cell; the check only guards the invariant.
            if crate::grid::PackedGrid::in_bounds(cx, cy) && !self.index.contains_key(&key) && self.index.insert(key, i as u16).is_ok() {
                i += 1;
            } else {
                self.points.swap_remove(i);
                self.stats.dropped_outside += 1;
            }
        }
        work
    }

    /// Pooling cell of a point: side = radius / 2, so a cell holds at most one kept point and a
    /// neighbour within the radius is within 2 cells.
    fn pool_cell(geom: &GridGeometry, x: Meters, y: Meters, radius: Meters) -> (i32, i32) {
        let side = (radius.to_bits() as i64 / 2).max(1);
        let px = (x.to_bits() as i64 - geom.origin_x.to_bits() as i64).div_euclid(side);
        let py = (y.to_bits() as i64 - geom.origin_y.to_bits() as i64).div_euclid(side);
        (px as i32, py as i32)
    }

    fn key(p: (i32, i32)) -> u32 {
        ((p.0 as u16 as u32) << 16) | p.1 as u16 as u32
    }

    /// True if a wall point lies within `clearance` of world point `(x, y)`; never for a
    /// clearance of zero or less (the rule is off).
    pub fn near_wall(&self, geom: &GridGeometry, x: Meters, y: Meters, clearance: Meters) -> bool {
        if clearance <= Meters::ZERO {
            return false;
        }
        let (cx, cy) = geom.cell_of(x, y);
        let r = GridGeometry::cells(clearance);
        let r2 = r * r;
        for dy in -r..=r {
            for dx in -r..=r {
                if dx * dx + dy * dy <= r2 && self.walls.get(cx + dx, cy + dy) {
                    return true;
                }
            }
        }
        false
    }

    /// True once the camera has looked at the point: its cell or one of its 8 neighbours is
    /// camera-seen. (The camera's ray stops at the first occupied cell, which for a point on the
    /// far side of an object's boundary cell is a neighbour; the planner's line-of-sight test
    /// likewise ignores the point's 3 × 3 cells, so the two agree.)
    #[inline]
    pub fn inspected(visual: &VisualGrid, cx: i32, cy: i32) -> bool {
        (-1..=1).any(|dy| (-1..=1).any(|dx| visual.seen(cx + dx, cy + dy)))
    }

    /// True once the LiDAR map holds the point's place as empty: its cell and its 8 neighbours
    /// are all free, so later beams have passed through where it was and nothing there is left
    /// to hit. A point on anything still standing keeps an occupied cell within one cell (its
    /// own surface), so range noise around a surface does not drop it; a point next to unknown
    /// space is kept too (nothing says it has gone).
    #[inline]
    pub fn vacated(lidar: &LidarGrid, cx: i32, cy: i32) -> bool {
        (-1..=1).all(|dy| (-1..=1).all(|dx| lidar.get(cx + dx, cy + dy) == Cell::Free))
    }

    /// Adds the labelled points of one scan taken at `pose`: map points go into the wall mask
    /// first, then each non-map point is filtered and pooled. Returns the work done.
    pub fn integrate(
        &mut self,
        geom: &GridGeometry,
        visual: &VisualGrid,
        pose: &Pose2,
        scan: &BeamScan,
        pool_radius: Meters,
        wall_clearance: Meters,
    ) -> u32 {
        let mut work = 0;
        let mut nonmap_beams = 0u32;
        for b in 0..BEAMS {
            let r = scan.ranges_mm[b];
            if r == RANGE_INVALID || r == RANGE_NO_RETURN {
                continue;
            }
            match scan.labels[b] {
                BeamLabel::Map => {
                    let (x, y) = hit_point(pose, b, r);
                    let (cx, cy) = geom.cell_of(x, y);
                    self.walls.put(cx, cy, true);
                    work += 1;
                }
                BeamLabel::NonMap => nonmap_beams += 1,
                BeamLabel::Unlabelled => {}
            }
        }
        if nonmap_beams == 0 {
            return work;
        }
        let wall_window = if wall_clearance > Meters::ZERO {
            let r = GridGeometry::cells(wall_clearance) as u32;
            (2 * r + 1) * (2 * r + 1)
        } else {
            0
        };
        for b in 0..BEAMS {
            let r = scan.ranges_mm[b];
            if scan.labels[b] != BeamLabel::NonMap || r == RANGE_INVALID || r == RANGE_NO_RETURN {
                continue;
            }
            let (x, y) = hit_point(pose, b, r);
            let (cx, cy) = geom.cell_of(x, y);
            if !crate::grid::PackedGrid::in_bounds(cx, cy) {
                // Outside the search area: nothing there can be looked at.
                self.stats.dropped_outside += 1;
                continue;
            }
            work += 9;
            if Self::inspected(visual, cx, cy) {
                self.stats.dropped_seen += 1;
                continue;
            }
            work += wall_window;
            if self.near_wall(geom, x, y, wall_clearance) {
                self.stats.dropped_near_wall += 1;
                continue;
            }
            work += 25;
            self.insert(geom, x, y, pool_radius);
        }
        work
    }

    /// Pools a point: merges it into a kept point within `radius`, or keeps it as a new point.
    pub fn insert(&mut self, geom: &GridGeometry, x: Meters, y: Meters, radius: Meters) {
        let (px, py) = Self::pool_cell(geom, x, y, radius);
        let r2 = (radius.to_bits() as i64) * (radius.to_bits() as i64);
        for dy in -2..=2 {
            for dx in -2..=2 {
                if let Some(&i) = self.index.get(&Self::key((px + dx, py + dy))) {
                    let p = &mut self.points[i as usize];
                    let ex = p.x.to_bits() as i64 - x.to_bits() as i64;
                    let ey = p.y.to_bits() as i64 - y.to_bits() as i64;
                    if ex * ex + ey * ey <= r2 {
                        p.hits = p.hits.saturating_add(1);
                        self.stats.pooled += 1;
                        return;
                    }
                }
            }
        }
        let key = Self::key((px, py));
        if self.points.is_full() || self.index.contains_key(&key) {
            self.stats.dropped_full += 1;
            return;
        }
        let i = self.points.len() as u16;
        // Both pushes succeed: the Vec is not full and the index has twice its capacity.
        if self.points.push(NonMapPoint { x, y, hits: 1 }).is_ok() && self.index.insert(key, i).is_ok() {
            self.stats.inserted += 1;
        }
    }

    /// Drops the points the camera has since looked at, whose place the LiDAR has since seen
    /// empty (if `drop_vacated`), or that a wall point has since come near. Returns the work done.
    pub fn filter(
        &mut self,
        geom: &GridGeometry,
        lidar: &LidarGrid,
        visual: &VisualGrid,
        pool_radius: Meters,
        wall_clearance: Meters,
        drop_vacated: bool,
    ) -> u32 {
        let mut i = 0;
        let mut work = 0;
        while i < self.points.len() {
            let p = self.points[i];
            let (cx, cy) = geom.cell_of(p.x, p.y);
            work += 9;
            let seen = Self::inspected(visual, cx, cy);
            let vacated = !seen && drop_vacated && {
                work += 9;
                Self::vacated(lidar, cx, cy)
            };
            let drop = seen
                || vacated
                || (wall_clearance > Meters::ZERO && {
                    work += 49;
                    self.near_wall(geom, p.x, p.y, wall_clearance)
                });
            if drop {
                if seen {
                    self.stats.dropped_seen += 1;
                } else if vacated {
                    self.stats.dropped_vacated += 1;
                } else {
                    self.stats.dropped_near_wall += 1;
                }
                self.remove(geom, i, pool_radius);
            } else {
                i += 1;
            }
        }
        work
    }

    fn remove(&mut self, geom: &GridGeometry, i: usize, pool_radius: Meters) {
        let p = self.points.swap_remove(i);
        self.index.swap_remove(&Self::key(Self::pool_cell(geom, p.x, p.y, pool_radius)));
        if i < self.points.len() {
            let moved = self.points[i];
            if let Some(slot) = self.index.get_mut(&Self::key(Self::pool_cell(geom, moved.x, moved.y, pool_radius))) {
                *slot = i as u16;
            }
        }
    }
}

impl Default for NonMapStore {
    fn default() -> Self {
        Self::new()
    }
}

/// World coordinates of beam `b`'s return at `range_mm`, seen from `pose`.
#[inline]
pub fn hit_point(pose: &Pose2, b: usize, range_mm: u16) -> (Meters, Meters) {
    let a = pose.theta + beam_angle(b);
    let r = mm_to_meters(range_mm);
    (pose.x.saturating_add(mul_unit(r, cos(a))), pose.y.saturating_add(mul_unit(r, sin(a))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Config;

    fn geom() -> GridGeometry {
        GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO }
    }

    #[test]
    fn pools_within_radius_and_keeps_apart_points() {
        let mut s = NonMapStore::new();
        let r = Config::mm(200);
        s.insert(&geom(), Config::mm(10_000), Config::mm(10_000), r);
        s.insert(&geom(), Config::mm(10_150), Config::mm(10_050), r); // 0.158 m away: pooled
        s.insert(&geom(), Config::mm(10_400), Config::mm(10_000), r); // 0.4 m away: new
        assert_eq!(s.points().len(), 2);
        assert_eq!(s.points()[0].hits, 2);
        assert_eq!(s.stats.pooled, 1);
    }

    #[test]
    fn filters_seen_and_near_wall_points() {
        let g = geom();
        let mut s = NonMapStore::new();
        let r = Config::mm(200);
        for i in 0..5 {
            s.insert(&g, Config::mm(5_000 + i * 1000), Config::mm(5_050), r);
        }
        assert_eq!(s.points().len(), 5);
        let mut vis = VisualGrid::new();
        // The camera has seen the cell of the first point.
        let (cx, cy) = g.cell_of(Config::mm(5_000), Config::mm(5_050));
        vis.grid.set(cx, cy, crate::Cell::Occupied);
        // A wall point 0.2 m from the third point.
        let (wx, wy) = g.cell_of(Config::mm(7_000), Config::mm(5_250));
        s.walls.put(wx, wy, true);
        let lidar = LidarGrid::new(g);
        s.filter(&g, &lidar, &vis, r, Config::mm(250), true);
        assert_eq!(s.points().len(), 3);
        let xs: heapless::Vec<i32, 8> = s.points().iter().map(|p| p.x.to_num::<i32>()).collect();
        assert!(!xs.contains(&5) && !xs.contains(&7));
        assert_eq!(s.stats.dropped_seen, 1);
        assert_eq!(s.stats.dropped_near_wall, 1);
        // The index still finds every remaining point: re-inserting pools, not duplicates.
        for p in s.points().to_vec_fixed().iter() {
            s.insert(&g, p.x, p.y, r);
        }
        assert_eq!(s.points().len(), 3);
        // A clearance of zero turns the wall rule off: a point on a wall cell stays.
        let (px, py) = (Config::mm(12_000), Config::mm(12_050));
        s.walls.put(g.cell_of(px, py).0, g.cell_of(px, py).1, true);
        assert!(s.near_wall(&g, px, py, Config::mm(250)));
        assert!(!s.near_wall(&g, px, py, Meters::ZERO));
        s.insert(&g, px, py, r);
        s.filter(&g, &lidar, &vis, r, Meters::ZERO, true);
        assert_eq!(s.points().len(), 4);
        assert_eq!(s.stats.dropped_near_wall, 1, "nothing more dropped near a wall");
    }

    #[test]
    fn drops_points_whose_place_the_lidar_has_since_seen_empty() {
        let g = geom();
        let r = Config::mm(200);
        let mut s = NonMapStore::new();
        let mut lidar = LidarGrid::new(g);
        let vis = VisualGrid::new();
        // Three points in a row, 1 m apart; the LiDAR has since seen a free 5 × 5 m square
        // around all of them, except: the second still has its own cell occupied (something
        // stands there), the third has an occupied neighbour (the surface it lies on).
        let at = |i: i32| (Config::mm(5_000 + i * 1000), Config::mm(5_050));
        for i in 0..3 {
            s.insert(&g, at(i).0, at(i).1, r);
        }
        let (x0, y0) = g.cell_of(Config::mm(4_000), Config::mm(3_000));
        for y in y0..y0 + 50 {
            for x in x0..x0 + 50 {
                lidar.grid.set(x, y, Cell::Free);
            }
        }
        let c1 = g.cell_of(at(1).0, at(1).1);
        lidar.grid.set(c1.0, c1.1, Cell::Occupied);
        let c2 = g.cell_of(at(2).0, at(2).1);
        lidar.grid.set(c2.0 + 1, c2.1 - 1, Cell::Occupied);
        // With the rule off (`nonmap_drop_vacated = false`) all three stay.
        s.filter(&g, &lidar, &vis, r, Meters::ZERO, false);
        assert_eq!((s.points().len(), s.stats.dropped_vacated), (3, 0));
        s.filter(&g, &lidar, &vis, r, Meters::ZERO, true);
        let xs: heapless::Vec<i32, 8> = s.points().iter().map(|p| p.x.to_num::<i32>()).collect();
        assert_eq!(s.stats.dropped_vacated, 1);
        assert_eq!(xs.len(), 2);
        assert!(xs.contains(&6) && xs.contains(&7), "the vacated point at x = 5 m went: {xs:?}");
        // Next to unknown space a point stays: nothing says it has gone.
        let c0 = g.cell_of(at(0).0, at(0).1);
        s.insert(&g, at(0).0, at(0).1, r);
        lidar.grid.set(c0.0 - 1, c0.1, Cell::Unknown);
        s.filter(&g, &lidar, &vis, r, Meters::ZERO, true);
        assert_eq!(s.points().len(), 3);
        assert_eq!(s.stats.dropped_vacated, 1);
    }

    trait ToVecFixed {
        fn to_vec_fixed(&self) -> heapless::Vec<NonMapPoint, 16>;
    }
    impl ToVecFixed for [NonMapPoint] {
        fn to_vec_fixed(&self) -> heapless::Vec<NonMapPoint, 16> {
            self.iter().copied().collect()
        }
    }
}
