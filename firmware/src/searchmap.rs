//! LIVE's search map (issue 32; METHOD.md §2, the paper's §II-A and eq. 1): each cell of the
//! known building holds the probability `m` that the target is there — 0.5 until the camera
//! has looked at it, 1 for the static map's own cells, 0 once the camera has seen it (free, or
//! an obstacle the detector looked at and did not fire on). Its entropy
//!
//! `H = −Σ m log₂ m + (1 − m) log₂ (1 − m)`
//!
//! is then exactly one bit per cell still at 0.5, so the map is kept as that count, over the
//! prior map's free cells inside the LiDAR grid's window (the paper sums over its global
//! costmap, the known building): [`SearchMap::entropy_bits`]. Every cell the camera sees for the
//! first time ([`crate::grid::VisualGrid::integrate_noting`]) that the prior marks free lowers
//! it by one; the window's move ([`crate::rolling`]) recounts it. With three values the
//! probability of a cell needs no storage of its own: [`SearchMap::probability`] derives it
//! from the prior and the visual grid. A simplification of the paper's Bayesian filter: with a
//! detector that never misses what is in view (as the simulator's), its update from 0.5 is 0.

use crate::capacity::GRID_CELLS;
use crate::grid::{GridGeometry, VisualGrid};
use crate::knownmap::PriorMap;

/// A cell's probability of holding the target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Probability {
    /// 0: the camera has seen it.
    Zero,
    /// 0.5: not yet seen (one bit of entropy).
    Half,
    /// 1: the static map's own cell (a wall).
    One,
    /// Not part of the search (unknown to the prior: outside the building).
    Outside,
}

/// The count behind the entropy.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SearchMap {
    /// Prior-free cells in the window the camera has not seen: the entropy, bits.
    unseen: u32,
    /// Prior-free cells in the window: the entropy at the start, bits.
    cells: u32,
}

impl SearchMap {
    /// Nothing to search (no prior map).
    pub const fn new() -> Self {
        SearchMap { unseen: 0, cells: 0 }
    }

    /// The map's entropy, bits (one per prior-free cell the camera has not seen).
    pub fn entropy_bits(&self) -> u32 {
        self.unseen
    }

    /// The prior-free cells in the window: the entropy before the camera saw anything.
    pub fn cells(&self) -> u32 {
        self.cells
    }

    /// Recounts over the window at `geom` (a new prior, a new search, a moved window). Returns
    /// the work charged: the grid's cells, the most it visits.
    pub fn recount(&mut self, prior: &PriorMap, geom: &GridGeometry, visual: &VisualGrid) -> u32 {
        let (mut cells, mut unseen) = (0, 0);
        prior.for_each_marked(geom, |x, y, px, py| {
            if prior.free_cell(px, py) {
                cells += 1;
                unseen += u32::from(!visual.seen(x, y));
            }
        });
        *self = SearchMap { unseen, cells };
        (GRID_CELLS * GRID_CELLS) as u32
    }

    /// The camera has seen window cell `(x, y)` for the first time.
    pub fn first_seen(&mut self, prior: &PriorMap, geom: &GridGeometry, x: i32, y: i32) {
        let (px, py) = prior.cell_under(geom, x, y);
        if prior.free_cell(px, py) {
            self.unseen = self.unseen.saturating_sub(1);
        }
    }

    /// Cell `(x, y)`'s probability (window cells of a grid at `geom`).
    pub fn probability(prior: &PriorMap, geom: &GridGeometry, visual: &VisualGrid, x: i32, y: i32) -> Probability {
        let (px, py) = prior.cell_under(geom, x, y);
        if prior.occupied_cell(px, py) {
            Probability::One
        } else if !prior.free_cell(px, py) {
            Probability::Outside
        } else if visual.seen(x, y) {
            Probability::Zero
        } else {
            Probability::Half
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::grid::{Cell, LidarGrid};
    use fixed_point::{Meters, Pose2};
    use std::boxed::Box;

    #[test]
    fn entropy_is_one_bit_per_unseen_free_cell_and_falls_as_the_camera_looks() {
        // A 10 × 10 m free room (cells 0..100) walled on the left (column 0 occupied).
        let mut prior = Box::new(PriorMap::new());
        prior.reset(Meters::ZERO, Meters::ZERO);
        let mut free = [0u8; GRID_CELLS / 8];
        for x in 1..100 {
            free[x / 8] |= 1 << (x % 8);
        }
        let mut occ = [0u8; GRID_CELLS / 8];
        occ[0] = 1;
        for y in 0..100 {
            prior.set_row_bits(y, 0, &occ, GRID_CELLS).unwrap();
            prior.set_free_row_bits(y, 0, &free, GRID_CELLS).unwrap();
        }
        let geom = GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO };
        let mut lidar = Box::new(LidarGrid::new(geom));
        assert_eq!(prior.seed(&mut lidar), (GRID_CELLS * GRID_CELLS) as u32);
        assert_eq!(lidar.get(0, 5), Cell::Occupied);
        assert_eq!(lidar.get(5, 5), Cell::Free);
        assert_eq!(lidar.get(200, 5), Cell::Unknown, "the prior's unknown stays unknown");
        let mut visual = Box::new(VisualGrid::new());
        let mut map = SearchMap::new();
        map.recount(&prior, &geom, &visual);
        assert_eq!((map.cells(), map.entropy_bits()), (99 * 100, 99 * 100));
        assert_eq!(SearchMap::probability(&prior, &geom, &visual, 0, 3), Probability::One);
        assert_eq!(SearchMap::probability(&prior, &geom, &visual, 3, 3), Probability::Half);
        assert_eq!(SearchMap::probability(&prior, &geom, &visual, 300, 3), Probability::Outside);
        // The camera looks: every first sighting of a free cell is one bit less.
        let pose = Pose2::from_f64(5.0, 5.0, 0.0).unwrap();
        let mut seen = 0;
        visual.integrate_noting(&lidar, &pose, fixed_point::BinaryAngle::from_degrees(90), Meters::from_num(4), |x, y| {
            seen += 1;
            map.first_seen(&prior, &geom, x, y);
        });
        assert!(seen > 100, "{seen}");
        assert_eq!(map.entropy_bits(), 99 * 100 - seen);
        assert_eq!(SearchMap::probability(&prior, &geom, &visual, 52, 50), Probability::Zero);
        // Looking again at the same cells changes nothing; a recount agrees with the updates.
        visual.integrate_noting(&lidar, &pose, fixed_point::BinaryAngle::from_degrees(90), Meters::from_num(4), |x, y| {
            map.first_seen(&prior, &geom, x, y)
        });
        assert_eq!(map.entropy_bits(), 99 * 100 - seen);
        let before = map;
        map.recount(&prior, &geom, &visual);
        assert_eq!(map, before);
    }
}
