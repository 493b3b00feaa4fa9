//! LIVE's waypoint manager (issue 32; METHOD.md §2, the paper's §II-C): a finite-state machine
//! that follows a global coverage route over a known building and, under `live`, inserts a
//! **priority waypoint** to look at the nearest inspection region at most once per
//! `live_priority_interval_us`, then resumes the route.
//!
//! The route is the central server's (the host's coverage planner, `host::live`): a list of
//! waypoints in the map's frame, each a place to stand and a heading, given with
//! [`crate::Controller::route_push`] (at most [`MAX_ROUTE_WAYPOINTS`]). The states:
//!
//! * **Route**: the goal is the first waypoint of the route not yet done that has a reachable
//!   cell within `viewpoint_snap_radius_m` (one without waits: the robot may reach it later). A
//!   waypoint the robot stands at (within `goal_tolerance_m`, facing its heading within
//!   `goal_heading_tolerance`) is done; one near a blacklisted goal (the controller blacklists a
//!   goal without progress) is skipped, done and counted.
//! * **Priority** (`live` only): the manager sends a new waypoint when the robot has reached
//!   one; then, if the interval has passed since the last priority waypoint ended (the route
//!   gets at least that long; the first may come at once) and an inspection region exists, the goal becomes a viewpoint on the line from the region to
//!   the robot at `λ·min(camera range, distance)` from it (as an object proposal's,
//!   [`super::proposals`]), facing it — or, when a wall of the LiDAR grid stands between that
//!   place and the region, the reachable place nearest the robot from which the camera would
//!   see it ([`Planner::stand_in_sight`]); the nearest such viewpoint by path wins. A region
//!   needs [`LIVE_REGION_MIN_HITS`] LiDAR returns first. It is done when
//!   the robot stands there, when the camera has seen the region (the non-map store then drops
//!   it), or when it is blacklisted; then the route resumes where it was left.
//! * **Done**: the route is finished; `live` still visits the regions left, nearest first, one
//!   after another; then the planner has nothing ([`crate::Mode::Exhausted`]).
//!
//! Inspection regions are the non-map store's points ([`crate::nonmap`]): with a prior map, the
//! known-map classifier's STFs ([`crate::knownmap`]), pooled within `nonmap_pool_radius_m` and
//! removed where the camera has looked; the paper's third filter, removal within
//! `nonmap_wall_clearance_m` of LTF points, is off by default (0 m), as for LIVES.

use super::proposals::{stand_off, PROPOSAL_LAMBDA_PER_MILLE};
use super::{Planner, Site, Step, Viewpoint, UNREACHABLE};
use crate::capacity::{CELL_MM, MAX_ROUTE_WAYPOINTS};
use crate::config::PlannerKind;
use crate::grid::{ray_end, Cell, GridGeometry, LidarGrid, Line};
use fixed_point::{atan2, BinaryAngle, Meters};

/// The LiDAR returns an inspection region must have gathered (its non-map store point's
/// `hits`) before a priority waypoint goes to it: a static object seen by one beam for a
/// second (five scans at 5 Hz) or by five beams once. Fewer are a stray return (a corner
/// of the map a few centimetres off, a person's last step) that would send the robot
/// across the building for nothing.
pub const LIVE_REGION_MIN_HITS: u16 = 5;

/// Rays cast out of an inspection region for a place the camera would see it from, when the
/// stand-off on the line to the robot would not ([`Planner::stand_in_sight`]).
pub const INSPECTION_RAYS: usize = 16;

/// The nearest such place to the region, cells (0.5 m: the camera sees the object whole).
pub const INSPECTION_MIN_CELLS: i64 = 5;

/// Whether the camera at cell `v` would see cell `c`: no occupied cell of the LiDAR grid on the
/// line between them but in `c`'s own 3 × 3 neighbourhood (the region's points lie on a
/// surface the grid holds).
fn sees(lidar: &LidarGrid, v: (i32, i32), c: (i32, i32), work: &mut u32) -> bool {
    for (x, y) in Line::new(v.0, v.1, c.0, c.1) {
        *work += 1;
        if (x - c.0).abs() <= 1 && (y - c.1).abs() <= 1 {
            return true;
        }
        if lidar.get(x, y) == Cell::Occupied {
            return false;
        }
    }
    true
}

/// One waypoint of the route: where to stand and which way to face, in the map's frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RouteWaypoint {
    /// x, metres.
    pub x: Meters,
    /// y, metres.
    pub y: Meters,
    /// Heading.
    pub heading: BinaryAngle,
}

/// The route was full: the waypoint was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RouteFull;

/// What the waypoint manager has done since the route was given or the search restarted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RouteStats {
    /// Route waypoints reached.
    pub reached: u32,
    /// Route waypoints skipped (blacklisted, or no reachable cell near them).
    pub skipped: u32,
    /// Priority waypoints inserted.
    pub priorities: u32,
    /// Priority waypoints ended because the camera saw their region before the robot got there.
    pub regions_seen: u32,
}

/// An inspection region seen from a viewpoint: (region cell, viewpoint cell, heading).
type RegionView = ((i32, i32), (i32, i32), BinaryAngle);

/// A priority waypoint being pursued: the region looked at and where from, in the map's frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Priority {
    region: (Meters, Meters),
    stand: (Meters, Meters),
    heading: BinaryAngle,
}

/// The waypoint manager's state.
pub struct Route {
    waypoints: heapless::Vec<RouteWaypoint, MAX_ROUTE_WAYPOINTS>,
    /// One bit per waypoint: done (reached or skipped).
    done: [u32; MAX_ROUTE_WAYPOINTS / 32],
    /// The route has been started (the first step may insert a priority waypoint).
    started: bool,
    priority: Option<Priority>,
    /// When the last priority waypoint ended.
    last_priority_us: Option<u64>,
    /// Counters.
    pub stats: RouteStats,
}

impl Route {
    /// No route.
    pub const fn new() -> Self {
        Route {
            waypoints: heapless::Vec::new(),
            done: [0; MAX_ROUTE_WAYPOINTS / 32],
            started: false,
            priority: None,
            last_priority_us: None,
            stats: RouteStats { reached: 0, skipped: 0, priorities: 0, regions_seen: 0 },
        }
    }

    /// Forgets the route.
    pub fn clear(&mut self) {
        self.waypoints.clear();
        self.restart();
    }

    /// Keeps the route but starts it over (a new search).
    pub fn restart(&mut self) {
        self.done = [0; MAX_ROUTE_WAYPOINTS / 32];
        self.started = false;
        self.priority = None;
        self.last_priority_us = None;
        self.stats = RouteStats::default();
    }

    /// Appends a waypoint.
    pub fn push(&mut self, w: RouteWaypoint) -> Result<(), RouteFull> {
        self.waypoints.push(w).map_err(|_| RouteFull)
    }

    /// The whole route.
    pub fn waypoints(&self) -> &[RouteWaypoint] {
        &self.waypoints
    }

    /// Whether waypoint `i` is done (reached or skipped).
    pub fn is_done(&self, i: usize) -> bool {
        self.done.get(i / 32).is_some_and(|w| w >> (i % 32) & 1 != 0)
    }

    fn mark_done(&mut self, i: usize) {
        if let Some(w) = self.done.get_mut(i / 32) {
            *w |= 1 << (i % 32);
        }
    }
}

impl Default for Route {
    fn default() -> Self {
        Self::new()
    }
}

impl Planner {
    /// One step of the waypoint manager (see the module's docs): the viewpoint to pursue, and
    /// the work.
    pub(super) fn follow_route(&mut self, step: &Step) -> (Option<Viewpoint>, u32) {
        let cfg = step.inputs.cfg;
        let geom = step.inputs.lidar.geom;
        let pose = step.inputs.pose;
        let tol2 = {
            let t = GridGeometry::cells(cfg.goal_tolerance_m) as i64;
            t * t
        };
        let robot = self.robot_cell;
        let at = |c: (i32, i32), h: BinaryAngle| {
            let (dx, dy) = ((c.0 - robot.0) as i64, (c.1 - robot.1) as i64);
            dx * dx + dy * dy <= tol2 && (h - pose.theta).unsigned_abs() <= cfg.goal_heading_tolerance.unsigned_abs()
        };
        let bl = GridGeometry::cells(cfg.blacklist_radius_m);
        let mut work = 0;

        // Priority: the one being pursued, until it is done.
        if let Some(p) = self.route.priority {
            let region = geom.cell_of(p.region.0, p.region.1);
            let stand = geom.cell_of(p.stand.0, p.stand.1);
            let seen = step.inputs.visual.seen(region.0, region.1);
            if seen {
                self.route.stats.regions_seen += 1;
            }
            let there = at(stand, p.heading);
            let claimed = self.is_claimed(stand, super::claim_radius(cfg));
            if seen || there || claimed || self.is_blacklisted(stand, bl) || self.distance(stand.0, stand.1) == UNREACHABLE {
                self.route.priority = None;
                // The interval runs from here: the route gets at least that long before the
                // next priority waypoint.
                self.route.last_priority_us = Some(step.inputs.now_us);
                if there && !seen {
                    // Looked from there and still not seen (occluded): not from there again.
                    self.blacklist(stand);
                }
            } else {
                return (Some(self.route_viewpoint(stand, p.heading, Site::Inspection)), work);
            }
        }

        // The route: its first waypoint not done that the robot can reach now.
        let mut target = None;
        let mut reached_one = !self.route.started;
        self.route.started = true;
        for i in 0..self.route.waypoints.len() {
            if self.route.is_done(i) {
                continue;
            }
            let w = self.route.waypoints[i];
            let c = geom.cell_of(w.x, w.y);
            work += 1;
            if self.is_blacklisted(c, bl) {
                self.route.stats.skipped += 1;
                self.route.mark_done(i);
                continue;
            }
            work += ((2 * step.snap + 1) * (2 * step.snap + 1)) as u32;
            let Some(s) = self.reachable_near(c, step.snap) else { continue };
            // Reached where it was snapped to (a waypoint close to a wall is stood at from
            // the nearest cell the robot can stand on).
            if at(s, w.heading) || at(c, w.heading) {
                self.route.stats.reached += 1;
                self.route.mark_done(i);
                reached_one = true;
                continue;
            }
            target = Some((s, w.heading));
            break;
        }

        // LIVE: a priority waypoint, at most once per interval (and, the route done, whenever
        // a region is left).
        if cfg.planner == PlannerKind::Live {
            let now = step.inputs.now_us;
            let due = target.is_none()
                || (reached_one && self.route.last_priority_us.is_none_or(|t| now.saturating_sub(t) >= cfg.live_priority_interval_us));
            if due {
                let (found, w) = self.nearest_region(step, bl);
                work += w;
                if let Some((region, stand, heading)) = found {
                    self.route.stats.priorities += 1;
                    self.route.priority =
                        Some(Priority { region: geom.center_of(region.0, region.1), stand: geom.center_of(stand.0, stand.1), heading });
                    return (Some(self.route_viewpoint(stand, heading, Site::Inspection)), work);
                }
            }
        }
        (target.map(|(c, h)| self.route_viewpoint(c, h, Site::Route)), work)
    }

    /// The inspection region whose viewpoint is nearest by path: (region cell, viewpoint cell,
    /// heading), and the work.
    fn nearest_region(&self, step: &Step, bl: i32) -> (Option<RegionView>, u32) {
        let geom = step.inputs.lidar.geom;
        let robot = self.robot_cell;
        let r_cells = GridGeometry::cells(step.inputs.cfg.camera_range_m) as i64;
        let claim = super::claim_radius(step.inputs.cfg);
        let mut best: Option<(u16, RegionView)> = None;
        let mut work = 0;
        for p in step.inputs.nonmap.points() {
            let c = geom.cell_of(p.x, p.y);
            work += 1;
            if p.hits < LIVE_REGION_MIN_HITS || step.inputs.visual.seen(c.0, c.1) {
                continue;
            }
            let usable = |v: (i32, i32)| v != c && !self.is_blacklisted(v, bl) && !self.is_claimed(v, claim);
            // The paper's stand-off on the line to the robot, if the camera would see the
            // region from there; else the nearest place that would.
            let v = stand_off(robot, c, r_cells);
            work += ((2 * step.snap + 1) * (2 * step.snap + 1)) as u32;
            let v = match self.reachable_near(v, step.snap) {
                Some(v) if usable(v) && sees(step.inputs.lidar, v, c, &mut work) => Some(v),
                _ => self.stand_in_sight(step.inputs.lidar, c, r_cells, &usable, &mut work),
            };
            let Some(v) = v else { continue };
            let d = self.distance(v.0, v.1);
            if best.is_none_or(|b| d < b.0) {
                best = Some((d, (c, v, atan2(c.1 - v.1, c.0 - v.0))));
            }
        }
        (best.map(|(_, r)| r), work)
    }

    /// The reachable cell nearest the robot by path from which the camera would see region
    /// cell `c`: on [`INSPECTION_RAYS`] rays out of `c`, from [`INSPECTION_MIN_CELLS`] to
    /// `λ·range_cells` away (λ as for proposals), each stopping at the first occupied cell of
    /// the LiDAR grid. `None` if no such cell is reachable and `usable`.
    fn stand_in_sight(
        &self,
        lidar: &LidarGrid,
        c: (i32, i32),
        range_cells: i64,
        usable: &dyn Fn((i32, i32)) -> bool,
        work: &mut u32,
    ) -> Option<(i32, i32)> {
        let reach_mm = PROPOSAL_LAMBDA_PER_MILLE * range_cells * CELL_MM / 1000;
        let reach = Meters::from_bits(((reach_mm << 16) / 1000) as i32);
        let (cx, cy) = lidar.geom.center_of(c.0, c.1);
        let mut best: Option<(u16, (i32, i32))> = None;
        for k in 0..INSPECTION_RAYS {
            let a = BinaryAngle::from_fraction(k as i64, INSPECTION_RAYS as i64);
            let end = ray_end(&lidar.geom, cx, cy, a, reach);
            for (x, y) in Line::new(c.0, c.1, end.0, end.1) {
                *work += 1;
                let (dx, dy) = ((x - c.0) as i64, (y - c.1) as i64);
                let near_region = dx.abs() <= 1 && dy.abs() <= 1;
                if !near_region && lidar.get(x, y) == Cell::Occupied {
                    break;
                }
                if dx * dx + dy * dy < INSPECTION_MIN_CELLS * INSPECTION_MIN_CELLS {
                    continue;
                }
                let d = self.distance(x, y);
                if d != UNREACHABLE && best.is_none_or(|b| d < b.0) && usable((x, y)) {
                    best = Some((d, (x, y)));
                }
            }
        }
        best.map(|b| b.1)
    }

    fn route_viewpoint(&self, cell: (i32, i32), heading: BinaryAngle, source: Site) -> Viewpoint {
        Viewpoint {
            cell,
            heading,
            source,
            utility: 0,
            path_units: self.distance(cell.0, cell.1),
            unseen: 0,
            surface: 0,
            frontier_near_path: 0,
            nonmap: 0,
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::frontier::FrontierSet;
    use crate::grid::{GridGeometry, LidarGrid, VisualGrid};
    use crate::nonmap::NonMapStore;
    use crate::Config;
    use fixed_point::Pose2;
    use std::boxed::Box;

    /// A 20 × 20 m room (walls on its border) at the origin, as a seeded prior would give.
    fn room() -> Box<LidarGrid> {
        let mut g = Box::new(LidarGrid::new(GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO }));
        for y in 0..=200 {
            for x in 0..=200 {
                let wall = x == 0 || y == 0 || x == 200 || y == 200;
                g.seed(x, y, if wall { 2 } else { -2 });
            }
        }
        g
    }

    /// Metres from millimetres.
    fn m(mm: i32) -> Meters {
        Config::mm(mm)
    }

    /// Millimetres of a length.
    fn mm(v: Meters) -> i64 {
        (v.to_bits() as i64 * 1000) >> 16
    }

    struct World {
        cfg: Config,
        lidar: Box<LidarGrid>,
        visual: Box<VisualGrid>,
        frontiers: Box<FrontierSet>,
        nonmap: Box<NonMapStore>,
        planner: Box<Planner>,
    }

    /// A goal: its centre (mm), its heading and its source.
    type Chosen = ((i64, i64), BinaryAngle, Site);

    impl World {
        fn new(kind: PlannerKind) -> World {
            let mut planner = Box::new(Planner::new());
            for (x, y, deg) in [(5_000, 5_000, 0), (15_000, 5_000, 0), (15_000, 15_000, 90)] {
                planner.route.push(RouteWaypoint { x: m(x), y: m(y), heading: BinaryAngle::from_degrees(deg) }).unwrap();
            }
            World {
                cfg: Config::DEFAULT.with_planner(kind),
                lidar: room(),
                visual: Box::new(VisualGrid::new()),
                frontiers: Box::new(FrontierSet::new()),
                nonmap: Box::new(NonMapStore::new()),
                planner,
            }
        }

        /// One planning step with the robot at `(x, y)` (mm) facing `heading`, at `t` seconds.
        fn step(&mut self, x: i64, y: i64, heading: BinaryAngle, t: u64) -> Option<Chosen> {
            let pose = Pose2::new(m(x as i32), m(y as i32), heading);
            let (g, _) = self.planner.plan(&self.cfg, &self.lidar, &self.visual, &self.frontiers, &self.nonmap, &pose, None, t * 1_000_000);
            g.map(|g| ((mm(g.pose.x), mm(g.pose.y)), g.pose.theta, g.viewpoint.source))
        }

        /// An inspection region at `(x, y)` (mm) with enough returns to be inspected.
        fn region(&mut self, x: i32, y: i32) {
            self.returns(x, y, LIVE_REGION_MIN_HITS);
        }

        /// `n` non-map returns at `(x, y)` (mm).
        fn returns(&mut self, x: i32, y: i32, n: u16) {
            let geom = self.lidar.geom;
            for _ in 0..n {
                self.nonmap.insert(&geom, m(x), m(y), self.cfg.nonmap_pool_radius_m);
            }
        }

        /// A wall from `(x0, y0)` to `(x1, y1)` (cells, inclusive, along one axis).
        fn wall(&mut self, (x0, y0): (i32, i32), (x1, y1): (i32, i32)) {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let _ = self.lidar.evidence.add(x, y, crate::grid::EVIDENCE_MAX);
                    self.lidar.grid.set(x, y, Cell::Occupied);
                }
            }
        }
    }

    /// Within 0.2 m.
    fn near(p: (i64, i64), q: (i64, i64)) -> bool {
        (p.0 - q.0).pow(2) + (p.1 - q.1).pow(2) < 200 * 200
    }

    const EAST: BinaryAngle = BinaryAngle::ZERO;
    const NORTH: BinaryAngle = BinaryAngle::QUARTER;

    #[test]
    fn the_manager_follows_the_route_and_inserts_a_priority_waypoint_only_after_a_waypoint_is_reached() {
        let mut w = World::new(PlannerKind::Live);
        let (at, _, src) = w.step(2_000, 5_000, EAST, 0).unwrap();
        assert!(near(at, (5_050, 5_050)) && src == Site::Route, "{at:?} {src:?}");
        // An inspection region appears while the robot walks: no priority before a waypoint.
        w.region(8_000, 12_000);
        let (at, _, src) = w.step(3_000, 5_000, EAST, 2).unwrap();
        assert!(near(at, (5_050, 5_050)) && src == Site::Route);
        // Waypoint 0 reached: the manager sends the priority waypoint, facing the region.
        let (at, heading, src) = w.step(5_050, 5_050, EAST, 4).unwrap();
        assert_eq!(src, Site::Inspection);
        assert_eq!(w.planner.route.stats.reached, 1);
        assert_eq!(w.planner.route.stats.priorities, 1);
        let bearing = atan2((12_050 - at.1) as i32, (8_050 - at.0) as i32);
        assert!((heading - bearing).unsigned_abs() < BinaryAngle::from_degrees(3).unsigned_abs(), "faces the region");
        // Still pursued on the next step; standing there facing it ends it (the camera looked
        // elsewhere, so its cell is blacklisted), and the route resumes at waypoint 1.
        assert_eq!(w.step(6_000, 6_000, EAST, 6).map(|g| g.2), Some(Site::Inspection));
        let (at, _, src) = w.step(at.0, at.1, heading, 8).unwrap();
        assert!(near(at, (15_050, 5_050)) && src == Site::Route, "{at:?} {src:?}");
        // Waypoint 1 reached 5 s after the priority ended: not due (10 s), the route goes on.
        let (at, _, src) = w.step(15_050, 5_050, EAST, 13).unwrap();
        assert!(near(at, (15_050, 15_050)) && src == Site::Route, "{at:?} {src:?}");
        assert_eq!(w.planner.route.stats.priorities, 1);
    }

    #[test]
    fn the_baselines_never_insert_priorities_and_a_blacklisted_waypoint_is_skipped() {
        let mut w = World::new(PlannerKind::LidarCoverage);
        w.region(8_000, 12_000);
        let (at, _, src) = w.step(5_050, 5_050, EAST, 30).unwrap();
        assert!(near(at, (15_050, 5_050)) && src == Site::Route, "{at:?} {src:?}");
        let geom = w.lidar.geom;
        w.planner.blacklist(geom.cell_of(m(15_000), m(5_000)));
        let (at, _, _) = w.step(6_000, 5_000, EAST, 31).unwrap();
        assert!(near(at, (15_050, 15_050)), "{at:?}");
        assert_eq!(w.planner.route.stats.skipped, 1);
        // The last one reached: the route is done and the baseline has nothing left.
        assert_eq!(w.step(15_050, 15_050, NORTH, 40), None);
        // `live` would still look at the region once the route is done.
        let mut l = World::new(PlannerKind::Live);
        l.region(8_000, 12_000);
        for i in 0..3 {
            l.planner.route.mark_done(i);
        }
        assert_eq!(l.step(15_050, 15_050, NORTH, 50).map(|g| g.2), Some(Site::Inspection));
    }

    #[test]
    fn a_region_of_a_few_stray_returns_gets_no_priority_waypoint() {
        let mut w = World::new(PlannerKind::Live);
        w.returns(8_000, 12_000, LIVE_REGION_MIN_HITS - 1);
        let (_, _, src) = w.step(5_050, 5_050, EAST, 4).unwrap();
        assert_eq!(src, Site::Route, "{} returns are a stray, not a region", LIVE_REGION_MIN_HITS - 1);
        assert_eq!(w.planner.route.stats.priorities, 0);
        // One more return and it is one.
        w.returns(8_000, 12_000, 1);
        w.planner.route.restart();
        let (_, _, src) = w.step(5_050, 5_050, EAST, 4).unwrap();
        assert_eq!(src, Site::Inspection);
    }

    #[test]
    fn a_region_behind_a_wall_is_looked_at_from_where_the_camera_sees_it() {
        let mut w = World::new(PlannerKind::Live);
        // A wall at x = 10 m from y = 0 to 15 m: the region at (12, 8) m is behind it for a
        // robot at (5, 5) m, where the paper's stand-off on the line to the robot (half the
        // camera's reach from the region, towards the robot) would face the wall.
        w.wall((100, 0), (100, 150));
        w.region(12_000, 8_000);
        let robot = (5_050, 5_050);
        let (at, heading, src) = w.step(robot.0, robot.1, EAST, 4).unwrap();
        assert_eq!(src, Site::Inspection);
        let geom = w.lidar.geom;
        let stand = geom.cell_of(m(at.0 as i32), m(at.1 as i32));
        let region = geom.cell_of(m(12_000), m(8_000));
        let mut work = 0;
        assert!(sees(&w.lidar, stand, region, &mut work), "stands at {at:?}, in sight of the region");
        assert!(at.0 > 10_100, "on the region's side of the wall: {at:?}");
        let (dx, dy) = (region.0 - stand.0, region.1 - stand.1);
        assert!((dx * dx + dy * dy) as i64 >= INSPECTION_MIN_CELLS * INSPECTION_MIN_CELLS);
        let bearing = atan2(dy, dx);
        assert!((heading - bearing).unsigned_abs() < BinaryAngle::from_degrees(3).unsigned_abs(), "faces the region");
        // In the open, the paper's stand-off is kept: on the line from the region to the robot.
        let mut open = World::new(PlannerKind::Live);
        open.region(12_000, 8_000);
        let (at, _, _) = open.step(robot.0, robot.1, EAST, 4).unwrap();
        // Within 150 mm of that line: |cross| / len < 150, in integers.
        let cross = (at.0 - 12_050) * (robot.1 - 8_050) - (at.1 - 8_050) * (robot.0 - 12_050);
        let len2 = (robot.0 - 12_050).pow(2) + (robot.1 - 8_050).pow(2);
        assert!(cross * cross < 150 * 150 * len2, "{at:?} is on the line to the robot");
    }
}
