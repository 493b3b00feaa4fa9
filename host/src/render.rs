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
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::Once;

use plotters::prelude::{BitMapBackend, DrawingBackend, RGBColor};
use plotters::style::{Color, FontDesc, FontFamily, FontStyle, ShapeStyle, TextStyle};

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

const FONT_FAMILY: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
static FONT_INIT: Once = Once::new();

/// Registers the embedded DejaVu Sans as plotters' "sans-serif" (once).
fn ensure_font() {
    FONT_INIT.call_once(|| {
        // The font is embedded and tested; if registration ever failed the
        // picture would simply have no text (text errors are not fatal).
        let _ = plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT_BYTES);
    });
}

const TITLE_FONT_PX: f64 = 18.0;
const LEGEND_FONT_PX: f64 = 13.0;
const LEGEND_ROW_H: u32 = 20;
const LEGEND_PAD: u32 = 10;

fn font(size: f64) -> FontDesc<'static> {
    FontDesc::new(FontFamily::Name(FONT_FAMILY), size, FontStyle::Normal)
}

fn text_width(text: &str, size: f64) -> u32 {
    ensure_font();
    match font(size).box_size(text) {
        Ok((w, _)) => w,
        Err(_) => (text.chars().count() as f64 * size * 0.6).ceil() as u32,
    }
}

fn finite(p: P2) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

fn valid_box(b: [P2; 2]) -> bool {
    finite(b[0]) && finite(b[1]) && b[1][0] > b[0][0] && b[1][1] > b[0][1]
}

fn grid_cell_m(grid: &GridView) -> Option<f64> {
    (grid.cell_m.is_finite() && grid.cell_m > 0.0).then_some(grid.cell_m)
}

/// The world box shown (before the margin): the given bounds, else the
/// grid's extent, else 10 m x 10 m at the origin.
fn world_box(input: &RenderInput) -> [P2; 2] {
    if valid_box(input.bounds) {
        return input.bounds;
    }
    let g = &input.grid;
    if let Some(c) = grid_cell_m(g) {
        let gb = [g.origin, [g.origin[0] + g.width as f64 * c, g.origin[1] + g.height as f64 * c]];
        if valid_box(gb) {
            return gb;
        }
    }
    [[0.0, 0.0], [10.0, 10.0]]
}

struct LegendRow {
    label: &'static str,
    swatch: Swatch,
}

#[derive(Clone, Copy)]
enum Swatch {
    Fill([u8; 3]),
    Outline([u8; 3]),
    Line([u8; 3]),
    Dots([u8; 3]),
    Squares([u8; 3]),
    Circle([u8; 3]),
    Arrow([u8; 3]),
    Triangle([u8; 3]),
    Robot,
    Goal,
    Star,
}

/// Whether the input has a true world (a replayed log has none: no truth rows, no outcome).
fn has_world(input: &RenderInput) -> bool {
    !(input.walls.is_empty() && input.obstacles.is_empty() && input.people.is_empty() && input.targets.is_empty())
}

fn legend_rows(input: &RenderInput) -> Vec<LegendRow> {
    use palette::*;
    let mut rows = vec![
        LegendRow { label: "Unknown (LiDAR)", swatch: Swatch::Fill(UNKNOWN) },
        LegendRow { label: "Free (LiDAR)", swatch: Swatch::Fill(FREE) },
        LegendRow { label: "Seen by camera", swatch: Swatch::Fill(SEEN) },
        LegendRow { label: "Occupied (LiDAR)", swatch: Swatch::Fill(OCCUPIED) },
    ];
    if has_world(input) {
        rows.extend([
            LegendRow { label: "True walls", swatch: Swatch::Line(WALL) },
            LegendRow { label: "True furniture / clutter", swatch: Swatch::Outline(OBSTACLE) },
            LegendRow { label: "People", swatch: Swatch::Circle(PERSON) },
            LegendRow { label: "Target (true)", swatch: Swatch::Outline(TARGET) },
        ]);
    }
    // Only what the picture holds: a replayed log of a map-only planner has no non-map points,
    // and a fully explored map no frontier.
    if !input.nonmap_points.is_empty() {
        rows.push(LegendRow { label: "Non-map points", swatch: Swatch::Dots(NONMAP) });
    }
    if !input.frontier_cells.is_empty() {
        rows.push(LegendRow { label: "Frontier cells", swatch: Swatch::Squares(FRONTIER) });
    }
    if !input.viewpoints.is_empty() {
        rows.push(LegendRow { label: "Candidate viewpoints", swatch: Swatch::Arrow(VIEWPOINT) });
    }
    rows.extend([
        LegendRow { label: "Driven path", swatch: Swatch::Line(TRAJECTORY) },
        LegendRow { label: "Start", swatch: Swatch::Triangle(START) },
        LegendRow { label: "Robot + camera cone", swatch: Swatch::Robot },
        LegendRow { label: "Goal + planned path", swatch: Swatch::Goal },
    ]);
    if has_world(input) {
        rows.push(LegendRow { label: "Target detected here", swatch: Swatch::Star });
    }
    rows
}

/// Rows after the swatch rows: status, scale bar, cell size.
const LEGEND_EXTRA_ROWS: u32 = 4;

/// Computes the picture's size and the world-to-pixel mapping.
pub fn layout(input: &RenderInput) -> Layout {
    let b = world_box(input);
    let view_min = [b[0][0] - MARGIN_M, b[0][1] - MARGIN_M];
    let span = [b[1][0] - b[0][0] + 2.0 * MARGIN_M, b[1][1] - b[0][1] + 2.0 * MARGIN_M];
    let cell = grid_cell_m(&input.grid).unwrap_or(FALLBACK_CELL_M);
    let mut px_per_m = DEFAULT_PX_PER_CELL / cell;
    let longest = span[0].max(span[1]) * px_per_m;
    if longest.is_nan() || longest > MAX_MAP_PX {
        px_per_m = MAX_MAP_PX / span[0].max(span[1]);
    }
    // Round down the tiny float noise before ceil (10 m * 20 px/m = 200 px,
    // not 201).
    let side = |s: f64| ((s * px_per_m - 1e-6).ceil().max(1.0)) as u32;
    let (map_w, map_h) = (side(span[0]), side(span[1]));
    let view_max = [view_min[0] + map_w as f64 / px_per_m, view_min[1] + map_h as f64 / px_per_m];
    let rows = legend_rows(input).len() as u32 + LEGEND_EXTRA_ROWS;
    let legend_h = 2 * LEGEND_PAD + rows * LEGEND_ROW_H + 10;
    let title_w = text_width(&input.title, TITLE_FONT_PX) + 2 * LEGEND_PAD;
    Layout {
        width: (map_w + LEGEND_W).max(title_w),
        height: TITLE_H + map_h.max(legend_h),
        map_x0: 0,
        map_y0: TITLE_H,
        map_w,
        map_h,
        px_per_m,
        view_min,
        view_max,
        legend_h,
    }
}

/// Renders the picture into memory.
pub fn render_rgb(input: &RenderInput) -> Result<RgbImage, RenderError> {
    ensure_font();
    let lay = layout(input);
    let (w, h) = (lay.width, lay.height);
    let mut data = vec![255u8; w as usize * h as usize * 3];

    // 1. grid raster (occupied cells are remembered and painted in step 3,
    //    above the faint true walls).
    let occupied = paint_grid(&mut data, &lay, &input.grid);

    // 2. the true world, faint.
    {
        let mut be = BitMapBackend::with_buffer(&mut data, (w, h));
        let mut c = Canvas::new(&mut be, lay);
        c.truth(input)?;
        be.present().map_err(backend_err)?;
    }

    // 3. LiDAR-occupied cells.
    for (i, &occ) in occupied.iter().enumerate() {
        if occ {
            let px = lay.map_x0 as usize + i % lay.map_w as usize;
            let py = lay.map_y0 as usize + i / lay.map_w as usize;
            let j = 3 * (py * w as usize + px);
            data[j..j + 3].copy_from_slice(&palette::OCCUPIED);
        }
    }

    // 4. overlays, title and legend.
    {
        let mut be = BitMapBackend::with_buffer(&mut data, (w, h));
        let mut c = Canvas::new(&mut be, lay);
        c.overlays(input)?;
        c.title(&input.title);
        c.legend(input)?;
        be.present().map_err(backend_err)?;
    }
    Ok(RgbImage { width: w, height: h, data })
}

/// Encodes a picture as PNG (RGB8) into a writer.
pub fn encode_png<W: Write>(out: W, img: &RgbImage) -> Result<(), RenderError> {
    let mut enc = png::Encoder::new(out, img.width, img.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header()?;
    writer.write_image_data(&img.data)?;
    writer.finish()?;
    Ok(())
}

/// Renders the picture and writes it as a PNG file at `path` (whatever its
/// extension).
pub fn render_png(path: &Path, input: &RenderInput) -> Result<(), RenderError> {
    let img = render_rgb(input)?;
    let file = std::fs::File::create(path)?;
    let mut out = BufWriter::new(file);
    encode_png(&mut out, &img)?;
    out.flush()?;
    Ok(())
}

fn backend_err<E: fmt::Display>(e: E) -> RenderError {
    RenderError::Backend(e.to_string())
}

/// Turns plotters' drawing errors (whose type plotters does not re-export)
/// into [`RenderError::Backend`].
trait OrBackend<T> {
    fn be(self) -> Result<T, RenderError>;
}

impl<T, E: fmt::Display> OrBackend<T> for Result<T, E> {
    fn be(self) -> Result<T, RenderError> {
        self.map_err(backend_err)
    }
}

/// Paints the grid into the map area; returns the map-area mask of
/// occupied pixels.
fn paint_grid(data: &mut [u8], lay: &Layout, grid: &GridView) -> Vec<bool> {
    let (mw, mh) = (lay.map_w as usize, lay.map_h as usize);
    let stride = lay.width as usize * 3;
    let mut occ = vec![false; mw * mh];
    let cell = grid_cell_m(grid);
    let origin_ok = finite(grid.origin);
    let to_cell = |v: f64, o: f64, n: usize| -> Option<usize> {
        let c = cell?;
        if !origin_ok {
            return None;
        }
        let k = ((v - o) / c).floor();
        (k >= 0.0 && k < n as f64).then_some(k as usize)
    };
    let cols: Vec<Option<usize>> = (0..mw)
        .map(|px| {
            let wx = lay.view_min[0] + (px as f64 + 0.5) / lay.px_per_m;
            to_cell(wx, grid.origin[0], grid.width)
        })
        .collect();
    let mut row_rgb: Vec<[u8; 3]> = vec![palette::UNKNOWN; mw];
    let mut row_occ: Vec<bool> = vec![false; mw];
    let mut cached: Option<Option<usize>> = None;
    for py in 0..mh {
        let wy = lay.view_max[1] - (py as f64 + 0.5) / lay.px_per_m;
        let cy = to_cell(wy, grid.origin[1], grid.height);
        if cached != Some(cy) {
            cached = Some(cy);
            let mut last: Option<(usize, [u8; 3], bool)> = None;
            for px in 0..mw {
                let (rgb, o) = match (cols[px], cy) {
                    (Some(cx), Some(cy)) => match last {
                        Some((lx, rgb, o)) if lx == cx => (rgb, o),
                        _ => {
                            let v = (grid.lidar)(cx, cy);
                            let (rgb, o) = if v >= 50 {
                                (palette::UNKNOWN, true)
                            } else if (grid.seen)(cx, cy) {
                                (palette::SEEN, false)
                            } else if v < 0 {
                                (palette::UNKNOWN, false)
                            } else {
                                (palette::FREE, false)
                            };
                            last = Some((cx, rgb, o));
                            (rgb, o)
                        }
                    },
                    _ => (palette::UNKNOWN, false),
                };
                row_rgb[px] = rgb;
                row_occ[px] = o;
            }
        }
        let y = lay.map_y0 as usize + py;
        let start = y * stride + lay.map_x0 as usize * 3;
        for (px, rgb) in row_rgb.iter().enumerate() {
            data[start + 3 * px..start + 3 * px + 3].copy_from_slice(rgb);
        }
        occ[py * mw..(py + 1) * mw].copy_from_slice(&row_occ);
    }
    occ
}

type DResult = Result<(), RenderError>;

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

fn stroke(c: [u8; 3], width: u32) -> ShapeStyle {
    ShapeStyle { color: rgb(c).to_rgba(), filled: false, stroke_width: width }
}

fn stroke_a(c: [u8; 3], alpha: f64, width: u32) -> ShapeStyle {
    ShapeStyle { color: rgb(c).mix(alpha), filled: false, stroke_width: width }
}

fn fill(c: [u8; 3]) -> ShapeStyle {
    ShapeStyle { color: rgb(c).to_rgba(), filled: true, stroke_width: 1 }
}

fn fill_a(c: [u8; 3], alpha: f64) -> ShapeStyle {
    ShapeStyle { color: rgb(c).mix(alpha), filled: true, stroke_width: 1 }
}

/// Clips segment a-b (pixel coordinates) to rectangle [lo, hi]
/// (Liang-Barsky). Returns the clipped segment and whether `a` was kept.
fn clip(a: [f64; 2], b: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> Option<([f64; 2], [f64; 2], bool)> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        for (p, q) in [(-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])] {
            if p == 0.0 {
                if q < 0.0 {
                    return None;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    if r > t1 {
                        return None;
                    }
                    t0 = t0.max(r);
                } else {
                    if r < t0 {
                        return None;
                    }
                    t1 = t1.min(r);
                }
            }
        }
    }
    let at = |t: f64| [a[0] + t * d[0], a[1] + t * d[1]];
    Some((at(t0), at(t1), t0 == 0.0))
}

fn ipt(p: [f64; 2]) -> (i32, i32) {
    (p[0].round() as i32, p[1].round() as i32)
}

/// Drawing helpers in pixel space with clipping to the map area.
struct Canvas<'b, 'a> {
    be: &'b mut BitMapBackend<'a>,
    lay: Layout,
    lo: [f64; 2],
    hi: [f64; 2],
}

impl<'b, 'a> Canvas<'b, 'a> {
    fn new(be: &'b mut BitMapBackend<'a>, lay: Layout) -> Self {
        let lo = [lay.map_x0 as f64 - 2.0, lay.map_y0 as f64 - 2.0];
        let hi = [(lay.map_x0 + lay.map_w) as f64 + 2.0, (lay.map_y0 + lay.map_h) as f64 + 2.0];
        Canvas { be, lay, lo, hi }
    }

    /// Pixel position of a world point, if finite.
    fn px(&self, p: P2) -> Option<[f64; 2]> {
        finite(p).then(|| self.lay.world_to_px(p))
    }

    /// Whether a pixel position is within `r` pixels of the map area.
    fn near_map(&self, q: [f64; 2], r: f64) -> bool {
        q[0] >= self.lo[0] - r && q[0] <= self.hi[0] + r && q[1] >= self.lo[1] - r && q[1] <= self.hi[1] + r
    }

    /// A polyline in pixel space (non-finite points break it), clipped.
    fn path_px(&mut self, pts: &[[f64; 2]], style: &ShapeStyle) -> DResult {
        let mut run: Vec<(i32, i32)> = Vec::new();
        let mut prev: Option<[f64; 2]> = None;
        for &q in pts {
            if !(q[0].is_finite() && q[1].is_finite()) {
                self.flush(&mut run, style)?;
                prev = None;
                continue;
            }
            if let Some(p) = prev {
                match clip(p, q, self.lo, self.hi) {
                    Some((a, b, kept_a)) => {
                        if !kept_a || run.is_empty() {
                            self.flush(&mut run, style)?;
                            run.push(ipt(a));
                        }
                        run.push(ipt(b));
                        if b != q {
                            self.flush(&mut run, style)?;
                        }
                    }
                    None => self.flush(&mut run, style)?,
                }
            }
            prev = Some(q);
        }
        self.flush(&mut run, style)
    }

    fn flush(&mut self, run: &mut Vec<(i32, i32)>, style: &ShapeStyle) -> DResult {
        if run.len() >= 2 {
            self.be.draw_path(run.drain(..), style).be()?;
        }
        run.clear();
        Ok(())
    }

    /// A polyline of world points.
    fn path(&mut self, pts: &[P2], style: &ShapeStyle) -> DResult {
        let px: Vec<[f64; 2]> = pts.iter().map(|&p| self.px(p).unwrap_or([f64::NAN, f64::NAN])).collect();
        self.path_px(&px, style)
    }

    /// A closed outline of world points.
    fn outline(&mut self, pts: &[P2], style: &ShapeStyle) -> DResult {
        if let Some(&first) = pts.first() {
            let mut closed = pts.to_vec();
            closed.push(first);
            self.path(&closed, style)?;
        }
        Ok(())
    }

    /// A dashed polyline of world points.
    fn dashed(&mut self, pts: &[P2], style: &ShapeStyle, on: f64, off: f64) -> DResult {
        let mut phase = 0.0; // distance into the current on+off period
        let period = on + off;
        let mut prev: Option<[f64; 2]> = None;
        for &p in pts {
            let Some(q) = self.px(p) else {
                prev = None;
                continue;
            };
            if let Some(a) = prev {
                let len = ((q[0] - a[0]).powi(2) + (q[1] - a[1]).powi(2)).sqrt();
                if !(len.is_finite()) || len > 1e5 {
                    // Absurdly long: draw it solid (clipped) instead of dashing.
                    self.path_px(&[a, q], style)?;
                } else {
                    // Bounded: every iteration ends a dash or a gap (steps of at least 1e-6 px,
                    // and the phase snaps to the boundary it reached, so rounding cannot stall).
                    let mut s = 0.0;
                    let max_iter = 2 * (len / period.max(1e-6)).ceil() as usize + 4;
                    for _ in 0..max_iter {
                        if s >= len {
                            break;
                        }
                        let in_on = phase < on;
                        let step = (if in_on { on - phase } else { period - phase }).max(1e-6);
                        let e = (s + step).min(len);
                        if in_on {
                            let at = |t: f64| [a[0] + (q[0] - a[0]) * t / len, a[1] + (q[1] - a[1]) * t / len];
                            self.path_px(&[at(s), at(e)], style)?;
                        }
                        phase = if e - s >= step {
                            if in_on {
                                on
                            } else {
                                0.0
                            }
                        } else {
                            (phase + (e - s)) % period
                        };
                        s = e;
                    }
                }
            }
            prev = Some(q);
        }
        Ok(())
    }

    fn circle(&mut self, p: P2, r: f64, style: &ShapeStyle) -> DResult {
        if let Some(q) = self.px(p) {
            if self.near_map(q, r) {
                self.be.draw_circle(ipt(q), r.round().max(1.0) as u32, style, style.filled).be()?;
            }
        }
        Ok(())
    }

    fn polygon_px(&mut self, pts: &[[f64; 2]], style: &ShapeStyle) -> DResult {
        if pts.iter().all(|q| self.near_map(*q, 0.0)) {
            if style.filled {
                self.be.fill_polygon(pts.iter().map(|&q| ipt(q)), style).be()?;
            } else {
                let mut closed = pts.to_vec();
                closed.push(pts[0]);
                self.path_px(&closed, style)?;
            }
        }
        Ok(())
    }

    /// A filled triangle pointing along `heading` (world radians) centred at `q`.
    fn triangle_px(&mut self, q: [f64; 2], heading: f64, len: f64, style: &ShapeStyle) -> DResult {
        let h = if heading.is_finite() { heading } else { std::f64::consts::FRAC_PI_2 };
        let (c, s) = (h.cos(), -h.sin());
        let tip = [q[0] + c * len * 0.6, q[1] + s * len * 0.6];
        let back = [q[0] - c * len * 0.4, q[1] - s * len * 0.4];
        let (nx, ny) = (-s * len * 0.4, c * len * 0.4);
        let tri = [tip, [back[0] + nx, back[1] + ny], [back[0] - nx, back[1] - ny]];
        self.polygon_px(&tri, style)
    }

    /// An arrow from `q` along `heading` of `len` pixels with a filled head.
    fn arrow_px(&mut self, q: [f64; 2], heading: f64, len: f64, colour: [u8; 3], width: u32) -> DResult {
        if !heading.is_finite() {
            return Ok(());
        }
        let (c, s) = (heading.cos(), -heading.sin());
        let tip = [q[0] + c * len, q[1] + s * len];
        let head = (len * 0.45).max(4.0);
        let base = [tip[0] - c * head, tip[1] - s * head];
        self.path_px(&[q, base], &stroke(colour, width))?;
        let (nx, ny) = (-s * head * 0.5, c * head * 0.5);
        self.polygon_px(&[tip, [base[0] + nx, base[1] + ny], [base[0] - nx, base[1] - ny]], &fill(colour))
    }

    fn star_px(&mut self, q: [f64; 2], r: f64, colour: [u8; 3], edge: [u8; 3]) -> DResult {
        let pts: Vec<[f64; 2]> = (0..10)
            .map(|i| {
                let a = std::f64::consts::FRAC_PI_2 + i as f64 * std::f64::consts::PI / 5.0;
                let rr = if i % 2 == 0 { r } else { r * 0.45 };
                [q[0] + rr * a.cos(), q[1] - rr * a.sin()]
            })
            .collect();
        self.polygon_px(&pts, &fill(colour))?;
        self.polygon_px(&pts, &stroke(edge, 1))
    }

    fn text(&mut self, s: &str, pos: (i32, i32), size: f64, colour: [u8; 3]) {
        let colour = rgb(colour);
        let style = TextStyle::from(font(size)).color(&colour);
        // Text is decoration: a font problem must not lose the picture.
        let _ = self.be.draw_text(s, &style, pos);
    }

    /// Layer 2: the true world, faint.
    fn truth(&mut self, input: &RenderInput) -> DResult {
        for o in input.obstacles {
            self.outline(o, &stroke_a(palette::OBSTACLE, 0.9, 1))?;
        }
        let wall = stroke(palette::WALL, 2);
        for w in input.walls {
            self.path(&w[..], &wall)?;
        }
        Ok(())
    }

    /// Layer 4: everything the run produced.
    fn overlays(&mut self, input: &RenderInput) -> DResult {
        let ppm = self.lay.px_per_m;
        let cell_px = grid_cell_m(&input.grid).unwrap_or(FALLBACK_CELL_M) * ppm;

        // Frontier cells: squares of one cell (at least 2 px).
        let side = cell_px.max(2.0);
        for &f in input.frontier_cells {
            if let Some(q) = self.px(f) {
                if self.near_map(q, 0.0) {
                    let a = [q[0] - side / 2.0, q[1] - side / 2.0];
                    let ul = (a[0].round() as i32, a[1].round() as i32);
                    let br = (ul.0 + side.round() as i32, ul.1 + side.round() as i32);
                    self.be.draw_rect(ul, br, &fill(palette::FRONTIER), true).be()?;
                }
            }
        }

        // Final camera cone.
        let (rp, rh) = input.robot;
        if let Some(q) = self.px(rp) {
            let (fov, range) = (input.camera_fov_rad, input.camera_range_m);
            if rh.is_finite() && fov.is_finite() && range.is_finite() && fov > 0.0 && range > 0.0 {
                let fov = fov.min(2.0 * std::f64::consts::PI);
                let n = 32;
                let mut pts = vec![q];
                for i in 0..=n {
                    let a = rh - fov / 2.0 + fov * i as f64 / n as f64;
                    pts.push([q[0] + range * ppm * a.cos(), q[1] - range * ppm * a.sin()]);
                }
                pts.push(q);
                self.path_px(&pts, &stroke(palette::CONE, 1))?;
            }
        }

        // Non-map points.
        for &p in input.nonmap_points {
            self.circle(p, 2.0, &fill(palette::NONMAP))?;
        }

        // Candidate viewpoints.
        for &(p, h) in input.viewpoints {
            if let Some(q) = self.px(p) {
                if self.near_map(q, 10.0) {
                    self.arrow_px(q, h, 9.0, palette::VIEWPOINT, 1)?;
                }
            }
        }

        // People.
        let pr = (PERSON_RADIUS_M * ppm).max(2.0);
        for &p in input.people {
            self.circle(p, pr, &fill_a(palette::PERSON, 0.35))?;
            self.circle(p, pr, &stroke(palette::PERSON, 1))?;
        }

        // Targets.
        for t in input.targets {
            self.outline(t, &stroke(palette::TARGET, 2))?;
        }

        // Planned path (dashed) and driven path.
        self.dashed(input.goal_path, &stroke(palette::GOAL, 2), 6.0, 4.0)?;
        self.path(input.trajectory, &stroke(palette::TRAJECTORY, 2))?;

        // Start pose.
        let (sp, sh) = input.start;
        if let Some(q) = self.px(sp) {
            if self.near_map(q, 12.0) {
                self.triangle_px(q, sh, 16.0, &fill(palette::START))?;
                self.triangle_px(q, sh, 16.0, &stroke([0, 90, 30], 1))?;
            }
        }

        // Where the target was detected.
        if let Some(fp) = input.found_at {
            if let Some(q) = self.px(fp) {
                if self.near_map(q, 10.0) {
                    self.star_px(q, 10.0, palette::FOUND, [120, 0, 0])?;
                    let (x, y) = ipt(q);
                    let pos = (x + 11, y - 16);
                    for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                        let halo = (pos.0 + dx, pos.1 + dy);
                        self.text("found", halo, LEGEND_FONT_PX + 1.0, palette::BACKGROUND);
                    }
                    self.text("found", pos, LEGEND_FONT_PX + 1.0, palette::FOUND);
                }
            }
        }

        // Goal pose.
        if let Some((gp, gh)) = input.goal {
            if let Some(q) = self.px(gp) {
                if self.near_map(q, 16.0) {
                    self.be.draw_circle(ipt(q), 4, &stroke(palette::GOAL, 2), false).be()?;
                    self.arrow_px(q, gh, 14.0, palette::GOAL, 2)?;
                }
            }
        }

        // Final robot pose.
        if let Some(q) = self.px(rp) {
            if self.near_map(q, 10.0) {
                let r = (0.2 * ppm).max(4.0);
                self.be.draw_circle(ipt(q), r.round() as u32, &fill(palette::TRAJECTORY), true).be()?;
                self.be.draw_circle(ipt(q), r.round() as u32, &stroke([0, 30, 110], 1), false).be()?;
                if rh.is_finite() {
                    let tip = [q[0] + rh.cos() * r, q[1] - rh.sin() * r];
                    self.path_px(&[q, tip], &stroke([255, 255, 255], 2))?;
                }
            }
        }

        // Frame around the map.
        let l = self.lay;
        self.be
            .draw_rect(
                (l.map_x0 as i32, l.map_y0 as i32),
                ((l.map_x0 + l.map_w) as i32 - 1, (l.map_y0 + l.map_h) as i32 - 1),
                &stroke(palette::FRAME, 1),
                false,
            )
            .be()?;
        Ok(())
    }

    fn title(&mut self, title: &str) {
        self.text(title, (LEGEND_PAD as i32, 8), TITLE_FONT_PX, palette::TEXT);
    }

    fn legend(&mut self, input: &RenderInput) -> DResult {
        let l = self.lay;
        // The legend is outside the map area: clip to the whole image.
        self.lo = [0.0, 0.0];
        self.hi = [l.width as f64, l.height as f64];
        let x0 = (l.map_x0 + l.map_w + LEGEND_PAD) as i32;
        let mut y = (l.map_y0 + LEGEND_PAD) as i32;
        let sw = 26; // swatch width
        let frame = stroke(palette::FRAME, 1);
        for row in legend_rows(input) {
            let cy = y + LEGEND_ROW_H as i32 / 2;
            let (ul, br) = ((x0, cy - 6), (x0 + sw, cy + 6));
            match row.swatch {
                Swatch::Fill(c) => {
                    self.be.draw_rect(ul, br, &fill(c), true).be()?;
                    self.be.draw_rect(ul, br, &frame, false).be()?;
                }
                Swatch::Outline(c) => {
                    self.be.draw_rect((ul.0 + 2, ul.1 + 1), (br.0 - 2, br.1 - 1), &stroke(c, 2), false).be()?;
                }
                Swatch::Line(c) => {
                    self.be.draw_path([(x0, cy + 3), (x0 + 9, cy - 3), (x0 + 17, cy + 2), (x0 + sw, cy - 3)], &stroke(c, 2)).be()?;
                }
                Swatch::Dots(c) => {
                    for (dx, dy) in [(4, -3), (12, 3), (20, -2)] {
                        self.be.draw_circle((x0 + dx, cy + dy), 2, &fill(c), true).be()?;
                    }
                }
                Swatch::Squares(c) => {
                    for k in 0..6 {
                        let (px, py) = (x0 + 2 + 4 * k, cy + if k % 2 == 0 { -1 } else { 1 });
                        self.be.draw_rect((px, py), (px + 3, py + 3), &fill(c), true).be()?;
                    }
                }
                Swatch::Circle(c) => {
                    let centre = (x0 + sw / 2, cy);
                    self.be.draw_circle(centre, 5, &fill_a(c, 0.35), true).be()?;
                    self.be.draw_circle(centre, 5, &stroke(c, 1), false).be()?;
                }
                Swatch::Arrow(c) => {
                    self.arrow_px([x0 as f64 + 4.0, cy as f64], 0.0, 18.0, c, 1)?;
                }
                Swatch::Triangle(c) => {
                    self.be.fill_polygon([(x0 + 20, cy), (x0 + 6, cy - 6), (x0 + 6, cy + 6)], &fill(c)).be()?;
                }
                Swatch::Robot => {
                    let apex = (x0 + 5, cy);
                    self.be.draw_path([(x0 + sw, cy - 7), apex, (x0 + sw, cy + 7)], &stroke(palette::CONE, 1)).be()?;
                    self.be.draw_circle(apex, 4, &fill(palette::TRAJECTORY), true).be()?;
                }
                Swatch::Goal => {
                    self.be.draw_line((x0, cy + 4), (x0 + 5, cy + 4), &stroke(palette::GOAL, 2)).be()?;
                    self.be.draw_line((x0 + 9, cy + 4), (x0 + 14, cy + 4), &stroke(palette::GOAL, 2)).be()?;
                    self.arrow_px([x0 as f64 + 16.0, cy as f64 + 4.0], 0.8, 12.0, palette::GOAL, 2)?;
                }
                Swatch::Star => {
                    self.star_px([(x0 + sw / 2) as f64, cy as f64], 8.0, palette::FOUND, [120, 0, 0])?;
                }
            }
            self.text(row.label, (x0 + sw + 8, cy - 5), LEGEND_FONT_PX, palette::TEXT);
            y += LEGEND_ROW_H as i32;
        }

        // Outcome (a simulated world only).
        y += 6;
        let status = match input.found_at {
            Some(p) if finite(p) => format!("Target FOUND at ({:.1}, {:.1})", p[0], p[1]),
            Some(_) => "Target FOUND".to_string(),
            None if has_world(input) => "Target NOT found".to_string(),
            None => String::new(),
        };
        let colour = if input.found_at.is_some() { palette::FOUND } else { [90, 90, 90] };
        self.text(&status, (x0, y + 5), LEGEND_FONT_PX + 1.0, colour);
        y += LEGEND_ROW_H as i32 + 4;

        // Scale bar: the largest "nice" length that fits in 150 px.
        let ppm = l.px_per_m;
        let metres = [100.0, 50.0, 20.0, 10.0, 5.0, 2.0, 1.0, 0.5, 0.2, 0.1].into_iter().find(|m| m * ppm <= 150.0).unwrap_or(0.1);
        let bar = (metres * ppm).round().max(1.0) as i32;
        let cy = y + 8;
        let ink = stroke(palette::TEXT, 1);
        self.be.draw_rect((x0, cy - 1), (x0 + bar, cy + 2), &fill(palette::TEXT), true).be()?;
        self.be.draw_line((x0, cy - 5), (x0, cy + 5), &ink).be()?;
        self.be.draw_line((x0 + bar, cy - 5), (x0 + bar, cy + 5), &ink).be()?;
        let label = if metres >= 1.0 { format!("{metres:.0} m") } else { format!("{metres:.1} m") };
        self.text(&label, (x0 + bar + 6, cy - 5), LEGEND_FONT_PX, palette::TEXT);
        y += LEGEND_ROW_H as i32;

        let cell = grid_cell_m(&input.grid).unwrap_or(FALLBACK_CELL_M);
        let note = format!("grid cell {cell:.2} m · north up");
        self.text(&note, (x0, y + 6), LEGEND_FONT_PX - 1.0, [90, 90, 90]);
        Ok(())
    }
}

/// One panel of a strip plot: a title, the y-axis limit, and named columns of values.
pub struct StripPanel<'a> {
    /// Panel title (the setting, e.g. `apartment easy`).
    pub title: String,
    /// The y axis runs from 0 to this (the time limit).
    pub y_max: f64,
    /// Columns: a label (the planner) and its values (one dot each; the mean is a bar).
    pub columns: Vec<(&'a str, Vec<f64>)>,
}

/// Writes strip plots (one panel per entry, two panels per row) as a PNG: each value a dot, each
/// column's mean a bar, the y axis from 0 to the panel's `y_max` with the unit `y_label`.
pub fn write_strip_plot(path: &Path, title: &str, y_label: &str, panels: &[StripPanel]) -> Result<(), RenderError> {
    ensure_font();
    const PW: u32 = 460;
    const PH: u32 = 300;
    const TOP: u32 = 36;
    let cols = panels.len().clamp(1, 2) as u32;
    let rows = (panels.len() as u32).div_ceil(cols).max(1);
    let (w, h) = (PW * cols, TOP + PH * rows);
    let mut data = vec![255u8; (w * h * 3) as usize];
    {
        let mut be = BitMapBackend::with_buffer(&mut data, (w, h));
        let black = [0, 0, 0];
        let text = |be: &mut BitMapBackend, s: &str, pos: (i32, i32), size: f64| {
            let colour = rgb(black);
            let _ = be.draw_text(s, &TextStyle::from(font(size)).color(&colour), pos);
        };
        text(&mut be, title, (10, 8), TITLE_FONT_PX);
        for (k, p) in panels.iter().enumerate() {
            let (ox, oy) = ((k as u32 % cols * PW) as i32, (TOP + k as u32 / cols * PH) as i32);
            let (x0, x1, y0, y1) = (ox + 60, ox + PW as i32 - 15, oy + 28, oy + PH as i32 - 40);
            text(&mut be, &p.title, (ox + 60, oy + 6), LEGEND_FONT_PX + 1.0);
            be.draw_rect((x0, y0), (x1, y1), &stroke([120, 120, 120], 1), false).be()?;
            let y_max = if p.y_max.is_finite() && p.y_max > 0.0 { p.y_max } else { 1.0 };
            let ypx = |v: f64| y1 - ((v.clamp(0.0, y_max) / y_max) * (y1 - y0) as f64).round() as i32;
            for i in 0..=4 {
                let v = y_max * i as f64 / 4.0;
                let y = ypx(v);
                be.draw_line((x0 - 4, y), (x0, y), &stroke([120, 120, 120], 1)).be()?;
                text(&mut be, &format!("{v:.0}"), (ox + 22, y - 7), LEGEND_FONT_PX - 1.0);
            }
            text(&mut be, y_label, (ox + 4, oy + 6), LEGEND_FONT_PX - 2.0);
            let n = p.columns.len().max(1) as i32;
            let slot = (x1 - x0) / n;
            for (j, (label, values)) in p.columns.iter().enumerate() {
                let cx = x0 + slot * j as i32 + slot / 2;
                let colour = palette::SERIES[j % palette::SERIES.len()];
                for (i, &v) in values.iter().enumerate() {
                    if !v.is_finite() {
                        continue;
                    }
                    let jitter = ((i as i32 * 7) % 11 - 5) * 2;
                    be.draw_circle((cx + jitter, ypx(v)), 3, &fill_a(colour, 0.7), true).be()?;
                }
                let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
                if !finite.is_empty() {
                    let m = finite.iter().sum::<f64>() / finite.len() as f64;
                    be.draw_line((cx - slot / 3, ypx(m)), (cx + slot / 3, ypx(m)), &stroke(colour, 3)).be()?;
                }
                text(&mut be, label, (cx - 6 * label.len() as i32 / 2 - 4, y1 + 8), LEGEND_FONT_PX - 1.0);
            }
        }
        be.present().map_err(backend_err)?;
    }
    let img = RgbImage { width: w, height: h, data };
    let mut out = BufWriter::new(std::fs::File::create(path)?);
    encode_png(&mut out, &img)?;
    out.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Instant;

    fn tmp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("lives-render-{}-{name}.png", std::process::id()))
    }

    /// Set LIVES_KEEP_RENDER=1 to keep the test pictures for a look.
    fn keep_or_remove(path: &Path) {
        if std::env::var_os("LIVES_KEEP_RENDER").is_none() {
            std::fs::remove_file(path).ok();
        } else {
            eprintln!("kept {}", path.display());
        }
    }

    fn png_size(bytes: &[u8]) -> (u32, u32) {
        assert!(bytes.len() > 33, "PNG too short");
        assert_eq!(&bytes[..8], &[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a], "PNG signature");
        assert_eq!(&bytes[12..16], b"IHDR");
        let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
        let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
        assert_eq!(&bytes[bytes.len() - 8..bytes.len() - 4], b"IEND");
        (w, h)
    }

    /// Grid 100 x 100 at origin (0, 0): x < 4.0 m free, 4.0..4.2 m occupied,
    /// beyond unknown; the camera has seen free cells with x < 2.0 m.
    fn lidar(x: usize, _y: usize) -> i8 {
        match x {
            0..=39 => 0,
            40..=41 => 100,
            _ => -1,
        }
    }
    fn seen(x: usize, _y: usize) -> bool {
        x < 20
    }

    fn has_colour_near(img: &RgbImage, (x, y): (u32, u32), r: i32, c: [u8; 3]) -> bool {
        (-r..=r).any(|dy| {
            (-r..=r).any(|dx| {
                let (xx, yy) = (x as i32 + dx, y as i32 + dy);
                xx >= 0 && yy >= 0 && (xx as u32) < img.width && (yy as u32) < img.height && img.pixel(xx as u32, yy as u32) == c
            })
        })
    }

    struct Data {
        walls: Vec<[P2; 2]>,
        obstacles: Vec<Vec<P2>>,
        people: Vec<P2>,
        targets: Vec<Vec<P2>>,
        nonmap: Vec<P2>,
        frontier: Vec<P2>,
        viewpoints: Vec<(P2, f64)>,
        traj: Vec<P2>,
        goal_path: Vec<P2>,
    }

    fn data() -> Data {
        Data {
            walls: vec![[[0.0, 0.0], [8.0, 0.0]], [[0.0, 6.0], [8.0, 6.0]], [[0.0, 0.0], [0.0, 6.0]]],
            obstacles: vec![vec![[6.0, 4.0], [7.0, 4.0], [7.0, 5.0], [6.0, 5.0]]],
            people: vec![[6.5, 2.0]],
            targets: vec![vec![[7.0, 1.0], [7.5, 1.0], [7.5, 1.3], [7.0, 1.3]]],
            nonmap: vec![[2.0, 5.0], [2.5, 5.0]],
            frontier: vec![[3.95, 2.0], [3.95, 2.1]],
            viewpoints: vec![([5.0, 5.0], 0.5)],
            traj: vec![[1.0, 1.0], [3.0, 1.0], [3.0, 2.5]],
            goal_path: vec![[3.0, 2.5], [5.0, 3.0]],
        }
    }

    fn input<'a>(d: &'a Data, found: Option<P2>) -> RenderInput<'a> {
        RenderInput {
            title: "test world · lives-gt · seed 1 · FOUND in 42.6 s · path 18.3 m".into(),
            bounds: [[0.0, 0.0], [8.0, 6.0]],
            walls: &d.walls,
            obstacles: &d.obstacles,
            people: &d.people,
            targets: &d.targets,
            grid: GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 100, height: 100, lidar: &lidar, seen: &seen },
            nonmap_points: &d.nonmap,
            frontier_cells: &d.frontier,
            viewpoints: &d.viewpoints,
            trajectory: &d.traj,
            start: ([1.0, 1.0], 0.0),
            robot: ([3.0, 2.5], 1.0),
            goal: Some(([5.0, 3.0], 0.0)),
            goal_path: &d.goal_path,
            found_at: found,
            camera_fov_rad: std::f64::consts::FRAC_PI_2,
            camera_range_m: 4.0,
        }
    }

    #[test]
    fn the_legend_lists_non_map_points_and_frontiers_only_when_the_picture_has_them() {
        let d = data();
        let labels = |inp: &RenderInput| legend_rows(inp).iter().map(|r| r.label).collect::<Vec<_>>();
        let full = labels(&input(&d, None));
        assert!(full.contains(&"Non-map points") && full.contains(&"Frontier cells"), "{full:?}");
        let mut inp = input(&d, None);
        inp.nonmap_points = &[];
        inp.frontier_cells = &[];
        let bare = labels(&inp);
        assert!(!bare.contains(&"Non-map points") && !bare.contains(&"Frontier cells"), "{bare:?}");
        assert_eq!(bare.len() + 2, full.len());
        // The legend's height follows its rows.
        assert!(layout(&inp).height <= layout(&input(&d, None)).height);
    }

    #[test]
    fn synthetic_input_writes_png_with_expected_size_and_colours() {
        let d = data();
        let inp = input(&d, Some([3.0, 2.5]));
        let lay = layout(&inp);
        // 8 m x 6 m plus 1 m margins at 20 px/m.
        assert_eq!((lay.map_w, lay.map_h), (200, 160));
        assert_eq!(lay.map_y0, TITLE_H);
        assert_eq!(lay.height, TITLE_H + 160u32.max(lay.legend_h));
        assert!(lay.width >= 200 + LEGEND_W);

        let path = tmp("synthetic");
        render_png(&path, &inp).expect("render");
        let bytes = std::fs::read(&path).unwrap();
        keep_or_remove(&path);
        assert_eq!(png_size(&bytes), (lay.width, lay.height));

        let img = render_rgb(&inp).unwrap();
        assert_eq!((img.width, img.height), (lay.width, lay.height));
        let at = |p: P2| img.pixel(lay.pixel_of(p).unwrap().0, lay.pixel_of(p).unwrap().1);
        assert_eq!(at([1.03, 3.53]), palette::SEEN, "camera-seen free cell");
        assert_eq!(at([3.03, 4.53]), palette::FREE, "LiDAR free cell");
        assert_eq!(at([4.13, 3.53]), palette::OCCUPIED, "LiDAR occupied cell");
        assert_eq!(at([5.53, 1.03]), palette::UNKNOWN, "LiDAR unknown cell");
        assert_eq!(at([-0.47, 3.03]), palette::UNKNOWN, "outside the grid");
        assert_eq!(at([2.0, 5.0]), palette::NONMAP, "non-map point");
        assert_eq!(at([3.95, 2.05]), palette::FRONTIER, "frontier cell");
        assert!(has_colour_near(&img, lay.pixel_of([2.0, 1.0]).unwrap(), 1, palette::TRAJECTORY));
        assert!(has_colour_near(&img, lay.pixel_of([3.0, 2.5]).unwrap(), 7, palette::FOUND));
        assert!(has_colour_near(&img, lay.pixel_of([7.25, 1.0]).unwrap(), 1, palette::TARGET));
        assert!(has_colour_near(&img, lay.pixel_of([4.0, 0.0]).unwrap(), 1, palette::WALL));
        assert!(has_colour_near(&img, lay.pixel_of([1.0, 1.0]).unwrap(), 2, palette::START));
        // The title was drawn: dark pixels in the title strip.
        let dark = (0..lay.width)
            .flat_map(|x| (0..TITLE_H).map(move |y| (x, y)))
            .filter(|&(x, y)| img.pixel(x, y).iter().all(|&c| c < 100))
            .count();
        assert!(dark > 100, "title text missing ({dark} dark pixels)");
        // The legend was drawn: swatches of the palette right of the map.
        let legend_has = |c: [u8; 3]| (lay.map_w..lay.width).any(|x| (TITLE_H..lay.height).any(|y| img.pixel(x, y) == c));
        for c in [palette::SEEN, palette::OCCUPIED, palette::NONMAP, palette::FRONTIER, palette::GOAL] {
            assert!(legend_has(c), "legend lacks {c:?}");
        }
    }

    #[test]
    fn not_found_run_renders() {
        let d = data();
        let img = render_rgb(&input(&d, None)).unwrap();
        assert!(img.width > 0 && img.height > 0);
    }

    #[test]
    fn long_title_widens_the_picture() {
        let d = data();
        let mut inp = input(&d, None);
        inp.title = "x".repeat(300);
        let lay = layout(&inp);
        assert!(lay.width > 200 + LEGEND_W);
        assert_eq!(render_rgb(&inp).unwrap().width, lay.width);
    }

    #[test]
    fn empty_and_nan_inputs_do_not_panic() {
        let never = |_: usize, _: usize| -> i8 { panic!("grid has no cells") };
        let no = |_: usize, _: usize| false;
        let empty = RenderInput {
            title: String::new(),
            bounds: [[f64::NAN, 0.0], [1.0, f64::INFINITY]],
            walls: &[],
            obstacles: &[],
            people: &[],
            targets: &[],
            grid: GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 0, height: 0, lidar: &never, seen: &no },
            nonmap_points: &[],
            frontier_cells: &[],
            viewpoints: &[],
            trajectory: &[],
            start: ([f64::NAN, f64::NAN], f64::NAN),
            robot: ([f64::NAN, 1.0], f64::NAN),
            goal: None,
            goal_path: &[],
            found_at: None,
            camera_fov_rad: f64::NAN,
            camera_range_m: f64::NAN,
        };
        let path = tmp("empty");
        render_png(&path, &empty).expect("empty input renders");
        let bytes = std::fs::read(&path).unwrap();
        std::fs::remove_file(&path).ok();
        let lay = layout(&empty);
        assert_eq!(png_size(&bytes), (lay.width, lay.height));

        let nan = [f64::NAN, f64::NAN];
        let inf = [f64::INFINITY, 0.0];
        let huge = [1e300, -1e300];
        let walls = vec![[nan, [1.0, 1.0]], [[0.0, 0.0], huge], [inf, [0.0, 0.0]]];
        let obstacles = vec![vec![nan, [1.0, 1.0], huge], vec![]];
        let pts = vec![nan, inf, huge, [1.0, 1.0], [-1e12, 5.0]];
        let vps = vec![(nan, 0.0), ([1.0, 1.0], f64::NAN), (huge, 1.0)];
        let lid = |_: usize, _: usize| -> i8 { 0 };
        let bad = RenderInput {
            title: "NaN everywhere".into(),
            bounds: [[0.0, 0.0], [5.0, 5.0]],
            walls: &walls,
            obstacles: &obstacles,
            people: &pts,
            targets: &obstacles,
            grid: GridView { origin: nan, cell_m: f64::NAN, width: 10, height: 10, lidar: &lid, seen: &no },
            nonmap_points: &pts,
            frontier_cells: &pts,
            viewpoints: &vps,
            trajectory: &pts,
            start: (huge, 0.0),
            robot: ([1.0, 1.0], 0.3),
            goal: Some((nan, 0.0)),
            goal_path: &pts,
            found_at: Some(nan),
            camera_fov_rad: 1.0,
            camera_range_m: 1e300,
        };
        let img = render_rgb(&bad).expect("NaN input renders");
        assert_eq!((img.width, img.height), (layout(&bad).width, layout(&bad).height));

        // Zero-size and inverted bounds with a valid grid fall back to the grid.
        let mut inv = bad;
        inv.bounds = [[5.0, 5.0], [0.0, 0.0]];
        inv.grid = GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 30, height: 20, lidar: &lid, seen: &no };
        let lay = layout(&inv);
        assert_eq!((lay.map_w, lay.map_h), (100, 80));
        render_rgb(&inv).expect("inverted bounds render");
    }

    #[test]
    fn huge_bounds_are_scaled_down() {
        let d = data();
        let mut inp = input(&d, None);
        inp.bounds = [[0.0, 0.0], [1e6, 10.0]];
        let lay = layout(&inp);
        assert!(lay.map_w as f64 <= MAX_MAP_PX + 1.0);
        assert!(lay.px_per_m > 0.0);
    }

    #[test]
    fn unwritable_path_is_an_io_error() {
        let d = data();
        let path = std::env::temp_dir().join("lives-render-no-such-dir").join("x").join("out.png");
        match render_png(&path, &input(&d, None)) {
            Err(RenderError::Io(_)) => {}
            other => panic!("expected Io error, got {other:?}"),
        }
    }

    #[test]
    fn full_size_grid_renders() {
        // 512 x 512 cells, 51.2 m square world, walls every 5 m.
        let lid = |x: usize, y: usize| -> i8 {
            if x.is_multiple_of(50) || y.is_multiple_of(50) {
                100
            } else if (x + y).is_multiple_of(7) || x > 400 {
                -1
            } else {
                0
            }
        };
        let sn = |x: usize, y: usize| (x / 30 + y / 30).is_multiple_of(2);
        let walls: Vec<[P2; 2]> = (0..=10)
            .flat_map(|k| {
                let v = k as f64 * 5.0;
                [[[v, 0.0], [v, 51.2]], [[0.0, v], [51.2, v]]]
            })
            .collect();
        let traj: Vec<P2> = (0..5000)
            .map(|i| {
                let t = i as f64 * 0.01;
                [25.0 + 20.0 * t.cos() * (t / 50.0), 25.0 + 20.0 * t.sin() * (t / 50.0)]
            })
            .collect();
        let nonmap: Vec<P2> = (0..2000).map(|i| [(i % 50) as f64, (i / 50) as f64]).collect();
        let frontier: Vec<P2> = (0..3000).map(|i| [40.05, i as f64 * 0.017]).collect();
        let inp = RenderInput {
            title: "big world · lives-gt · seed 7 · NOT FOUND · path 120.0 m".into(),
            bounds: [[0.0, 0.0], [51.2, 51.2]],
            walls: &walls,
            obstacles: &[],
            people: &[[10.0, 10.0]],
            targets: &[],
            grid: GridView { origin: [0.0, 0.0], cell_m: 0.1, width: 512, height: 512, lidar: &lid, seen: &sn },
            nonmap_points: &nonmap,
            frontier_cells: &frontier,
            viewpoints: &[],
            trajectory: &traj,
            start: ([25.0, 25.0], 0.0),
            robot: ([30.0, 30.0], 2.0),
            goal: Some(([35.0, 35.0], 1.0)),
            goal_path: &[[30.0, 30.0], [35.0, 35.0]],
            found_at: None,
            camera_fov_rad: std::f64::consts::FRAC_PI_2,
            camera_range_m: 4.0,
        };
        let t = Instant::now();
        let path = tmp("big");
        render_png(&path, &inp).expect("render");
        let dt = t.elapsed();
        let bytes = std::fs::read(&path).unwrap();
        keep_or_remove(&path);
        let lay = layout(&inp);
        assert_eq!((lay.map_w, lay.map_h), (1064, 1064));
        assert_eq!(png_size(&bytes), (lay.width, lay.height));
        eprintln!("512x512-cell render + PNG write: {:.1} ms", dt.as_secs_f64() * 1e3);
    }
}
