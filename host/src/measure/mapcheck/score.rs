//! The map figures: walls recovered, phantom walls and free-space leak, and their picture.

use super::*;
use firmware::Cell;
use serde::Serialize;
use std::path::Path;

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

pub(super) fn share(k: u64, n: u64) -> Option<f64> {
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
            if reference.is_wall(x, y) && (!reference.seen_walls_only || seen(x, y)) {
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
