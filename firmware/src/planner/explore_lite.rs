//! `explore-lite` (after ROS `explore_lite`): the frontier of least
//! `EXPLORE_LITE_POTENTIAL_SCALE · d − EXPLORE_LITE_GAIN_SCALE · cells`, `d` the Euclidean
//! distance in metres from the robot to the frontier's anchor cell and `cells` the frontier's
//! size (its defaults 3 and 1; explore_lite multiplies both terms by the costmap resolution,
//! which does not change the order). LiDAR frontiers first, camera frontiers once the LiDAR map
//! has none (as `nearest`; explore_lite itself stops there), facing the direction of travel. It
//! switches to any better frontier (no hysteresis). Simplified: frontiers are the pieces of at
//! most [`crate::frontier::SPLIT_CELLS`] cells, not whole groups.

use super::{Planner, Sites, Step};
use crate::frontier::FrontierSource;

/// `explore-lite`: cost per metre of distance (explore_lite's `potential_scale` default).
pub const EXPLORE_LITE_POTENTIAL_SCALE: i64 = 3;
/// `explore-lite`: gain per frontier cell (explore_lite's `gain_scale` default).
pub const EXPLORE_LITE_GAIN_SCALE: i64 = 1;

impl Planner {
    /// The sites of `explore-lite`, each with its score (Q16.16); scored by
    /// [`super::Score::Own`]. Returns the work.
    pub(super) fn explore_lite_sites(&mut self, step: &Step, sites: &mut Sites) -> u32 {
        let robot = step.robot;
        let euclid_bits = |c: (i32, i32)| {
            let d2 = ((c.0 - robot.0) as i64).pow(2) + ((c.1 - robot.1) as i64).pow(2);
            // Q16.16 metres: sqrt(d2 · 2³²) is the distance in cells · 2¹⁶.
            fixed_point::isqrt_u64((d2 as u64) << 32) as i64 / crate::capacity::CELLS_PER_METER
        };
        let lidar_first = self.lidar_frontiers_reachable(step);
        self.frontier_sites(
            step,
            sites,
            |f| !(lidar_first && f.source != FrontierSource::Lidar),
            |f| EXPLORE_LITE_GAIN_SCALE * f.cells as i64 * 65_536 - EXPLORE_LITE_POTENTIAL_SCALE * euclid_bits(f.anchor),
        )
    }
}
