//! `nearest` (Yamauchi 1997): the reachable LiDAR frontier of shortest path (camera frontiers
//! once the LiDAR map has none), facing the direction of travel; every reached goal is retired.

use super::{Planner, Sites, Step};
use crate::frontier::FrontierSource;
use fixed_point::BinaryAngle;

impl Planner {
    /// The sites of `nearest`: LiDAR frontiers (camera frontiers when no LiDAR frontier is
    /// reachable) and the current goal; scored by [`super::Score::Nearest`]. Returns the work.
    pub(super) fn nearest_sites(&mut self, step: &Step, current: Option<((i32, i32), BinaryAngle)>, sites: &mut Sites) -> u32 {
        let lidar_first = self.lidar_frontiers_reachable(step);
        let work = self.frontier_sites(step, sites, |f| !(lidar_first && f.source != FrontierSource::Lidar), |_| 0);
        self.push_current(current, sites);
        work
    }
}
