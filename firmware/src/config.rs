//! Every parameter a user may tune, with units in the names and documented defaults.
//!
//! All values are fixed-point or integer so that the controller's decisions do not depend on a
//! platform's float behaviour. `Config::default()` is the tuned default (see `docs/architecture.md`
//! for the rationale of each number).
//!
//! Not every value of a field's type is one the core can work with: a length longer than the grid,
//! a robot wider than its inflation table, a negative weight. [`Config::validate`] checks a whole
//! configuration against the ranges written on each field (they keep the core's integer arithmetic
//! in range and every loop short); [`crate::Controller::set_config`] and the serial node refuse a
//! configuration that fails it, with a [`ConfigError`] naming the field and its range.

use crate::capacity::{CELL_MM, GRID_CELLS, MAX_ROBOT_RADIUS_CELLS};
use fixed_point::{BinaryAngle, Meters};

/// A utility weight: Q16.16, "utility points per unit of the term".
pub type Weight = fixed_point::fixed::types::I16F16;

/// Which viewpoint-selection rule the planner uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PlannerKind {
    /// LIVES, structured: object proposals, rooms and a global tour with precedence over them
    /// and the frontier viewpoints of both maps, the non-map term in the view utility
    /// ([`crate::planner::schedule`]).
    Lives,
    /// The paper's "multisensor frontier" baseline: the greedy LIVES utility with
    /// `w_nonmap = 0` ([`crate::planner::greedy`]).
    Multisensor,
    /// Yamauchi's nearest frontier: the reachable frontier with the shortest path, LiDAR frontiers
    /// first, camera frontiers once the LiDAR map has none.
    Nearest,
    /// A baseline after ROS `explore_lite`: the frontier of least
    /// `potential_scale · distance − gain_scale · size` (its defaults 3 and 1; distance Euclidean
    /// in metres, size in cells), LiDAR frontiers first, camera frontiers once the LiDAR map has
    /// none, facing the direction of travel. See [`crate::planner`].
    ExploreLite,
    /// A baseline in the spirit of RRT exploration: frontier points found by random trees, scored
    /// by the original assigner's revenue. See [`crate::rrt`].
    Rrt,
    /// The paper's LIVES (Algorithm 1): the greedy argmax of the four-term utility, non-map
    /// term included ([`crate::planner::greedy`]).
    LivesGreedy,
    /// The structured search without the non-map term (no proposals, `w_nonmap = 0`): the
    /// ablation that measures what non-map knowledge adds to it.
    LivesNoNonMap,
}

impl PlannerKind {
    /// Every kind, in wire order.
    pub const ALL: [PlannerKind; 7] = [
        PlannerKind::Lives,
        PlannerKind::Multisensor,
        PlannerKind::Nearest,
        PlannerKind::ExploreLite,
        PlannerKind::Rrt,
        PlannerKind::LivesGreedy,
        PlannerKind::LivesNoNonMap,
    ];

    /// The structured search (tasks, rooms, a tour): `lives` and its ablation.
    pub const fn is_structured(self) -> bool {
        matches!(self, PlannerKind::Lives | PlannerKind::LivesNoNonMap)
    }

    /// One of the baselines (`nearest`, `explore-lite`, `rrt`): scored by their own rules, facing
    /// the direction of travel, every reached goal retired.
    pub const fn is_baseline(self) -> bool {
        matches!(self, PlannerKind::Nearest | PlannerKind::ExploreLite | PlannerKind::Rrt)
    }
}

/// Work budgets per stage, in work units (cells or points touched). A stage that exceeds its
/// budget still completes (its work is bounded by the capacities anyway) and is counted in
/// [`crate::Status::overruns`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageBudgets {
    /// LiDAR-map update, cells touched.
    pub lidar_cells: u32,
    /// Visual-map update, cells touched.
    pub visual_cells: u32,
    /// Non-map store update and filters, points and cells examined.
    pub nonmap_ops: u32,
    /// One planning step (inflation, frontiers, path distance, utilities), cells and points.
    pub plan_ops: u32,
    /// One scan classification, multiply-accumulates.
    pub classify_macs: u32,
}

/// The controller's configuration. Distances in metres ([`Meters`], Q16.16), angles as
/// [`BinaryAngle`], times in microseconds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// Viewpoint-selection rule. Default [`PlannerKind::Lives`].
    pub planner: PlannerKind,
    /// World coordinates of the grids' lower-left corner (the search area, given at start).
    /// At most [`MAX_ORIGIN_M`] (32 716.8 m), so that the whole grid lies within the range of
    /// [`Meters`].
    pub origin_x_m: Meters,
    /// See [`Config::origin_x_m`].
    pub origin_y_m: Meters,
    /// Readings at or beyond this range are "no return": they clear cells up to it and mark
    /// nothing. Default 30 m (VLP-16 indoor). In (0, [`MAX_LIDAR_RANGE_M`]] (100 m, a VLP-16's
    /// reach; rays stop at the grid's edge anyway).
    pub lidar_max_range_m: Meters,
    /// Readings below this are invalid (the robot's own body). Default 0.10 m. In
    /// [0, `lidar_max_range_m`).
    pub lidar_min_range_m: Meters,
    /// Camera field of view (full angle). Default 90°. Any angle but zero: (0°, 360°).
    pub camera_fov: BinaryAngle,
    /// Camera range. Default 4.0 m. In (0, [`GRID_SIDE_M`]] (51.2 m, the grid's side).
    pub camera_range_m: Meters,
    /// Clearance the planner keeps from occupied cells (robot radius plus margin). Default 0.35 m.
    /// In [0, [`MAX_ROBOT_RADIUS_M`]] (1.5 m: the planner's inflation table,
    /// [`crate::capacity::MAX_INFLATION_OFFSETS`], holds a disc that wide).
    pub robot_radius_m: Meters,
    /// Frontier groups with fewer cells are dropped. Default 8 (0.8 m of frontier).
    pub min_frontier_cells: u16,
    /// Weight of the path length to a viewpoint, utility per metre (subtracted). Default 1.0.
    ///
    /// Every weight (this one, the other `w_*`, `gaze_min_gain` and `switch_margin`) is at least
    /// 0: [0, 32 768). Any such Q16.16 value times the largest count a term can reach (2²¹
    /// unseen cells, 2¹⁸ frontier cells, 1024 points, 1.3 · 10⁶ mm of path) stays below 2⁵², so
    /// the planner's 64-bit utility sums cannot overflow.
    pub w_dist_per_m: Weight,
    /// Weight of camera-unseen cells inside a viewpoint's cone, per cell. Default 0.02.
    pub w_unknown_per_cell: Weight,
    /// In the unseen-cells term, a cell the LiDAR has not seen either counts this many eighths of
    /// a cell (8 = every camera-unseen cell alike, the paper's count; lower values favour looking
    /// at what the LiDAR has found over looking into the unknown). Default 8. In [0, 8].
    pub unseen_unknown_eighths: u8,
    /// Weight of unseen surfaces in a viewpoint's cone: per ray (of 24 across the field of view)
    /// that ends on a LiDAR-occupied cell the camera has not seen. The target stands on the
    /// floor, so the LiDAR sees it as an occupied cell: surfaces are where it can be. An
    /// addition to the paper's unseen-cells term; 0 (off) by default, which is the paper's utility.
    pub w_surface_per_ray: Weight,
    /// Weight of frontier cells near the path to a viewpoint, per cell. Default 0.01.
    pub w_frontier_per_cell: Weight,
    /// Weight of non-map points inside a viewpoint's cone, per pooled point. Default 1.5.
    /// Ignored (zero) under [`PlannerKind::Multisensor`].
    pub w_nonmap_per_point: Weight,
    /// At most this many non-map points count per 0.8 m block in the non-map term (0 = no cap,
    /// the paper's plain count). Default 0.
    pub nonmap_block_cap: u8,
    /// At most this many non-map points count in one view (a viewpoint's or the gaze's cone;
    /// 0 = no cap, the paper's plain count). The target is one object: beyond a few points, more
    /// points in view mean more furniture, not a better chance of seeing the target, and an
    /// uncapped count sends the robot across the building to the largest furniture cluster.
    /// Default 0: on the tuning worlds a cap of 8 did not hold up on held-out worlds
    /// (docs/experiments/look-while-walking.md, "Capping the non-map count").
    pub nonmap_view_cap: u16,
    /// `lives` and `multisensor` also score the four headings at the robot's own cell (turning in
    /// place to look is an action). Default false (the paper's candidates).
    pub look_around_here: bool,
    /// Look while walking: on the way to a goal the camera faces the heading (of 16) with the
    /// most to see from where the robot is — camera-unseen cells and, for `lives`, non-map
    /// points — instead of the direction of travel; the base (holonomic, like Spot's) walks its
    /// path facing that way. The paper's robot faces where it walks. Default true: on the
    /// procedurally generated tuning worlds in both settings (`lives tune --worlds 192 --grid
    /// gaze=true`) it is faster than facing the way of travel by a paired 0.027 ± 0.024 of the
    /// time limit (docs/experiments/look-while-walking.md). It applies to every planner.
    pub gaze: bool,
    /// The least view utility (same units as the utility's terms) worth turning the camera for
    /// while walking; below it the camera faces the direction of travel. Default 4.0.
    pub gaze_min_gain: Weight,
    /// `lives` also scores one viewpoint per cluster of non-map points (an addition to the
    /// paper, whose candidates are frontier centroids only). Default true.
    pub nonmap_viewpoints: bool,
    /// How far from a non-map cluster its viewpoint stands (towards the robot). Default 1.5 m.
    /// In [0, [`GRID_SIDE_M`]].
    pub nonmap_standoff_m: Meters,
    /// "Near the path" for the frontier term: blocks of 8 × 8 cells around each path cell.
    /// Default 1 (the path's block and its 8 neighbours, 0.8–1.6 m). In [0,
    /// [`MAX_NEAR_PATH_BLOCKS`]] (4 blocks, 3.2–4.0 m: each step of each candidate's path
    /// visits (2·4 + 1)² blocks).
    pub frontier_near_path_blocks: u8,
    /// Non-map points closer than this to a kept point are merged into it. Default 0.20 m. In
    /// [[`MIN_NONMAP_POOL_RADIUS_M`], [`MAX_NONMAP_RADIUS_M`]] (0.01–2 m: the pooling cells,
    /// half the radius wide, are numbered in 16 bits across the grid, and points 2 m apart are not
    /// one object).
    pub nonmap_pool_radius_m: Meters,
    /// Non-map points closer than this to a map (wall) point are dropped (the paper's rule
    /// against localisation drift); zero turns the rule off. Default 0 (off): with the
    /// classifier's labels half of every piece of furniture is labelled map, and the rule then
    /// dropped nearly all the rest (docs/experiments/near-wall-rule.md). 0.25 m on a
    /// robot whose localisation drifts. In [0, [`MAX_NONMAP_RADIUS_M`]] (2 m: every non-map
    /// point of every scan searches a disc this wide for a wall point).
    pub nonmap_wall_clearance_m: Meters,
    /// Drop a non-map point once the LiDAR map holds its place as empty (its cell and 8
    /// neighbours free: later beams passed through where it was). Whatever stood there, such as a
    /// person walking by, has moved on; without the rule a walking person leaves a trail of
    /// points that draws `lives` to where the person was. An addition to the paper's filters.
    /// Default true (docs/experiments/vacated-nonmap-points.md).
    pub nonmap_drop_vacated: bool,
    /// Replan at least this often while exploring. Default 3.0 s.
    pub replan_interval_us: u64,
    /// A new best viewpoint replaces the current goal only if it beats the current goal's
    /// re-scored utility by this much (hysteresis against goal oscillation). Default 6.0.
    pub switch_margin: Weight,
    /// The goal counts as reached within this distance. Default 0.30 m. In (0, [`GRID_SIDE_M`]].
    pub goal_tolerance_m: Meters,
    /// ... and within this heading error. Default 20°. Any angle but zero, of either sign:
    /// (0°, 180°].
    pub goal_heading_tolerance: BinaryAngle,
    /// A goal towards which the robot has not gained `progress_m` for this long is blacklisted.
    /// Default 15 s.
    pub goal_timeout_us: u64,
    /// A goal the base reports blocked for this long is blacklisted (shorter blocks, such as a
    /// person passing, are waited out). Default 3 s.
    pub blocked_timeout_us: u64,
    /// Progress that resets the goal timeout. Default 0.25 m. In (0, [`GRID_SIDE_M`]] (with 0 a
    /// robot standing still would be making progress).
    pub progress_m: Meters,
    /// Candidate viewpoints within this distance of a blacklisted goal are dropped. Default 0.5 m.
    /// In [0, [`GRID_SIDE_M`]].
    pub blacklist_radius_m: Meters,
    /// A frontier's viewpoint is moved to the nearest reachable cell within this distance when
    /// its own cell is not reachable. Default 1.0 m. In [0, [`MAX_VIEWPOINT_SNAP_RADIUS_M`]]
    /// (5 m: every candidate searches the disc of this radius, (2·50 + 1)² cells at most).
    pub viewpoint_snap_radius_m: Meters,
    /// No pose or scan for this long stops the robot. Default 1.0 s.
    pub watchdog_us: u64,
    /// Per-stage work budgets.
    pub budgets: StageBudgets,
    /// Correct the odometry's drift by matching each scan against the LiDAR grid
    /// ([`crate::matcher`]): the pose the maps are drawn at is `map_from_odom ∘ pose`, and each
    /// accepted match updates `map_from_odom` ([`crate::Controller::map_from_odom`]). Default
    /// true: with the simulator's default odometry drift (2 %/m), a 300 s search in `office
    /// hard` keeps 38 % of the walls without it and 98 % with it (`lives mapcheck`, docs/mapcheck.md).
    pub scan_matching: bool,
}

const fn m(millimetres: i32) -> Meters {
    // Exact for whole millimetres up to rounding of 1/1000 in Q16.16 (≤ 7.6 µm).
    Meters::from_bits(((millimetres as i64 * 65_536 + 500) / 1000) as i32)
}

const fn w(thousandths: i32) -> Weight {
    Weight::from_bits(((thousandths as i64 * 65_536 + 500) / 1000) as i32)
}

// The ranges [`Config::validate`] admits (each explained on its field).

/// The grid's side, 51.2 m ([`GRID_CELLS`] cells of [`CELL_MM`] mm): the bound of the lengths
/// measured on the grid (camera range, standoff, tolerances, radii).
pub const GRID_SIDE_M: Meters = m(GRID_CELLS as i32 * CELL_MM as i32);
/// The largest grid origin: the grid's far edge is then the largest [`Meters`] value.
pub const MAX_ORIGIN_M: Meters = Meters::from_bits(Meters::MAX.to_bits() - GRID_SIDE_M.to_bits());
/// The longest LiDAR range, 100 m.
pub const MAX_LIDAR_RANGE_M: Meters = m(100_000);
/// The largest robot radius, 1.5 m ([`MAX_ROBOT_RADIUS_CELLS`] cells).
pub const MAX_ROBOT_RADIUS_M: Meters = m(MAX_ROBOT_RADIUS_CELLS as i32 * CELL_MM as i32);
/// The largest [`Config::frontier_near_path_blocks`].
pub const MAX_NEAR_PATH_BLOCKS: u8 = 4;
/// The smallest non-map pooling radius, 0.01 m.
pub const MIN_NONMAP_POOL_RADIUS_M: Meters = m(10);
/// The largest non-map pooling radius and wall clearance, 2 m.
pub const MAX_NONMAP_RADIUS_M: Meters = m(2_000);
/// The largest viewpoint snap radius, 5 m.
pub const MAX_VIEWPOINT_SNAP_RADIUS_M: Meters = m(5_000);

/// A configuration the core cannot work with ([`Config::validate`]): the first field outside its
/// range, and the range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ConfigError {
    /// The field, as named in [`Config`] (and by `lives --set` for those it sets).
    pub field: &'static str,
    /// The values it may take, in its units: `"(0, 51.2] m"`.
    pub allowed: &'static str,
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "`{}` must be in {}", self.field, self.allowed)
    }
}

/// `Ok` if `ok`, else the error for `field`.
fn check(ok: bool, field: &'static str, allowed: &'static str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError { field, allowed })
    }
}

impl Config {
    /// This configuration running `kind`, with the planner's own defaults where its original
    /// differs from ours: `explore-lite` (ROS `explore_lite`) takes frontiers from 0.5 m
    /// (5 cells), blacklists a goal without progress for 30 s (`goal_timeout_us`) and lets any
    /// better frontier replace the goal (no switch margin). Every place that runs a planner (the
    /// simulated search, the bridge to a robot, the dataset walker) gets its configuration here,
    /// so the core, not a host, decides what each planner does.
    pub fn with_planner(self, kind: PlannerKind) -> Config {
        let base = Config { planner: kind, ..self };
        match kind {
            PlannerKind::ExploreLite => Config { min_frontier_cells: 5, goal_timeout_us: 30_000_000, switch_margin: Weight::ZERO, ..base },
            _ => base,
        }
    }

    /// The defaults, as a `const` so a `static` can hold them.
    pub const DEFAULT: Config = Config {
        planner: PlannerKind::Lives,
        origin_x_m: Meters::ZERO,
        origin_y_m: Meters::ZERO,
        lidar_max_range_m: m(30_000),
        lidar_min_range_m: m(100),
        camera_fov: BinaryAngle::from_degrees(90),
        camera_range_m: m(4_000),
        robot_radius_m: m(350),
        min_frontier_cells: 8,
        w_dist_per_m: w(1_000),
        w_unknown_per_cell: w(20),
        unseen_unknown_eighths: 8,
        w_surface_per_ray: w(0),
        w_frontier_per_cell: w(10),
        w_nonmap_per_point: w(1_500),
        look_around_here: false,
        gaze: true,
        gaze_min_gain: w(4_000),
        nonmap_block_cap: 0,
        nonmap_view_cap: 0,
        nonmap_viewpoints: true,
        nonmap_standoff_m: m(1_500),
        frontier_near_path_blocks: 1,
        nonmap_pool_radius_m: m(200),
        nonmap_wall_clearance_m: Meters::ZERO,
        nonmap_drop_vacated: true,
        replan_interval_us: 3_000_000,
        switch_margin: w(6_000),
        goal_tolerance_m: m(300),
        goal_heading_tolerance: BinaryAngle::from_degrees(20),
        goal_timeout_us: 15_000_000,
        blocked_timeout_us: 3_000_000,
        progress_m: m(250),
        blacklist_radius_m: m(500),
        viewpoint_snap_radius_m: m(1_000),
        watchdog_us: 1_000_000,
        scan_matching: true,
        budgets: StageBudgets {
            lidar_cells: 400_000,
            visual_cells: 40_000,
            nonmap_ops: 100_000,
            plan_ops: 12_000_000,
            classify_macs: 2_000_000,
        },
    };

    /// Metres from whole millimetres (for building configs in `const` context and tests).
    pub const fn mm(millimetres: i32) -> Meters {
        m(millimetres)
    }

    /// A weight from thousandths.
    pub const fn weight_milli(thousandths: i32) -> Weight {
        w(thousandths)
    }

    /// Checks every field against its range (written on each field) and returns the first one
    /// outside it. Fields without a range take any value of their type: the planner, the flags,
    /// the counts and caps (`min_frontier_cells`, `nonmap_block_cap`, `nonmap_view_cap`), the
    /// times and the budgets. `Config::DEFAULT` passes.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let positive = |v: Meters, max: Meters| Meters::ZERO < v && v <= max;
        let within = |v: Meters, min: Meters, max: Meters| min <= v && v <= max;
        let on_grid = "[0, 51.2] m";
        let weight = "[0, 32768)";
        check(self.origin_x_m <= MAX_ORIGIN_M, "origin_x_m", "[-32768, 32716.8] m")?;
        check(self.origin_y_m <= MAX_ORIGIN_M, "origin_y_m", "[-32768, 32716.8] m")?;
        check(positive(self.lidar_max_range_m, MAX_LIDAR_RANGE_M), "lidar_max_range_m", "(0, 100] m")?;
        check(
            Meters::ZERO <= self.lidar_min_range_m && self.lidar_min_range_m < self.lidar_max_range_m,
            "lidar_min_range_m",
            "[0, lidar_max_range_m)",
        )?;
        check(self.camera_fov != BinaryAngle::ZERO, "camera_fov", "(0°, 360°)")?;
        check(positive(self.camera_range_m, GRID_SIDE_M), "camera_range_m", "(0, 51.2] m")?;
        check(within(self.robot_radius_m, Meters::ZERO, MAX_ROBOT_RADIUS_M), "robot_radius_m", "[0, 1.5] m")?;
        check(self.w_dist_per_m >= Weight::ZERO, "w_dist_per_m", weight)?;
        check(self.w_unknown_per_cell >= Weight::ZERO, "w_unknown_per_cell", weight)?;
        check(self.unseen_unknown_eighths <= 8, "unseen_unknown_eighths", "[0, 8]")?;
        check(self.w_surface_per_ray >= Weight::ZERO, "w_surface_per_ray", weight)?;
        check(self.w_frontier_per_cell >= Weight::ZERO, "w_frontier_per_cell", weight)?;
        check(self.w_nonmap_per_point >= Weight::ZERO, "w_nonmap_per_point", weight)?;
        check(self.gaze_min_gain >= Weight::ZERO, "gaze_min_gain", weight)?;
        check(within(self.nonmap_standoff_m, Meters::ZERO, GRID_SIDE_M), "nonmap_standoff_m", on_grid)?;
        check(self.frontier_near_path_blocks <= MAX_NEAR_PATH_BLOCKS, "frontier_near_path_blocks", "[0, 4]")?;
        check(within(self.nonmap_pool_radius_m, MIN_NONMAP_POOL_RADIUS_M, MAX_NONMAP_RADIUS_M), "nonmap_pool_radius_m", "[0.01, 2] m")?;
        check(within(self.nonmap_wall_clearance_m, Meters::ZERO, MAX_NONMAP_RADIUS_M), "nonmap_wall_clearance_m", "[0, 2] m")?;
        check(self.switch_margin >= Weight::ZERO, "switch_margin", weight)?;
        check(positive(self.goal_tolerance_m, GRID_SIDE_M), "goal_tolerance_m", "(0, 51.2] m")?;
        check(self.goal_heading_tolerance != BinaryAngle::ZERO, "goal_heading_tolerance", "(0°, 180°]")?;
        check(positive(self.progress_m, GRID_SIDE_M), "progress_m", "(0, 51.2] m")?;
        check(within(self.blacklist_radius_m, Meters::ZERO, GRID_SIDE_M), "blacklist_radius_m", on_grid)?;
        check(within(self.viewpoint_snap_radius_m, Meters::ZERO, MAX_VIEWPOINT_SNAP_RADIUS_M), "viewpoint_snap_radius_m", "[0, 5] m")
    }

    /// The non-map weight actually used by the selected planner.
    pub fn effective_w_nonmap(&self) -> Weight {
        match self.planner {
            PlannerKind::Lives | PlannerKind::LivesGreedy => self.w_nonmap_per_point,
            PlannerKind::Multisensor | PlannerKind::Nearest | PlannerKind::ExploreLite | PlannerKind::Rrt | PlannerKind::LivesNoNonMap => {
                Weight::ZERO
            }
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::protocol::ConfigMsg;

    /// One bit of a Q16.16 value.
    fn bit(v: Meters, d: i32) -> Meters {
        Meters::from_bits(v.to_bits() + d)
    }

    /// `set` at `inside` passes and at `outside` fails, naming `field` (a field the wire can name).
    fn boundary<T: Copy + core::fmt::Debug>(field: &str, set: fn(&mut Config, T), inside: T, outside: T) {
        let mut c = Config::DEFAULT;
        set(&mut c, inside);
        assert_eq!(c.validate(), Ok(()), "{field} = {inside:?} is in range");
        set(&mut c, outside);
        let e = c.validate().expect_err(field);
        assert_eq!(e.field, field, "{field} = {outside:?}: {e}");
        assert!(ConfigMsg::field_index(e.field).is_some(), "{field} is a field on the wire");
    }

    /// A length in `[min, max]` (or `(0, max]` when `min` is zero and `open`): both ends.
    fn length(field: &str, set: fn(&mut Config, Meters), min: Meters, open: bool, max: Meters) {
        if open {
            boundary(field, set, bit(Meters::ZERO, 1), Meters::ZERO);
        } else {
            boundary(field, set, min, bit(min, -1));
        }
        boundary(field, set, max, bit(max, 1));
    }

    #[test]
    fn the_defaults_are_in_range() {
        assert_eq!(Config::DEFAULT.validate(), Ok(()));
        for planner in PlannerKind::ALL {
            assert_eq!(Config { planner, ..Config::DEFAULT }.validate(), Ok(()));
        }
    }

    #[test]
    fn each_planner_gets_its_own_defaults_from_the_core_and_they_are_in_range() {
        for planner in PlannerKind::ALL {
            let c = Config::DEFAULT.with_planner(planner);
            assert_eq!(c.planner, planner);
            assert_eq!(c.validate(), Ok(()), "{planner:?}");
            if planner == PlannerKind::ExploreLite {
                assert_eq!((c.min_frontier_cells, c.goal_timeout_us, c.switch_margin), (5, 30_000_000, Weight::ZERO));
            } else {
                assert_eq!(c, Config { planner, ..Config::DEFAULT }, "{planner:?}: only explore-lite differs");
            }
        }
    }

    #[test]
    fn every_range_is_enforced_at_its_ends() {
        let grid = GRID_SIDE_M;
        let zero = Meters::ZERO;
        boundary("origin_x_m", |c, v| c.origin_x_m = v, MAX_ORIGIN_M, bit(MAX_ORIGIN_M, 1));
        boundary("origin_y_m", |c, v| c.origin_y_m = v, MAX_ORIGIN_M, bit(MAX_ORIGIN_M, 1));
        assert_eq!(Config { origin_x_m: Meters::MIN, origin_y_m: Meters::MIN, ..Config::DEFAULT }.validate(), Ok(()));
        length("lidar_max_range_m", |c, v| (c.lidar_min_range_m, c.lidar_max_range_m) = (Meters::ZERO, v), zero, true, MAX_LIDAR_RANGE_M);
        let lidar_max = Config::DEFAULT.lidar_max_range_m;
        boundary("lidar_min_range_m", |c, v| c.lidar_min_range_m = v, bit(lidar_max, -1), lidar_max);
        boundary("lidar_min_range_m", |c, v| c.lidar_min_range_m = v, zero, bit(zero, -1));
        boundary("camera_fov", |c, v| c.camera_fov = v, BinaryAngle(1), BinaryAngle::ZERO);
        boundary("camera_fov", |c, v| c.camera_fov = v, BinaryAngle(-1), BinaryAngle::ZERO);
        length("camera_range_m", |c, v| c.camera_range_m = v, zero, true, grid);
        length("robot_radius_m", |c, v| c.robot_radius_m = v, zero, false, MAX_ROBOT_RADIUS_M);
        type SetWeight = fn(&mut Config, Weight);
        let weights: [(&str, SetWeight); 7] = [
            ("w_dist_per_m", |c, v| c.w_dist_per_m = v),
            ("w_unknown_per_cell", |c, v| c.w_unknown_per_cell = v),
            ("w_surface_per_ray", |c, v| c.w_surface_per_ray = v),
            ("w_frontier_per_cell", |c, v| c.w_frontier_per_cell = v),
            ("w_nonmap_per_point", |c, v| c.w_nonmap_per_point = v),
            ("gaze_min_gain", |c, v| c.gaze_min_gain = v),
            ("switch_margin", |c, v| c.switch_margin = v),
        ];
        for (field, set) in weights {
            boundary(field, set, Weight::ZERO, Weight::from_bits(-1));
            boundary(field, set, Weight::MAX, Weight::MIN);
        }
        boundary("unseen_unknown_eighths", |c, v| c.unseen_unknown_eighths = v, 8, 9);
        length("nonmap_standoff_m", |c, v| c.nonmap_standoff_m = v, zero, false, grid);
        boundary("frontier_near_path_blocks", |c, v| c.frontier_near_path_blocks = v, MAX_NEAR_PATH_BLOCKS, MAX_NEAR_PATH_BLOCKS + 1);
        length("nonmap_pool_radius_m", |c, v| c.nonmap_pool_radius_m = v, MIN_NONMAP_POOL_RADIUS_M, false, MAX_NONMAP_RADIUS_M);
        length("nonmap_wall_clearance_m", |c, v| c.nonmap_wall_clearance_m = v, zero, false, MAX_NONMAP_RADIUS_M);
        length("goal_tolerance_m", |c, v| c.goal_tolerance_m = v, zero, true, grid);
        boundary("goal_heading_tolerance", |c, v| c.goal_heading_tolerance = v, BinaryAngle::HALF, BinaryAngle::ZERO);
        boundary("goal_heading_tolerance", |c, v| c.goal_heading_tolerance = v, BinaryAngle(-1), BinaryAngle::ZERO);
        length("progress_m", |c, v| c.progress_m = v, zero, true, grid);
        length("blacklist_radius_m", |c, v| c.blacklist_radius_m = v, zero, false, grid);
        length("viewpoint_snap_radius_m", |c, v| c.viewpoint_snap_radius_m = v, zero, false, MAX_VIEWPOINT_SNAP_RADIUS_M);
    }

    #[test]
    fn the_ranges_are_what_the_errors_say() {
        // The texts of the errors against the limits they describe.
        let mm = Config::mm;
        assert_eq!((GRID_SIDE_M, MAX_LIDAR_RANGE_M, MAX_ROBOT_RADIUS_M), (mm(51_200), mm(100_000), mm(1_500)));
        assert_eq!((MIN_NONMAP_POOL_RADIUS_M, MAX_NONMAP_RADIUS_M, MAX_VIEWPOINT_SNAP_RADIUS_M), (mm(10), mm(2_000), mm(5_000)));
        assert!((MAX_ORIGIN_M.to_bits() - mm(32_716_800).to_bits()).abs() <= 1, "32 716.8 m");
        let e = Config { viewpoint_snap_radius_m: Config::mm(3_000_000), ..Config::DEFAULT }.validate().unwrap_err();
        assert_eq!(std::format!("{e}"), "`viewpoint_snap_radius_m` must be in [0, 5] m");
        let e = Config { camera_range_m: Meters::ZERO, ..Config::DEFAULT }.validate().unwrap_err();
        assert_eq!(std::format!("{e}"), "`camera_range_m` must be in (0, 51.2] m");
    }
}
