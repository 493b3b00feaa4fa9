//! Picture renderer: one PNG that shows a whole search run at a glance.
//!
//! The renderer takes plain data ([`RenderInput`]) so it does not depend on
//! the simulator or controller types. The picture is north-up (x right,
//! y up), cropped to the world's bounds plus a [`MARGIN_M`] margin, at
//! [`DEFAULT_PX_PER_CELL`] pixels per grid cell. Layers, bottom to top:
//!
//! 1. the LiDAR occupancy grid (unknown / free / camera-seen free),
//! 2. the true world, faint (walls, furniture/clutter outlines),
//! 3. LiDAR-occupied cells,
//! 4. frontier cells, camera cone, non-map points, viewpoints, people,
//!    targets, planned path, driven path, start, goal, robot, found marker,
//! 5. the title line (top strip) and the legend (panel right of the map).
//!
//! Non-finite coordinates are skipped everywhere; empty inputs give an empty
//! (but valid) picture. Text uses the embedded DejaVu Sans font
//! (`host/assets/DejaVuSans.ttf`, license in `host/assets/DejaVu-LICENSE.txt`).

use std::fmt;

mod draw;
mod legend;
pub mod picture;
mod strip;
pub use draw::*;
pub use legend::*;
pub use strip::*;

/// A world point (metres): `[x, y]`.
pub type P2 = [f64; 2];

/// A read-only view of the controller's maps.
pub struct GridView<'a> {
    /// World coordinates of the lower-left corner of cell (0, 0).
    pub origin: P2,
    /// Cell side in metres (0.10 in this project).
    pub cell_m: f64,
    /// Number of cells along x.
    pub width: usize,
    /// Number of cells along y.
    pub height: usize,
    /// LiDAR occupancy of cell (x, y): -1 (any negative) unknown,
    /// 0..50 free, 50..=100 occupied.
    pub lidar: &'a dyn Fn(usize, usize) -> i8,
    /// Whether the camera has seen cell (x, y).
    pub seen: &'a dyn Fn(usize, usize) -> bool,
}

/// Everything the picture shows. All coordinates are world metres,
/// headings are radians counter-clockwise from +x.
pub struct RenderInput<'a> {
    /// One line drawn above the map.
    pub title: String,
    /// World min / max to show (the renderer adds a [`MARGIN_M`] margin).
    pub bounds: [P2; 2],
    /// True-world wall segments.
    pub walls: &'a [[P2; 2]],
    /// True-world furniture/clutter outlines (closed polygons).
    pub obstacles: &'a [Vec<P2>],
    /// Current person positions (drawn as circles of radius [`PERSON_RADIUS_M`]).
    pub people: &'a [P2],
    /// True target outlines (closed polygons).
    pub targets: &'a [Vec<P2>],
    /// The controller's maps.
    pub grid: GridView<'a>,
    /// The planner's non-map ("maybe the target is here") points.
    pub nonmap_points: &'a [P2],
    /// World coordinates of frontier cell centres.
    pub frontier_cells: &'a [P2],
    /// Candidate viewpoints (position, heading); may be empty.
    pub viewpoints: &'a [(P2, f64)],
    /// The robot's driven path.
    pub trajectory: &'a [P2],
    /// Start pose.
    pub start: (P2, f64),
    /// Final robot pose.
    pub robot: (P2, f64),
    /// Current goal pose, if any.
    pub goal: Option<(P2, f64)>,
    /// Planned path to the goal (drawn dashed).
    pub goal_path: &'a [P2],
    /// Robot position when the target was detected (`None`: not found).
    pub found_at: Option<P2>,
    /// Camera field of view (radians) for the final camera cone.
    pub camera_fov_rad: f64,
    /// Camera range (metres) for the final camera cone.
    pub camera_range_m: f64,
}

/// Why a picture could not be written.
#[derive(Debug)]
pub enum RenderError {
    /// Creating or writing the file failed.
    Io(std::io::Error),
    /// Drawing or PNG encoding failed.
    Backend(String),
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Io(e) => write!(f, "cannot write picture: {e}"),
            RenderError::Backend(msg) => write!(f, "cannot draw picture: {msg}"),
        }
    }
}

impl std::error::Error for RenderError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            RenderError::Io(e) => Some(e),
            RenderError::Backend(_) => None,
        }
    }
}

impl From<std::io::Error> for RenderError {
    fn from(e: std::io::Error) -> Self {
        RenderError::Io(e)
    }
}

impl From<png::EncodingError> for RenderError {
    fn from(e: png::EncodingError) -> Self {
        match e {
            png::EncodingError::IoError(e) => RenderError::Io(e),
            other => RenderError::Backend(format!("PNG encoding: {other}")),
        }
    }
}

/// Margin added around [`RenderInput::bounds`], metres.
pub const MARGIN_M: f64 = 1.0;
/// Pixels per grid cell (one 0.10 m cell = 2 px, i.e. 20 px/m).
pub const DEFAULT_PX_PER_CELL: f64 = 2.0;
/// Height of the title strip above the map, pixels.
pub const TITLE_H: u32 = 30;
/// Width of the legend panel right of the map, pixels.
pub const LEGEND_W: u32 = 230;
/// Radius of a person, metres.
pub const PERSON_RADIUS_M: f64 = 0.25;
/// Largest map side in pixels; larger worlds are drawn at a smaller scale.
pub const MAX_MAP_PX: f64 = 6000.0;
/// Cell size assumed when the grid's own `cell_m` is unusable.
const FALLBACK_CELL_M: f64 = 0.10;

/// The colours of the picture (RGB), shared by the map and the legend.
pub mod palette {
    /// Series colours of plots (one per planner).
    pub const SERIES: [[u8; 3]; 6] = [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189], [140, 86, 75]];
    /// Image background (title strip, legend panel).
    pub const BACKGROUND: [u8; 3] = [255, 255, 255];
    /// LiDAR unknown cells (and the area outside the grid).
    pub const UNKNOWN: [u8; 3] = [218, 218, 218];
    /// LiDAR free cells.
    pub const FREE: [u8; 3] = [255, 255, 255];
    /// Free (or unknown) cells the camera has seen.
    pub const SEEN: [u8; 3] = [190, 231, 226];
    /// LiDAR occupied cells.
    pub const OCCUPIED: [u8; 3] = [35, 35, 35];
    /// True walls (faint).
    pub const WALL: [u8; 3] = [150, 150, 150];
    /// True furniture/clutter outlines (faint).
    pub const OBSTACLE: [u8; 3] = [176, 146, 110];
    /// People.
    pub const PERSON: [u8; 3] = [139, 84, 36];
    /// True target outline.
    pub const TARGET: [u8; 3] = [220, 20, 30];
    /// Non-map points.
    pub const NONMAP: [u8; 3] = [255, 140, 0];
    /// Frontier cells.
    pub const FRONTIER: [u8; 3] = [225, 0, 225];
    /// Candidate viewpoints.
    pub const VIEWPOINT: [u8; 3] = [120, 120, 0];
    /// Driven path and the robot.
    pub const TRAJECTORY: [u8; 3] = [25, 85, 230];
    /// Start pose.
    pub const START: [u8; 3] = [0, 165, 60];
    /// Final camera cone outline.
    pub const CONE: [u8; 3] = [0, 110, 125];
    /// Goal pose and planned path.
    pub const GOAL: [u8; 3] = [130, 20, 170];
    /// Found marker.
    pub const FOUND: [u8; 3] = [230, 0, 0];
    /// Text.
    pub const TEXT: [u8; 3] = [20, 20, 20];
    /// Map frame and legend swatch borders.
    pub const FRAME: [u8; 3] = [110, 110, 110];
}

/// Where things go in the picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Left edge of the map area (always 0).
    pub map_x0: u32,
    /// Top edge of the map area (= [`TITLE_H`]).
    pub map_y0: u32,
    /// Map area width, pixels.
    pub map_w: u32,
    /// Map area height, pixels.
    pub map_h: u32,
    /// Scale, pixels per metre.
    pub px_per_m: f64,
    /// World coordinates of the map area's lower-left corner.
    pub view_min: P2,
    /// World coordinates of the map area's upper-right corner.
    pub view_max: P2,
    /// Height of the legend panel content, pixels.
    pub legend_h: u32,
}

impl Layout {
    /// Image coordinates (pixels, y down, continuous) of a world point.
    pub fn world_to_px(&self, p: P2) -> [f64; 2] {
        [self.map_x0 as f64 + (p[0] - self.view_min[0]) * self.px_per_m, self.map_y0 as f64 + (self.view_max[1] - p[1]) * self.px_per_m]
    }

    /// The image pixel containing a world point, if it is inside the map area.
    pub fn pixel_of(&self, p: P2) -> Option<(u32, u32)> {
        let [x, y] = self.world_to_px(p);
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let (x0, y0) = (self.map_x0 as f64, self.map_y0 as f64);
        if x < x0 || y < y0 || x >= x0 + self.map_w as f64 || y >= y0 + self.map_h as f64 {
            return None;
        }
        Some((x.floor() as u32, y.floor() as u32))
    }
}

/// An RGB8 picture in memory (row-major, top row first).
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `width * height * 3` bytes.
    pub data: Vec<u8>,
}

impl RgbImage {
    /// The colour of pixel (x, y); panics when out of range.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }
}

#[cfg(test)]
mod tests;
