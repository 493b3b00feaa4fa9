//! Fonts, the legend's rows and the picture's layout.

use std::sync::Once;

use super::*;
use plotters::style::{FontDesc, FontFamily, FontStyle};

pub(super) const FONT_FAMILY: &str = "sans-serif";
pub(super) static FONT_BYTES: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
pub(super) static FONT_INIT: Once = Once::new();

/// Registers the embedded DejaVu Sans as plotters' "sans-serif" (once).
pub(super) fn ensure_font() {
    FONT_INIT.call_once(|| {
        // The font is embedded and tested; if registration ever failed the
        // picture would simply have no text (text errors are not fatal).
        let _ = plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT_BYTES);
    });
}

pub(super) const TITLE_FONT_PX: f64 = 18.0;
pub(super) const LEGEND_FONT_PX: f64 = 13.0;
pub(super) const LEGEND_ROW_H: u32 = 20;
pub(super) const LEGEND_PAD: u32 = 10;

pub(super) fn font(size: f64) -> FontDesc<'static> {
    FontDesc::new(FontFamily::Name(FONT_FAMILY), size, FontStyle::Normal)
}

pub(super) fn text_width(text: &str, size: f64) -> u32 {
    ensure_font();
    match font(size).box_size(text) {
        Ok((w, _)) => w,
        Err(_) => (text.chars().count() as f64 * size * 0.6).ceil() as u32,
    }
}

pub(super) fn finite(p: P2) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

pub(super) fn valid_box(b: [P2; 2]) -> bool {
    finite(b[0]) && finite(b[1]) && b[1][0] > b[0][0] && b[1][1] > b[0][1]
}

pub(super) fn grid_cell_m(grid: &GridView) -> Option<f64> {
    (grid.cell_m.is_finite() && grid.cell_m > 0.0).then_some(grid.cell_m)
}

/// The world box shown (before the margin): the given bounds, else the
/// grid's extent, else 10 m x 10 m at the origin.
pub(super) fn world_box(input: &RenderInput) -> [P2; 2] {
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

pub(super) struct LegendRow {
    pub(super) label: &'static str,
    pub(super) swatch: Swatch,
}

#[derive(Clone, Copy)]
pub(super) enum Swatch {
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
pub(super) fn has_world(input: &RenderInput) -> bool {
    !(input.walls.is_empty() && input.obstacles.is_empty() && input.people.is_empty() && input.targets.is_empty())
}

pub(super) fn legend_rows(input: &RenderInput) -> Vec<LegendRow> {
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
pub(super) const LEGEND_EXTRA_ROWS: u32 = 4;

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
