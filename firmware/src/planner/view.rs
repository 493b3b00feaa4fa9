//! The view utility: what the camera would gain from a pose — camera-unseen cells and surfaces
//! in its cone, non-map points in it, frontier cells near the path there. One formula serves
//! the planners that score viewpoints (`lives`, `multisensor`, the tour) and the gaze.

use super::{Planner, SCORE_RAYS};
use crate::capacity::{BLOCKS, BLOCK_CELLS, GRID_AREA, MAX_NONMAP_SITES};
use crate::config::{Config, Weight};
use crate::frontier::FrontierSet;
use crate::grid::{Cell, GridGeometry, LidarGrid, Line, PackedGrid, VisualGrid};
use crate::nonmap::NonMapStore;
use fixed_point::{atan2, BinaryAngle, Meters, Pose2};

/// Headings the gaze is chosen from (every 22.5°).
pub const GAZE_HEADINGS: usize = 16;
/// Within this distance of its goal the robot stops choosing a gaze and turns to the goal's
/// heading (the viewpoint's own view).
pub const GAZE_HANDOVER_M: Meters = Meters::from_bits(1 << 16);

/// The view terms of one pose and heading.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct View {
    /// `w_unknown·unseen + w_surface·surface + w_nonmap·nonmap`, Q16.16 utility bits (the
    /// frontier-near-path term is the path's, not the view's, and is added by the caller).
    pub gain: i64,
    /// Estimated camera-unseen cells in the cone.
    pub unseen: u32,
    /// Rays of the cone ending on an unseen surface.
    pub surface: u32,
    /// Non-map points in the cone (from the last [`Planner::visible_nonmap`]).
    pub nonmap: u32,
}

impl Planner {
    /// The view from `cell` facing `heading`: the camera-unseen cells and surfaces in the cone
    /// (occluded by the LiDAR map) and, with `w_nonmap` non-zero, the non-map points in it
    /// (call [`Planner::visible_nonmap`] for `cell` first). Returns the view and its work.
    pub fn view(
        &self,
        cfg: &Config,
        lidar: &LidarGrid,
        visual: &VisualGrid,
        cell: (i32, i32),
        heading: BinaryAngle,
        w_nonmap: Weight,
    ) -> (View, u32) {
        let range_cells = GridGeometry::cells(cfg.camera_range_m);
        let v = visual.unseen_in_cone(lidar, cell.0, cell.1, heading, cfg.camera_fov, range_cells, SCORE_RAYS, cfg.unseen_unknown_eighths);
        let nonmap = if w_nonmap != Weight::ZERO { self.in_cone(cfg, heading) } else { 0 };
        let gain = cfg.w_unknown_per_cell.to_bits() as i64 * v.unseen_cells as i64
            + cfg.w_surface_per_ray.to_bits() as i64 * v.unseen_surface_rays as i64
            + w_nonmap.to_bits() as i64 * nonmap as i64;
        (View { gain, unseen: v.unseen_cells, surface: v.unseen_surface_rays, nonmap }, v.work)
    }

    /// Frontier cells in blocks near the path from the robot to `(x, y)`, each block once.
    pub(super) fn frontier_near_path(&mut self, frontiers: &FrontierSet, x: i32, y: i32, reach: i32) -> (u32, u32) {
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

    /// Collects the bearings of the non-map points visible (range + line of sight) from `c`.
    pub(super) fn visible_nonmap(&mut self, lidar: &LidarGrid, nonmap: &NonMapStore, c: (i32, i32), range_cells: i32) -> u32 {
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
            let (view, w) = self.view(cfg, lidar, visual, robot, heading, w_nonmap);
            work += w;
            let gain = view.gain;
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
    pub(super) fn in_cone(&self, cfg: &Config, heading: BinaryAngle) -> u32 {
        let n = self.in_cone_per_block(heading, cfg.camera_fov, cfg.nonmap_block_cap);
        match cfg.nonmap_view_cap {
            0 => n,
            cap => n.min(cap as u32),
        }
    }

    /// The points within the cone; with `cap > 0`, at most `cap` count per 0.8 m block (a scaled
    /// count: several distinct objects outweigh one large piece of furniture).
    pub(super) fn in_cone_per_block(&self, heading: BinaryAngle, fov: BinaryAngle, cap: u8) -> u32 {
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
}
