//! Buildings larger than the grid: the maps' window follows the robot.
//!
//! The controller's grids cover [`GRID_CELLS`]² cells (51.2 m at 0.1 m). When an accepted pose
//! comes within [`WINDOW_MARGIN_CELLS`] of an edge and the LiDAR map reaches that edge (or the
//! robot is within [`WINDOW_HARD_MARGIN_CELLS`] of it whatever the map), the window moves along
//! that axis by the multiple of [`WINDOW_SHIFT_CELLS`] that brings the robot nearest the middle
//! (Nav2's rolling costmap re-centres on the robot the same way, at every update). A shift moves
//! every grid's cells in place (`copy_within` over rows, new cells unknown), moves the grid's
//! origin, translates every stored cell coordinate — planner blacklist, the goal's viewpoint
//! cell, the last step's frontiers and candidates, the `rrt` baseline's tree nodes and frontier
//! points — and drops what falls outside; world coordinates (poses, goal poses and paths,
//! non-map points) need nothing, but non-map points outside the new window are dropped and the
//! pooling index is rebuilt. The controller then replans.
//!
//! What leaves the window is kept in [`memory`], tile by tile, as each cell's state (LiDAR and
//! camera) run-length coded, and restored when it comes back: a robot that returns to a part of
//! the building finds its walls, its free space and what its camera has searched there.
//!
//! **Why the map must reach the edge.** A floor that fits the grid should never shift it: the
//! simulator centres its worlds (up to 45 m) in the grid, so a robot in a corner of the office
//! world is 3.4 m from the grid's edge, and a replayed log's trajectory is centred the same way
//! (ACES: 45 × 40 m, 3.1 m from the edge). Shifting there throws away the far side of a building
//! that fits. Only when the map is cut off by the edge, or the robot is about to leave the
//! window, does it move.
//!
//! **Why 160 cells.** A shift must keep every packed format aligned (4 cells a byte, 2 a byte, 32
//! a word, 8-cell frontier blocks) and move the origin by an exact number of Q16.16 bits, so
//! that a world point falls in exactly the cell it fell in before, less the shift: 0.1 m is
//! 6553.6 bits, 5 cells are exactly 32 768. The least common multiple of 32 and 5 is 160 cells,
//! 16 m; after a shift the robot is within 8 m of the middle (≥ 17.6 m from every edge), so it
//! travels at least 14.6 m before the next one.
//!
//! **Work.** A shift writes each of the six cell arrays once (LiDAR ternary view and evidence,
//! visual grid, wall mask, traversability mask, distance field: 6 × 512² cells, 832 KiB) plus
//! the stored coordinates, and reads the tiles that leave and writes those that come back
//! ([`memory`]); the count is [`WindowStats::last_work`] and is added to the LiDAR stage's work
//! of the tick ([`crate::controller::StageCost::lidar`]).

pub mod memory;

use crate::capacity::{BLOCK_CELLS, CELLS_PER_METER, GRID_AREA, GRID_CELLS, MEMORY_TILE_CELLS};
use crate::config::MAX_ORIGIN_M;
use crate::frontier::FrontierSet;
use crate::grid::{Cell, GridGeometry, LidarGrid, PackedGrid, VisualGrid};
use crate::nonmap::NonMapStore;
use crate::planner::{Goal, Planner};
use fixed_point::{Meters, Pose2};
use memory::WindowMemory;

/// A pose this close to an edge (cells; 3 m) moves the window, if the LiDAR map reaches that edge.
/// Measured on the CARMEN logs (`docs/experiments/real-lidar-maps.md`): 8 m moved the window 12 times in the
/// ACES log, whose 45 × 40 m trajectory fits the grid, and forgot half its map; 3 m never moves
/// it for a floor that fits, and the robot still sees at least 3 m ahead before a shift.
pub const WINDOW_MARGIN_CELLS: i32 = 30;
/// A pose this close to an edge (cells; 1 m) moves the window whatever the map holds: the robot
/// must not leave it.
pub const WINDOW_HARD_MARGIN_CELLS: i32 = 10;
/// The window moves by multiples of this (cells; 16 m): see the module's docs.
pub const WINDOW_SHIFT_CELLS: i32 = 160;

const _: () = assert!(WINDOW_SHIFT_CELLS % 32 == 0 && WINDOW_SHIFT_CELLS % BLOCK_CELLS as i32 == 0);
const _: () = assert!((WINDOW_SHIFT_CELLS as i64 * 65_536) % CELLS_PER_METER == 0);
// After a shift the robot is at least this far from the edge it neared: it does not shift back.
const _: () = assert!(GRID_CELLS as i32 / 2 - WINDOW_SHIFT_CELLS / 2 > WINDOW_MARGIN_CELLS);
const _: () = assert!(WINDOW_HARD_MARGIN_CELLS < WINDOW_MARGIN_CELLS);

pub use crate::grid::WindowStats;

/// Everything in the controller that holds grid cell coordinates.
pub struct Maps<'a> {
    /// The LiDAR map (its geometry is the window's).
    pub lidar: &'a mut LidarGrid,
    /// The visual map.
    pub visual: &'a mut VisualGrid,
    /// Non-map points and the wall mask.
    pub nonmap: &'a mut NonMapStore,
    /// The last step's frontiers.
    pub frontiers: &'a mut FrontierSet,
    /// Blacklist, distance field, candidates, `rrt` trees.
    pub planner: &'a mut Planner,
    /// The goal being pursued.
    pub goal: &'a mut Option<Goal>,
    /// What has left the window.
    pub memory: &'a mut WindowMemory,
}

/// Called with every accepted pose: moves the window if the robot nears an edge (see the
/// module's docs). Returns true if it moved (the controller then replans). The work, shift or
/// not, is added to the next scan's LiDAR-stage work.
pub fn follow(maps: Maps<'_>, pose: &Pose2, pool_radius: Meters) -> bool {
    let (cx, cy) = maps.lidar.geom.cell_of(pose.x, pose.y);
    if !PackedGrid::in_bounds(cx, cy) {
        return false;
    }
    let mut work = 0;
    let sx = axis_shift(maps.lidar, cx, true, &mut work);
    let sy = axis_shift(maps.lidar, cy, false, &mut work);
    maps.lidar.pending_work = maps.lidar.pending_work.saturating_add(work);
    if (sx, sy) == (0, 0) {
        return false;
    }
    shift(maps, sx, sy, pool_radius).is_some()
}

/// The shift along one axis for a robot at cell `c` on it (0: none).
fn axis_shift(lidar: &mut LidarGrid, c: i32, x_axis: bool, work: &mut u32) -> i32 {
    let n = GRID_CELLS as i32;
    let high = c >= n - WINDOW_MARGIN_CELLS;
    if c >= WINDOW_MARGIN_CELLS && !high {
        return 0;
    }
    let hard = c < WINDOW_HARD_MARGIN_CELLS || c >= n - WINDOW_HARD_MARGIN_CELLS;
    if !hard {
        // Does the LiDAR map reach that edge? Its outermost row or column holds an observed cell.
        let edge = if high { n - 1 } else { 0 };
        *work += n as u32;
        let reached = (0..n).any(|i| {
            let (x, y) = if x_axis { (edge, i) } else { (i, edge) };
            lidar.get(x, y) != Cell::Unknown
        });
        if !reached {
            return 0;
        }
    }
    // The multiple of the quantum nearest the robot's offset from the middle.
    let q = WINDOW_SHIFT_CELLS;
    (c - n / 2 + q / 2).div_euclid(q) * q
}

/// Moves the window by `(sx, sy)` cells (multiples of [`WINDOW_SHIFT_CELLS`]; the new cell
/// `(x, y)` is the old `(x + sx, y + sy)`) and everything stored in cell coordinates with it.
/// Returns the work, or `None` (nothing changes, counted in [`WindowStats::refused`]) when a
/// shift is not such a multiple or the new origin would leave the fixed-point range
/// ([`Meters::MIN`] ..= [`MAX_ORIGIN_M`]).
pub fn shift(maps: Maps<'_>, sx: i32, sy: i32, pool_radius: Meters) -> Option<u32> {
    let Maps { lidar, visual, nonmap, frontiers, planner, goal, memory } = maps;
    let q = WINDOW_SHIFT_CELLS;
    let moved = |o: Meters, s: i32| {
        let bits = o.to_bits() as i64 + s as i64 * 65_536 / CELLS_PER_METER;
        (s % q == 0 && bits >= Meters::MIN.to_bits() as i64 && bits <= MAX_ORIGIN_M.to_bits() as i64)
            .then(|| Meters::from_bits(bits as i32))
    };
    let (Some(ox), Some(oy)) = (moved(lidar.geom.origin_x, sx), moved(lidar.geom.origin_y, sy)) else {
        lidar.window.refused += 1;
        return None;
    };
    let geom = GridGeometry { origin_x: ox, origin_y: oy };
    // World tiles: the window's tile (i, j) is world tile `base + (i, j)`.
    let t = MEMORY_TILE_CELLS as i32;
    let tiles = GRID_CELLS as i32 / t;
    let old = (lidar.window.moved_cells.0 / t, lidar.window.moved_cells.1 / t);
    let new = (old.0 + sx / t, old.1 + sy / t);
    let inside = |base: (i32, i32), w: (i32, i32)| (0..tiles).contains(&(w.0 - base.0)) && (0..tiles).contains(&(w.1 - base.1));
    let window_tiles = || (0..tiles).flat_map(move |j| (0..tiles).map(move |i| (i, j)));
    let mut work = 0;
    for (i, j) in window_tiles() {
        let w = (old.0 + i, old.1 + j);
        if !inside(new, w) {
            work += memory.keep(lidar, visual, (i * t, j * t), w);
        }
    }
    lidar.shift(sx, sy, geom);
    visual.grid.shift(sx, sy);
    for (i, j) in window_tiles() {
        let w = (new.0 + i, new.1 + j);
        if !inside(old, w) {
            work += memory.restore(lidar, visual, (i * t, j * t), w);
        }
    }
    work += 3 * GRID_AREA as u32;
    work += nonmap.shift(sx, sy, &geom, pool_radius);
    let (w, mut dropped) = frontiers.shift(sx, sy);
    work += w;
    let (w, d) = planner.shift(sx, sy);
    work += w;
    dropped += d;
    if let Some(g) = goal.as_mut() {
        work += 1;
        let c = (g.viewpoint.cell.0 - sx, g.viewpoint.cell.1 - sy);
        if PackedGrid::in_bounds(c.0, c.1) {
            g.viewpoint.cell = c;
        } else {
            *goal = None;
            dropped += 1;
        }
    }
    let st = &mut lidar.window;
    st.shifts += 1;
    st.moved_cells = (st.moved_cells.0.saturating_add(sx), st.moved_cells.1.saturating_add(sy));
    st.last_shift = (sx, sy);
    st.last_work = work;
    st.dropped += dropped;
    lidar.pending_work = lidar.pending_work.saturating_add(work);
    Some(work)
}
