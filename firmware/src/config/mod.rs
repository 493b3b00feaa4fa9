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
//!
//! Each parameter is declared once, as a row of the table in `config/params.rs`: its field, type,
//! default, unit, range (the check and the words of its error), `lives --set` name and a line of
//! description. [`Config`], [`Config::DEFAULT`], [`Config::validate`], [`PARAMS`] (which a host
//! lists and sets through) and the wire's [`crate::protocol::ConfigMsg`] are generated from it;
//! `docs/params.md` is its listing (`lives params --markdown`).

use crate::capacity::{CELL_MM, GRID_CELLS, MAX_ROBOT_RADIUS_CELLS};
use fixed_point::{BinaryAngle, Meters};
use serde::{Deserialize, Serialize};

mod params;
mod table;

pub(crate) use params::config_params;
pub use params::{Config, PARAMS};
pub(crate) use table::config_rows;
pub use table::{ParamInfo, ParamValue, Unit};

/// A utility weight: Q16.16, "utility points per unit of the term".
pub type Weight = fixed_point::fixed::types::I16F16;

/// Which viewpoint-selection rule the planner uses. It crosses the wire as itself (postcard: the
/// variant's index), so the variant order is wire order: append only, and bump the protocol
/// version.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
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
    /// LIVE (known map): LiDAR coverage of the known building plus priority waypoints to look at
    /// the nearest inspection region, at most once per `live_priority_interval_us`
    /// ([`crate::planner::coverage`]; the route comes from the host, [`crate::Controller::route_push`]).
    Live,
    /// LIVE's baseline "heuristic visual coverage": a route whose camera views cover the known
    /// free space, followed waypoint by waypoint, no priority waypoints.
    VisualCoverage,
    /// LIVE's baseline "LiDAR coverage": a route covering the known building with the LiDAR's
    /// footprint, followed waypoint by waypoint, no priority waypoints.
    LidarCoverage,
}

impl PlannerKind {
    /// Every kind, in wire order.
    pub const ALL: [PlannerKind; 10] = [
        PlannerKind::Lives,
        PlannerKind::Multisensor,
        PlannerKind::Nearest,
        PlannerKind::ExploreLite,
        PlannerKind::Rrt,
        PlannerKind::LivesGreedy,
        PlannerKind::LivesNoNonMap,
        PlannerKind::Live,
        PlannerKind::VisualCoverage,
        PlannerKind::LidarCoverage,
    ];

    /// LIVE and its baselines: a route over a known building, followed by the waypoint manager.
    pub const fn is_coverage(self) -> bool {
        matches!(self, PlannerKind::Live | PlannerKind::VisualCoverage | PlannerKind::LidarCoverage)
    }

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
/// [`crate::Status::overruns`]. On the wire as they are (protocol `BudgetsMsg`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
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

impl StageBudgets {
    /// The defaults ([`Config::DEFAULT`]'s).
    pub const DEFAULT: StageBudgets =
        StageBudgets { lidar_cells: 400_000, visual_cells: 40_000, nonmap_ops: 100_000, plan_ops: 12_000_000, classify_macs: 2_000_000 };
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

impl Config {
    /// This configuration running `kind`, with the planner's own defaults where its original
    /// differs from ours: `explore-lite` (ROS `explore_lite`) takes frontiers from 0.5 m
    /// (5 cells), blacklists a goal without progress for 30 s (`goal_timeout_us`) and lets any
    /// better frontier replace the goal (no switch margin); the route followers of a known map
    /// (`live`, `visual-cpp`, `lidar-cpp`) face their way (no gaze). Every place that runs a
    /// planner (the simulated search, the bridge to a robot, the dataset walker) gets its
    /// configuration here, so the core, not a host, decides what each planner does.
    ///
    /// A configuration already running `kind` is returned as it is: its planner's defaults came
    /// with the choice of the planner, and what was set since (`--set`) stands. Choose the planner
    /// first, then apply the overrides.
    pub fn with_planner(self, kind: PlannerKind) -> Config {
        if self.planner == kind {
            return self;
        }
        let base = Config { planner: kind, ..self };
        match kind {
            PlannerKind::ExploreLite => Config { min_frontier_cells: 5, goal_timeout_us: 30_000_000, switch_margin: Weight::ZERO, ..base },
            // A route follower faces where it walks (the paper's robots follow their paths with a
            // carrot planner and move_base); the camera looks where the route turns it.
            k if k.is_coverage() => Config { gaze: false, ..base },
            _ => base,
        }
    }

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
            PlannerKind::Lives | PlannerKind::LivesGreedy => self.w_nonmap_per_point,
            PlannerKind::Multisensor
            | PlannerKind::Nearest
            | PlannerKind::ExploreLite
            | PlannerKind::Rrt
            | PlannerKind::LivesNoNonMap
            | PlannerKind::Live
            | PlannerKind::VisualCoverage
            | PlannerKind::LidarCoverage => Weight::ZERO,
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
            } else if planner.is_coverage() {
                assert_eq!(c, Config { planner, gaze: false, ..Config::DEFAULT }, "{planner:?}: a route follower faces its way");
            } else {
                assert_eq!(c, Config { planner, ..Config::DEFAULT }, "{planner:?}: only explore-lite and the route followers differ");
            }
        }
    }

    #[test]
    fn what_is_set_after_the_planner_is_chosen_outlives_its_defaults() {
        let mut c = Config::DEFAULT.with_planner(PlannerKind::ExploreLite);
        c.min_frontier_cells = 8;
        c.switch_margin = Weight::from_num(6);
        let again = c.with_planner(PlannerKind::ExploreLite);
        assert_eq!(again, c, "choosing the same planner again changes nothing");
        let other = c.with_planner(PlannerKind::Multisensor);
        assert_eq!(
            (other.planner, other.min_frontier_cells),
            (PlannerKind::Multisensor, 8),
            "another planner keeps what it has no default for"
        );
        assert_eq!(other.with_planner(PlannerKind::ExploreLite).min_frontier_cells, 5, "choosing explore-lite afresh brings its defaults");
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

    /// Numbers to try for `p`: its type's ends, those around zero and around its default.
    fn candidates(p: &ParamInfo, default: i64) -> impl Iterator<Item = i64> + '_ {
        let (lo, hi) = p.raw_range;
        [lo, hi, -1, 0, 1, 2, default.saturating_sub(1), default.saturating_add(1)].into_iter().filter(move |v| (lo..=hi).contains(v))
    }

    /// `Config::DEFAULT` with `p` set to `raw`, if its type holds it.
    fn with(p: &ParamInfo, raw: i64) -> Option<Config> {
        let mut c = Config::DEFAULT;
        (p.set)(&mut c, raw).then_some(c)
    }

    /// `c` after crossing the wire: encoded by postcard and decoded again.
    fn across_the_wire(c: &Config) -> Config {
        let mut buf = [0u8; 512];
        let bytes = postcard::to_slice(&ConfigMsg::from_config(c), &mut buf).unwrap();
        postcard::from_bytes::<ConfigMsg>(bytes).unwrap().config()
    }

    #[test]
    fn every_parameter_of_the_table_reaches_every_form() {
        assert_eq!(PARAMS.len(), ConfigMsg::FIELDS.len());
        for (i, p) in PARAMS.iter().enumerate() {
            assert_eq!(ConfigMsg::field_index(p.field), Some(i as u8), "{}: row {i} is wire field {i}", p.field);
            let Some(default) = (p.get)(&Config::DEFAULT) else {
                // The budgets: not one number, but they cross the wire like the rest.
                assert_eq!(p.unit, Unit::Budgets);
                let c = Config { budgets: StageBudgets { plan_ops: 7, ..StageBudgets::DEFAULT }, ..Config::DEFAULT };
                assert_eq!(across_the_wire(&c), c);
                continue;
            };
            // A value in range other than the default crosses the wire and reads back.
            let v = candidates(p, default)
                .find(|&v| v != default && with(p, v).is_some_and(|c| c.validate().is_ok()))
                .unwrap_or_else(|| panic!("{}: no value in range but the default", p.field));
            let c = with(p, v).unwrap();
            assert_ne!(c, Config::DEFAULT, "{}: set changes the field", p.field);
            assert_eq!(across_the_wire(&c), c, "{} = {v}", p.field);
            assert_eq!((p.get)(&across_the_wire(&c)), Some(v), "{}", p.field);
            // A value outside its range is refused, naming it and its range; a field without a
            // range takes any value of its type.
            let refused = candidates(p, default).filter_map(|v| with(p, v)?.validate().err()).collect::<std::vec::Vec<_>>();
            match p.allowed {
                Some(allowed) => {
                    let e = refused.first().unwrap_or_else(|| panic!("{}: nothing is out of its range", p.field));
                    assert_eq!(*e, ConfigError { field: p.field, allowed }, "{}", p.field);
                }
                None => assert_eq!(refused, [], "{} has no range", p.field),
            }
        }
    }
}
