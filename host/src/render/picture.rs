//! What the pictures of a search and of a replay share: the outline of a world's shape and the
//! layers of the controller's state ([`controller_layers`]).

use crate::sim::Shape;
use firmware::capacity::GRID_CELLS;

/// The outline of a shape as a closed polygon.
pub fn outline(shape: &Shape) -> Vec<[f64; 2]> {
    match shape {
        Shape::Rect { center, size, yaw } => {
            let (s, c) = yaw.sin_cos();
            [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]
                .iter()
                .map(|k| {
                    let (dx, dy) = (k[0] * size[0] / 2.0, k[1] * size[1] / 2.0);
                    [center[0] + c * dx - s * dy, center[1] + s * dx + c * dy]
                })
                .collect()
        }
        Shape::Circle { center, radius } => (0..24)
            .map(|i| i as f64 * std::f64::consts::TAU / 24.0)
            .map(|a| [center[0] + radius * a.cos(), center[1] + radius * a.sin()])
            .collect(),
        Shape::Polygon { points } => points.clone(),
    }
}

/// What a picture shows of the controller's state, in metres (shared by the search and replay
/// pictures).
pub struct ControllerLayers {
    /// Lower-left corner of the grid.
    pub origin: [f64; 2],
    /// Cell size.
    pub cell_m: f64,
    /// Stored non-map points.
    pub nonmap: Vec<[f64; 2]>,
    /// Centres of the frontier cells of both maps.
    pub frontier_cells: Vec<[f64; 2]>,
    /// The twelve best candidates of the last planning step (position, heading): enough to show
    /// the choice, few enough to keep the map readable.
    pub viewpoints: Vec<([f64; 2], f64)>,
    /// The current goal (position, heading).
    pub goal: Option<([f64; 2], f64)>,
    /// Its planned path.
    pub goal_path: Vec<[f64; 2]>,
}

/// Reads the layers of a picture off `ctrl`.
pub fn controller_layers(ctrl: &firmware::Controller) -> ControllerLayers {
    let geom = ctrl.lidar.geom;
    let origin = [geom.origin_x.to_num::<f64>(), geom.origin_y.to_num::<f64>()];
    let cell = 1.0 / firmware::capacity::CELLS_PER_METER as f64;
    let centre = |x: i32, y: i32| [origin[0] + (x as f64 + 0.5) * cell, origin[1] + (y as f64 + 0.5) * cell];
    let nonmap: Vec<[f64; 2]> = ctrl.nonmap.points().iter().map(|p| [p.x.to_num::<f64>(), p.y.to_num::<f64>()]).collect();
    let mut frontier_cells = Vec::new();
    for y in 0..GRID_CELLS as i32 {
        for x in 0..GRID_CELLS as i32 {
            if firmware::FrontierSet::is_frontier(&ctrl.lidar.grid, x, y) || firmware::FrontierSet::is_frontier(&ctrl.visual.grid, x, y) {
                frontier_cells.push(centre(x, y));
            }
        }
    }
    let mut ranked: Vec<_> = ctrl.planner.candidates.iter().collect();
    ranked.sort_by_key(|v| std::cmp::Reverse(v.utility));
    let viewpoints: Vec<([f64; 2], f64)> = ranked.iter().take(12).map(|v| (centre(v.cell.0, v.cell.1), v.heading.to_radians())).collect();
    let goal = ctrl.goal().map(|g| ([g.pose.x.to_num::<f64>(), g.pose.y.to_num::<f64>()], g.pose.theta.to_radians()));
    let goal_path: Vec<[f64; 2]> =
        ctrl.goal().map(|g| g.path.iter().map(|w| [w.0.to_num::<f64>(), w.1.to_num::<f64>()]).collect()).unwrap_or_default();
    ControllerLayers { origin, cell_m: cell, nonmap, frontier_cells, viewpoints, goal, goal_path }
}
