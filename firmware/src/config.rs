//! Every parameter a user may tune, with units in the names and documented defaults.
//!
//! All values are fixed-point or integer so that the controller's decisions do not depend on a
//! platform's float behaviour. `Config::default()` is the tuned default (see `docs/architecture.md`
//! for the rationale of each number).

use fixed_point::{BinaryAngle, Meters};

/// A utility weight: Q16.16, "utility points per unit of the term".
pub type Weight = fixed_point::fixed::types::I16F16;

/// Which viewpoint-selection rule the planner uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PlannerKind {
    /// LIVES: all four utility terms (path distance, unseen cells, frontier cells near the path,
    /// non-map points in the camera cone).
    Lives,
    /// The paper's "multisensor frontier" baseline: LIVES with `w_nonmap = 0`.
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
}

impl PlannerKind {
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
    pub origin_x_m: Meters,
    /// See [`Config::origin_x_m`].
    pub origin_y_m: Meters,
    /// Readings at or beyond this range are "no return": they clear cells up to it and mark
    /// nothing. Default 30 m (VLP-16 indoor).
    pub lidar_max_range_m: Meters,
    /// Readings below this are invalid (the robot's own body). Default 0.10 m.
    pub lidar_min_range_m: Meters,
    /// Camera field of view (full angle). Default 90°.
    pub camera_fov: BinaryAngle,
    /// Camera range. Default 4.0 m.
    pub camera_range_m: Meters,
    /// Clearance the planner keeps from occupied cells (robot radius plus margin). Default 0.35 m.
    pub robot_radius_m: Meters,
    /// Frontier groups with fewer cells are dropped. Default 8 (0.8 m of frontier).
    pub min_frontier_cells: u16,
    /// Weight of the path length to a viewpoint, utility per metre (subtracted). Default 1.0.
    pub w_dist_per_m: Weight,
    /// Weight of camera-unseen cells inside a viewpoint's cone, per cell. Default 0.02.
    pub w_unknown_per_cell: Weight,
    /// In the unseen-cells term, a cell the LiDAR has not seen either counts this many eighths of
    /// a cell (8 = every camera-unseen cell alike, the paper's count; lower values favour looking
    /// at what the LiDAR has found over looking into the unknown). Default 8.
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
    /// (docs/architecture.md, "Capping the non-map count").
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
    /// time limit (docs/architecture.md, "Look while walking"). It applies to every planner.
    pub gaze: bool,
    /// The least view utility (same units as the utility's terms) worth turning the camera for
    /// while walking; below it the camera faces the direction of travel. Default 4.0.
    pub gaze_min_gain: Weight,
    /// `lives` also scores one viewpoint per cluster of non-map points (an addition to the
    /// paper, whose candidates are frontier centroids only). Default true.
    pub nonmap_viewpoints: bool,
    /// How far from a non-map cluster its viewpoint stands (towards the robot). Default 1.5 m.
    pub nonmap_standoff_m: Meters,
    /// "Near the path" for the frontier term: blocks of 8 × 8 cells around each path cell.
    /// Default 1 (the path's block and its 8 neighbours, 0.8–1.6 m).
    pub frontier_near_path_blocks: u8,
    /// Non-map points closer than this to a kept point are merged into it. Default 0.20 m.
    pub nonmap_pool_radius_m: Meters,
    /// Non-map points closer than this to a map (wall) point are dropped (the paper's rule
    /// against localisation drift); zero turns the rule off. Default 0 (off): with the
    /// classifier's labels half of every piece of furniture is labelled map, and the rule then
    /// dropped nearly all the rest (docs/architecture.md, "The near-wall rule"). 0.25 m on a
    /// robot whose localisation drifts.
    pub nonmap_wall_clearance_m: Meters,
    /// Drop a non-map point once the LiDAR map holds its place as empty (its cell and 8
    /// neighbours free: later beams passed through where it was). Whatever stood there, such as a
    /// person walking by, has moved on; without the rule a walking person leaves a trail of
    /// points that draws `lives` to where the person was. An addition to the paper's filters.
    /// Default true (docs/architecture.md, "Vacated non-map points").
    pub nonmap_drop_vacated: bool,
    /// Replan at least this often while exploring. Default 3.0 s.
    pub replan_interval_us: u64,
    /// A new best viewpoint replaces the current goal only if it beats the current goal's
    /// re-scored utility by this much (hysteresis against goal oscillation). Default 6.0.
    pub switch_margin: Weight,
    /// The goal counts as reached within this distance. Default 0.30 m.
    pub goal_tolerance_m: Meters,
    /// ... and within this heading error. Default 20°.
    pub goal_heading_tolerance: BinaryAngle,
    /// A goal towards which the robot has not gained `progress_m` for this long is blacklisted.
    /// Default 15 s.
    pub goal_timeout_us: u64,
    /// A goal the base reports blocked for this long is blacklisted (shorter blocks, such as a
    /// person passing, are waited out). Default 3 s.
    pub blocked_timeout_us: u64,
    /// Progress that resets the goal timeout. Default 0.25 m.
    pub progress_m: Meters,
    /// Candidate viewpoints within this distance of a blacklisted goal are dropped. Default 0.5 m.
    pub blacklist_radius_m: Meters,
    /// A frontier's viewpoint is moved to the nearest reachable cell within this distance when
    /// its own cell is not reachable. Default 1.0 m.
    pub viewpoint_snap_radius_m: Meters,
    /// No pose or scan for this long stops the robot. Default 1.0 s.
    pub watchdog_us: u64,
    /// Per-stage work budgets.
    pub budgets: StageBudgets,
}

const fn m(millimetres: i32) -> Meters {
    // Exact for whole millimetres up to rounding of 1/1000 in Q16.16 (≤ 7.6 µm).
    Meters::from_bits(((millimetres as i64 * 65_536 + 500) / 1000) as i32)
}

const fn w(thousandths: i32) -> Weight {
    Weight::from_bits(((thousandths as i64 * 65_536 + 500) / 1000) as i32)
}

impl Config {
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

    /// The non-map weight actually used by the selected planner.
    pub fn effective_w_nonmap(&self) -> Weight {
        match self.planner {
            PlannerKind::Lives => self.w_nonmap_per_point,
            PlannerKind::Multisensor | PlannerKind::Nearest | PlannerKind::ExploreLite | PlannerKind::Rrt => Weight::ZERO,
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}
