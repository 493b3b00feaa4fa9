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

use crate::replay::{self, ReplayReport, ScanRecord, TimedPose};
use crate::search::{PlannerChoice, SearchResult, SearchSpec};
use crate::sim::Scenario;
use firmware::Cell;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

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
    /// Reference returns that fell beyond the margin (not scored).
    pub beyond: u64,
}

impl Reference {
    /// An empty reference for an `n`-cell grid, with margin enough for rays of `range_m`.
    pub fn new(n: i32, range_m: f64) -> Self {
        let margin = (range_m.max(0.0) / cell_m()).ceil() as i32 + 3;
        let side = n + 2 * margin;
        Reference { n, margin, side, wall: vec![false; (side * side) as usize], viewpoints: Vec::new(), beyond: 0 }
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
    /// viewpoint out to `range_m`, visiting every cell each crosses (Amanatides–Woo) and stopping
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
        for o in &self.viewpoints {
            if !(o[0].is_finite() && o[1].is_finite()) {
                continue;
            }
            let (x0, y0) = (o[0].floor() as i64, o[1].floor() as i64);
            for d in &dirs {
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
                while let Some(i) = self.index(x, y) {
                    vis[i] = true;
                    if self.wall[i] && (x, y) != (x0, y0) {
                        break;
                    }
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
        }
        vis
    }
}

/// The three map figures and their counts. A share is `None` when its denominator is zero.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapScores {
    /// Reference wall cells inside the grid.
    pub reference_wall_cells: u64,
    /// Of which have an occupied grid cell within 0.2 m.
    pub recovered_cells: u64,
    /// `recovered_cells / reference_wall_cells`.
    pub walls_recovered: Option<f64>,
    /// Occupied grid cells.
    pub occupied_cells: u64,
    /// Of which have no reference wall cell within 0.2 m.
    pub phantom_cells: u64,
    /// `phantom_cells / occupied_cells`.
    pub phantom_walls: Option<f64>,
    /// Free grid cells.
    pub free_cells: u64,
    /// Of which lie farther than 0.2 m from every cell a viewpoint sees in the reference map.
    pub leak_cells: u64,
    /// `leak_cells / free_cells`.
    pub free_space_leak: Option<f64>,
    /// Cells (grid and margin) some viewpoint sees in the reference map.
    pub reference_visible_cells: u64,
    /// Reference wall cells in the margin around the grid (seen, but outside the grid).
    pub reference_walls_outside_grid: u64,
}

fn share(k: u64, n: u64) -> Option<f64> {
    (n > 0).then(|| k as f64 / n as f64)
}

/// What a grid cell is, for the picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellClass {
    /// Unknown in the grid, no reference wall.
    Unknown,
    /// Free, within 0.2 m of a cell a viewpoint sees.
    Free,
    /// Free, a leak.
    Leak,
    /// Occupied, a reference wall within 0.2 m.
    Wall,
    /// Occupied, a phantom.
    Phantom,
    /// Not occupied, a reference wall with no occupied cell within 0.2 m (a lost wall).
    Lost,
}

/// Scores `grid` against `reference`; the leak's rays run `rays` per viewpoint out to `range_m`.
pub fn score(grid: &MapGrid, reference: &Reference, range_m: f64, rays: usize) -> MapScores {
    score_cells(grid, reference, range_m, rays).0
}

/// [`score`], with each grid cell's class (row-major, `grid.n` per row).
pub fn score_cells(grid: &MapGrid, reference: &Reference, range_m: f64, rays: usize) -> (MapScores, Vec<CellClass>) {
    assert_eq!(grid.n, reference.n, "the reference is drawn for this grid");
    let near = near_offsets();
    let n = grid.n;
    let (mut ref_walls, mut recovered, mut occupied, mut phantom, mut free, mut leak) = (0, 0, 0, 0, 0, 0);
    let vis = reference.visible(range_m, rays);
    let seen = |x: i32, y: i32| reference.index(x as i64, y as i64).is_some_and(|i| vis[i]);
    let mut classes = vec![CellClass::Unknown; (n * n) as usize];
    for y in 0..n {
        for x in 0..n {
            let class = &mut classes[(y * n + x) as usize];
            if reference.is_wall(x, y) {
                ref_walls += 1;
                let found = near.iter().any(|&(dx, dy)| grid.get(x + dx, y + dy) == Cell::Occupied);
                recovered += found as u64;
                if !found {
                    *class = CellClass::Lost;
                }
            }
            match grid.get(x, y) {
                Cell::Occupied => {
                    occupied += 1;
                    let ok = near.iter().any(|&(dx, dy)| reference.is_wall(x + dx, y + dy));
                    phantom += !ok as u64;
                    *class = if ok { CellClass::Wall } else { CellClass::Phantom };
                }
                Cell::Free => {
                    free += 1;
                    let ok = near.iter().any(|&(dx, dy)| seen(x + dx, y + dy));
                    leak += !ok as u64;
                    if *class != CellClass::Lost {
                        *class = if ok { CellClass::Free } else { CellClass::Leak };
                    }
                }
                Cell::Unknown => {}
            }
        }
    }
    let scores = MapScores {
        reference_wall_cells: ref_walls,
        recovered_cells: recovered,
        walls_recovered: share(recovered, ref_walls),
        occupied_cells: occupied,
        phantom_cells: phantom,
        phantom_walls: share(phantom, occupied),
        free_cells: free,
        leak_cells: leak,
        free_space_leak: share(leak, free),
        reference_visible_cells: vis.iter().filter(|v| **v).count() as u64,
        reference_walls_outside_grid: reference.walls_outside_grid(),
    };
    (scores, classes)
}

/// Writes the classes as a PNG, two pixels per cell, north up: free white, leak orange, matched
/// wall black, phantom magenta, lost reference wall red, unknown grey.
pub fn write_png(path: &Path, n: i32, classes: &[CellClass]) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let px = 2usize;
    let side = n as usize * px;
    let mut data = vec![0u8; side * side * 3];
    for y in 0..n as usize {
        for x in 0..n as usize {
            let rgb: [u8; 3] = match classes[y * n as usize + x] {
                CellClass::Unknown => [200, 200, 200],
                CellClass::Free => [255, 255, 255],
                CellClass::Leak => [255, 140, 0],
                CellClass::Wall => [0, 0, 0],
                CellClass::Phantom => [220, 0, 220],
                CellClass::Lost => [230, 0, 0],
            };
            for j in 0..px {
                for i in 0..px {
                    let row = side - 1 - (y * px + j);
                    let k = (row * side + x * px + i) * 3;
                    data[k..k + 3].copy_from_slice(&rgb);
                }
            }
        }
    }
    let file = std::fs::File::create(path).map_err(|e| err(&e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), side as u32, side as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|e| err(&e))?;
    w.write_image_data(&data).map_err(|e| err(&e))?;
    w.finish().map_err(|e| err(&e))
}

/// A rigid transform of the plane: `p ↦ R(θ) p + (x, y)`, as `[x, y, θ]`.
pub type Rigid = [f64; 3];

/// `t` applied to the point `p`.
pub fn apply(t: &Rigid, p: [f64; 2]) -> [f64; 2] {
    let (s, c) = t[2].sin_cos();
    [t[0] + c * p[0] - s * p[1], t[1] + s * p[0] + c * p[1]]
}

/// `a ⊕ b`: pose `b` expressed in `a`'s frame, composed onto `a`.
pub fn compose(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    let p = apply(a, [b[0], b[1]]);
    [p[0], p[1], wrap(a[2] + b[2])]
}

/// `a⁻¹`.
pub fn inverse(a: &[f64; 3]) -> [f64; 3] {
    let (s, c) = a[2].sin_cos();
    [-c * a[0] - s * a[1], s * a[0] - c * a[1], wrap(-a[2])]
}

/// An angle in (−π, π].
pub fn wrap(a: f64) -> f64 {
    let w = a.sin().atan2(a.cos());
    if w <= -std::f64::consts::PI {
        w + std::f64::consts::TAU
    } else {
        w
    }
}

/// The rigid transform `T` minimising `Σ |T(from_i) − to_i|²` over matched positions (the 2D
/// Kabsch/Umeyama solution without scale), with the RMS and largest residual, metres. One pair
/// gives the transform of its poses (`to ⊕ from⁻¹`, headings included); none gives `None`.
pub fn fit_rigid(pairs: &[([f64; 3], [f64; 3])]) -> Option<(Rigid, f64, f64)> {
    let t = match pairs.len() {
        0 => return None,
        1 => compose(&pairs[0].1, &inverse(&pairs[0].0)),
        n => {
            let k = n as f64;
            let ca = pairs.iter().fold([0.0, 0.0], |s, (a, _)| [s[0] + a[0] / k, s[1] + a[1] / k]);
            let cb = pairs.iter().fold([0.0, 0.0], |s, (_, b)| [s[0] + b[0] / k, s[1] + b[1] / k]);
            let (mut cross, mut dot) = (0.0, 0.0);
            for (a, b) in pairs {
                let (ax, ay, bx, by) = (a[0] - ca[0], a[1] - ca[1], b[0] - cb[0], b[1] - cb[1]);
                cross += ax * by - ay * bx;
                dot += ax * bx + ay * by;
            }
            let th = cross.atan2(dot);
            let r = apply(&[0.0, 0.0, th], ca);
            [cb[0] - r[0], cb[1] - r[1], th]
        }
    };
    let res: Vec<f64> = pairs
        .iter()
        .map(|(a, b)| {
            let p = apply(&t, [a[0], a[1]]);
            (p[0] - b[0]).hypot(p[1] - b[1])
        })
        .collect();
    let rms = (res.iter().map(|r| r * r).sum::<f64>() / res.len() as f64).sqrt();
    Some((t, rms, res.iter().cloned().fold(0.0, f64::max)))
}

/// One ground-truth relation: the true pose of the robot at `t2` in its frame at `t1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relation {
    /// First time stamp, seconds.
    pub t1: f64,
    /// Second time stamp, seconds.
    pub t2: f64,
    /// `δ* = [x, y, yaw]`, metres and radians.
    pub delta: [f64; 3],
}

fn read_text(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The numbers of line `line_no` of `path`: exactly `names.len()` of them, finite. Blank lines
/// and `#` comments give `None`.
fn numbers(path: &Path, line_no: usize, text: &str, names: &[&str]) -> Result<Option<Vec<f64>>, String> {
    let text = text.trim();
    if text.is_empty() || text.starts_with('#') {
        return Ok(None);
    }
    let toks: Vec<&str> = text.split_ascii_whitespace().collect();
    let at = || format!("{}:{line_no}", path.display());
    if toks.len() != names.len() {
        return Err(format!("{}: expected {} numbers `{}`, found {} fields", at(), names.len(), names.join(" "), toks.len()));
    }
    toks.iter()
        .zip(names)
        .map(|(t, name)| match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("{}: {name} `{t}` is not a finite number", at())),
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Reads a relations file: lines `t1 t2 x y z roll pitch yaw` (z, roll and pitch are read and
/// must be numbers, but a planar pose has no use for them).
pub fn read_relations(path: &Path) -> Result<Vec<Relation>, String> {
    let mut out = Vec::new();
    for (i, line) in read_text(path)?.lines().enumerate() {
        if let Some(v) = numbers(path, i + 1, line, &["t1", "t2", "x", "y", "z", "roll", "pitch", "yaw"])? {
            out.push(Relation { t1: v[0], t2: v[1], delta: [v[2], v[3], v[7]] });
        }
    }
    if out.is_empty() {
        return Err(format!("{}: no relations in the file (expected lines `t1 t2 x y z roll pitch yaw`)", path.display()));
    }
    Ok(out)
}

/// Reads a poses file: lines `timestamp x y theta`.
pub fn read_poses(path: &Path) -> Result<Vec<TimedPose>, String> {
    let mut out = Vec::new();
    for (i, line) in read_text(path)?.lines().enumerate() {
        if let Some(v) = numbers(path, i + 1, line, &["timestamp", "x", "y", "theta"])? {
            out.push(TimedPose { t_s: v[0], pose: [v[1], v[2], v[3]] });
        }
    }
    if out.is_empty() {
        return Err(format!("{}: no poses in the file (expected lines `timestamp x y theta`)", path.display()));
    }
    Ok(out)
}

/// Poses looked up by time stamp (the nearest within [`MATCH_S`]).
pub struct PoseIndex(Vec<TimedPose>);

impl PoseIndex {
    /// Indexes `poses` (any order; of equal time stamps the first is kept).
    pub fn new(poses: &[TimedPose]) -> Self {
        let mut v: Vec<TimedPose> = poses.iter().filter(|p| p.t_s.is_finite() && p.pose.iter().all(|c| c.is_finite())).copied().collect();
        v.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        v.dedup_by(|b, a| a.t_s == b.t_s);
        PoseIndex(v)
    }

    /// The pose at `t`, if one lies within [`MATCH_S`].
    pub fn at(&self, t: f64) -> Option<[f64; 3]> {
        let i = self.0.partition_point(|p| p.t_s < t);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|j| self.0.get(j))
            .filter(|p| (p.t_s - t).abs() <= MATCH_S)
            .min_by(|a, b| (a.t_s - t).abs().total_cmp(&(b.t_s - t).abs()))
            .map(|p| p.pose)
    }
}

/// The relation errors of one pose estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelationStats {
    /// Relations whose two time stamps both have a pose.
    pub used: usize,
    /// Mean translational error, metres (`None` when none was used).
    pub trans_mean_m: Option<f64>,
    /// Its standard deviation (population, over the relations used).
    pub trans_std_m: Option<f64>,
    /// Mean absolute rotational error, degrees.
    pub rot_mean_deg: Option<f64>,
    /// Its standard deviation.
    pub rot_std_deg: Option<f64>,
    /// Mean squared translational error, m² (the paper's squared form).
    pub trans_sq_mean_m2: Option<f64>,
    /// Mean squared rotational error, deg².
    pub rot_sq_mean_deg2: Option<f64>,
}

/// The relations metric of Kümmerle et al. 2009: for every relation whose two time stamps both
/// have a pose in `poses`, `δ_est = p(t1)⁻¹ ⊕ p(t2)` and the error `e = δ*⁻¹ ⊕ δ_est`
/// (`δ_est ⊖ δ*`); its translational error is `|(e_x, e_y)|`, its rotational error `|e_θ|`.
pub fn relation_errors(poses: &PoseIndex, relations: &[Relation]) -> RelationStats {
    let mut te = Vec::new();
    let mut re = Vec::new();
    for r in relations {
        let (Some(a), Some(b)) = (poses.at(r.t1), poses.at(r.t2)) else { continue };
        let est = compose(&inverse(&a), &b);
        let e = compose(&inverse(&r.delta), &est);
        te.push(e[0].hypot(e[1]));
        re.push(wrap(e[2]).abs().to_degrees());
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let std = |v: &[f64]| mean(v).map(|m| (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64).sqrt());
    let sq = |v: &[f64]| mean(&v.iter().map(|x| x * x).collect::<Vec<_>>());
    RelationStats {
        used: te.len(),
        trans_mean_m: mean(&te),
        trans_std_m: std(&te),
        rot_mean_deg: mean(&re),
        rot_std_deg: std(&re),
        trans_sq_mean_m2: sq(&te),
        rot_sq_mean_deg2: sq(&re),
    }
}

/// The relations part of the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelationsReport {
    /// The relations file.
    pub file: String,
    /// Relations in it.
    pub relations: usize,
    /// The poses in the log's lines (for the raw CSAIL log: raw odometry), every scan of the log.
    pub log_poses: RelationStats,
    /// The poses the controller mapped each scan it used at.
    pub controller: RelationStats,
    /// The `--align` poses (e.g. the SLAM-corrected CSAIL poses), when given.
    pub align_poses: Option<RelationStats>,
}

/// How the reference was placed in this run's frame (`--reference` with `--align`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Alignment {
    /// The poses file.
    pub file: String,
    /// Poses in it.
    pub poses: usize,
    /// Of which have a pose of this run (the controller's) at their time stamp.
    pub matched: usize,
    /// The transform from this run's frame to the poses' frame `[x, y, θ]` (m, rad).
    pub transform: [f64; 3],
    /// RMS distance between the moved run positions and the matched poses, metres.
    pub rms_m: f64,
    /// The largest, metres.
    pub max_m: f64,
}

/// What the run was scored against.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferenceInfo {
    /// `log-poses` (the log's own scans at its own poses), `other-log` (`--reference`) or
    /// `true-world` (simulation).
    pub kind: String,
    /// The log drawn, for `log-poses` and `other-log`.
    pub file: Option<String>,
    /// Scans (logs) or true positions (simulation) the reference was drawn from; also the
    /// viewpoints of the leak.
    pub viewpoints: usize,
    /// Rays cast per viewpoint for the leak.
    pub rays_per_viewpoint: usize,
    /// `--align`.
    pub alignment: Option<Alignment>,
}

/// `lives mapcheck --json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapcheckReport {
    /// The log, or `world apartment easy lives seed 1`.
    pub subject: String,
    /// The reference.
    pub reference: ReferenceInfo,
    /// Lower-left corner of the grid, metres.
    pub grid_origin: [f64; 2],
    /// Cell side, metres.
    pub cell_m: f64,
    /// Grid side, metres.
    pub grid_size_m: f64,
    /// The controller's clearing range (its LiDAR range), metres: the reference's range and the
    /// leak's ray length.
    pub clearing_range_m: f64,
    /// The figures.
    pub map: MapScores,
    /// `--relations`.
    pub relations: Option<RelationsReport>,
    /// The replay (logs).
    pub replay: Option<ReplayReport>,
    /// The search (simulation).
    pub search: Option<SearchResult>,
}

/// Draws the plain projection of `scans` (each at its pose, moved by `to_grid` into the grid's
/// world frame) into `reference`: every return in `[min_range, max_range)` marks its cell, and each
/// scan's position becomes a viewpoint. `origin` is the grid's lower-left corner.
pub fn project_scans(reference: &mut Reference, scans: &[&ScanRecord], to_grid: &Rigid, origin: [f64; 2], min_range: f64, max_range: f64) {
    let c = cell_m();
    for s in scans {
        let pose = compose(to_grid, &s.pose);
        if !pose.iter().all(|v| v.is_finite()) {
            continue;
        }
        reference.viewpoints.push([(pose[0] - origin[0]) / c, (pose[1] - origin[1]) / c]);
        for (i, &r) in s.ranges_m.iter().enumerate() {
            let r = r as f64;
            if !(r.is_finite() && r >= min_range && r < max_range) {
                continue;
            }
            let a = pose[2] + s.angle_min + i as f64 * s.angle_increment;
            let p = [pose[0] + r * a.cos(), pose[1] + r * a.sin()];
            reference.mark((p[0] - origin[0]) / c, (p[1] - origin[1]) / c);
        }
    }
}

/// The scans of a log that draw a reference: finite poses that are not strays
/// ([`replay::place_grid`]).
fn drawable(scans: &[ScanRecord]) -> Vec<&ScanRecord> {
    let stray = replay::place_grid(scans).map(|p| p.stray).unwrap_or_default();
    scans
        .iter()
        .enumerate()
        .filter(|(i, s)| s.pose.iter().all(|v| v.is_finite()) && !stray.get(*i).copied().unwrap_or(false))
        .map(|(_, s)| s)
        .collect()
}

/// `lives mapcheck` arguments.
#[derive(clap::Args, Debug)]
pub struct MapcheckArgs {
    /// The log to replay and score (as `lives replay` reads it); omit it with `--world`.
    #[arg(required_unless_present = "world", conflicts_with = "world")]
    pub file: Option<PathBuf>,
    /// Score against the map drawn from another log of the same building (e.g. the SLAM-corrected
    /// CSAIL log) instead of this log's own poses; needs `--align`.
    #[arg(long, value_name = "OTHER.log", requires = "align")]
    pub reference: Option<PathBuf>,
    /// Poses `timestamp x y theta` in the `--reference` log's frame, keyed by this log's time
    /// stamps: they place the reference in this run's frame (least squares over every match).
    #[arg(long, value_name = "POSES.txt", requires = "reference")]
    pub align: Option<PathBuf>,
    /// Ground-truth relations `t1 t2 x y z roll pitch yaw` (Kümmerle et al. 2009): report the
    /// relation errors of the log's poses and of the controller's.
    #[arg(long, value_name = "FILE", conflicts_with = "world")]
    pub relations: Option<PathBuf>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Write a picture of the scored grid here (two pixels per cell): free white, free-space leak
    /// orange, matched wall black, phantom wall magenta, lost reference wall red, unknown grey.
    #[arg(long, value_name = "FILE.png")]
    pub png: Option<PathBuf>,
    /// Do not run a classifier.
    #[arg(long, conflicts_with = "model")]
    pub no_classifier: bool,
    /// The int8 classifier blob to run (as `lives replay` and `lives search`).
    #[arg(long, value_name = "BLOB")]
    pub model: Option<PathBuf>,
    /// The controller's LiDAR range for a log, metres (as `lives replay --max-range`).
    #[arg(long, value_name = "METRES", conflicts_with = "world")]
    pub max_range: Option<f64>,
    /// Override a controller parameter (repeatable; `lives params` lists them).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Simulate a search in this world instead (as `lives search --world`) and score its map
    /// against the true world.
    #[arg(long)]
    pub world: Option<String>,
    /// easy or hard (with `--world`; default easy).
    #[arg(long, requires = "world")]
    pub scenario: Option<Scenario>,
    /// The planner (with `--world`; default lives).
    #[arg(long, requires = "world")]
    pub planner: Option<PlannerChoice>,
    /// The seed (with `--world`; default 1).
    #[arg(long, requires = "world")]
    pub seed: Option<u64>,
    /// Change the simulated robot (with `--world`; as `lives search --sim`).
    #[arg(long = "sim", value_name = "NAME=VALUE", requires = "world")]
    pub sim: Vec<String>,
}

/// Runs `lives mapcheck`. `load_spec(world, scenario, planner, seed)` builds a search as `lives
/// search` does. Exit status 0, 1 when the log was not clean (as `lives replay`), `Err` (status 2)
/// on bad input.
pub fn run_command(
    args: &MapcheckArgs,
    load_spec: impl FnOnce(&str, Option<Scenario>, PlannerChoice, u64) -> Result<SearchSpec, String>,
) -> Result<std::process::ExitCode, String> {
    let (report, clean) = match (&args.world, &args.file) {
        (Some(world), _) => {
            let planner = args.planner.unwrap_or(PlannerChoice::Lives);
            let mut spec = load_spec(world, args.scenario, planner, args.seed.unwrap_or(1))?;
            for a in &args.sim {
                crate::overrides::apply_sim(&mut spec.sim, &mut spec.controller, a)?;
            }
            for a in &args.set {
                crate::overrides::apply(&mut spec.controller, a)?;
            }
            if args.model.is_some() && !planner.uses_classifier() {
                return Err(format!("--model is the classifier `lives` runs; `{planner}` runs none"));
            }
            spec.model = crate::model::model_option(args.model.as_deref(), args.no_classifier)?;
            (check_search(&spec, args.png.as_deref())?, true)
        }
        (None, Some(file)) => check_log(file, args)?,
        (None, None) => return Err("give a log to replay, or --world".into()),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?);
    } else {
        print!("{}", table(&report));
    }
    Ok(if clean { std::process::ExitCode::SUCCESS } else { std::process::ExitCode::from(1) })
}

/// Replays `file` and scores it (the bool: the log was clean).
pub fn check_log(file: &Path, args: &MapcheckArgs) -> Result<(MapcheckReport, bool), String> {
    // The options exactly as `lives replay` takes them.
    let opts = replay::options(args.model.as_deref(), args.no_classifier, &args.set, args.max_range)?;
    // Read every input file before the replay, so a bad one fails fast.
    let relations = args.relations.as_deref().map(|p| read_relations(p).map(|r| (p, r))).transpose()?;
    let align = args.align.as_deref().map(|p| read_poses(p).map(|r| (p, r))).transpose()?;
    let other = args.reference.as_deref().map(|p| replay::read_log(p).map_err(|e| e.to_string())).transpose()?;
    let t0 = Instant::now();
    let log = replay::read_log(file).map_err(|e| e.to_string())?;
    let read_s = t0.elapsed().as_secs_f64();
    let log_poses: Vec<TimedPose> = log.scans.iter().map(|s| TimedPose { t_s: s.t_s, pose: s.pose }).collect();
    let own = (other.is_none()).then(|| log.scans.clone());
    let run = replay::replay_log(log, &opts, t0, read_s).map_err(|e| e.to_string())?;
    let clean = run.bad_records.total == 0 && run.error.is_none();
    let cfg = run.controller.config();
    let range = cfg.lidar_max_range_m.to_num::<f64>();
    let min_range = cfg.lidar_min_range_m.to_num::<f64>();
    let geom = run.controller.lidar.geom;
    let origin = [geom.origin_x.to_num::<f64>(), geom.origin_y.to_num::<f64>()];
    let grid = MapGrid::of(&run.controller.lidar);
    let mut reference = Reference::new(grid.n, range);
    let (kind, ref_file, alignment) = match (&other, &align) {
        (Some(other), Some((apath, aposes))) => {
            let index = PoseIndex::new(&run.poses);
            let pairs: Vec<([f64; 3], [f64; 3])> = aposes.iter().filter_map(|p| index.at(p.t_s).map(|q| (q, p.pose))).collect();
            let Some((t, rms, max)) = fit_rigid(&pairs) else {
                return Err(format!(
                    "{}: none of its {} time stamps matches a scan the replay of {} used (within {} ms)",
                    apath.display(),
                    aposes.len(),
                    file.display(),
                    MATCH_S * 1e3
                ));
            };
            let to_grid = inverse(&t);
            project_scans(&mut reference, &drawable(&other.scans), &to_grid, origin, min_range, range);
            let a = Alignment {
                file: apath.display().to_string(),
                poses: aposes.len(),
                matched: pairs.len(),
                transform: t,
                rms_m: rms,
                max_m: max,
            };
            ("other-log", Some(other.file.display().to_string()), Some(a))
        }
        (None, _) => {
            let own = own.unwrap_or_default();
            project_scans(&mut reference, &drawable(&own), &[0.0, 0.0, 0.0], origin, min_range, range);
            ("log-poses", Some(file.display().to_string()), None)
        }
        (Some(_), None) => return Err("--reference needs --align POSES.txt (its poses keyed by this log's time stamps)".into()),
    };
    let (map, classes) = score_cells(&grid, &reference, range, RAYS);
    if let Some(p) = &args.png {
        write_png(p, grid.n, &classes)?;
    }
    let relations = relations.map(|(p, rels)| RelationsReport {
        file: p.display().to_string(),
        relations: rels.len(),
        log_poses: relation_errors(&PoseIndex::new(&log_poses), &rels),
        controller: relation_errors(&PoseIndex::new(&run.poses), &rels),
        align_poses: align.as_ref().map(|(_, a)| relation_errors(&PoseIndex::new(a), &rels)),
    });
    let report = MapcheckReport {
        subject: file.display().to_string(),
        reference: ReferenceInfo {
            kind: kind.into(),
            file: ref_file,
            viewpoints: reference.viewpoints.len(),
            rays_per_viewpoint: RAYS,
            alignment,
        },
        grid_origin: origin,
        cell_m: cell_m(),
        grid_size_m: grid.n as f64 * cell_m(),
        clearing_range_m: range,
        map,
        relations,
        replay: Some(run.report),
        search: None,
    };
    Ok((report, clean))
}

/// Runs the search `spec` and scores its final LiDAR grid against the true world.
pub fn check_search(spec: &SearchSpec, png: Option<&Path>) -> Result<MapcheckReport, String> {
    use crate::sim::geometry::{SceneBuilder, NO_OWNER};
    let run = crate::search::try_run(spec, |_| {}).map_err(|e| format!("the classifier model does not validate: {e}"))?;
    let cfg = run.controller.config();
    let range = cfg.lidar_max_range_m.to_num::<f64>();
    let geom = run.controller.lidar.geom;
    let origin = [geom.origin_x.to_num::<f64>(), geom.origin_y.to_num::<f64>()];
    let grid = MapGrid::of(&run.controller.lidar);
    // The static true world: walls, furniture, clutter and the placed targets (people move).
    let world = run.sim.world();
    let mut b = SceneBuilder::new();
    for w in &world.walls {
        b.wall(w[0], w[1]);
    }
    for (i, o) in world.obstacles.iter().enumerate() {
        b.shape(&o.shape, o.kind, i as u32);
    }
    for (i, s) in run.sim.target_shapes().iter().enumerate() {
        b.shape(s, crate::sim::HitKind::Target, crate::sim::geometry::TARGET_OWNER_BASE + i as u32);
    }
    let scene = b.build(0.5);
    // One scan per tick, taken at trajectory[k] (the last entry is where the base stopped after
    // the last tick, not scanned).
    let scanned = &run.trajectory[..run.trajectory.len().min(run.result.ticks as usize)];
    let beams = spec.sim.beams.max(1);
    let sim_range = spec.sim.lidar_max_range_m.min(range);
    let mut reference = Reference::new(grid.n, range);
    let c = cell_m();
    for p in scanned {
        reference.viewpoints.push([(p[0] - origin[0]) / c, (p[1] - origin[1]) / c]);
        for k in 0..beams {
            let a = 2.0 * std::f64::consts::PI * k as f64 / beams as f64;
            let d = [a.cos(), a.sin()];
            if let Some(h) = scene.raycast(*p, d, sim_range, NO_OWNER) {
                if h.t < spec.sim.lidar_min_range_m {
                    continue;
                }
                // Just behind the surface, so a wall on a cell boundary goes to the far cell.
                let t = h.t + 1e-6;
                reference.mark((p[0] + t * d[0] - origin[0]) / c, (p[1] + t * d[1] - origin[1]) / c);
            }
        }
    }
    let (map, classes) = score_cells(&grid, &reference, range, RAYS);
    if let Some(p) = png {
        write_png(p, grid.n, &classes)?;
    }
    let r = &run.result;
    Ok(MapcheckReport {
        subject: format!("world {} {} {} seed {}", r.world, r.scenario, r.planner, r.seed),
        reference: ReferenceInfo {
            kind: "true-world".into(),
            file: None,
            viewpoints: reference.viewpoints.len(),
            rays_per_viewpoint: RAYS,
            alignment: None,
        },
        grid_origin: origin,
        cell_m: c,
        grid_size_m: grid.n as f64 * c,
        clearing_range_m: range,
        map,
        relations: None,
        replay: None,
        search: Some(run.result),
    })
}

fn pct(v: Option<f64>) -> String {
    v.map_or("n/a".into(), |v| format!("{:.1} %", 100.0 * v))
}

fn pm(mean: Option<f64>, std: Option<f64>, digits: usize) -> String {
    match (mean, std) {
        (Some(m), Some(s)) => format!("{m:.digits$} ± {s:.digits$}"),
        _ => "n/a".into(),
    }
}

/// The human-readable table.
pub fn table(r: &MapcheckReport) -> String {
    let mut s = String::new();
    let m = &r.map;
    let _ = writeln!(s, "mapcheck {}", r.subject);
    if let Some(p) = &r.replay {
        let _ = writeln!(
            s,
            "  replay: {} scans read, {} used, {} rejected ({} outside the grid); grid {:.1} m at ({:.1}, {:.1}), clearing range {:.1} m",
            p.scans_read,
            p.scans_used,
            p.scans_rejected,
            p.rejected.outside_grid,
            r.grid_size_m,
            r.grid_origin[0],
            r.grid_origin[1],
            r.clearing_range_m
        );
    }
    if let Some(q) = &r.search {
        let _ = writeln!(
            s,
            "  search: {} after {:.1} s, {} ticks; grid {:.1} m at ({:.1}, {:.1}), LiDAR range {:.1} m",
            q.outcome, q.time_s, q.ticks, r.grid_size_m, r.grid_origin[0], r.grid_origin[1], r.clearing_range_m
        );
    }
    let what = match r.reference.kind.as_str() {
        "log-poses" => "the log's own scans at its own poses".to_string(),
        "other-log" => format!("the scans of {} at its poses", r.reference.file.as_deref().unwrap_or("?")),
        _ => "the true world's walls and obstacles the run's noise-free rays hit".to_string(),
    };
    let _ =
        writeln!(s, "  reference: {what}; {} viewpoints × {} rays for the leak", r.reference.viewpoints, r.reference.rays_per_viewpoint);
    if let Some(a) = &r.reference.alignment {
        let _ = writeln!(
            s,
            "  aligned by {}: {} of {} poses matched, transform ({:.3} m, {:.3} m, {:.2}°), residual RMS {:.2} m, max {:.2} m",
            a.file,
            a.matched,
            a.poses,
            a.transform[0],
            a.transform[1],
            a.transform[2].to_degrees(),
            a.rms_m,
            a.max_m
        );
    }
    let _ = writeln!(s, "  {:<18} {:>8}   cells (within {TOLERANCE_M} m, at {} m cells)", "figure", "value", r.cell_m);
    let _ = writeln!(
        s,
        "  {:<18} {:>8}   {} of {} reference wall cells in the grid ({} more in the margin outside it)",
        "walls recovered",
        pct(m.walls_recovered),
        m.recovered_cells,
        m.reference_wall_cells,
        m.reference_walls_outside_grid
    );
    let _ =
        writeln!(s, "  {:<18} {:>8}   {} of {} occupied cells", "phantom walls", pct(m.phantom_walls), m.phantom_cells, m.occupied_cells);
    let _ = writeln!(s, "  {:<18} {:>8}   {} of {} free cells", "free-space leak", pct(m.free_space_leak), m.leak_cells, m.free_cells);
    if let Some(rel) = &r.relations {
        let _ = writeln!(s, "  relations {} ({} relations): translation (m) and rotation (°), mean ± std", rel.file, rel.relations);
        let mut row = |name: &str, st: &RelationStats| {
            let _ = writeln!(
                s,
                "  {:<18} {:>5} used   {:>15} m   {:>15}°",
                name,
                st.used,
                pm(st.trans_mean_m, st.trans_std_m, 2),
                pm(st.rot_mean_deg, st.rot_std_deg, 2)
            );
        };
        row("log poses", &rel.log_poses);
        row("controller", &rel.controller);
        if let Some(a) = &rel.align_poses {
            row("--align poses", a);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    const N: i32 = 40;

    /// A reference with a vertical wall at column `x` from row 10 to 29, seen from `(10.5, 20.5)`.
    fn wall_reference(x: i32) -> Reference {
        let mut r = Reference::new(N, 3.0);
        for y in 10..30 {
            r.mark_cell(x, y);
        }
        r.viewpoints.push([10.5, 20.5]);
        r
    }

    fn grid_with_wall(x: i32) -> MapGrid {
        let mut g = MapGrid::new(N);
        for y in 10..30 {
            g.set(x, y, Cell::Occupied);
        }
        g
    }

    #[test]
    fn near_offsets_are_the_13_cells_within_two_tenths() {
        let v = near_offsets();
        assert_eq!(v.len(), 13);
        assert!(v.contains(&(2, 0)) && v.contains(&(1, 1)) && v.contains(&(0, -2)));
        assert!(!v.contains(&(2, 1)), "√5 · 0.1 m = 0.224 m is beyond 0.2 m");
    }

    #[test]
    fn a_wall_fully_recovered() {
        let s = score(&grid_with_wall(20), &wall_reference(20), 3.0, RAYS);
        assert_eq!((s.reference_wall_cells, s.recovered_cells, s.occupied_cells, s.phantom_cells), (20, 20, 20, 0));
        assert_eq!((s.walls_recovered, s.phantom_walls), (Some(1.0), Some(0.0)));
        // No free cells: no leak figure.
        assert_eq!((s.free_cells, s.free_space_leak), (0, None));
    }

    #[test]
    fn a_wall_shifted_by_two_tenths_is_recovered_and_by_three_tenths_is_not() {
        // 0.2 m: every cell matches its neighbour two columns over.
        let s = score(&grid_with_wall(22), &wall_reference(20), 3.0, RAYS);
        assert_eq!((s.recovered_cells, s.phantom_cells), (20, 0));
        // 0.3 m: nothing matches; every reference cell lost, every grid cell a phantom.
        let s = score(&grid_with_wall(23), &wall_reference(20), 3.0, RAYS);
        assert_eq!((s.recovered_cells, s.phantom_cells), (0, 20));
        assert_eq!((s.walls_recovered, s.phantom_walls), (Some(0.0), Some(1.0)));
        // Half the grid's wall shifted: rows 10–19 at 0.3 m, rows 20–29 in place.
        let mut g = grid_with_wall(20);
        for y in 10..20 {
            g.set(20, y, Cell::Unknown);
            g.set(23, y, Cell::Occupied);
        }
        let s = score(&g, &wall_reference(20), 3.0, RAYS);
        // Reference cell (20, 19) has the grid's (20, 20) one cell above it, (20, 18) has it two
        // above: both recovered. Rows 10–17 have no occupied cell within 0.2 m (the nearest in
        // column 23 are 3 cells away): lost. 2 + 10 = 12 recovered.
        assert_eq!(s.recovered_cells, 12);
        // Grid cells (23, 10..20): nearest reference column is 3 cells away: all phantom.
        assert_eq!(s.phantom_cells, 10);
    }

    #[test]
    fn free_space_behind_a_wall_leaks() {
        // The viewpoint at (10.5, 20.5) sees up to and including the wall at column 20, rows
        // 10–29; the wall is 20 cells long, so rays leaving above or below it go on.
        let reference = wall_reference(20);
        // Free cells in front of the wall: seen.
        let mut g = grid_with_wall(20);
        for x in 12..20 {
            g.set(x, 20, Cell::Free);
        }
        let s = score(&g, &reference, 3.0, RAYS);
        assert_eq!((s.free_cells, s.leak_cells), (8, 0));
        // Free cells straight behind the wall, at x = 21..=28, row 20: the nearest cell the
        // viewpoint sees is the wall cell (20, 20); x = 21 and 22 are within 0.2 m of it, the
        // six from 23 on are leaks.
        for x in 21..29 {
            g.set(x, 20, Cell::Free);
        }
        let s = score(&g, &reference, 3.0, RAYS);
        assert_eq!((s.free_cells, s.leak_cells), (16, 6));
        assert_eq!(s.free_space_leak, Some(6.0 / 16.0));
        // Without the wall in the reference the viewpoint sees them (all within 3 m = 30 cells):
        // no leak.
        let mut open = Reference::new(N, 3.0);
        open.viewpoints.push([10.5, 20.5]);
        assert_eq!(score(&g, &open, 3.0, RAYS).leak_cells, 0);
        // With a 1 m clearing range (10 cells) the rays see the cells within 10 cells of the
        // viewpoint: on row 20 up to column 20 (entered at t = 9.5; column 21's nearest point
        // is 10.5 cells away, as are those of its neighbours off the row). Free cells up to
        // column 22 lie within 0.2 m of (20, 20); columns 23..=28 leak.
        let s = score(&g, &open, 1.0, RAYS);
        assert_eq!(s.leak_cells, 6);
    }

    #[test]
    fn a_diagonal_wall_stops_rays() {
        // A 45° staircase wall of 8-connected cells; a viewpoint on one side, free cells on the
        // other, far from the wall: a ray cannot slip between two diagonal wall cells.
        let mut r = Reference::new(N, 3.0);
        for k in 0..N {
            r.mark_cell(k, k);
        }
        r.viewpoints.push([5.5, 30.5]);
        let mut g = MapGrid::new(N);
        g.set(30, 10, Cell::Free);
        g.set(31, 5, Cell::Free);
        let s = score(&g, &r, 5.0, RAYS);
        assert_eq!((s.free_cells, s.leak_cells), (2, 2));
    }

    #[test]
    fn pose_algebra() {
        let a = [1.0, 2.0, 0.5];
        let b = [-0.3, 0.7, -1.2];
        let ab = compose(&a, &b);
        let back = compose(&inverse(&a), &ab);
        for k in 0..3 {
            assert!((back[k] - b[k]).abs() < 1e-12, "{back:?}");
        }
        assert_eq!(wrap(std::f64::consts::PI), std::f64::consts::PI);
        assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
    }

    fn timed(t: f64, pose: [f64; 3]) -> TimedPose {
        TimedPose { t_s: t, pose }
    }

    #[test]
    fn relation_errors_on_a_hand_made_trajectory() {
        // The truth: 1 m forward, then a 90° left turn in place, then 1 m forward.
        // p0 = (0, 0, 0), p1 = (1, 0, 0), p2 = (1, 0, 90°), p3 = (1, 1, 90°).
        let q = std::f64::consts::FRAC_PI_2;
        let rels = [
            Relation { t1: 0.0, t2: 1.0, delta: [1.0, 0.0, 0.0] },
            Relation { t1: 1.0, t2: 2.0, delta: [0.0, 0.0, q] },
            Relation { t1: 2.0, t2: 3.0, delta: [1.0, 0.0, 0.0] },
            // A relation whose end has no pose: not used.
            Relation { t1: 3.0, t2: 4.0, delta: [1.0, 0.0, 0.0] },
        ];
        // A perfect estimate, in another frame (moved and turned): zero error.
        let moved = |p: [f64; 3]| compose(&[5.0, -3.0, 1.0], &p);
        let perfect: Vec<TimedPose> = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, q], [1.0, 1.0, q]]
            .iter()
            .enumerate()
            .map(|(i, p)| timed(i as f64, moved(*p)))
            .collect();
        let s = relation_errors(&PoseIndex::new(&perfect), &rels);
        assert_eq!(s.used, 3);
        assert!(s.trans_mean_m.unwrap() < 1e-12 && s.rot_mean_deg.unwrap() < 1e-9, "{s:?}");
        // An estimate that drives 1.2 m on the first leg and turns 100° instead of 90°:
        // relation 1: δ_est = (1.2, 0, 0): error 0.2 m, 0°;
        // relation 2: δ_est = (0, 0, 100°): error 0 m, 10°;
        // relation 3: from (1.2, 0, 100°) 1 m forward: δ_est = (1, 0, 0): no error.
        let ten = 10f64.to_radians();
        let p2 = [1.2, 0.0, q + ten];
        let est = [timed(0.0, [0.0, 0.0, 0.0]), timed(1.0, [1.2, 0.0, 0.0]), timed(2.0, p2), timed(3.0, compose(&p2, &[1.0, 0.0, 0.0]))];
        let s = relation_errors(&PoseIndex::new(&est), &rels);
        assert_eq!(s.used, 3);
        let close = |a: Option<f64>, b: f64| (a.unwrap() - b).abs() < 1e-9;
        // Translations 0.2, 0, 0: mean 0.2/3, population std √(Σ(x−m)²/3).
        let m: f64 = 0.2 / 3.0;
        let sd = (((0.2 - m) * (0.2 - m) + 2.0 * m * m) / 3.0).sqrt();
        assert!(close(s.trans_mean_m, m) && close(s.trans_std_m, sd), "{s:?}");
        // Rotations 0°, 10°, 0°.
        let m: f64 = 10.0 / 3.0;
        let sd = (((10.0 - m) * (10.0 - m) + 2.0 * m * m) / 3.0).sqrt();
        assert!(close(s.rot_mean_deg, m) && close(s.rot_std_deg, sd), "{s:?}");
        // Time stamps match within 1 ms, not beyond.
        let shifted: Vec<TimedPose> = est.iter().map(|p| timed(p.t_s + 0.0009, p.pose)).collect();
        assert_eq!(relation_errors(&PoseIndex::new(&shifted), &rels).used, 3);
        let shifted: Vec<TimedPose> = est.iter().map(|p| timed(p.t_s + 0.0011, p.pose)).collect();
        let s = relation_errors(&PoseIndex::new(&shifted), &rels);
        assert_eq!((s.used, s.trans_mean_m), (0, None));
    }

    #[test]
    fn rigid_fit_recovers_a_known_transform() {
        let t = [3.0, -2.0, 0.7];
        let pts = [[0.0, 0.0, 0.1], [4.0, 1.0, 0.2], [-2.0, 5.0, 0.3], [1.0, -3.0, 0.0]];
        let pairs: Vec<([f64; 3], [f64; 3])> = pts.iter().map(|p| (*p, compose(&t, p))).collect();
        let (f, rms, max) = fit_rigid(&pairs).unwrap();
        for k in 0..3 {
            assert!((f[k] - t[k]).abs() < 1e-9, "{f:?}");
        }
        assert!(rms < 1e-9 && max < 1e-9);
        // One pair: the transform of its poses.
        let (f, _, _) = fit_rigid(&pairs[1..2]).unwrap();
        for k in 0..3 {
            assert!((f[k] - t[k]).abs() < 1e-9, "{f:?}");
        }
        // A point 1 m off among four: the residuals say so.
        let mut bad = pairs.clone();
        bad[0].1[0] += 1.0;
        let (_, rms, max) = fit_rigid(&bad).unwrap();
        assert!(rms > 0.3 && max > 0.5 && max < 1.0, "{rms} {max}");
        assert!(fit_rigid(&[]).is_none());
    }

    #[test]
    fn bad_relation_and_pose_lines_name_the_file_and_line() {
        let dir = std::env::temp_dir().join(format!("lives-mapcheck-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rel = dir.join("bad.relations");
        std::fs::write(&rel, "# comment\n1 2 0.1 0 0 0 0 0.05\n\n1 2 0.1 0 0 0 0\n").unwrap();
        let e = read_relations(&rel).unwrap_err();
        assert_eq!(e, format!("{}:4: expected 8 numbers `t1 t2 x y z roll pitch yaw`, found 7 fields", rel.display()));
        std::fs::write(&rel, "1 2 0.1 0 0 0 0 nan\n").unwrap();
        assert_eq!(read_relations(&rel).unwrap_err(), format!("{}:1: yaw `nan` is not a finite number", rel.display()));
        std::fs::write(&rel, "# only a comment\n").unwrap();
        assert!(read_relations(&rel).unwrap_err().contains("no relations"));
        std::fs::write(&rel, "1 2 0.1 0 0 0 0 0.05\n").unwrap();
        assert_eq!(read_relations(&rel).unwrap(), [Relation { t1: 1.0, t2: 2.0, delta: [0.1, 0.0, 0.05] }]);
        let poses = dir.join("bad.txt");
        std::fs::write(&poses, "1.5 0 0 x0\n").unwrap();
        assert_eq!(read_poses(&poses).unwrap_err(), format!("{}:1: theta `x0` is not a finite number", poses.display()));
        let missing = dir.join("missing.txt");
        assert!(read_poses(&missing).unwrap_err().starts_with(&format!("{}: ", missing.display())));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
