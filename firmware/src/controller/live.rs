//! LIVE's inputs to the controller (issue 32, `docs/live.md`): the building's prior map
//! ([`crate::knownmap`]), which seeds the LiDAR grid and the search map ([`crate::searchmap`]),
//! and the coverage route its waypoint manager follows ([`crate::planner::coverage`]). The link
//! brings them as `MapRow` and `Route` messages ([`crate::node::apply_map_row`],
//! [`crate::node::apply_route`]).

use super::Controller;
use crate::knownmap::PriorError;
use crate::planner::coverage::{RouteFull, RouteWaypoint};
use crate::searchmap::SearchMap;
use fixed_point::{BinaryAngle, Meters, Pose2};

impl Controller {
    /// Forgets the prior map; its window's lower-left corner becomes `(x, y)` (LIVE's known-map
    /// mode is off until a row arrives).
    pub fn prior_map_reset(&mut self, x: Meters, y: Meters) {
        self.known.prior.reset(x, y);
        self.search = SearchMap::new();
        self.seeded = false;
    }

    /// Row `y` of the prior map from column `x0`: `n` cells, bit `i` of `bits` (least
    /// significant first) cell `x0 + i`, 1 occupied ([`crate::knownmap::PriorMap::set_row_bits`]).
    pub fn prior_map_row(&mut self, y: usize, x0: usize, bits: &[u8], n: usize) -> Result<(), PriorError> {
        self.seeded = false;
        self.known.prior.set_row_bits(y, x0, bits, n)
    }

    /// The free cells of row `y` of the prior map, as [`Controller::prior_map_row`] (1 free):
    /// they seed the LiDAR grid's free space (so the planner can plan across the known
    /// building) and are the cells LIVE's search map covers.
    pub fn prior_map_free_row(&mut self, y: usize, x0: usize, bits: &[u8], n: usize) -> Result<(), PriorError> {
        self.seeded = false;
        self.known.prior.set_free_row_bits(y, x0, bits, n)
    }

    /// Forgets the coverage route (LIVE's waypoint manager, [`crate::planner::coverage`]) and
    /// the goal taken from it: the next tick plans on the route that follows (a team's
    /// coordinator re-assigning waypoints; no goal outlives the route it came from).
    pub fn route_clear(&mut self) {
        self.planner.route.clear();
        if self.cfg.planner.is_coverage() {
            self.goal = None;
        }
    }

    /// Appends a waypoint to the coverage route: where to stand and which way to face, in the
    /// map's frame. Refused when the route holds [`crate::capacity::MAX_ROUTE_WAYPOINTS`].
    pub fn route_push(&mut self, x: Meters, y: Meters, heading: BinaryAngle) -> Result<(), RouteFull> {
        self.planner.route.push(RouteWaypoint { x, y, heading })
    }

    /// A known building whose map is not yet in the LiDAR grid as it is now (a new map, a new
    /// search, a moved window): seeds the grid's unobserved cells and counts the search map over
    /// the window. The work goes to the next scan's LiDAR stage.
    pub(super) fn seed_from_prior(&mut self) {
        if self.seeded || self.known.prior.rows_received() == 0 {
            return;
        }
        let w = self.known.prior.seed(&mut self.lidar) + self.search.recount(&self.known.prior, &self.lidar.geom, &self.visual);
        self.lidar.pending_work = self.lidar.pending_work.saturating_add(w);
        self.seeded = true;
    }

    /// The camera's view from `pose` into the visual grid; with a known building, each cell seen
    /// for the first time lowers the search map's entropy. Returns the work.
    pub(super) fn integrate_visual(&mut self, pose: &Pose2) -> u32 {
        let (fov, range) = (self.cfg.camera_fov, self.cfg.camera_range_m);
        if !self.seeded {
            return self.visual.integrate(&self.lidar, pose, fov, range);
        }
        let (search, prior, geom) = (&mut self.search, &self.known.prior, self.lidar.geom);
        self.visual.integrate_noting(&self.lidar, pose, fov, range, |x, y| search.first_seen(prior, &geom, x, y))
    }

    /// A teammate's camera saw cell `(x, y)` of the grid (an `occupied` one: a surface it looked
    /// at): it is seen here too, so this robot's planner does not go to look at it again, and
    /// with a known building the search map counts it. Returns whether it was new here; a cell
    /// outside the grid is ignored.
    pub fn merge_seen(&mut self, x: i32, y: i32, occupied: bool) -> bool {
        if !crate::grid::PackedGrid::in_bounds(x, y) || self.visual.seen(x, y) {
            return false;
        }
        if self.seeded {
            self.search.first_seen(&self.known.prior, &self.lidar.geom, x, y);
        }
        self.visual.grid.set(x, y, if occupied { crate::grid::Cell::Occupied } else { crate::grid::Cell::Free });
        true
    }

    /// A teammate's LiDAR observed cell `(x, y)` of the grid (`occupied` or free; maps merged
    /// from the robots' known start poses): a cell this robot's LiDAR has never observed takes
    /// it as a prior map's cell is taken ([`crate::knownmap::SEED_OCCUPIED`],
    /// [`crate::knownmap::SEED_FREE`]), so that its own scans still overrule it; an observed one
    /// keeps its own evidence.
    pub fn merge_lidar(&mut self, x: i32, y: i32, occupied: bool) {
        self.lidar.seed(x, y, if occupied { crate::knownmap::SEED_OCCUPIED } else { crate::knownmap::SEED_FREE });
    }

    /// The goals of the teammates this robot gives way to (map frame; at most
    /// [`crate::capacity::MAX_TEAM_CLAIMS`]): it chooses no site within half the camera's range
    /// of one, and drops its own goal if it lies there (the next tick plans again). A robot
    /// alone has none, and nothing changes.
    pub fn set_team_claims(&mut self, goals: &[(Meters, Meters)]) {
        let mut cells: heapless::Vec<(i32, i32), { crate::capacity::MAX_TEAM_CLAIMS }> = heapless::Vec::new();
        for &(x, y) in goals {
            // More than the capacity are ignored.
            let _ = cells.push(self.lidar.geom.cell_of(x, y));
        }
        self.planner.set_claims(&cells);
        let r = crate::planner::claim_radius(&self.cfg);
        if self.goal.as_ref().is_some_and(|g| self.planner.is_claimed(g.viewpoint.cell, r)) {
            self.goal = None;
        }
    }
}
