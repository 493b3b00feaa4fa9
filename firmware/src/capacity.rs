//! Compile-time capacities: everything that sizes the core's memory is here.
//!
//! The static memory these imply is tabulated in `docs/architecture.md`; a test
//! (`firmware/tests/memory.rs`) checks that the table and `size_of::<Controller>()` agree.

/// Grid width and height in cells (512 × 512 at 0.10 m covers 51.2 m × 51.2 m).
pub const GRID_CELLS: usize = 512;
/// Cells per metre (0.10 m cells).
pub const CELLS_PER_METER: i64 = 10;
/// Cell side in millimetres.
pub const CELL_MM: i64 = 1000 / CELLS_PER_METER;
/// Total cells in a grid.
pub const GRID_AREA: usize = GRID_CELLS * GRID_CELLS;

/// The classifier's beam grid: 897 beams over 360° (the paper's VLP-16 projection).
pub const BEAMS: usize = 897;
/// Most beams a scan may carry on input (before resampling onto [`BEAMS`]).
pub const MAX_INPUT_BEAMS: usize = 2048;

/// Non-map points kept after pooling (a power of two: it sizes the pool's hash index).
pub const MAX_NONMAP_POINTS: usize = 1024;

/// Frontier groups kept per grid; more are dropped (smallest first) and counted.
pub const MAX_FRONTIERS_PER_GRID: usize = 96;
/// Work list for grouping frontier cells (8-connected flood fill).
pub const FRONTIER_QUEUE: usize = 8192;

/// Non-map clusters (one per 0.8 m block holding points) that get a viewpoint of their own.
pub const MAX_NONMAP_SITES: usize = 64;
/// Candidate viewpoints scored per planning step (4 per frontier centroid, 1 per non-map cluster).
pub const MAX_VIEWPOINTS: usize = 4 * 2 * MAX_FRONTIERS_PER_GRID + MAX_NONMAP_SITES;
/// Open list of the path-distance search (Dijkstra); overflow is counted, never silent.
pub const DIJKSTRA_HEAP: usize = 16384;
/// Waypoints in a goal's path.
pub const MAX_PATH_WAYPOINTS: usize = 64;
/// Blacklisted goal positions remembered (oldest forgotten first).
pub const MAX_BLACKLIST: usize = 64;
/// Camera rays cast for the visual-map update.
pub const MAX_CAMERA_RAYS: usize = 512;
/// The largest robot radius (clearance) the planner inflates obstacles by, in cells: 1.5 m
/// ([`crate::config::MAX_ROBOT_RADIUS_M`]).
pub const MAX_ROBOT_RADIUS_CELLS: usize = 15;
/// Inflation disk offsets (robot radius up to [`MAX_ROBOT_RADIUS_CELLS`]).
pub const MAX_INFLATION_OFFSETS: usize = (2 * MAX_ROBOT_RADIUS_CELLS + 1) * (2 * MAX_ROBOT_RADIUS_CELLS + 1);
/// Side of a frontier-count block (cells) used for the "frontier cells near the path" term.
pub const BLOCK_CELLS: usize = 8;
/// Blocks per grid side.
pub const BLOCKS: usize = GRID_CELLS / BLOCK_CELLS;

/// Most scan points the scan matcher places per candidate pose (`crate::matcher`): a scan's
/// returns are subsampled to this many.
pub const MATCH_MAX_POINTS: usize = 160;

/// Tasks (frontier clusters, viewpoints) one global tour orders (`crate::tour`): it sizes the
/// tour problem's `(MAX_TASKS + 1)²` cost matrix and bounds the solver's work per replan
/// (`crate::tour::MAX_SOLVE_WORK`).
pub const MAX_TASKS: usize = 48;

/// Side of the coarse lattice the room segmentation (`crate::rooms`) works on: 2 × 2 cells
/// (0.2 m) per coarse cell.
pub const COARSE_CELLS: usize = GRID_CELLS / 2;
/// Coarse cells in the lattice (65 536): one byte each for clearance and room label.
pub const COARSE_AREA: usize = COARSE_CELLS * COARSE_CELLS;
/// Rooms (and corridors) kept by the segmentation; room cores beyond it are dropped and counted.
/// Ids are `1..=MAX_ROOMS`.
pub const MAX_ROOMS: usize = 64;
/// Doorways kept by the segmentation; more are dropped and counted.
pub const MAX_DOORS: usize = 128;
/// Work list of the segmentation's flood fills and wavefront (a ring; a power of two). It holds
/// a wavefront, not an area, so it is much smaller than [`COARSE_AREA`]; overflow is counted.
pub const ROOM_QUEUE: usize = 16384;

/// Object proposals (clusters of non-map points that fit a target) kept per planning step
/// (`crate::planner::proposals`), best evidence first.
pub const MAX_PROPOSALS: usize = 12;

/// Teammates' goals a robot of a team keeps clear of (`Controller::set_team_claims`).
pub const MAX_TEAM_CLAIMS: usize = 8;

/// Waypoints of a coverage route (LIVE's waypoint manager, `crate::planner::coverage`): the
/// host's route over a known building; more are refused.
pub const MAX_ROUTE_WAYPOINTS: usize = 256;

/// Side of a tile of the rolling window's memory (`crate::rolling::memory`), cells: a shift
/// ([`crate::rolling::WINDOW_SHIFT_CELLS`] = 160) moves whole tiles.
pub const MEMORY_TILE_CELLS: usize = 32;
/// Tiles the window's memory keeps outside the window (10.24 m² each: 2 600 m² of building);
/// more are not kept (counted).
pub const MEMORY_TILES: usize = 256;
/// Bytes of run-length-coded cells the window's memory keeps. A tile of walls and free space
/// takes about 100–170 (the CSAIL logs: 7.5–12 KB at the most for 42–69 tiles outside the
/// window); a tile that does not fit is not kept (counted).
pub const MEMORY_BYTES: usize = 32 * 1024;
