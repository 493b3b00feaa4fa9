//! `rrt`: the frontier points of [`crate::rrt::RrtExplorer`]'s trees (LiDAR points first, camera
//! points once none is reachable), scored by the original assigner's revenue, facing the
//! direction of travel. A goal is kept until it is reached or fails (see `Controller`).
//!
//! When the trees hold no reachable point while the map still has frontiers (a full global tree
//! that cannot grow, a winding corridor the random trees have not threaded yet), the grid's
//! frontier detector supplies the points, as the image-based frontier detector does beside the
//! two tree detectors in Umari and Mukhopadhyay's `rrt_exploration`: without it the search
//! ended "exhausted" with frontiers left (issue 29).

use super::{Planner, Site, Sites, Step};
use crate::frontier::FrontierSource;
use crate::rrt;

impl Planner {
    /// Grows the trees and returns their points as sites with their revenue; scored by
    /// [`super::Score::Own`]. Returns the work.
    pub(super) fn rrt_sites(&mut self, step: &Step, sites: &mut Sites) -> u32 {
        let snap = step.snap;
        let mut work = self.rrt.grow(step.inputs.lidar, step.inputs.visual, step.robot);
        let mut unreachable = 0;
        let lidar_points = self.rrt.points().any(|p| p.source == FrontierSource::Lidar && self.reachable_near(p.cell, snap).is_some());
        let before = sites.len();
        for &p in self.rrt.points() {
            if lidar_points && p.source != FrontierSource::Lidar {
                continue;
            }
            let Some(c) = self.snap_site(p.cell, snap, &mut work, &mut unreachable) else { continue };
            let _ = sites.push((c, Site::frontier(p.source), None, rrt::revenue(step.inputs.lidar, step.inputs.visual, p, step.robot)));
        }
        self.stats.unreachable += unreachable;
        if sites.len() == before {
            // The grid's frontiers, LiDAR first, scored by the same revenue.
            let lidar_first = self.lidar_frontiers_reachable(step);
            work += self.frontier_sites(
                step,
                sites,
                |f| !(lidar_first && f.source != FrontierSource::Lidar),
                |f| rrt::revenue(step.inputs.lidar, step.inputs.visual, rrt::RrtPoint { cell: f.anchor, source: f.source }, step.robot),
            );
        }
        work
    }
}
