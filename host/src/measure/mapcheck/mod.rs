//! `lives mapcheck`: how good is the controller's LiDAR map, and how good are its poses
//! (issue 27 item 5; `docs/mapcheck.md` says what each figure means and how it is computed).
//!
//! A run (a replayed log, or a simulated search) leaves the controller's LiDAR grid: 512 × 512
//! cells of 0.1 m, each unknown, free or occupied. It is scored against a *reference*, a set of
//! wall cells on the same lattice, and the *viewpoints* the reference was seen from:
//!
//! * a log, by default: a plain projection of the log's own scans at the log's own (for the
//!   corrected CARMEN logs, SLAM-corrected) poses — every return at least the minimum range and
//!   below the replay's range marks its cell as a reference wall;
//! * a log with `--reference OTHER --align POSES`: the same projection of another log of the same
//!   building, moved into this log's frame by the rigid transform that best fits this run's poses
//!   onto `POSES` (least squares over every matched time stamp, [`fit_rigid`]);
//! * a simulated search: the true world's walls, furniture, clutter and targets (not its people)
//!   where noise-free rays from the robot's true positions, one per LiDAR beam over 360° out to the
//!   LiDAR's range, first meet them.
//!
//! The figures, all at the grid's cells, with "within 0.2 m" meaning a cell whose centre lies
//! within 0.2 m of the other cell's centre ([`near_offsets`]):
//!
//! * **walls recovered**: the share of reference wall cells inside the grid with an occupied grid
//!   cell within 0.2 m;
//! * **phantom walls**: the share of occupied grid cells with no reference wall cell within 0.2 m;
//! * **free-space leak**: the share of free grid cells farther than 0.2 m from every cell a
//!   viewpoint sees in the reference map: from each viewpoint, [`RAYS`] rays over 360° out to the
//!   replay's clearing range, each visiting every cell it crosses and stopping at (after marking)
//!   the first reference wall cell.
//!
//! And the relations metric of Kümmerle et al. 2009 ([`relation_errors`]).

use firmware::Cell;

mod command;
mod poses;
mod report;
mod score;
pub use command::*;
pub use poses::*;
pub use report::*;
pub use score::*;

/// The scoring tolerance: "within 0.2 m" (issue 27).
pub const TOLERANCE_M: f64 = 0.2;
/// Rays cast from each viewpoint for the free-space leak (0.5° apart).
pub const RAYS: usize = 720;
/// Two time stamps are the same pose when they differ by at most this (seconds).
pub const MATCH_S: f64 = 1e-3;

/// The grid's cell side, metres.
pub fn cell_m() -> f64 {
    1.0 / firmware::capacity::CELLS_PER_METER as f64
}

/// The cell offsets `(dx, dy)` whose centre lies within [`TOLERANCE_M`] of a cell's centre
/// (13 offsets at 0.1 m cells: up to 2 cells along an axis, 1 along both diagonally).
pub fn near_offsets() -> Vec<(i32, i32)> {
    let c = cell_m();
    let r = (TOLERANCE_M / c).ceil() as i32;
    let mut v = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            if ((dx * dx + dy * dy) as f64) * c * c <= TOLERANCE_M * TOLERANCE_M + 1e-9 {
                v.push((dx, dy));
            }
        }
    }
    v
}

/// A LiDAR grid to score: `n × n` cells, cell `(x, y)` at `cells[y * n + x]`.
#[derive(Clone, Debug, PartialEq)]
pub struct MapGrid {
    /// Side, cells.
    pub n: i32,
    /// The cells.
    pub cells: Vec<Cell>,
}

impl MapGrid {
    /// All unknown.
    pub fn new(n: i32) -> Self {
        MapGrid { n, cells: vec![Cell::Unknown; (n * n) as usize] }
    }

    /// A copy of the controller's LiDAR grid.
    pub fn of(lidar: &firmware::grid::LidarGrid) -> Self {
        let n = firmware::capacity::GRID_CELLS as i32;
        let mut g = MapGrid::new(n);
        for y in 0..n {
            for x in 0..n {
                g.cells[(y * n + x) as usize] = lidar.get(x, y);
            }
        }
        g
    }

    /// The cell at `(x, y)`; `Unknown` outside.
    pub fn get(&self, x: i32, y: i32) -> Cell {
        if x < 0 || y < 0 || x >= self.n || y >= self.n {
            Cell::Unknown
        } else {
            self.cells[(y * self.n + x) as usize]
        }
    }

    /// Sets cell `(x, y)` (inside).
    pub fn set(&mut self, x: i32, y: i32, c: Cell) {
        self.cells[(y * self.n + x) as usize] = c;
    }
}

/// The reference: wall cells on the grid's lattice over the grid and a margin around it (walls
/// just outside the grid still stop rays and still match occupied cells at its edge), and the
/// viewpoints it was seen from. Coordinates are in cells of the grid's frame: a world point `p`
/// is at `(p − origin) / 0.1`.
#[derive(Clone, Debug)]
pub struct Reference {
    /// The grid's side, cells.
    pub n: i32,
    /// Cells of margin on each side.
    pub margin: i32,
    side: i32,
    wall: Vec<bool>,
    /// Viewpoints, cell units in the grid's frame.
    pub viewpoints: Vec<[f64; 2]>,
    /// How far each viewpoint's scanner reaches, metres (its scan's `range_max`), by index; a
    /// viewpoint without one reaches the clearing range.
    pub reach_m: Vec<f64>,
    /// Reference returns that fell beyond the margin (not scored).
    pub beyond: u64,
    /// Score walls recovered on the reference walls a viewpoint sees only (a floor map holds
    /// walls the robot never came near; a log's projection holds only walls it hit).
    pub seen_walls_only: bool,
}

impl Reference {
    /// An empty reference for an `n`-cell grid, with margin enough for rays of `range_m`.
    pub fn new(n: i32, range_m: f64) -> Self {
        let margin = (range_m.max(0.0) / cell_m()).ceil() as i32 + 3;
        let side = n + 2 * margin;
        Reference {
            n,
            margin,
            side,
            wall: vec![false; (side * side) as usize],
            viewpoints: Vec::new(),
            reach_m: Vec::new(),
            beyond: 0,
            seen_walls_only: false,
        }
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        let (i, j) = (x + self.margin as i64, y + self.margin as i64);
        (i >= 0 && j >= 0 && i < self.side as i64 && j < self.side as i64).then(|| (j * self.side as i64 + i) as usize)
    }

    /// Whether cell `(x, y)` (grid coordinates, possibly in the margin) is a reference wall.
    pub fn is_wall(&self, x: i32, y: i32) -> bool {
        self.index(x as i64, y as i64).is_some_and(|i| self.wall[i])
    }

    /// Marks the cell holding the point `(u, v)` (cell units) as a wall.
    pub fn mark(&mut self, u: f64, v: f64) {
        if !(u.is_finite() && v.is_finite()) {
            return;
        }
        match self.index(u.floor() as i64, v.floor() as i64) {
            Some(i) => self.wall[i] = true,
            None => self.beyond += 1,
        }
    }

    /// Marks cell `(x, y)` as a wall.
    pub fn mark_cell(&mut self, x: i32, y: i32) {
        self.mark(x as f64 + 0.5, y as f64 + 0.5);
    }

    /// Reference wall cells outside the grid (in the margin): walls the grid cannot hold.
    pub fn walls_outside_grid(&self) -> u64 {
        let mut k = 0;
        for j in 0..self.side {
            for i in 0..self.side {
                let (x, y) = (i - self.margin, j - self.margin);
                let inside = (0..self.n).contains(&x) && (0..self.n).contains(&y);
                if self.wall[(j * self.side + i) as usize] && !inside {
                    k += 1;
                }
            }
        }
        k
    }

    /// The cells the viewpoints see: [`RAYS`]-style rays, `rays` of them over 360° from each
    /// viewpoint out to the nearer of `range_m` and its reach ([`Reference::reach_m`]), visiting every cell each crosses (Amanatides–Woo) and stopping
    /// after the first reference wall cell. A wall in the viewpoint's own cell does not stop them
    /// (the robot stands there).
    pub fn visible(&self, range_m: f64, rays: usize) -> Vec<bool> {
        let mut vis = vec![false; self.wall.len()];
        let len = range_m / cell_m();
        let dirs: Vec<[f64; 2]> = (0..rays)
            .map(|k| {
                let a = 2.0 * std::f64::consts::PI * k as f64 / rays as f64;
                [a.cos(), a.sin()]
            })
            .collect();
        for (k, o) in self.viewpoints.iter().enumerate() {
            if !(o[0].is_finite() && o[1].is_finite()) {
                continue;
            }
            let len = self.reach_m.get(k).map_or(len, |r| len.min(r / cell_m()));
            let own = (o[0].floor() as i64, o[1].floor() as i64);
            for d in &dirs {
                walk_ray(*o, *d, len, |x, y| {
                    let Some(i) = self.index(x, y) else { return false };
                    vis[i] = true;
                    !self.wall[i] || (x, y) == own
                });
            }
        }
        vis
    }
}

/// Visits the cells a ray from `o` (cell units) in direction `d` (a unit vector) crosses, in
/// order, out to `len` cells (Amanatides–Woo: every cell it enters, so it cannot slip between two
/// diagonal cells), while `visit(x, y)` returns true.
pub fn walk_ray(o: [f64; 2], d: [f64; 2], len: f64, mut visit: impl FnMut(i64, i64) -> bool) {
    let (x0, y0) = (o[0].floor() as i64, o[1].floor() as i64);
    let (sx, sy) = (if d[0] > 0.0 { 1 } else { -1 }, if d[1] > 0.0 { 1 } else { -1 });
    let step = |dc: f64| if dc.abs() > 1e-12 { 1.0 / dc.abs() } else { f64::INFINITY };
    let first = |oc: f64, c: i64, dc: f64| {
        if dc > 1e-12 {
            ((c + 1) as f64 - oc) / dc
        } else if dc < -1e-12 {
            (oc - c as f64) / -dc
        } else {
            f64::INFINITY
        }
    };
    let (tdx, tdy) = (step(d[0]), step(d[1]));
    let (mut tmx, mut tmy) = (first(o[0], x0, d[0]), first(o[1], y0, d[1]));
    let (mut x, mut y) = (x0, y0);
    while visit(x, y) {
        if tmx < tmy {
            if tmx > len {
                break;
            }
            x += sx;
            tmx += tdx;
        } else {
            if tmy > len {
                break;
            }
            y += sy;
            tmy += tdy;
        }
    }
}

#[cfg(test)]
mod tests;
