//! The parameter table: every field of [`Config`], written once.
//!
//! Each row is one parameter, in wire order (the order of [`crate::protocol::ConfigMsg`] and its
//! `FIELDS`; append new rows at the end, as a new wire field, and bump the protocol version):
//!
//! ```text
//! /// The field's documentation (rustdoc on `Config`).
//! name: Type = default, Unit, "one-line description"
//!     [, check |value, config| in_range => "allowed range as the error gives it"]
//!     [, set "the --set name"];
//! ```
//!
//! From it come [`Config`], [`Config::DEFAULT`], [`Config::validate`] (the checks in row order, so
//! the first failing field is the first row whose check fails), [`PARAMS`] (what the host lists
//! and `--set` sets), and, in `protocol::config_msg`, `ConfigMsg` with its conversions. The wire
//! type follows from the field's type ([`ParamValue`]); [`Unit`] says how people write a value.

use super::table::{define_config, positive, within, ParamInfo, ParamValue, Unit};
use super::*;

/// Calls `$gen!` with the table's rows, as [`super::table::config_rows`] reads them: each generator
/// turns the rows into its items.
macro_rules! config_params {
    ($gen:ident) => {
        $crate::config::config_rows! { $gen;
            /// Viewpoint-selection rule. Default [`PlannerKind::Lives`].
            planner: PlannerKind = PlannerKind::Lives, Planner, "viewpoint-selection rule";
            /// World coordinates of the grids' lower-left corner (the search area, given at start).
            /// At most [`MAX_ORIGIN_M`] (32 716.8 m), so that the whole grid lies within the range of
            /// [`Meters`].
            origin_x_m: Meters = Meters::ZERO, Metres, "x of the grids' lower-left corner in the world",
                check |v, _| v <= MAX_ORIGIN_M => "[-32768, 32716.8] m";
            /// See [`Config::origin_x_m`].
            origin_y_m: Meters = Meters::ZERO, Metres, "y of the grids' lower-left corner in the world",
                check |v, _| v <= MAX_ORIGIN_M => "[-32768, 32716.8] m";
            /// Readings at or beyond this range are "no return": they clear cells up to it and mark
            /// nothing. Default 30 m (VLP-16 indoor). In (0, [`MAX_LIDAR_RANGE_M`]] (100 m, a VLP-16's
            /// reach; rays stop at the grid's edge anyway).
            lidar_max_range_m: Meters = m(30_000), Metres, "LiDAR readings at or beyond this are no return",
                check |v, _| positive(v, MAX_LIDAR_RANGE_M) => "(0, 100] m";
            /// Readings below this are invalid (the robot's own body). Default 0.10 m. In
            /// [0, `lidar_max_range_m`).
            lidar_min_range_m: Meters = m(100), Metres, "LiDAR readings below this are invalid (the robot's body)",
                check |v, c| Meters::ZERO <= v && v < c.lidar_max_range_m => "[0, lidar_max_range_m)";
            /// Camera field of view (full angle). Default 90°. Any angle but zero: (0°, 360°).
            camera_fov: BinaryAngle = BinaryAngle::from_degrees(90), Degrees, "camera field of view",
                check |v, _| v != BinaryAngle::ZERO => "(0°, 360°)", set "camera_fov_deg";
            /// Camera range. Default 4.0 m. In (0, [`GRID_SIDE_M`]] (51.2 m, the grid's side).
            camera_range_m: Meters = m(4_000), Metres, "camera range",
                check |v, _| positive(v, GRID_SIDE_M) => "(0, 51.2] m", set "camera_range_m";
            /// Clearance the planner keeps from occupied cells (robot radius plus margin). Default 0.35 m.
            /// In [0, [`MAX_ROBOT_RADIUS_M`]] (1.5 m: the planner's inflation table,
            /// [`crate::capacity::MAX_INFLATION_OFFSETS`], holds a disc that wide).
            robot_radius_m: Meters = m(350), Metres, "clearance kept from occupied cells",
                check |v, _| within(v, Meters::ZERO, MAX_ROBOT_RADIUS_M) => "[0, 1.5] m", set "robot_radius_m";
            /// Frontier groups with fewer cells are dropped. Default 8 (0.8 m of frontier).
            min_frontier_cells: u16 = 8, Count, "smallest frontier kept, cells", set "min_frontier_cells";
            /// Weight of the path length to a viewpoint, utility per metre (subtracted). Default 1.0.
            ///
            /// Every weight (this one, the other `w_*`, `gaze_min_gain` and `switch_margin`) is at least
            /// 0: [0, 32 768). Any such Q16.16 value times the largest count a term can reach (2²¹
            /// unseen cells, 2¹⁸ frontier cells, 1024 points, 1.3 · 10⁶ mm of path) stays below 2⁵², so
            /// the planner's 64-bit utility sums cannot overflow.
            w_dist_per_m: Weight = w(1_000), Weight, "utility per metre of path",
                check |v, _| v >= Weight::ZERO => "[0, 32768)", set "w_dist_per_m";
            /// Weight of camera-unseen cells inside a viewpoint's cone, per cell. Default 0.02.
            w_unknown_per_cell: Weight = w(20), Weight, "utility per camera-unseen cell in the cone",
                check |v, _| v >= Weight::ZERO => "[0, 32768)", set "w_unknown_per_cell";
            /// In the unseen-cells term, a cell the LiDAR has not seen either counts this many eighths of
            /// a cell (8 = every camera-unseen cell alike, the paper's count; lower values favour looking
            /// at what the LiDAR has found over looking into the unknown). Default 8. In [0, 8].
            unseen_unknown_eighths: u8 = 8, Count, "weight of LiDAR-unknown cells in the unseen term, eighths (8 = paper)",
                check |v, _| v <= 8 => "[0, 8]", set "unseen_unknown_eighths";
            /// Weight of unseen surfaces in a viewpoint's cone: per ray (of 24 across the field of view)
            /// that ends on a LiDAR-occupied cell the camera has not seen. The target stands on the
            /// floor, so the LiDAR sees it as an occupied cell: surfaces are where it can be. An
            /// addition to the paper's unseen-cells term; 0 (off) by default, which is the paper's utility.
            w_surface_per_ray: Weight = w(0), Weight, "utility per cone ray ending on an unseen surface",
                check |v, _| v >= Weight::ZERO => "[0, 32768)", set "w_surface_per_ray";
            /// Weight of frontier cells near the path to a viewpoint, per cell. Default 0.01.
            w_frontier_per_cell: Weight = w(10), Weight, "utility per frontier cell near the path",
                check |v, _| v >= Weight::ZERO => "[0, 32768)", set "w_frontier_per_cell";
            /// Weight of non-map points inside a viewpoint's cone, per pooled point. Default 1.5.
            /// Ignored (zero) under [`PlannerKind::Multisensor`].
            w_nonmap_per_point: Weight = w(1_500), Weight, "utility per non-map point in the cone",
                check |v, _| v >= Weight::ZERO => "[0, 32768)", set "w_nonmap_per_point";
            /// At most this many non-map points count per 0.8 m block in the non-map term (0 = no cap,
            /// the paper's plain count). Default 0.
            nonmap_block_cap: u8 = 0, Count, "non-map points counted per 0.8 m block (0 = all)", set "nonmap_block_cap";
            /// At most this many non-map points count in one view (a viewpoint's or the gaze's cone;
            /// 0 = no cap, the paper's plain count). The target is one object: beyond a few points, more
            /// points in view mean more furniture, not a better chance of seeing the target, and an
            /// uncapped count sends the robot across the building to the largest furniture cluster.
            /// Default 0: on the tuning worlds a cap of 8 did not hold up on held-out worlds
            /// (docs/experiments/look-while-walking.md, "Capping the non-map count").
            nonmap_view_cap: u16 = 0, Count, "non-map points counted in one view (0 = all)", set "nonmap_view_cap";
            /// `lives` and `multisensor` also score the four headings at the robot's own cell (turning in
            /// place to look is an action). Default false (the paper's candidates).
            look_around_here: bool = false, Flag, "score turning in place at the robot's cell", set "look_around_here";
            /// Look while walking: on the way to a goal the camera faces the heading (of 16) with the
            /// most to see from where the robot is — camera-unseen cells and, for `lives`, non-map
            /// points — instead of the direction of travel; the base (holonomic, like Spot's) walks its
            /// path facing that way. The paper's robot faces where it walks. Default true: on the
            /// procedurally generated tuning worlds in both settings (`lives tune --worlds 192 --grid
            /// gaze=true`) it is faster than facing the way of travel by a paired 0.027 ± 0.024 of the
            /// time limit (docs/experiments/look-while-walking.md). It applies to every planner.
            gaze: bool = true, Flag, "look while walking (camera faces the best heading, not the travel direction)", set "gaze";
            /// The least view utility (same units as the utility's terms) worth turning the camera for
            /// while walking; below it the camera faces the direction of travel. Default 4.0.
            gaze_min_gain: Weight = w(4_000), Weight, "least view utility worth turning the camera for while walking",
                check |v, _| v >= Weight::ZERO => "[0, 32768)", set "gaze_min_gain";
            /// `lives` also scores one viewpoint per cluster of non-map points (an addition to the
            /// paper, whose candidates are frontier centroids only). Default true.
            nonmap_viewpoints: bool = true, Flag, "viewpoints aimed at non-map clusters (lives)", set "nonmap_viewpoints";
            /// How far from a non-map cluster its viewpoint stands (towards the robot). Default 1.5 m.
            /// In [0, [`GRID_SIDE_M`]].
            nonmap_standoff_m: Meters = m(1_500), Metres, "distance of a non-map viewpoint from its cluster",
                check |v, _| within(v, Meters::ZERO, GRID_SIDE_M) => "[0, 51.2] m", set "nonmap_standoff_m";
            /// "Near the path" for the frontier term: blocks of 8 × 8 cells around each path cell.
            /// Default 1 (the path's block and its 8 neighbours, 0.8–1.6 m). In [0,
            /// [`MAX_NEAR_PATH_BLOCKS`]] (4 blocks, 3.2–4.0 m: each step of each candidate's path
            /// visits (2·4 + 1)² blocks).
            frontier_near_path_blocks: u8 = 1, Count, "\"near the path\" for the frontier term, blocks of 8 × 8 cells",
                check |v, _| v <= MAX_NEAR_PATH_BLOCKS => "[0, 4]";
            /// Non-map points closer than this to a kept point are merged into it. Default 0.20 m. In
            /// [[`MIN_NONMAP_POOL_RADIUS_M`], [`MAX_NONMAP_RADIUS_M`]] (0.01–2 m: the pooling cells,
            /// half the radius wide, are numbered in 16 bits across the grid, and points 2 m apart are not
            /// one object).
            nonmap_pool_radius_m: Meters = m(200), Metres, "pooling radius of non-map points",
                check |v, _| within(v, MIN_NONMAP_POOL_RADIUS_M, MAX_NONMAP_RADIUS_M) => "[0.01, 2] m", set "nonmap_pool_radius_m";
            /// Non-map points closer than this to a map (wall) point are dropped (the paper's rule
            /// against localisation drift); zero turns the rule off. Default 0 (off): with the
            /// classifier's labels half of every piece of furniture is labelled map, and the rule then
            /// dropped nearly all the rest (docs/experiments/near-wall-rule.md). 0.25 m on a
            /// robot whose localisation drifts. In [0, [`MAX_NONMAP_RADIUS_M`]] (2 m: every non-map
            /// point of every scan searches a disc this wide for a wall point).
            nonmap_wall_clearance_m: Meters = Meters::ZERO, Metres, "non-map points nearer a wall point are dropped (0: the rule is off)",
                check |v, _| within(v, Meters::ZERO, MAX_NONMAP_RADIUS_M) => "[0, 2] m", set "nonmap_wall_clearance_m";
            /// Drop a non-map point once the LiDAR map holds its place as empty (its cell and 8
            /// neighbours free: later beams passed through where it was). Whatever stood there, such as a
            /// person walking by, has moved on; without the rule a walking person leaves a trail of
            /// points that draws `lives` to where the person was. An addition to the paper's filters.
            /// Default true (docs/experiments/vacated-nonmap-points.md).
            nonmap_drop_vacated: bool = true, Flag, "drop non-map points whose place the LiDAR has since seen empty", set "nonmap_drop_vacated";
            /// Replan at least this often while exploring. Default 3.0 s.
            replan_interval_us: u64 = 3_000_000, Seconds, "time between replans", set "replan_interval_s";
            /// A new best viewpoint replaces the current goal only if it beats the current goal's
            /// re-scored utility by this much (hysteresis against goal oscillation). Default 6.0.
            switch_margin: Weight = w(6_000), Weight, "utility a new goal must gain over the current one",
                check |v, _| v >= Weight::ZERO => "[0, 32768)", set "switch_margin";
            /// The goal counts as reached within this distance. Default 0.30 m. In (0, [`GRID_SIDE_M`]].
            goal_tolerance_m: Meters = m(300), Metres, "the goal counts as reached within this distance",
                check |v, _| positive(v, GRID_SIDE_M) => "(0, 51.2] m";
            /// ... and within this heading error. Default 20°. Any angle but zero, of either sign:
            /// (0°, 180°].
            goal_heading_tolerance: BinaryAngle = BinaryAngle::from_degrees(20), Degrees, "... and within this heading error",
                check |v, _| v != BinaryAngle::ZERO => "(0°, 180°]";
            /// A goal towards which the robot has not gained `progress_m` for this long is blacklisted.
            /// Default 15 s.
            goal_timeout_us: u64 = 15_000_000, Seconds, "time without progress before a goal is blacklisted", set "goal_timeout_s";
            /// A goal the base reports blocked for this long is blacklisted (shorter blocks, such as a
            /// person passing, are waited out). Default 3 s.
            blocked_timeout_us: u64 = 3_000_000, Seconds, "time a goal may be blocked before it is blacklisted";
            /// Progress that resets the goal timeout. Default 0.25 m. In (0, [`GRID_SIDE_M`]] (with 0 a
            /// robot standing still would be making progress).
            progress_m: Meters = m(250), Metres, "progress that resets the goal timeout",
                check |v, _| positive(v, GRID_SIDE_M) => "(0, 51.2] m";
            /// Candidate viewpoints within this distance of a blacklisted goal are dropped. Default 0.5 m.
            /// In [0, [`GRID_SIDE_M`]].
            blacklist_radius_m: Meters = m(500), Metres, "viewpoints this near a blacklisted goal are dropped",
                check |v, _| within(v, Meters::ZERO, GRID_SIDE_M) => "[0, 51.2] m";
            /// A frontier's viewpoint is moved to the nearest reachable cell within this distance when
            /// its own cell is not reachable. Default 1.0 m. In [0, [`MAX_VIEWPOINT_SNAP_RADIUS_M`]]
            /// (5 m: every candidate searches the disc of this radius, (2·50 + 1)² cells at most).
            viewpoint_snap_radius_m: Meters = m(1_000), Metres, "how far from a frontier's anchor its viewpoint may stand",
                check |v, _| within(v, Meters::ZERO, MAX_VIEWPOINT_SNAP_RADIUS_M) => "[0, 5] m", set "viewpoint_snap_radius_m";
            /// No pose or scan for this long stops the robot. Default 1.0 s.
            watchdog_us: u64 = 1_000_000, Seconds, "no pose or scan for this long stops the robot";
            /// Per-stage work budgets.
            budgets: StageBudgets = StageBudgets::DEFAULT, Budgets, "per-stage work budgets: LiDAR, visual, non-map, plan, classify";
            /// Correct the odometry's drift by matching each scan against the LiDAR grid
            /// ([`crate::matcher`]): the pose the maps are drawn at is `map_from_odom ∘ pose`, and each
            /// accepted match updates `map_from_odom` ([`crate::Controller::map_from_odom`]). Default
            /// true: with the simulator's default odometry drift (2 %/m), a 300 s search in `office
            /// hard` keeps 38 % of the walls without it and 98 % with it (`lives mapcheck`, docs/mapcheck.md).
            scan_matching: bool = true, Flag, "correct odometry drift by matching each scan against the LiDAR grid", set "scan_matching";
            /// LIVE's waypoint manager (`live`): a priority waypoint to look at the nearest inspection
            /// region is inserted at most once per this interval (the paper's "maximum rate of
            /// occurrence of priority waypoints", a tunable it does not give). Default 10 s, fixed
            /// before `live` was measured (docs/live.md).
            live_priority_interval_us: u64 = 10_000_000, Seconds, "LIVE: least time between two priority waypoints", set "live_priority_interval_s";
            /// With [`Config::scan_matching`]: refine each match on a smooth field (the LiDAR grid's
            /// evidence convolved with a cubic B-spline) by Gauss–Newton, with a weak translation
            /// prior and none on rotation (`crate::matcher::FIELD_PRIOR_T`), instead of
            /// hill-climbing on interpolated evidence under the odometry's motion prior. Default
            /// false (the simulator's matcher, calibrated on its odometry); `lives replay`,
            /// `lives mapcheck` of a log and a real robot turn it on: on the raw MIT CSAIL log it
            /// brings the relation error from raw odometry's 1.68 m / 5.07° to 0.17 m / 1.13°
            /// (docs/experiments/real-lidar-maps.md).
            scan_match_field: bool = false, Flag, "with scan_matching: refine matches on a smooth field by Gauss-Newton (real logs)", set "scan_match_field";
            /// The least clearance the planner accepts (Nav2's inscribed radius): a cell within it
            /// of an occupied cell is never traversable; a cell farther than it but within
            /// [`Config::robot_radius_m`] is traversable at a cost (each step onto it costs
            /// [`crate::planner::NARROW_STEP_FACTOR`] times an open step), so the robot keeps
            /// `robot_radius_m` where there is room and passes doors a 0.1 m map draws narrower
            /// than that. The planner uses the smaller of the two: at `robot_radius_m` or more every
            /// inflated cell is lethal, which is the planner without the band. Default 0.35 m, off:
            /// 0.25 m (the default robot's body) passes every planner through the doors of real
            /// floor maps but did not keep `lives`'s results in the built-in settings
            /// (docs/experiments/soft-clearance.md). In [0, [`MAX_ROBOT_RADIUS_M`]].
            lethal_radius_m: Meters = m(350), Metres, "least clearance accepted; up to robot_radius_m a cell costs more (0.25 = the body)",
                check |v, _| within(v, Meters::ZERO, MAX_ROBOT_RADIUS_M) => "[0, 1.5] m", set "lethal_radius_m";
        }
    };
}
pub(crate) use config_params;

config_params!(define_config);
