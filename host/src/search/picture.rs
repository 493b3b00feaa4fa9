//! The picture of a finished simulated search: the world, the controller's maps and layers, the
//! path, written as a PNG by the renderer (`crate::render`).

use super::SearchRun;
use crate::render::picture::{controller_layers, outline, ControllerLayers};
use crate::render::{render_png, GridView, RenderError, RenderInput};
use firmware::capacity::GRID_CELLS;
use std::path::Path;

/// Writes the picture of `run` to `path` with `title`.
pub fn write_png(run: &SearchRun, path: &Path, title: &str) -> Result<(), RenderError> {
    let ctrl = &run.controller;
    let world = run.sim.world();
    let ControllerLayers { origin, cell_m: cell, nonmap, frontier_cells, viewpoints, goal, goal_path } = controller_layers(ctrl);
    let obstacles: Vec<Vec<[f64; 2]>> = world.obstacles.iter().map(|o| outline(&o.shape)).collect();
    let targets: Vec<Vec<[f64; 2]>> = run.sim.target_shapes().iter().map(outline).collect();
    let people: Vec<[f64; 2]> = run.sim.people().iter().map(|p| p.0).collect();
    let pose = run.sim.pose();
    let lidar = |x: usize, y: usize| ctrl.lidar.get(x as i32, y as i32).to_ros();
    let seen = |x: usize, y: usize| ctrl.visual.seen(x as i32, y as i32);
    let input = RenderInput {
        title: title.to_string(),
        bounds: world.bounds,
        walls: &world.walls,
        obstacles: &obstacles,
        people: &people,
        targets: &targets,
        grid: GridView { origin, cell_m: cell, width: GRID_CELLS, height: GRID_CELLS, lidar: &lidar, seen: &seen },
        nonmap_points: &nonmap,
        frontier_cells: &frontier_cells,
        viewpoints: &viewpoints,
        trajectory: &run.trajectory,
        start: ([run.start[0], run.start[1]], run.start[2]),
        robot: ([pose[0], pose[1]], pose[2]),
        goal,
        goal_path: &goal_path,
        found_at: run.found_at,
        camera_fov_rad: run.sim.config().camera_fov_rad,
        camera_range_m: run.sim.config().camera_range_m,
    };
    render_png(path, &input)
}
