//! The paper's Algorithm 1 (`lives-greedy`, `multisensor`): four candidate viewpoints per frontier of
//! either map, scored by the LIVES utility (Q16.16 fixed point)
//! `U = − w_dist·path_m + w_unknown·unseen_cells + w_surface·unseen_surface_rays
//!      + w_frontier·frontier_cells_near_path + w_nonmap·nonmap_points_in_cone`
//! ([`super::view`]), and the argmax (ties: the first candidate in frontier order wins).
//!
//! `unseen_cells` is estimated by casting rays across the camera cone from the viewpoint
//! (occluded by LiDAR-occupied cells); `frontier_cells_near_path` counts the frontier cells of
//! either map in the 8 × 8-cell blocks within `frontier_near_path_blocks` of the path, each block
//! once; `nonmap_points_in_cone` counts stored non-map points within camera range and field of
//! view with an unoccluded line of sight. `lives-greedy` also looks at clusters of non-map points from
//! `nonmap_standoff_m` (`nonmap_viewpoints`), and every rule but the baselines may turn in place
//! (`look_around_here`).

use super::{Planner, Site, Sites, Step};
use crate::capacity::{BLOCKS, BLOCK_CELLS, MAX_NONMAP_SITES};
use crate::config::PlannerKind;
use crate::grid::{GridGeometry, LidarGrid, PackedGrid};
use crate::nonmap::NonMapStore;
use fixed_point::{atan2, BinaryAngle};

impl Planner {
    /// The sites of `lives-greedy` and `multisensor`: every frontier, the non-map clusters
    /// (`lives-greedy`),
    /// the robot's own cell, the current goal. Returns the work.
    pub(super) fn greedy_sites(&mut self, step: &Step, current: Option<((i32, i32), BinaryAngle)>, sites: &mut Sites) -> u32 {
        let cfg = step.inputs.cfg;
        let snap = step.snap;
        let mut work = self.frontier_sites(step, sites, |_| true, |_| 0);
        if cfg.planner == PlannerKind::LivesGreedy && cfg.nonmap_viewpoints {
            let standoff = GridGeometry::cells(cfg.nonmap_standoff_m);
            for (p, _) in self.nonmap_clusters(step.inputs.lidar, step.inputs.nonmap) {
                work += ((2 * snap + 1) * (2 * snap + 1)) as u32;
                match self.nonmap_viewpoint(p, standoff, snap) {
                    Some((c, h)) => {
                        let _ = sites.push((c, Site::NonMapCluster, Some(h), 0));
                    }
                    None => self.stats.unreachable += 1,
                }
            }
        }
        if cfg.look_around_here && PackedGrid::in_bounds(step.robot.0, step.robot.1) {
            // Turning in place is an action too: the four headings at the robot's own cell.
            let _ = sites.push((step.robot, Site::Here, None, 0));
        }
        self.push_current(current, sites);
        work
    }

    /// Non-map clusters: points bucketed by block, as (centroid cell, points), at most
    /// [`MAX_NONMAP_SITES`], blocks in raster order of first appearance.
    pub(super) fn nonmap_clusters(&self, lidar: &LidarGrid, nonmap: &NonMapStore) -> heapless::Vec<((i32, i32), u32), MAX_NONMAP_SITES> {
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
    pub(super) fn nonmap_viewpoint(&self, p: (i32, i32), standoff: i32, snap: i32) -> Option<((i32, i32), BinaryAngle)> {
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
}
