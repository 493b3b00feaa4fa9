//! Conversions from the controller's types to the recording's messages.

use base64::Engine as _;
use firmware::capacity::{CELLS_PER_METER, GRID_CELLS};
use firmware::grid::{Cell, GridGeometry, PackedGrid};
use firmware::planner::Site;

use super::msg::*;
use super::*;

pub(super) const LOG_INFO: u8 = 2;
pub(super) const LOG_WARNING: u8 = 3;

pub(super) fn site_name(s: Site) -> &'static str {
    match s {
        Site::LidarFrontier => "lidar-frontier",
        Site::VisualFrontier => "visual-frontier",
        Site::NonMapCluster => "nonmap-cluster",
        Site::Here => "here",
        Site::Current => "current",
        Site::Room => "room",
        Site::Route => "route",
        Site::Inspection => "inspection",
    }
}

pub(super) fn base64(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

/// The centre of cell `c`, metres.
pub(crate) fn cell_centre(geom: &GridGeometry, c: (i32, i32)) -> [f64; 2] {
    let (x, y) = geom.center_of(c.0, c.1);
    [x.to_num::<f64>(), y.to_num::<f64>()]
}

/// The smallest box `[x0, y0, x1, y1]` (inclusive cells) holding every cell either grid knows.
pub(super) fn known_box(a: &PackedGrid, b: &PackedGrid) -> Option<[i32; 4]> {
    let n = GRID_CELLS as i32;
    let mut bx: Option<[i32; 4]> = None;
    for y in 0..n {
        for x in 0..n {
            if a.get(x, y) != Cell::Unknown || b.get(x, y) != Cell::Unknown {
                bx = Some(match bx {
                    None => [x, y, x, y],
                    Some([x0, y0, x1, y1]) => [x0.min(x), y0.min(y), x1.max(x), y1.max(y)],
                });
            }
        }
    }
    bx
}

pub(super) fn grid_msg(t_us: u64, geom: &GridGeometry, grid: &PackedGrid, [x0, y0, x1, y1]: [i32; 4]) -> Grid<'static> {
    let cell = 1.0 / CELLS_PER_METER as f64;
    let cols = (x1 - x0 + 1) as u32;
    let mut data = Vec::with_capacity(cols as usize * (y1 - y0 + 1) as usize);
    for y in y0..=y1 {
        for x in x0..=x1 {
            data.push(grid.get(x, y).to_ros() as u8);
        }
    }
    let (ox, oy) = (geom.origin_x.to_num::<f64>() + x0 as f64 * cell, geom.origin_y.to_num::<f64>() + y0 as f64 * cell);
    Grid {
        timestamp: Time::of(t_us),
        frame_id: FRAME_MAP,
        pose: Pose::xy_yaw(ox, oy, 0.0),
        column_count: cols,
        cell_size: Vec2 { x: cell, y: cell },
        row_stride: cols,
        cell_stride: 1,
        fields: &GRID_FIELDS,
        data: base64(&data),
    }
}
