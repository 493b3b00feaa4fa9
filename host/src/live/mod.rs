//! LIVE (issue 32; `../docs/live.md`): searching a building whose map is known. The controller
//! core labels scans against the map, keeps the search map and runs the waypoint manager
//! (`firmware::knownmap`, `firmware::searchmap`, `firmware::planner::coverage`); this module is
//! the central server's side: the coverage routes ([`coverage`]) and loading a map and a route
//! into a controller ([`load`]).

pub mod coverage;

use crate::io::map_file::Cell3;
use firmware::protocol::{HostToCore, MapRowMsg, RouteMsg, WireWaypoint, MAP_ROW_BYTES, MAX_ROUTE_CHUNK};
use firmware::{Controller, PlannerKind};

/// The footprint a planner's route covers: the camera's for `visual-cpp`, the LiDAR's for
/// `live` and `lidar-cpp` (LIVE's route is "Lidar CPP"); `None` for planners without a route.
pub fn footprint(kind: PlannerKind, cfg: &firmware::Config) -> Option<coverage::Footprint> {
    match kind {
        PlannerKind::VisualCoverage => {
            Some(coverage::Footprint::Camera { range_m: cfg.camera_range_m.to_num::<f64>(), fov_rad: cfg.camera_fov.to_radians() })
        }
        PlannerKind::Live | PlannerKind::LidarCoverage => {
            Some(coverage::Footprint::Lidar { range_m: cfg.lidar_max_range_m.to_num::<f64>() })
        }
        _ => None,
    }
}

/// The map messages of a known building (cells on the grid of `cfg`, row by row from the
/// lowest y): one [`HostToCore::MapRow`] per row that holds a known cell (and always the first,
/// which resets the map held), each plane without its trailing zero bytes.
pub fn map_messages(cells: &[Cell3], cfg: &firmware::Config) -> Vec<HostToCore> {
    let n = firmware::capacity::GRID_CELLS;
    cells
        .chunks(n)
        .take(n)
        .enumerate()
        .filter(|(y, row)| *y == 0 || row.iter().any(|c| *c != Cell3::Unknown))
        .map(|(y, row)| {
            let plane = |want: Cell3| {
                let mut bits = heapless::Vec::<u8, MAP_ROW_BYTES>::new();
                // Cannot fail: a row is at most MAP_ROW_BYTES bytes.
                let _ = bits.resize(row.len().div_ceil(8), 0);
                for (x, _) in row.iter().enumerate().filter(|(_, c)| **c == want) {
                    bits[x / 8] |= 1 << (x % 8);
                }
                while bits.last() == Some(&0) {
                    bits.pop();
                }
                bits
            };
            HostToCore::MapRow(MapRowMsg {
                reset: y == 0,
                origin_x: cfg.origin_x_m.to_bits(),
                origin_y: cfg.origin_y_m.to_bits(),
                y: y as u16,
                x0: 0,
                n: row.len() as u16,
                occupied: plane(Cell3::Occupied),
                free: plane(Cell3::Free),
            })
        })
        .collect()
}

/// The route as [`HostToCore::Route`] messages (at most the controller's capacity of
/// waypoints; a waypoint off the fixed-point range ends it).
pub fn route_messages(route: &coverage::Route) -> Vec<HostToCore> {
    let wire: Vec<WireWaypoint> = route
        .waypoints
        .iter()
        .take(firmware::capacity::MAX_ROUTE_WAYPOINTS)
        .map_while(|w| {
            Some(WireWaypoint {
                x: fixed_point::meters_from_f64(w.x)?.to_bits(),
                y: fixed_point::meters_from_f64(w.y)?.to_bits(),
                heading: firmware::BinaryAngle::from_radians(w.heading)?.0,
            })
        })
        .collect();
    let mut out: Vec<HostToCore> = wire
        .chunks(MAX_ROUTE_CHUNK)
        .enumerate()
        .map(|(k, c)| {
            HostToCore::Route(RouteMsg { first: (k * MAX_ROUTE_CHUNK) as u16, waypoints: heapless::Vec::from_slice(c).unwrap_or_default() })
        })
        .collect();
    if out.is_empty() {
        out.push(HostToCore::Route(RouteMsg::default()));
    }
    out
}

/// Loads a known building into `ctrl` as the node would from the link ([`map_messages`],
/// `firmware::node::apply_map_row`).
pub fn load(ctrl: &mut Controller, cells: &[Cell3]) {
    let cfg = *ctrl.config();
    for m in map_messages(cells, &cfg) {
        if let HostToCore::MapRow(m) = m {
            // Rows within the grid and the grid's width: cannot be refused.
            let _ = firmware::node::apply_map_row(ctrl, &m);
        }
    }
}

/// Gives `ctrl` the route as the node would from the link; returns the waypoints it holds.
pub fn give_route(ctrl: &mut Controller, route: &coverage::Route) -> usize {
    for m in route_messages(route) {
        if let HostToCore::Route(r) = m {
            let _ = firmware::node::apply_route(ctrl, &r);
        }
    }
    ctrl.planner.route.waypoints().len()
}

/// What LIVE's side of a search did (`SearchResult::live`).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct LiveSummary {
    /// The footprint the route covers (`camera`, `lidar`); absent for a planner without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub route_footprint: Option<String>,
    /// Why there is no route, if there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub route_error: Option<String>,
    /// Waypoints given to the controller.
    pub route_waypoints: usize,
    /// The route's path length from the start, metres.
    pub route_length_m: f64,
    /// Share of the map's free cells the route's footprints cover.
    pub route_coverage: f64,
    /// Route waypoints reached, skipped; priority waypoints inserted (the waypoint manager's
    /// counts at the end).
    pub waypoints_reached: u32,
    pub waypoints_skipped: u32,
    pub priority_waypoints: u32,
    /// Scan points classified `[LTF, STF, DF]` over the search.
    pub features: [u32; 3],
    /// The search map's entropy (bits: one per free cell the camera has not seen) at the start
    /// and at the end.
    pub entropy_start_bits: u32,
    pub entropy_end_bits: u32,
    /// `[time s, entropy bits]` every [`ENTROPY_EVERY_S`] of the search.
    pub entropy: Vec<[f64; 2]>,
}

/// How often a search samples the search map's entropy, seconds.
pub const ENTROPY_EVERY_S: f64 = 5.0;

/// Plans the route of `cfg`'s planner (if it follows one) over `cells` from `start` (world
/// x, y): LIVE's central server. Returns what it did and the route.
pub fn plan_route(cfg: &firmware::Config, cells: &[Cell3], start: [f64; 2]) -> (LiveSummary, Option<coverage::Route>) {
    let mut s = LiveSummary::default();
    let Some(fp) = footprint(cfg.planner, cfg) else { return (s, None) };
    s.route_footprint = Some(match fp {
        coverage::Footprint::Camera { .. } => "camera".to_string(),
        coverage::Footprint::Lidar { .. } => "lidar".to_string(),
    });
    let map = coverage::KnownGrid {
        cells,
        side: firmware::capacity::GRID_CELLS,
        origin: [cfg.origin_x_m.to_num::<f64>(), cfg.origin_y_m.to_num::<f64>()],
    };
    match coverage::plan(&map, coverage::Clearance::of(cfg), start, fp) {
        Ok(route) => {
            s.route_waypoints = route.waypoints.len().min(firmware::capacity::MAX_ROUTE_WAYPOINTS);
            s.route_length_m = crate::run::round3(route.length_m);
            s.route_coverage = crate::run::round3(route.covered as f64 / route.free.max(1) as f64);
            (s, Some(route))
        }
        Err(e) => {
            s.route_error = Some(e.to_string());
            (s, None)
        }
    }
}

/// [`plan_route`] for `ctrl`, and gives it the route.
pub fn plan_and_give(ctrl: &mut Controller, cells: &[Cell3], start: [f64; 2]) -> LiveSummary {
    let cfg = *ctrl.config();
    let (mut s, route) = plan_route(&cfg, cells, start);
    if let Some(r) = route {
        s.route_waypoints = give_route(ctrl, &r);
    }
    s
}

/// Fills the end-of-search counts of `s` from `ctrl`.
pub fn finish(s: &mut LiveSummary, ctrl: &Controller) {
    let st = ctrl.planner.route.stats;
    (s.waypoints_reached, s.waypoints_skipped, s.priority_waypoints) = (st.reached, st.skipped, st.priorities);
    s.features = ctrl.known.counts;
    s.entropy_end_bits = ctrl.search.entropy_bits();
}

/// `world`'s true map ([`crate::io::map_file::export::true_map`]: its walls and furniture, not
/// its targets, clutter or people) on the grid of `cfg` (the controller's configuration for
/// that world): what `lives eval --known-map` gives every search.
pub fn true_map_cells(world: &crate::sim::World, cfg: &firmware::Config) -> Result<Vec<Cell3>, String> {
    let map = crate::io::map_file::export::true_map(world, "true map");
    map.to_controller_grid([cfg.origin_x_m.to_num::<f64>(), cfg.origin_y_m.to_num::<f64>()]).map_err(|e| e.to_string())
}
