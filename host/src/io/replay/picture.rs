//! The picture of a replay: the controller's LiDAR grid and camera-seen cells, non-map points,
//! frontier cells, the best candidates of the last planning step, the laser's trajectory, and
//! every goal the controller would have sent (dots with a tick along the heading, in the goal
//! colour; the last one also with its planned path). There is no true world to draw.

use super::ReplayRun;
use crate::render::{encode_png, layout, palette, render_rgb, GridView, RenderError, RenderInput, RgbImage};
use firmware::capacity::GRID_CELLS;
use std::io::Write;
use std::path::Path;

/// Writes the picture of `run` to `path`.
pub fn write_png(run: &ReplayRun, path: &Path, title: &str) -> Result<(), RenderError> {
    let img = render(run, title)?;
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    encode_png(&mut out, &img)?;
    out.flush()?;
    Ok(())
}

/// Renders the picture of `run` into memory.
pub fn render(run: &ReplayRun, title: &str) -> Result<RgbImage, RenderError> {
    let ctrl = &run.controller;
    let crate::render::picture::ControllerLayers { origin, cell_m: cell, nonmap, frontier_cells, viewpoints, goal, goal_path } =
        crate::render::picture::controller_layers(ctrl);
    let lidar = |x: usize, y: usize| ctrl.lidar.get(x as i32, y as i32).to_ros();
    let seen = |x: usize, y: usize| ctrl.visual.seen(x as i32, y as i32);
    // Show what was mapped: the trajectory's box grown by 10 m (the laser reaches well beyond
    // it), clipped to the grid.
    let b = run.report.trajectory_bounds;
    let size = super::grid_size_m();
    let bounds = [
        [(b[0][0] - 10.0).max(origin[0]), (b[0][1] - 10.0).max(origin[1])],
        [(b[1][0] + 10.0).min(origin[0] + size), (b[1][1] + 10.0).min(origin[1] + size)],
    ];
    let (fp, lp) = (run.first_pose, run.last_pose);
    let input = RenderInput {
        title: title.to_string(),
        bounds,
        walls: &[],
        obstacles: &[],
        people: &[],
        targets: &[],
        grid: GridView { origin, cell_m: cell, width: GRID_CELLS, height: GRID_CELLS, lidar: &lidar, seen: &seen },
        nonmap_points: &nonmap,
        frontier_cells: &frontier_cells,
        viewpoints: &viewpoints,
        trajectory: &run.trajectory,
        start: ([fp[0], fp[1]], fp[2]),
        robot: ([lp[0], lp[1]], lp[2]),
        goal,
        goal_path: &goal_path,
        found_at: None,
        camera_fov_rad: ctrl.config().camera_fov.to_radians().abs(),
        camera_range_m: ctrl.config().camera_range_m.to_num::<f64>(),
    };
    let mut img = render_rgb(&input)?;
    // Every goal it would have sent: a dot with a tick along the heading, in the goal colour.
    let lay = layout(&input);
    for g in &run.report.goals {
        let [px, py] = lay.world_to_px([g.x, g.y]);
        let h = g.heading_deg.to_radians();
        disc(&mut img, px, py, 3.5, palette::GOAL);
        for k in 0..=12 {
            let d = k as f64;
            dot(&mut img, px + d * h.cos(), py - d * h.sin(), palette::GOAL);
        }
    }
    Ok(img)
}

fn dot(img: &mut RgbImage, x: f64, y: f64, c: [u8; 3]) {
    if !(x.is_finite() && y.is_finite()) || x < 0.0 || y < 0.0 {
        return;
    }
    let (x, y) = (x as u32, y as u32);
    if x < img.width && y < img.height {
        let i = 3 * (y as usize * img.width as usize + x as usize);
        img.data[i..i + 3].copy_from_slice(&c);
    }
}

fn disc(img: &mut RgbImage, x: f64, y: f64, r: f64, c: [u8; 3]) {
    let ri = r.ceil() as i32;
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            if ((dx * dx + dy * dy) as f64) <= r * r {
                dot(img, x + dx as f64, y + dy as f64, c);
            }
        }
    }
}
