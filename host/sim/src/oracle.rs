//! The oracle of a search: how soon a robot that knew the world and where the target is could
//! have detected it. It is the physical limit of a trial, against which `lives eval` reports
//! every planner's time (`time / oracle`).
//!
//! The oracle walks the shortest path, on the true world's free space inflated by the body's
//! radius (walls, obstacles and the placed targets; people are left out, they move), from the
//! trial's start to the nearest pose from which the simulator's own detector fires:
//!
//! `time = max(path length / speed_mps, turn / turn_rate_rps)`,
//!
//! minimised over every reachable standing point, where `turn` is the least turn from the start's
//! heading to a heading at which the detector fires there. It is a lower bound: the base never
//! drives faster than `speed_mps` nor turns faster than `turn_rate_rps`, and it can do both at
//! once (the simulated Spot walks one way while it turns to face another, `Sim::set_gaze`). A
//! planner that drives facing its path and turns at the end ("path / speed + the turn at the
//! end") is slower than this; the maximum is what no planner can beat. (The sum with the
//! path's arrival heading is not a bound: a 0.1 m step backwards would "arrive" facing a target
//! behind the start without any turn.)
//!
//! The detector's rule is the simulator's ([`Sim::visible_fraction`]): a share of at least
//! `detect_min_visible_fraction` of the target's outline samples within `camera_range_m`, within
//! half of `camera_fov_rad` of the heading, and in line of sight (walls, obstacles and other
//! targets block; here people do not). The camera is at the body's centre, as in the simulator.
//!
//! Paths are shortest paths on a 0.1 m grid with 16 neighbours per cell (the 8 adjacent ones
//! and the 8 a knight's move away): within 2.7 % of the straight line in any direction. A
//! cell is free when the body's disc at its centre touches nothing, and a move between two
//! cells needs the cells it passes free too. The start and view points are cell centres (the
//! start within 0.071 m of the true start).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::geometry::wrap_angle;
use crate::simulator::DETECT_SAMPLES;
use crate::{Sim, SimConfig, World, P2};

/// Grid resolution of the oracle's paths.
pub const ORACLE_RESOLUTION_M: f64 = 0.1;

/// The oracle's answer for one trial.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Oracle {
    /// The time to detection: the longer of the drive and the turn (s).
    pub time_s: f64,
    /// The shortest path's length to the view point (m).
    pub path_m: f64,
    /// The least turn from the start's heading to the view's (rad, ≥ 0).
    pub turn_rad: f64,
    /// Where the robot stands and looks when it detects the target: `[x, y, yaw]`.
    pub view: [f64; 3],
}

/// The oracle of the trial `seed` of `world` with the robot `config` (the same seed picks the
/// same start jitter and target place as the search's [`Sim::new`]). `None` if no reachable pose
/// detects any target.
pub fn oracle(world: &World, config: &SimConfig, seed: u64) -> Option<Oracle> {
    oracle_of(&Sim::new(world.clone(), config.clone(), seed))
}

#[derive(PartialEq)]
struct Item {
    d: f64,
    i: usize,
}
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Item {
    fn cmp(&self, other: &Self) -> Ordering {
        // A min-heap on the distance; ties by index for determinism.
        other.d.total_cmp(&self.d).then_with(|| other.i.cmp(&self.i))
    }
}

/// The 16 moves (dx, dy) and, for each, the cells it passes besides its ends.
const MOVES: [(i64, i64); 16] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (1, -1),
    (-1, 1),
    (-1, -1),
    (1, 2),
    (2, 1),
    (-1, 2),
    (-2, 1),
    (1, -2),
    (2, -1),
    (-1, -2),
    (-2, -1),
];

fn passed(dx: i64, dy: i64) -> Vec<(i64, i64)> {
    match (dx.abs(), dy.abs()) {
        (1, 1) => vec![(dx, 0), (0, dy)],
        // A knight's move passes the two cells on its way: (1, 2) passes (0, 1) and (1, 1).
        (1, 2) => vec![(0, dy / 2), (dx, dy / 2)],
        (2, 1) => vec![(dx / 2, 0), (dx / 2, dy)],
        _ => vec![],
    }
}

/// The free space of a disc of radius `radius` on a [`ORACLE_RESOLUTION_M`] grid over `world`'s
/// bounds, with the placed target shapes as obstacles too, and a Dijkstra search over it.
struct Grid {
    scene: crate::geometry::Scene,
    origin: P2,
    nx: usize,
    ny: usize,
    radius: f64,
}

impl Grid {
    fn new(world: &World, targets: &[crate::Shape], radius: f64) -> Grid {
        let (origin, nx, ny) = world.grid_over_bounds(ORACLE_RESOLUTION_M);
        let radius = if radius.is_finite() { radius.max(0.0) } else { 0.0 };
        Grid { scene: world.static_scene(targets), origin, nx, ny, radius }
    }

    fn center(&self, i: usize) -> P2 {
        let res = ORACLE_RESOLUTION_M;
        [self.origin[0] + ((i % self.nx) as f64 + 0.5) * res, self.origin[1] + ((i / self.nx) as f64 + 0.5) * res]
    }

    /// Shortest paths from `from` (whose cell counts as free), visiting cells in order of
    /// distance: `visit(distance, cell centre)` returns false to stop.
    fn dijkstra(&self, from: P2, mut visit: impl FnMut(f64, P2) -> bool) {
        let (nx, ny, res) = (self.nx, self.ny, ORACLE_RESOLUTION_M);
        let sx = ((from[0] - self.origin[0]) / res).floor();
        let sy = ((from[1] - self.origin[1]) / res).floor();
        if !(sx >= 0.0 && sy >= 0.0 && (sx as usize) < nx && (sy as usize) < ny) {
            return;
        }
        let s = sy as usize * nx + sx as usize;
        // 0 unknown, 1 free, 2 blocked (computed on first touch).
        let mut state = vec![0u8; nx * ny];
        state[s] = 1;
        let free = |x: i64, y: i64, state: &mut Vec<u8>| -> bool {
            if x < 0 || y < 0 || x as usize >= nx || y as usize >= ny {
                return false;
            }
            let i = y as usize * nx + x as usize;
            if state[i] == 0 {
                state[i] = if self.scene.disc_collides(self.center(i), self.radius) { 2 } else { 1 };
            }
            state[i] == 1
        };
        let mut dist = vec![f64::INFINITY; nx * ny];
        let mut done = vec![false; nx * ny];
        dist[s] = 0.0;
        let mut heap = BinaryHeap::new();
        heap.push(Item { d: 0.0, i: s });
        while let Some(Item { d, i }) = heap.pop() {
            if done[i] {
                continue;
            }
            done[i] = true;
            if !visit(d, self.center(i)) {
                return;
            }
            let (x, y) = ((i % nx) as i64, (i / nx) as i64);
            for (dx, dy) in MOVES {
                let (tx, ty) = (x + dx, y + dy);
                if !free(tx, ty, &mut state) || !passed(dx, dy).into_iter().all(|(px, py)| free(x + px, y + py, &mut state)) {
                    continue;
                }
                let j = ty as usize * nx + tx as usize;
                let nd = d + res * ((dx * dx + dy * dy) as f64).sqrt();
                if nd < dist[j] {
                    dist[j] = nd;
                    heap.push(Item { d: nd, i: j });
                }
            }
        }
    }
}

/// The length of the shortest path (the oracle's grid and moves, a disc of `radius`) from `from`
/// to a point within `standoff` of `to`; `None` if there is none. Obstacles, walls and nothing
/// else block (no targets, no people): for the distances the scenario rules compare.
pub fn shortest_path_m(world: &World, from: P2, to: P2, radius: f64, standoff: f64) -> Option<f64> {
    let grid = Grid::new(world, &[], radius);
    let mut found = None;
    grid.dijkstra(from, |d, c| {
        if crate::geometry::dist(c, to) <= standoff {
            found = Some(d);
            false
        } else {
            true
        }
    });
    found
}

/// The oracle of `sim` as it stands at its start (its pose, its placed targets).
pub fn oracle_of(sim: &Sim) -> Option<Oracle> {
    let config = sim.config();
    let (speed, turn_rate) = (config.speed_mps, config.turn_rate_rps);
    if !(speed > 0.0 && turn_rate > 0.0) {
        return None;
    }
    let grid = Grid::new(sim.world(), sim.target_shapes(), config.robot_radius_m);
    let start = sim.pose();
    // Which targets a cell may see: those whose outline comes within the camera's range.
    let reach: Vec<(P2, f64)> = sim
        .target_shapes()
        .iter()
        .map(|sh| {
            let c = sh.center();
            let r = sh.outline_samples(DETECT_SAMPLES).iter().map(|p| crate::geometry::dist(*p, c)).fold(0.0, f64::max);
            (c, r + config.camera_range_m)
        })
        .collect();
    let need = config.detect_min_visible_fraction;
    let half_fov = config.camera_fov_rad / 2.0;
    let mut best: Option<Oracle> = None;
    grid.dijkstra([start[0], start[1]], |d, c| {
        if best.is_some_and(|b| d / speed >= b.time_s) {
            return false;
        }
        for (t, &(tc, r)) in reach.iter().enumerate() {
            if crate::geometry::dist(c, tc) > r {
                continue;
            }
            let bearings = sim.static_sightlines(t, c);
            if let Some(turn) = turn_to_fire(&bearings, start[2], half_fov, need) {
                let time = (d / speed).max(turn.abs() / turn_rate);
                if best.is_none_or(|b| time < b.time_s) {
                    best = Some(Oracle { time_s: time, path_m: d, turn_rad: turn.abs(), view: [c[0], c[1], wrap_angle(start[2] + turn)] });
                }
            }
        }
        true
    });
    best
}

/// Does the detector fire at `yaw` given the visible samples' `bearings` (out of
/// [`DETECT_SAMPLES`])?
fn fires(bearings: &[f64], yaw: f64, half_fov: f64, need: f64) -> bool {
    let n = bearings.iter().filter(|b| b.is_nan() || wrap_angle(*b - yaw).abs() <= half_fov).count();
    let f = n as f64 / DETECT_SAMPLES as f64;
    f > 0.0 && f >= need
}

/// The signed smallest turn from `heading` to a heading at which the detector fires (`None` if
/// there is none).
fn turn_to_fire(bearings: &[f64], heading: f64, half_fov: f64, need: f64) -> Option<f64> {
    if fires(bearings, heading, half_fov, need) {
        return Some(0.0);
    }
    // The nearest firing heading puts a sample on the edge of the field of view.
    const IN: f64 = 1e-9;
    bearings
        .iter()
        .filter(|b| !b.is_nan())
        .flat_map(|b| [b + half_fov - IN, b - half_fov + IN])
        .filter(|&y| fires(bearings, y, half_fov, need))
        .map(|y| wrap_angle(y - heading))
        .min_by(|a, b| a.abs().total_cmp(&b.abs()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 20 × 4 m corridor, closed, the robot at (2, 2) facing `yaw_deg`, a suitcase at `target`,
    /// and `extra` TOML.
    fn corridor(yaw_deg: f64, target: P2, extra: &str) -> World {
        corridor_from(2.0, yaw_deg, target, extra)
    }

    /// [`corridor`] with the robot at (`x`, 2).
    fn corridor_from(x: f64, yaw_deg: f64, target: P2, extra: &str) -> World {
        let text = format!(
            r#"name = "corridor"
time_limit_s = 60
[start]
position = [{x}, 2.0]
yaw_deg = {yaw_deg}
[[walls]]
points = [[0, 0], [20, 0], [20, 4], [0, 4]]
closed = true
[[targets]]
name = "suitcase"
rect = {{ center = [{}, {}], size = [0.4, 0.4] }}
{extra}"#,
            target[0], target[1]
        );
        World::from_toml_str(&text, "corridor.toml").unwrap()
    }

    fn robot() -> SimConfig {
        SimConfig { camera_range_m: 4.0, speed_mps: 0.5, turn_rate_rps: 1.0, robot_radius_m: 0.25, ..SimConfig::default() }
    }

    #[test]
    fn in_a_straight_corridor_the_oracle_drives_to_the_camera_range() {
        // Facing the suitcase 10 m down the corridor: the robot needs 30 % of its outline within
        // the camera's 4 m, so it drives about 6 m (12 s at 0.5 m/s) and does not turn.
        let w = corridor(0.0, [12.0, 2.0], "");
        let o = oracle(&w, &robot(), 1).expect("reachable");
        assert_eq!(o.turn_rad, 0.0);
        // The detector's outline: 0.4 m square, 32 samples, 30 % needed: the near face (8 or 9
        // samples) and a little of the sides. Its near face is at x = 11.8: the robot must stand
        // at x ≥ 11.8 − 4 = 7.8 at least, and at most a side's depth (0.4 m) nearer.
        assert!(o.view[0] >= 7.75 && o.view[0] <= 8.3, "{o:?}");
        assert!((o.path_m - (o.view[0] - 2.0)).abs() < 0.12, "a straight path: {o:?}");
        assert!((o.time_s - o.path_m / 0.5).abs() < 1e-12);
    }

    #[test]
    fn a_target_behind_the_start_costs_about_the_turn() {
        // The suitcase 3 m behind the robot, within the camera's range. Turning on the spot needs
        // 135° ± 4.4° (the target spans 4.4° either side of 180°, and 30 % of it must come within
        // 45° of the heading): 2.28-2.44 s at 1 rad/s. Stepping aside while turning changes the
        // bearing and saves a little of it, never much: every pose the robot reaches in t
        // seconds (0.5 t m away) still needs well over 90° of turn, more than t rad for t < 1.6.
        let w = corridor_from(5.0, 0.0, [2.0, 2.0], "");
        let o = oracle(&w, &robot(), 1).expect("in view after a turn");
        assert!(o.time_s <= (139.5f64).to_radians() && o.time_s >= 1.6, "{o:?}");
        assert!((o.time_s - (o.path_m / 0.5).max(o.turn_rad)).abs() < 1e-12, "{o:?}");
        // A step back would not save the turn: the heading is the start's, whatever the path.
        assert!(o.turn_rad >= 1.6, "{o:?}");
        // From the view pose the simulator's detector fires.
        let mut sim = Sim::new(w, robot(), 1);
        sim.place_robot(o.view);
        assert_eq!(sim.detect(), Some(0), "{o:?}");
    }

    #[test]
    fn driving_and_turning_overlap_so_the_longer_of_the_two_counts() {
        // The door world below, but the robot starts facing west (180°), away from the door and
        // the target: it must turn more than 90° (over 1.6 s at 1 rad/s) while it walks
        // 3.4-4.5 m (6.8-9 s): the walk is the longer, so the time is the walk's alone.
        let w = corridor(180.0, [8.0, 1.0], "[[walls]]\npoints = [[6, 0], [6, 3]]\n");
        let o = oracle(&w, &robot(), 1).expect("through the door");
        assert!(o.turn_rad > 1.6 && o.path_m > 3.4, "{o:?}");
        assert!((o.time_s - o.path_m / 0.5).abs() < 1e-12, "{o:?}");
    }

    #[test]
    fn a_wall_makes_the_oracle_go_round_through_the_door() {
        // A wall across the corridor at x = 6 with a 1 m door at y 3..4: the target at (8, 1) is
        // hidden from the start. The path must pass the door (x = 6, y 3.0..4.0 less the body's
        // 0.25 m: y in [3.25, 3.75]).
        let w = corridor(0.0, [8.0, 1.0], "[[walls]]\npoints = [[6, 0], [6, 3]]\n");
        let o = oracle(&w, &robot(), 1).expect("through the door");
        // The robot sees the target once its line of sight clears the wall's end (6, 3), about
        // when it reaches the doorway: some 3.7 m from (2, 2) to (5.7, 3.4), no more than the
        // 4.2 m to (6, 3.25).
        assert!(o.path_m >= 3.4 && o.path_m <= 4.5, "{o:?}");
        assert!(o.view[0] >= 5.0 && o.view[1] > 3.2, "it must look past the wall's end: {o:?}");
        // Without the wall it is visible from the start after a short turn.
        let open = oracle(&corridor(0.0, [8.0, 1.0], ""), &robot(), 1).expect("open");
        assert!(open.time_s < o.time_s);
        // The oracle's view pose really detects, by the simulator's own detector.
        let mut sim = Sim::new(w.clone(), robot(), 1);
        sim.place_robot(o.view);
        assert_eq!(sim.detect(), Some(0), "{o:?}");
        // And a view pose a little short of it (0.3 m back along the corridor) does not.
        let mut short = Sim::new(w, robot(), 1);
        short.place_robot([o.view[0] - 0.3, o.view[1], o.view[2]]);
        assert_eq!(short.detect(), None, "{o:?}");
    }

    #[test]
    fn an_unreachable_target_out_of_sight_has_no_oracle() {
        // A closed wall at x = 6: nothing beyond it can be seen or reached.
        let w = corridor(0.0, [8.0, 2.0], "[[walls]]\npoints = [[6, 0], [6, 4]]\n");
        assert_eq!(oracle(&w, &robot(), 1), None);
    }
}
