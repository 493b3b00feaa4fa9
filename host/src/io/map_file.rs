//! Prior maps in the ROS `map_server` format (issue 32; `docs/map-files.md`): a YAML file that
//! names an image (PGM `P5`/`P2` or PNG) and places it in the world, read into a three-state
//! [`PriorMap`] and resampled onto the controller's grid ([`PriorMap::to_grid`]). `export`
//! writes a world's true map in the same format (`lives map export`).
//!
//! The rules are map_server's: a pixel of value `v` has occupancy `p = (255 - v) / 255` (`v /
//! 255` with `negate`), and is occupied when `p > occupied_thresh`, free when `p < free_thresh`,
//! unknown otherwise (`scale` mode's in-between values too: the controller's grid has three
//! states); the image's top row is the map's highest y. Every problem is a [`MapError`] naming
//! the file (and the key or line where there is one); no input makes the reader panic.

pub mod export;
mod image;
pub mod world;

use std::fmt;
use std::path::{Path, PathBuf};

/// A map cell's state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Cell3 {
    // The order is the precedence when cells are merged: occupied over free over unknown.
    Unknown,
    Free,
    Occupied,
}

/// A map read from a map_server YAML file and its image.
#[derive(Clone, Debug, PartialEq)]
pub struct PriorMap {
    /// The YAML file it came from, as given (errors name it).
    pub file: String,
    /// The side of a cell, metres.
    pub resolution_m: f64,
    /// The pose of the lower-left cell's lower-left corner in the map frame: x, y (metres) and
    /// yaw (radians, counter-clockwise; map_server's `origin`). The image's rows and columns run
    /// along the axes turned by the yaw ([`PriorMap::world`]).
    pub origin: [f64; 3],
    /// Cells in x (the image's columns).
    pub width: usize,
    /// Cells in y (the image's rows).
    pub height: usize,
    /// `width * height` cells, row by row from the lowest y (`cells[y * width + x]`; the image's
    /// last row is row 0).
    pub cells: Vec<Cell3>,
}

/// Cells of each state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CellCounts {
    pub occupied: usize,
    pub free: usize,
    pub unknown: usize,
}

/// Why a map could not be read or placed. `Display` is `FILE:LINE: problem` (`FILE: problem`
/// when there is no line); the problem names the key where one is at fault.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MapError {
    /// The file at fault: the YAML file, or the image it names.
    pub file: String,
    /// The 1-based line of the YAML file, where known.
    pub line: Option<usize>,
    pub message: String,
}

impl fmt::Display for MapError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{}: {}", self.file, l, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

impl std::error::Error for MapError {}

impl MapError {
    fn new(file: &str, message: impl Into<String>) -> MapError {
        MapError { file: file.to_string(), line: None, message: message.into() }
    }
}

/// A YAML file larger than this is refused (a map_server YAML is a few hundred bytes).
pub const MAX_YAML_BYTES: u64 = 1 << 20;
/// An image with more pixels than this is refused (a 51.2 m grid at 0.1 m is 262,144 cells; a
/// 5 cm map of a 400 m building, 64 M).
pub const MAX_PIXELS: usize = 1 << 26;
/// An image file larger than this is refused.
pub const MAX_IMAGE_BYTES: u64 = 1 << 30;

/// map_server's `mode`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Trinary,
    Scale,
}

/// The YAML file's contents, checked.
#[derive(Clone, Debug, PartialEq)]
pub struct MapMeta {
    /// The `image` key as written.
    pub image: String,
    pub resolution_m: f64,
    pub origin: [f64; 3],
    pub negate: bool,
    pub occupied_thresh: f64,
    pub free_thresh: f64,
    pub mode: Mode,
}

/// The thresholds ROS map_saver writes (its unknown grey 205 is p = 0.19608, just above 0.196),
/// used when the file gives none.
pub const DEFAULT_OCCUPIED_THRESH: f64 = 0.65;
pub const DEFAULT_FREE_THRESH: f64 = 0.196;

/// The 1-based line where top-level `key` is set in `text`, if it is found.
fn key_line(text: &str, key: &str) -> Option<usize> {
    text.lines()
        .position(|l| {
            let l = l.trim_start_matches('\u{feff}');
            l.strip_prefix(key).is_some_and(|rest| rest.trim_start().starts_with(':'))
                || l.strip_prefix(&format!("\"{key}\"")).is_some_and(|r| r.trim_start().starts_with(':'))
        })
        .map(|i| i + 1)
}

fn value_text(v: &serde_yaml_ng::Value) -> String {
    match v {
        serde_yaml_ng::Value::Null => "nothing".into(),
        serde_yaml_ng::Value::Bool(b) => b.to_string(),
        serde_yaml_ng::Value::Number(n) => n.to_string(),
        serde_yaml_ng::Value::String(s) => format!("{s:?}"),
        serde_yaml_ng::Value::Sequence(_) => "a list".into(),
        serde_yaml_ng::Value::Mapping(_) => "a mapping".into(),
        serde_yaml_ng::Value::Tagged(_) => "a tagged value".into(),
    }
}

fn as_number(v: &serde_yaml_ng::Value) -> Option<f64> {
    match v {
        serde_yaml_ng::Value::Number(n) => n.as_f64(),
        // `.nan`, `.inf` are numbers to YAML; a quoted "1.5" is not, but map_server's parser
        // (yaml-cpp `as<double>`) takes it, so do we.
        serde_yaml_ng::Value::String(s) => s.trim().parse::<f64>().ok(),
        _ => None,
    }
}

impl MapMeta {
    /// Parses and checks a map_server YAML file's text; `file` is its name for errors.
    pub fn parse(text: &str, file: &str) -> Result<MapMeta, MapError> {
        use serde_yaml_ng::Value;
        let doc: Value = serde_yaml_ng::from_str(text).map_err(|e| MapError {
            file: file.to_string(),
            // (libyaml may place an error at the end, past the last line.)
            line: e.location().map(|l| l.line().clamp(1, yaml_lines(text))),
            message: format!("not valid YAML: {}", strip_location(&e.to_string())),
        })?;
        let Value::Mapping(map) = doc else {
            return Err(MapError::new(
                file,
                format!("not a map_server map file: expected keys (image, resolution, origin, ...), found {}", value_text(&doc)),
            ));
        };
        let err = |key: &str, message: String| MapError {
            file: file.to_string(),
            line: key_line(text, key),
            message: format!("`{key}`: {message}"),
        };
        let get = |key: &str| map.get(Value::String(key.to_string()));
        let number = |key: &str, default: Option<f64>| -> Result<f64, MapError> {
            match get(key) {
                None => default.ok_or_else(|| {
                    MapError::new(file, format!("no `{key}` key (a map_server map file needs image, resolution and origin)"))
                }),
                Some(v) => as_number(v).ok_or_else(|| err(key, format!("expected a number, found {}", value_text(v)))),
            }
        };
        let image = match get("image") {
            None => return Err(MapError::new(file, "no `image` key (a map_server map file needs image, resolution and origin)")),
            Some(Value::String(s)) if !s.trim().is_empty() => s.trim().to_string(),
            Some(v) => return Err(err("image", format!("expected the image's file name, found {}", value_text(v)))),
        };
        let resolution_m = number("resolution", None)?;
        if !(resolution_m.is_finite() && resolution_m > 0.0) {
            return Err(err("resolution", format!("{resolution_m} is not a positive number of metres per cell")));
        }
        let origin = match get("origin") {
            None => return Err(MapError::new(file, "no `origin` key (a map_server map file needs image, resolution and origin)")),
            Some(Value::Sequence(s)) if s.len() == 3 => {
                let mut o = [0.0; 3];
                for (k, (v, name)) in s.iter().zip(["x", "y", "yaw"]).enumerate() {
                    o[k] = as_number(v).ok_or_else(|| err("origin", format!("{name} should be a number, found {}", value_text(v))))?;
                    if !o[k].is_finite() {
                        return Err(err("origin", format!("{name} is {}, not a finite number", o[k])));
                    }
                }
                o
            }
            Some(v) => return Err(err("origin", format!("expected [x, y, yaw], found {}", value_text(v)))),
        };
        let negate = match get("negate") {
            None => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => match as_number(v) {
                Some(0.0) => false,
                Some(1.0) => true,
                _ => return Err(err("negate", format!("expected 0 or 1, found {}", value_text(v)))),
            },
        };
        let occupied_thresh = number("occupied_thresh", Some(DEFAULT_OCCUPIED_THRESH))?;
        let free_thresh = number("free_thresh", Some(DEFAULT_FREE_THRESH))?;
        for (key, t) in [("occupied_thresh", occupied_thresh), ("free_thresh", free_thresh)] {
            if !(0.0..=1.0).contains(&t) {
                return Err(err(key, format!("{t} is outside [0, 1]")));
            }
        }
        if free_thresh >= occupied_thresh {
            return Err(err("free_thresh", format!("{free_thresh} is not below occupied_thresh {occupied_thresh}")));
        }
        let mode = match get("mode") {
            None => Mode::Trinary,
            Some(Value::String(s)) if s == "trinary" => Mode::Trinary,
            Some(Value::String(s)) if s == "scale" => Mode::Scale,
            Some(Value::String(s)) if s == "raw" => {
                return Err(err("mode", "raw maps (pixel values as occupancy percentages) are not supported: use trinary or scale".into()))
            }
            Some(v) => return Err(err("mode", format!("expected trinary or scale, found {}", value_text(v)))),
        };
        Ok(MapMeta { image, resolution_m, origin, negate, occupied_thresh, free_thresh, mode })
    }

    /// The state of a pixel of value `v` (0–255, the channels averaged).
    pub fn classify(&self, v: u8) -> Cell3 {
        let v = if self.negate { 255 - v } else { v };
        let p = (255.0 - v as f64) / 255.0;
        if p > self.occupied_thresh {
            Cell3::Occupied
        } else if p < self.free_thresh {
            Cell3::Free
        } else {
            // Trinary: unknown. Scale: map_server's 1-99, which three states cannot hold.
            Cell3::Unknown
        }
    }
}

/// The lines of `text` as YAML counts them (breaks: CR LF, CR, LF, NEL, LS, PS); at least 1.
pub fn yaml_lines(text: &str) -> usize {
    let mut n = 1;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\r' => {
                n += 1;
                if chars.peek() == Some(&'\n') {
                    chars.next();
                }
            }
            '\n' | '\u{85}' | '\u{2028}' | '\u{2029}' => n += 1,
            _ => {}
        }
    }
    // A final break ends the last line rather than starting one.
    if text.ends_with(['\n', '\r', '\u{85}', '\u{2028}', '\u{2029}']) && n > 1 {
        n -= 1;
    }
    n
}

/// serde_yaml_ng's messages say " at line L column C" (at the end, or before the context); the
/// line is ours to report, so that part goes.
fn strip_location(s: &str) -> String {
    let mut out = s.to_string();
    while let Some(i) = out.find(" at line ") {
        let rest = out[i + " at line ".len()..].trim_start_matches(|c: char| c.is_ascii_digit());
        let rest = match rest.strip_prefix(" column ") {
            Some(r) => r.trim_start_matches(|c: char| c.is_ascii_digit()),
            None => rest,
        };
        out = format!("{}{rest}", &out[..i]);
    }
    out
}

fn read_bounded(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, MapError> {
    use std::io::Read;
    let name = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|e| MapError::new(&name, format!("cannot read the {what}: {e}")))?;
    let mut data = Vec::new();
    f.take(limit + 1).read_to_end(&mut data).map_err(|e| MapError::new(&name, format!("cannot read the {what}: {e}")))?;
    if data.len() as u64 > limit {
        return Err(MapError::new(&name, format!("the {what} is larger than {limit} bytes")));
    }
    Ok(data)
}

impl PriorMap {
    /// Reads the map_server YAML file `yaml` and the image it names (relative to the YAML
    /// file's directory unless absolute).
    pub fn load(yaml: &Path) -> Result<PriorMap, MapError> {
        let file = yaml.display().to_string();
        let bytes = read_bounded(yaml, MAX_YAML_BYTES, "map file")?;
        let text = std::str::from_utf8(&bytes).map_err(|e| MapError::new(&file, format!("not UTF-8 text (byte {})", e.valid_up_to())))?;
        let meta = MapMeta::parse(text, &file)?;
        let image_path = Self::image_path(yaml, &meta.image);
        let image_name = image_path.display().to_string();
        if !image_path.is_file() {
            return Err(MapError {
                file: file.clone(),
                line: key_line(text, "image"),
                message: format!("`image`: {image_name} does not exist or is not a file"),
            });
        }
        let data = read_bounded(&image_path, MAX_IMAGE_BYTES, "image")?;
        Self::from_meta(meta, &data, &file, &image_name)
    }

    /// Where the image named `image` in `yaml` is.
    pub fn image_path(yaml: &Path, image: &str) -> PathBuf {
        let p = Path::new(image);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            yaml.parent().unwrap_or(Path::new("")).join(p)
        }
    }

    /// The map described by `meta` with the image bytes `data` (PGM or PNG); `file` names the
    /// YAML file, `image_file` the image, for errors.
    pub fn from_meta(meta: MapMeta, data: &[u8], file: &str, image_file: &str) -> Result<PriorMap, MapError> {
        let gray = image::decode(data).map_err(|m| MapError::new(image_file, m))?;
        let (width, height) = (gray.width, gray.height);
        let mut cells = vec![Cell3::Unknown; width * height];
        for y in 0..height {
            let row = &gray.pixels[(height - 1 - y) * width..(height - y) * width];
            for (c, &v) in cells[y * width..(y + 1) * width].iter_mut().zip(row) {
                *c = meta.classify(v);
            }
        }
        Ok(PriorMap { file: file.to_string(), resolution_m: meta.resolution_m, origin: meta.origin, width, height, cells })
    }

    /// Cells of each state.
    pub fn counts(&self) -> CellCounts {
        let mut n = CellCounts::default();
        for c in &self.cells {
            match c {
                Cell3::Occupied => n.occupied += 1,
                Cell3::Free => n.free += 1,
                Cell3::Unknown => n.unknown += 1,
            }
        }
        n
    }

    /// The cell at map column `x`, row `y` (row 0 the lowest), if inside.
    pub fn get(&self, x: usize, y: usize) -> Option<Cell3> {
        (x < self.width && y < self.height).then(|| self.cells[y * self.width + x])
    }

    /// The cell containing the point `p` (metres), if inside the map.
    pub fn at(&self, p: [f64; 2]) -> Option<Cell3> {
        self.cell_at(p).and_then(|(x, y)| self.get(x, y))
    }

    /// The column and row of the cell containing the point `p` (metres), if inside the map.
    pub fn cell_at(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        let l = self.local(p);
        let fx = (l[0] / self.resolution_m).floor();
        let fy = (l[1] / self.resolution_m).floor();
        (fx >= 0.0 && fy >= 0.0 && fx < self.width as f64 && fy < self.height as f64).then_some((fx as usize, fy as usize))
    }

    /// The point `l` of the image's frame (metres from the lower-left cell's lower-left corner,
    /// along its rows and columns) in the map frame: turned by the origin's yaw, then moved to
    /// the origin.
    pub fn world(&self, l: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.origin[2].sin_cos();
        [self.origin[0] + c * l[0] - s * l[1], self.origin[1] + s * l[0] + c * l[1]]
    }

    /// The inverse of [`PriorMap::world`].
    pub fn local(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.origin[2].sin_cos();
        let d = [p[0] - self.origin[0], p[1] - self.origin[1]];
        [c * d[0] + s * d[1], -s * d[0] + c * d[1]]
    }

    /// Axis-aligned `[min, max]` corners (metres, in the map frame) of the box of cells that are
    /// not unknown (of its four corners, turned by the origin's yaw), or `None` when every cell
    /// is unknown.
    pub fn known_bounds(&self) -> Option<[[f64; 2]; 2]> {
        let (mut lo, mut hi) = ([usize::MAX; 2], [0usize; 2]);
        for (i, c) in self.cells.iter().enumerate() {
            if *c != Cell3::Unknown {
                let (x, y) = (i % self.width, i / self.width);
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x + 1), hi[1].max(y + 1)];
            }
        }
        (lo[0] != usize::MAX).then(|| {
            let r = self.resolution_m;
            let corners =
                [[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]].map(|[x, y]| self.world([x as f64 * r, y as f64 * r]));
            let (mut a, mut b) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in corners {
                for k in 0..2 {
                    a[k] = a[k].min(p[k]);
                    b[k] = b[k].max(p[k]);
                }
            }
            [a, b]
        })
    }

    /// The map resampled onto a square grid of `grid_cells` cells a side, `cells_per_m` to the
    /// metre, lower-left corner at `grid_origin` (the controller's: 0.1 m cells,
    /// `firmware::capacity::GRID_CELLS`). Returns the grid's cells row by row from the lowest y.
    ///
    /// A grid cell takes the map cell under its centre, raised (occupied over free over unknown)
    /// by every map cell whose centre lies in it, so a wall of a finer map is not lost between
    /// grid centres. A known map cell whose centre falls outside the grid is an error: the map
    /// is larger than the grid (or placed off it).
    pub fn to_grid(&self, cells_per_m: f64, grid_cells: usize, grid_origin: [f64; 2]) -> Result<Vec<Cell3>, MapError> {
        if !(cells_per_m.is_finite() && cells_per_m > 0.0)
            || grid_cells == 0
            || grid_cells > 1 << 14
            || !grid_origin.iter().all(|v| v.is_finite())
        {
            return Err(MapError::new(
                &self.file,
                format!("cannot place a map on a grid of {grid_cells} cells at {cells_per_m} per metre from {grid_origin:?}"),
            ));
        }
        let n = grid_cells;
        let cell = 1.0 / cells_per_m;
        let res = self.resolution_m;
        let mut grid = vec![Cell3::Unknown; n * n];
        // The map cell under each grid cell's centre (a map coarser than the grid).
        for gy in 0..n {
            let cy = grid_origin[1] + (gy as f64 + 0.5) * cell;
            for gx in 0..n {
                let cx = grid_origin[0] + (gx as f64 + 0.5) * cell;
                if let Some((mx, my)) = self.cell_at([cx, cy]) {
                    grid[gy * n + gx] = self.cells[my * self.width + mx];
                }
            }
        }
        // Every known map cell into the grid cell holding its centre (a map finer than the grid).
        let mut outside = 0usize;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (i, &c) in self.cells.iter().enumerate() {
            if c == Cell3::Unknown {
                continue;
            }
            let p = self.world([((i % self.width) as f64 + 0.5) * res, ((i / self.width) as f64 + 0.5) * res]);
            let g = [((p[0] - grid_origin[0]) * cells_per_m).floor(), ((p[1] - grid_origin[1]) * cells_per_m).floor()];
            if g.iter().all(|v| *v >= 0.0 && *v < n as f64) {
                let k = g[1] as usize * n + g[0] as usize;
                grid[k] = grid[k].max(c);
            } else {
                outside += 1;
                for a in 0..2 {
                    lo[a] = lo[a].min(p[a] - res / 2.0);
                    hi[a] = hi[a].max(p[a] + res / 2.0);
                }
            }
        }
        if outside > 0 {
            let side = n as f64 * cell;
            let known = self.known_bounds().unwrap_or([lo, hi]);
            return Err(MapError::new(
                &self.file,
                format!(
                    "the map is larger than the controller's grid: its known cells span x {:.2}..{:.2} m, y {:.2}..{:.2} m ({:.1} x {:.1} m), and {outside} of them fall outside the grid of {side:.1} m square from ({:.2}, {:.2}) (x {:.2}..{:.2} m, y {:.2}..{:.2} m)",
                    known[0][0],
                    known[1][0],
                    known[0][1],
                    known[1][1],
                    known[1][0] - known[0][0],
                    known[1][1] - known[0][1],
                    grid_origin[0],
                    grid_origin[1],
                    grid_origin[0],
                    grid_origin[0] + side,
                    grid_origin[1],
                    grid_origin[1] + side,
                ),
            ));
        }
        Ok(grid)
    }

    /// The lower-left corner of the controller's grid centred on the map's known cells (on the
    /// 0.1 m lattice), as a search centres its grid on a world; the map's origin when every
    /// cell is unknown.
    pub fn centred_grid_origin(&self) -> [f64; 2] {
        let c = match self.known_bounds() {
            Some([lo, hi]) => [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0],
            None => [self.origin[0], self.origin[1]],
        };
        crate::run::centred_origin(c)
    }

    /// [`PriorMap::to_grid`] onto the controller's grid (0.1 m cells,
    /// `firmware::capacity::GRID_CELLS` a side) from `grid_origin`.
    pub fn to_controller_grid(&self, grid_origin: [f64; 2]) -> Result<Vec<Cell3>, MapError> {
        use firmware::capacity::{CELLS_PER_METER, GRID_CELLS};
        self.to_grid(CELLS_PER_METER as f64, GRID_CELLS, grid_origin)
    }
}

#[cfg(test)]
mod tests;
