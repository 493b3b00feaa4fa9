//! A world's true map, as map_server would hold a map of it (`lives map export`): its walls and
//! static obstacles (furniture and clutter; not the targets, not the people) rasterised at the
//! controller's 0.1 m over [`World::grid_over_bounds`] (the world's bounds and 0.5 m around, the
//! corner moved down onto the 0.1 m lattice), written as `NAME.pgm` (occupied 0, free 254,
//! unknown 205, as map_saver writes them) and `NAME.yaml`.
//!
//! A cell is occupied when a wall or an obstacle's outline passes through it (the cell that
//! holds each point of it, as the controller's grid places a LiDAR hit) or its centre is inside
//! an obstacle; free when it is reached from the start cell through cells that are not occupied
//! (4-connected: the building's floor); unknown otherwise (outside the building, inside closed
//! furniture).

use super::{Cell3, PriorMap};
use crate::sim::World;
use std::collections::VecDeque;
use std::path::Path;

/// The exported map's cell, metres: the controller's.
pub const EXPORT_RESOLUTION_M: f64 = 1.0 / firmware::capacity::CELLS_PER_METER as f64;

/// Pixel values map_saver writes.
pub const PGM_OCCUPIED: u8 = 0;
pub const PGM_FREE: u8 = 254;
pub const PGM_UNKNOWN: u8 = 205;

/// The true map of `world`; `file` is the name it will carry.
pub fn true_map(world: &World, file: &str) -> PriorMap {
    let res = EXPORT_RESOLUTION_M;
    let (o, nx, ny) = world.grid_over_bounds(res);
    // Onto the lattice (a search's grid is placed on it too), one more cell to keep the margin.
    let origin = [(o[0] / res).floor() * res, (o[1] / res).floor() * res];
    let (nx, ny) = ((nx + 1).min(2001), (ny + 1).min(2001));
    let mut cells = vec![Cell3::Unknown; nx * ny];
    let index = |p: [f64; 2]| -> Option<usize> {
        let x = ((p[0] - origin[0]) / res).floor();
        let y = ((p[1] - origin[1]) / res).floor();
        (x >= 0.0 && y >= 0.0 && x < nx as f64 && y < ny as f64).then(|| y as usize * nx + x as usize)
    };
    let mark_segment = |cells: &mut Vec<Cell3>, a: [f64; 2], b: [f64; 2]| {
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        // Points every eighth of a cell: every cell the segment crosses by more than that.
        let steps = ((len / (res / 8.0)).ceil() as usize).clamp(1, 1 << 20);
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            if let Some(i) = index([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]) {
                cells[i] = Cell3::Occupied;
            }
        }
    };
    for w in &world.walls {
        mark_segment(&mut cells, w[0], w[1]);
    }
    for ob in &world.obstacles {
        let poly = ob.shape.polygon();
        for k in 0..poly.len() {
            mark_segment(&mut cells, poly[k], poly[(k + 1) % poly.len()]);
        }
        let [lo, hi] = ob.shape.aabb();
        let (Some(a), Some(b)) = (index(lo), index(hi)) else { continue };
        for y in a / nx..=b / nx {
            for x in a % nx..=b % nx {
                let c = [origin[0] + (x as f64 + 0.5) * res, origin[1] + (y as f64 + 0.5) * res];
                if ob.shape.contains(c) {
                    cells[y * nx + x] = Cell3::Occupied;
                }
            }
        }
    }
    // The floor: flooded from the start.
    if let Some(s) = index([world.start.pose[0], world.start.pose[1]]).filter(|&s| cells[s] == Cell3::Unknown) {
        let mut queue = VecDeque::from([s]);
        cells[s] = Cell3::Free;
        while let Some(i) = queue.pop_front() {
            let (x, y) = (i % nx, i / nx);
            let mut next = |j: usize| {
                if cells[j] == Cell3::Unknown {
                    cells[j] = Cell3::Free;
                    queue.push_back(j);
                }
            };
            if x > 0 {
                next(i - 1);
            }
            if x + 1 < nx {
                next(i + 1);
            }
            if y > 0 {
                next(i - nx);
            }
            if y + 1 < ny {
                next(i + nx);
            }
        }
    }
    PriorMap { file: file.to_string(), resolution_m: res, origin: [origin[0], origin[1], 0.0], width: nx, height: ny, cells }
}

/// A grid's map (`lives replay --map-out`, as `map_saver` saves a SLAM map): `n × n` cells of
/// `res` metres, lower-left corner at `origin`, `cell(x, y)` its state; cropped to the known
/// cells' box grown by [`GRID_MAP_MARGIN_CELLS`] (clipped to the grid). `None` when every cell is
/// unknown.
pub fn from_grid(cell: impl Fn(usize, usize) -> Cell3, n: usize, origin: [f64; 2], res: f64, file: &str) -> Option<PriorMap> {
    let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
    for y in 0..n {
        for x in 0..n {
            if cell(x, y) != Cell3::Unknown {
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
            }
        }
    }
    if lo[0] == usize::MAX {
        return None;
    }
    let m = GRID_MAP_MARGIN_CELLS;
    let (x0, y0) = (lo[0].saturating_sub(m), lo[1].saturating_sub(m));
    let (x1, y1) = ((hi[0] + m).min(n - 1), (hi[1] + m).min(n - 1));
    let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
    let mut cells = Vec::with_capacity(w * h);
    for y in y0..=y1 {
        for x in x0..=x1 {
            cells.push(cell(x, y));
        }
    }
    let o = [origin[0] + x0 as f64 * res, origin[1] + y0 as f64 * res, 0.0];
    Some(PriorMap { file: file.to_string(), resolution_m: res, origin: o, width: w, height: h, cells })
}

/// Unknown cells kept around a grid map's known ones.
pub const GRID_MAP_MARGIN_CELLS: usize = 5;

/// The map as a binary PGM, its top row the map's highest y.
pub fn to_pgm(map: &PriorMap, comment: &str) -> Vec<u8> {
    let mut out = format!("P5\n# {}\n{} {}\n255\n", comment.replace(['\n', '\r'], " "), map.width, map.height).into_bytes();
    for y in (0..map.height).rev() {
        out.extend(map.cells[y * map.width..(y + 1) * map.width].iter().map(|c| match c {
            Cell3::Occupied => PGM_OCCUPIED,
            Cell3::Free => PGM_FREE,
            Cell3::Unknown => PGM_UNKNOWN,
        }));
    }
    out
}

/// The map_server YAML for `map` with its image at `image` (relative to the YAML file).
pub fn to_yaml(map: &PriorMap, image: &str) -> String {
    // The image name is quoted as a JSON string, which YAML reads the same way.
    format!(
        "image: {}\nmode: trinary\nresolution: {}\norigin: [{}, {}, 0.0]\nnegate: 0\noccupied_thresh: {}\nfree_thresh: {}\n",
        serde_json::to_string(image).unwrap_or_default(),
        map.resolution_m,
        map.origin[0],
        map.origin[1],
        super::DEFAULT_OCCUPIED_THRESH,
        super::DEFAULT_FREE_THRESH,
    )
}

/// Writes `map` as `yaml` and the PGM beside it (the YAML's name with `.pgm`); returns the
/// PGM's path.
pub fn write(map: &PriorMap, yaml: &Path, comment: &str) -> Result<std::path::PathBuf, String> {
    let pgm = yaml.with_extension("pgm");
    // Nothing is written unless both files can be: a directory or a device as the map file.
    for p in [yaml, pgm.as_path()] {
        if p.exists() && !p.is_file() {
            return Err(format!("{}: exists and is not a regular file (a directory or a device): give a file name", p.display()));
        }
    }
    if pgm == yaml {
        return Err(format!("{}: the map file needs a name other than its image's (use .yaml)", yaml.display()));
    }
    let image = pgm.file_name().map(|n| n.to_string_lossy().into_owned()).ok_or_else(|| format!("{}: not a file name", yaml.display()))?;
    if let Some(dir) = yaml.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(&pgm, to_pgm(map, comment)).map_err(|e| format!("{}: {e}", pgm.display()))?;
    std::fs::write(yaml, to_yaml(map, &image)).map_err(|e| format!("{}: {e}", yaml.display()))?;
    Ok(pgm)
}
