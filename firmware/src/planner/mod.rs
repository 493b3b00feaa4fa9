//! Viewpoint selection: where the robot goes next and which way its camera looks.
//!
//! Every planning step starts the same way ([`reach`]):
//! 1. **Traversable cells** (Nav2's inflation, in two levels): LiDAR-free cells farther than
//!    `robot_radius_m` from every occupied cell are *open*; free cells between `lethal_radius_m`
//!    (the body) and `robot_radius_m` are the *narrow band*, passable at [`NARROW_STEP_FACTOR`]
//!    times the step cost; cells within `lethal_radius_m` and unknown cells are never traversable.
//!    So the robot keeps its full clearance where there is room and still passes a door that a
//!    0.1 m map draws narrower than that (docs/experiments/soft-clearance.md). By default
//!    `lethal_radius_m` equals `robot_radius_m`: no band. Viewpoints stand on
//!    open cells where they can ([`Planner::reachable_near`]), and a path pulled taut crosses no
//!    more narrow cells than the grid path it straightens. A robot within the clearance of
//!    something may still leave, but only away from it (see [`Planner::inflate`]).
//! 2. **Path distance** from the robot to every passable cell: Dijkstra on the 8-connected grid
//!    with integer step costs 5 (straight) and 7 (diagonal) — one unit is 0.02 m, 7/5 ≈ √2 —,
//!    five times those onto a narrow cell, and no corner cutting. The open list is a
//!    fixed-capacity binary heap ([`DIJKSTRA_HEAP`]); an overflow is counted in
//!    [`PlanStats::heap_overflows`].
//!
//! Then one rule, by [`PlannerKind`], proposes *sites* (a cell, what produced it, a heading if
//! it has one, the rule's own score) and [`Planner::choose`] scores and picks among them:
//! - [`schedule`]: the structured search (`lives`, `lives-no-nonmap`): object proposals
//!   ([`proposals`]), rooms ([`crate::rooms`]) and a global tour with precedence
//!   ([`crate::tour`]); it returns the tour's first task rather than scoring sites;
//! - [`greedy`]: the paper's Algorithm 1 (`lives-greedy`, `multisensor`): four viewpoints per
//!   frontier, the LIVES utility ([`view`]), the argmax;
//! - [`nearest`]: Yamauchi's nearest frontier;
//! - [`explore_lite`]: after ROS `explore_lite`;
//! - [`rrt_points`]: frontier points of random trees ([`crate::rrt`]);
//! - [`coverage`]: LIVE's waypoint manager over a known building (`live`, `visual-cpp`,
//!   `lidar-cpp`): the host's coverage route, and priority waypoints to inspection regions.
//!
//! Whatever the rule, the goal is a viewpoint pose and a path of at most [`MAX_PATH_WAYPOINTS`]
//! waypoints down the distance field ([`Planner::goal_for`]).

pub mod coverage;
pub mod explore_lite;
pub mod greedy;
pub mod nearest;
pub mod proposals;
pub mod reach;
pub mod rrt_points;
pub mod schedule;
pub mod view;

use crate::capacity::{
    BLOCKS, DIJKSTRA_HEAP, GRID_AREA, GRID_CELLS, MAX_BLACKLIST, MAX_FRONTIERS_PER_GRID, MAX_NONMAP_POINTS, MAX_NONMAP_SITES,
    MAX_PATH_WAYPOINTS, MAX_PROPOSALS, MAX_ROOMS, MAX_TASKS, MAX_VIEWPOINTS,
};
use crate::config::{Config, PlannerKind, Weight};
use crate::frontier::{FrontierSet, FrontierSource};
use crate::grid::{BitGrid, GridGeometry, LidarGrid, PackedGrid, VisualGrid};
use crate::nonmap::NonMapStore;
use crate::rrt::{self, RrtExplorer};
use fixed_point::{BinaryAngle, Meters, Pose2};
use heapless::binary_heap::{BinaryHeap, Min};

pub use explore_lite::{EXPLORE_LITE_GAIN_SCALE, EXPLORE_LITE_POTENTIAL_SCALE};
pub use reach::{MAX_SEGMENT_CELLS, NARROW_STEP_FACTOR, STEP_DIAGONAL, STEP_STRAIGHT, UNREACHABLE};
pub use view::{GAZE_HANDOVER_M, GAZE_HEADINGS};

/// Rays cast across the camera cone when scoring a viewpoint's unseen cells.
pub const SCORE_RAYS: usize = 24;

/// One entry of a step's site list: where, what kind, a fixed heading if the site has one, and a
/// baseline's own score of it.
pub(crate) type SiteEntry = ((i32, i32), Site, Option<BinaryAngle>, i64);

/// Capacity of one step's site list: frontier pieces of both maps, non-map clusters, the
/// robot's own cell, the current goal, and the `rrt` baseline's points.
pub(crate) const SITES: usize = 2 * MAX_FRONTIERS_PER_GRID + MAX_NONMAP_SITES + 2 + rrt::RRT_POINTS;

/// A step's site list.
pub(crate) type Sites = heapless::Vec<SiteEntry, SITES>;

/// The four viewpoint headings.
pub const HEADINGS: [BinaryAngle; 4] = [BinaryAngle::ZERO, BinaryAngle::QUARTER, BinaryAngle::HALF, BinaryAngle(-(1 << 30))];

/// What produced a candidate viewpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Site {
    /// A frontier of the LiDAR map (four headings).
    LidarFrontier,
    /// A frontier of the visual map (four headings).
    VisualFrontier,
    /// A cluster of non-map points, looked at from `nonmap_standoff_m` (`lives` only).
    NonMapCluster,
    /// The robot's own cell: turning in place to look (`look_around_here`).
    Here,
    /// The goal being pursued, re-scored for hysteresis (never a new goal itself).
    Current,
    /// A room the camera has not seen, looked into from its most open cell (the tour).
    Room,
    /// A waypoint of a coverage route (LIVE and its baselines).
    Route,
    /// A priority waypoint looking at an inspection region (LIVE).
    Inspection,
}

impl Site {
    /// The site kind of a frontier of `source`'s map.
    pub const fn frontier(source: FrontierSource) -> Site {
        match source {
            FrontierSource::Lidar => Site::LidarFrontier,
            FrontierSource::Visual => Site::VisualFrontier,
        }
    }
}

/// A scored candidate viewpoint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Viewpoint {
    /// Cell where the robot would stand.
    pub cell: (i32, i32),
    /// Which way the camera faces: one of [`HEADINGS`] at a frontier, the bearing of the
    /// cluster at a non-map site.
    pub heading: BinaryAngle,
    /// What produced it.
    pub source: Site,
    /// Utility, Q16.16 bits.
    pub utility: i64,
    /// Path distance in units of 0.02 m.
    pub path_units: u16,
    /// Estimated camera-unseen cells in its cone.
    pub unseen: u32,
    /// Rays of its cone ending on an unseen surface (LiDAR-occupied, camera-unseen).
    pub surface: u32,
    /// Frontier cells near the path.
    pub frontier_near_path: u32,
    /// Non-map points in its cone.
    pub nonmap: u32,
}

impl Viewpoint {
    /// The path distance in metres (Q16.16, truncated).
    pub fn path_length_m(&self) -> Meters {
        let path_mm = self.path_units as i64 * (crate::capacity::CELL_MM / STEP_STRAIGHT as i64);
        Meters::from_bits(((path_mm << 16) / 1000) as i32)
    }
}

/// A goal for the base: a viewpoint pose and how to get there.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Goal {
    /// Where to stand and which way to look.
    pub pose: Pose2,
    /// The viewpoint it came from.
    pub viewpoint: Viewpoint,
    /// Waypoints from (near) the robot to the goal, the last one the goal position.
    pub path: heapless::Vec<(Meters, Meters), MAX_PATH_WAYPOINTS>,
    /// Path length.
    pub path_length_m: Meters,
}

impl Goal {
    /// The same goal in another frame: `t` maps this goal's frame into it (pose and waypoints;
    /// the viewpoint's grid cell stays as it was).
    pub fn transformed(&self, t: &Pose2) -> Goal {
        let mut path = heapless::Vec::new();
        for &(x, y) in self.path.iter() {
            // Cannot fail: the same capacity.
            let _ = path.push(t.transform_point(x, y));
        }
        Goal { pose: t.compose(&self.pose), viewpoint: self.viewpoint, path, path_length_m: self.path_length_m }
    }
}

/// Counters of the last planning step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlanStats {
    /// Viewpoints scored.
    pub candidates: u32,
    /// Frontiers with no reachable cell near their anchor.
    pub unreachable: u32,
    /// Frontiers dropped for being near a blacklisted goal.
    pub blacklisted: u32,
    /// Dijkstra pushes refused because the open list was full.
    pub heap_overflows: u32,
    /// Candidates skipped because the robot already stands there facing that way.
    pub already_there: u32,
    /// Cells reached by the path-distance search.
    pub reachable_cells: u32,
    /// Work units spent.
    pub work: u32,
}

/// The planner's working memory and its blacklist.
pub struct Planner {
    blocked: BitGrid,
    dist: [u16; GRID_AREA],
    heap: BinaryHeap<u64, Min, DIJKSTRA_HEAP>,
    block_stamp: [u16; BLOCKS * BLOCKS],
    stamp: u16,
    blacklist: heapless::Deque<(i32, i32), MAX_BLACKLIST>,
    visible: heapless::Vec<(BinaryAngle, u32), MAX_NONMAP_POINTS>,
    /// The candidates scored in the last step (for logs and pictures).
    pub candidates: heapless::Vec<Viewpoint, MAX_VIEWPOINTS>,
    /// Counters of the last step.
    pub stats: PlanStats,
    robot_cell: (i32, i32),
    /// The `rrt` baseline's trees and frontier points (idle under the other planners).
    pub rrt: RrtExplorer,
    /// The room segmentation of the last structured step.
    pub rooms: crate::rooms::Rooms,
    /// Object proposals of the last structured step, and the clustering's scratch.
    pub proposals: proposals::ProposalScratch,
    /// The tasks of the last structured step (index + 1 is the tour's node).
    pub tasks: heapless::Vec<schedule::Task, MAX_TASKS>,
    task_pool: heapless::Vec<schedule::Task, TASK_POOL>,
    room_scratch: heapless::Vec<(i32, i32), MAX_ROOMS>,
    problem: crate::tour::TourProblem,
    /// The tour solver (its best tour: the last structured step's order of `tasks`).
    pub tour: crate::tour::TourSolver,
    last_tour: heapless::Vec<((i32, i32), schedule::TaskKind), MAX_TASKS>,
    /// The task the last structured step chose: (its viewpoint cell, its anchor, its kind).
    last_goal: Option<schedule::Pursued>,
    /// The room of the task the last structured step chose.
    last_goal_room: Option<u8>,
    /// Counters of the last structured step.
    pub sched: schedule::ScheduleStats,
    /// LIVE's waypoint manager: the coverage route and where along it the robot is.
    pub route: coverage::Route,
    /// A team's goals this robot leaves to its teammates (`Controller::set_team_claims`).
    claims: heapless::Vec<(i32, i32), { crate::capacity::MAX_TEAM_CLAIMS }>,
}

/// How far from a teammate's goal a robot of a team chooses none of its own, in cells: half the
/// camera's range (the teammate's camera looks there; Burgard et al. 2005 lower the utility of
/// what a teammate's target will let it see).
pub(crate) fn claim_radius(cfg: &Config) -> i32 {
    GridGeometry::cells(cfg.camera_range_m) / 2
}

/// Whether `c` is within `radius_cells` of one of `cells`.
fn within<'a>(mut cells: impl Iterator<Item = &'a (i32, i32)>, c: (i32, i32), radius_cells: i32) -> bool {
    let r2 = radius_cells as i64 * radius_cells as i64;
    cells.any(|b| ((b.0 - c.0) as i64).pow(2) + ((b.1 - c.1) as i64).pow(2) <= r2)
}

/// Candidate tasks of one structured step before the [`MAX_TASKS`] best are kept: every
/// frontier, every proposal, the room tasks.
const TASK_POOL: usize = 2 * MAX_FRONTIERS_PER_GRID + MAX_PROPOSALS + schedule::MAX_ROOM_TASKS;

/// What a planning step reads besides the planner's own state: the configuration, the maps, their
/// frontiers, the non-map points and the robot's pose now.
#[derive(Clone, Copy)]
pub struct PlanInputs<'a> {
    /// The configuration (the rule, its weights, the radii).
    pub cfg: &'a Config,
    /// The LiDAR map: where the robot can go.
    pub lidar: &'a LidarGrid,
    /// The visual map: what the camera has seen.
    pub visual: &'a VisualGrid,
    /// Both maps' frontiers, computed on them.
    pub frontiers: &'a FrontierSet,
    /// The non-map points.
    pub nonmap: &'a NonMapStore,
    /// The robot's pose now (its heading decides which views it already has).
    pub pose: &'a Pose2,
    /// The controller's clock now (LIVE's priority interval).
    pub now_us: u64,
}

/// What a selection rule reads in one planning step.
pub(crate) struct Step<'a> {
    pub inputs: PlanInputs<'a>,
    /// The robot's cell.
    pub robot: (i32, i32),
    /// `viewpoint_snap_radius_m` in cells.
    pub snap: i32,
}

/// How [`Planner::choose`] scores a site.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Score {
    /// The LIVES utility over four headings (or the site's own heading), `w_nonmap` weighing
    /// the non-map term (zero for `multisensor`).
    Utility(Weight),
    /// Minus the path distance (`nearest`), facing the direction of travel.
    Nearest,
    /// The rule's own score of the site (`explore-lite`, `rrt`), facing the direction of travel.
    Own,
}

impl Planner {
    /// Empty, no blacklist.
    pub const fn new() -> Self {
        Self {
            blocked: BitGrid::new(),
            dist: [UNREACHABLE; GRID_AREA],
            heap: BinaryHeap::new(),
            block_stamp: [0; BLOCKS * BLOCKS],
            stamp: 0,
            blacklist: heapless::Deque::new(),
            claims: heapless::Vec::new(),
            visible: heapless::Vec::new(),
            candidates: heapless::Vec::new(),
            stats: PlanStats {
                candidates: 0,
                unreachable: 0,
                blacklisted: 0,
                heap_overflows: 0,
                already_there: 0,
                reachable_cells: 0,
                work: 0,
            },
            robot_cell: (0, 0),
            rrt: RrtExplorer::new(),
            rooms: crate::rooms::Rooms::new(),
            proposals: proposals::ProposalScratch::new(),
            tasks: heapless::Vec::new(),
            task_pool: heapless::Vec::new(),
            room_scratch: heapless::Vec::new(),
            problem: crate::tour::TourProblem::new(),
            tour: crate::tour::TourSolver::new(),
            last_tour: heapless::Vec::new(),
            last_goal: None,
            last_goal_room: None,
            sched: schedule::ScheduleStats {
                tasks: [0; 4],
                dropped: 0,
                rooms: 0,
                tour_units: 0,
                solved: false,
                kept: false,
                pursued: false,
            },
            route: coverage::Route::new(),
        }
    }

    /// Forgets the blacklist and the last step.
    pub fn clear(&mut self) {
        self.blacklist.clear();
        self.candidates.clear();
        self.rrt.clear();
        self.dist.fill(UNREACHABLE);
        self.stats = PlanStats::default();
        self.tasks.clear();
        self.last_tour.clear();
        self.last_goal = None;
        self.sched = schedule::ScheduleStats::default();
        // The route is an input, like the prior map: a new search follows it from its start.
        self.route.restart();
    }

    /// Moves the window by `(sx, sy)` cells ([`crate::rolling::shift`]): the distance field and
    /// traversability mask move with the cells (new cells unreachable and blocked), blacklist
    /// entries, the last step's candidates and the `rrt` trees are translated, and whatever falls
    /// outside the window is dropped (counted in the return's second value). Returns the work
    /// (cells and entries touched) and the entries dropped.
    pub(crate) fn shift(&mut self, sx: i32, sy: i32) -> (u32, u32) {
        self.blocked.shift(sx, sy, true);
        crate::grid::shift_2d(&mut self.dist, GRID_CELLS, sx as i64, sy as i64, UNREACHABLE);
        let mut work = 2 * GRID_AREA as u32;
        let mut dropped = 0;
        let n = self.blacklist.len() + self.candidates.len();
        self.blacklist.retain_mut(|c| {
            *c = (c.0 - sx, c.1 - sy);
            PackedGrid::in_bounds(c.0, c.1) || {
                dropped += 1;
                false
            }
        });
        self.candidates.retain_mut(|v| {
            v.cell = (v.cell.0 - sx, v.cell.1 - sy);
            PackedGrid::in_bounds(v.cell.0, v.cell.1) || {
                dropped += 1;
                false
            }
        });
        self.robot_cell = (self.robot_cell.0 - sx, self.robot_cell.1 - sy);
        work += n as u32;
        // The tour's memory of its last order moves too (tasks are recomputed every step).
        self.last_tour.retain_mut(|(c, _)| {
            *c = (c.0 - sx, c.1 - sy);
            PackedGrid::in_bounds(c.0, c.1)
        });
        self.tasks.clear();
        self.last_goal = self.last_goal.map(|(c, a, k)| ((c.0 - sx, c.1 - sy), (a.0 - sx, a.1 - sy), k));
        work += self.rooms.shift(sx, sy);
        let (w, d) = self.rrt.shift(sx, sy);
        (work + w, dropped + d)
    }

    /// Remembers a failed goal; candidates near it are dropped from now on.
    pub fn blacklist(&mut self, cell: (i32, i32)) {
        if self.blacklist.is_full() {
            self.blacklist.pop_front();
        }
        let _ = self.blacklist.push_back(cell);
    }

    /// Goals blacklisted so far (oldest first).
    pub fn blacklisted(&self) -> impl Iterator<Item = &(i32, i32)> {
        self.blacklist.iter()
    }

    /// The teammates' goals this robot leaves to them (at most
    /// [`crate::capacity::MAX_TEAM_CLAIMS`]; more are ignored).
    pub fn set_claims(&mut self, cells: &[(i32, i32)]) {
        self.claims.clear();
        for &c in cells.iter().take(crate::capacity::MAX_TEAM_CLAIMS) {
            let _ = self.claims.push(c);
        }
    }

    /// Whether site `c` is within `radius_cells` of a teammate's goal.
    pub(crate) fn is_claimed(&self, c: (i32, i32), radius_cells: i32) -> bool {
        within(self.claims.iter(), c, radius_cells)
    }

    pub(super) fn is_blacklisted(&self, c: (i32, i32), radius_cells: i32) -> bool {
        within(self.blacklist.iter(), c, radius_cells)
    }

    fn offer(&mut self, vp: Viewpoint, best: &mut Option<Viewpoint>, current_utility: &mut Option<i64>, already_there: bool) {
        if vp.source == Site::Current {
            *current_utility = Some(vp.utility);
            return;
        }
        if already_there {
            // The robot stands there looking that way: the camera already shows what it offers.
            self.stats.already_there += 1;
            return;
        }
        self.stats.candidates += 1;
        let _ = self.candidates.push(vp);
        if best.is_none_or(|b| vp.utility > b.utility) {
            *best = Some(vp);
        }
    }

    /// One planning step at time `now_us`. `current` is the goal being pursued (cell and
    /// heading), re-scored with the same terms so the caller can apply hysteresis; returns
    /// `(best, current_utility)`.
    #[allow(clippy::too_many_arguments)]
    pub fn plan(
        &mut self,
        cfg: &Config,
        lidar: &LidarGrid,
        visual: &VisualGrid,
        frontiers: &FrontierSet,
        nonmap: &NonMapStore,
        pose: &Pose2,
        current: Option<((i32, i32), BinaryAngle)>,
        now_us: u64,
    ) -> (Option<Goal>, Option<i64>) {
        let work = self.prepare(cfg, lidar, pose);
        let (goal, current_utility) = self.select(PlanInputs { cfg, lidar, visual, frontiers, nonmap, pose, now_us }, current);
        self.stats.work += work;
        (goal, current_utility)
    }

    /// The first half of a planning step: which cells the robot may stand on and the path
    /// distance to each, from the robot's cell now. The controller runs it on one tick and
    /// [`Planner::select`] on the next, so that no tick carries a whole step (issue 28, real
    /// time). Returns the work.
    pub fn prepare(&mut self, cfg: &Config, lidar: &LidarGrid, pose: &Pose2) -> u32 {
        self.stats = PlanStats::default();
        self.candidates.clear();
        let robot = lidar.geom.cell_of(pose.x, pose.y);
        self.robot_cell = robot;
        let work = self.inflate(lidar, cfg.robot_radius_m, cfg.lethal_radius_m, robot);
        work + self.distances(lidar, robot)
    }

    /// The second half of a planning step, on the distance field of the last
    /// [`Planner::prepare`]: the rule's choice and its goal. Paths start from the cell `prepare`
    /// saw. Returns `(best, current_utility)`; its work is in [`PlanStats::work`].
    pub fn select(&mut self, inputs: PlanInputs<'_>, current: Option<((i32, i32), BinaryAngle)>) -> (Option<Goal>, Option<i64>) {
        self.candidates.clear();
        let robot = self.robot_cell;
        let mut work = 0;
        let PlanInputs { cfg, lidar, .. } = inputs;
        let step = Step { inputs, robot, snap: GridGeometry::cells(cfg.viewpoint_snap_radius_m) };
        let mut sites = Sites::new();
        let score = match cfg.planner {
            PlannerKind::Lives | PlannerKind::LivesNoNonMap => {
                let (best, w) = self.schedule(&step, current);
                self.stats.work = work + w;
                return (best.map(|vp| self.goal_for(lidar, vp)), None);
            }
            PlannerKind::Live | PlannerKind::VisualCoverage | PlannerKind::LidarCoverage => {
                let (best, w) = self.follow_route(&step);
                self.stats.work = work + w;
                return (best.map(|vp| self.goal_for(lidar, vp)), None);
            }
            PlannerKind::LivesGreedy | PlannerKind::Multisensor => {
                work += self.greedy_sites(&step, current, &mut sites);
                Score::Utility(cfg.effective_w_nonmap())
            }
            PlannerKind::Nearest => {
                work += self.nearest_sites(&step, current, &mut sites);
                Score::Nearest
            }
            PlannerKind::ExploreLite => {
                work += self.explore_lite_sites(&step, &mut sites);
                Score::Own
            }
            PlannerKind::Rrt => {
                work += self.rrt_sites(&step, &mut sites);
                Score::Own
            }
        };
        let (best, current_utility, w) = self.choose(&step, &sites, score);
        self.stats.work = work + w;
        let goal = best.map(|vp| self.goal_for(lidar, vp));
        (goal, current_utility)
    }

    /// Scores every site and returns the best viewpoint, the current goal's utility (a
    /// [`Site::Current`] entry) and the work. Blacklisted sites are dropped (except the current
    /// goal), and so are viewpoints the robot already stands at, facing that way.
    fn choose(&mut self, step: &Step, sites: &[SiteEntry], score: Score) -> (Option<Viewpoint>, Option<i64>, u32) {
        let cfg = step.inputs.cfg;
        let bl = GridGeometry::cells(cfg.blacklist_radius_m);
        let range_cells = GridGeometry::cells(cfg.camera_range_m);
        let mut work = 0;
        let mut best: Option<Viewpoint> = None;
        let mut current_utility = None;
        let here = GridGeometry::cells(cfg.goal_tolerance_m) as i64 * STEP_STRAIGHT as i64;
        let (robot, pose) = (step.robot, step.inputs.pose);
        let already_there = |cell: (i32, i32), h: BinaryAngle, d: u16| {
            (cell == robot || (d as i64) <= here) && (h - pose.theta).unsigned_abs() <= cfg.goal_heading_tolerance.unsigned_abs()
        };
        let claim = claim_radius(cfg);
        for &(site, kind, fixed_heading, own_score) in sites.iter() {
            if kind != Site::Current && (self.is_blacklisted(site, bl) || self.is_claimed(site, claim)) {
                self.stats.blacklisted += 1;
                continue;
            }
            let path_units = self.distance(site.0, site.1);
            let path_mm = path_units as i64 * (crate::capacity::CELL_MM / STEP_STRAIGHT as i64);
            let dist_term = (cfg.w_dist_per_m.to_bits() as i64 * path_mm) / 1000;
            let w_nonmap = match score {
                Score::Utility(w) => w,
                Score::Nearest | Score::Own => {
                    let heading = fixed_heading.unwrap_or_else(|| self.travel_heading(site, pose));
                    let vp = Viewpoint {
                        cell: site,
                        heading,
                        source: kind,
                        utility: if score == Score::Nearest { -dist_term } else { own_score },
                        path_units,
                        unseen: 0,
                        surface: 0,
                        frontier_near_path: 0,
                        nonmap: 0,
                    };
                    let at = already_there(site, heading, path_units);
                    self.offer(vp, &mut best, &mut current_utility, at);
                    continue;
                }
            };
            let (near, w) = self.frontier_near_path(step.inputs.frontiers, site.0, site.1, cfg.frontier_near_path_blocks as i32);
            work += w;
            work +=
                if w_nonmap != Weight::ZERO { self.visible_nonmap(step.inputs.lidar, step.inputs.nonmap, site, range_cells) } else { 0 };
            let headings: &[BinaryAngle] = match &fixed_heading {
                Some(h) => core::slice::from_ref(h),
                None => &HEADINGS,
            };
            for &heading in headings {
                let (view, w) = self.view(cfg, step.inputs.lidar, step.inputs.visual, site, heading, w_nonmap);
                work += w;
                let utility = view.gain + cfg.w_frontier_per_cell.to_bits() as i64 * near as i64 - dist_term;
                let vp = Viewpoint {
                    cell: site,
                    heading,
                    source: kind,
                    utility,
                    path_units,
                    unseen: view.unseen,
                    surface: view.surface,
                    frontier_near_path: near,
                    nonmap: view.nonmap,
                };
                let at = already_there(site, heading, path_units);
                self.offer(vp, &mut best, &mut current_utility, at);
            }
        }
        (best, current_utility, work)
    }

    /// The frontiers' sites: each frontier's anchor snapped to a reachable cell, in frontier
    /// order; `keep` filters frontiers and `own` gives the rule's own score. Misses are counted
    /// in [`PlanStats::unreachable`]. Returns the work.
    fn frontier_sites(
        &mut self,
        step: &Step,
        sites: &mut Sites,
        keep: impl Fn(&crate::frontier::Frontier) -> bool,
        own: impl Fn(&crate::frontier::Frontier) -> i64,
    ) -> u32 {
        let mut work = 0;
        let mut unreachable = 0;
        for f in step.inputs.frontiers.frontiers() {
            if !keep(f) {
                continue;
            }
            let Some(c) = self.snap_site(f.anchor, step.snap, &mut work, &mut unreachable) else { continue };
            let _ = sites.push((c, Site::frontier(f.source), None, own(f)));
        }
        self.stats.unreachable += unreachable;
        work
    }

    /// True if some LiDAR frontier has a reachable cell near its anchor (the baselines turn to
    /// camera frontiers only when none has).
    fn lidar_frontiers_reachable(&self, step: &Step) -> bool {
        step.inputs
            .frontiers
            .frontiers()
            .iter()
            .any(|f| f.source == FrontierSource::Lidar && self.reachable_near(f.anchor, step.snap).is_some())
    }

    /// The current goal as a [`Site::Current`] entry, if it is still reachable.
    fn push_current(&self, current: Option<((i32, i32), BinaryAngle)>, sites: &mut Sites) {
        if let Some((c, h)) = current {
            if self.distance(c.0, c.1) != UNREACHABLE {
                let _ = sites.push((c, Site::Current, Some(h), 0));
            }
        }
    }
}

impl Default for Planner {
    fn default() -> Self {
        Self::new()
    }
}
