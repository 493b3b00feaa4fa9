//! A simulator world traced from a floor map (`lives worlds --from-map MAP.yaml`): a building
//! someone has mapped (a `map_saver` map, a floor plan drawn to scale, `lives replay --map-out`)
//! becomes a world every planner can search, with a start and targets the user places or the
//! seed scatters.
//!
//! **Walls.** Every free cell of the map is floor; every other cell (occupied, unknown, outside
//! the image) is solid. Each side a free cell shares with a solid cell is a wall, and the sides
//! along one grid line are merged into maximal straight segments. So the floor is enclosed
//! wherever the map stops (an unknown cell is a wall the robot cannot pass, as it could not in
//! the mapped building), a one-cell wall becomes two faces a cell apart, and a piece of furniture
//! the map holds becomes the outline of its cells. Everything traced is map (walls): the map is
//! the building as it was recorded. The segments are placed by the map's origin (yaw included),
//! then the whole world is shifted so that its free space starts 1 m from the world frame's
//! origin (the world format's coordinates lie in [0, 51] m, like the controller's grid); the
//! shift is reported so that positions in the map frame can be found again.
//!
//! **Targets.** Given positions (map frame) are the target's candidates, or `random_targets`
//! positions drawn from the seed among the floor cells a 0.3 m robot reaches from the start
//! ([`crate::sim::reach::ReachMap`]) at least `min_target_path_m` of path away, where a 0.5 ×
//! 0.35 m suitcase stands clear of every wall. The simulation's seed picks one per search.
//!
//! What this module must not do: run searches or know the controller.

use super::{Cell3, PriorMap};
use crate::sim::world::WORLD_LIMIT_M;
use crate::sim::{reach::ReachMap, Start, Target, World};
use crate::sim::{Shape, P2};

/// The free space starts this far from the world frame's axes.
pub const MARGIN_M: f64 = 1.0;
/// The suitcase the built-in worlds hide.
pub const TARGET_SIZE_M: [f64; 2] = [0.5, 0.35];
/// A random target's centre stands this far from every wall (the suitcase's half diagonal and a
/// little).
pub const TARGET_CLEARANCE_M: f64 = 0.35;
/// The robot radius the reachability of random targets is computed for (the default robot's).
pub const REACH_RADIUS_M: f64 = 0.3;
/// Most wall segments a traced world may have: a world file holds at most 1 MiB (about 20 000
/// segments). A real building's map gives a few thousand (the Intel lab's 4 582); more is a
/// speckled map (noise, a scanned drawing) to clean first or cut with `--window`.
pub const MAX_SEGMENTS: usize = 20_000;
/// Most random target positions.
pub const MAX_RANDOM_TARGETS: usize = 1000;

/// What to trace and where to start.
#[derive(Clone, Debug)]
pub struct FromMap {
    /// The world's name.
    pub name: String,
    /// The start: x, y (metres, map frame) and yaw (radians).
    pub start: [f64; 3],
    /// Target positions (metres, map frame); the seed picks one per search.
    pub targets: Vec<[f64; 2]>,
    /// Draw this many target positions from `seed` (in addition to `targets`).
    pub random_targets: usize,
    /// The seed of the random positions.
    pub seed: u64,
    /// Random positions lie at least this much path (metres) from the start.
    pub min_target_path_m: f64,
    /// The time limit; default `60 + 3 (w + h)` s rounded to 10 s (the procedural hard worlds').
    pub time_limit_s: Option<f64>,
    /// Keep only the floor within a square of this side (metres) centred on the start, the map
    /// frame's axes (for a building larger than a world may be).
    pub window_m: Option<f64>,
}

/// The world and the shift from the map frame to the world frame (add it to a map position).
#[derive(Clone, Debug)]
pub struct Traced {
    pub world: World,
    pub shift: [f64; 2],
    /// Wall segments traced.
    pub segments: usize,
}

/// Traces `map` into a world (module doc). Errors name the map file and what is wrong.
pub fn world_from_map(map: &PriorMap, opts: &FromMap) -> Result<Traced, String> {
    let file = &map.file;
    let r = map.resolution_m;
    if let Some(side) = opts.window_m.filter(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(format!("--window {side}: expected a positive side in metres"));
    }
    if !opts.start.iter().all(|v| v.is_finite()) || map.at([opts.start[0], opts.start[1]]) != Some(Cell3::Free) {
        return Err(format!("{file}: the start ({}, {}) is not on a free cell of the map", opts.start[0], opts.start[1]));
    }
    let half = opts.window_m.map_or(f64::INFINITY, |s| s / 2.0);
    let in_window = |x: i64, y: i64| {
        let c = map.world([(x as f64 + 0.5) * r, (y as f64 + 0.5) * r]);
        (c[0] - opts.start[0]).abs() <= half && (c[1] - opts.start[1]).abs() <= half
    };
    let free = |x: i64, y: i64| x >= 0 && y >= 0 && map.get(x as usize, y as usize) == Some(Cell3::Free) && in_window(x, y);
    let (w, h) = (map.width as i64, map.height as i64);
    // Sides between a free and a solid cell, merged along each grid line: (from, to) in cell
    // corners of the image's frame.
    let mut runs: Vec<([i64; 2], [i64; 2])> = Vec::new();
    // Past the cap the count goes on but no run is kept (a speckled 2001² map would hold millions).
    let mut extra = 0usize;
    let mut flush = |start: &mut Option<i64>, end: i64, line: i64, horizontal: bool, runs: &mut Vec<_>| {
        if let Some(s) = start.take() {
            if runs.len() > MAX_SEGMENTS {
                extra += 1;
                return;
            }
            runs.push(if horizontal { ([s, line], [end, line]) } else { ([line, s], [line, end]) });
        }
    };
    for j in 0..=h {
        let mut start = None;
        for x in 0..=w {
            let edge = x < w && (free(x, j) != free(x, j - 1));
            if edge && start.is_none() {
                start = Some(x);
            } else if !edge {
                flush(&mut start, x, j, true, &mut runs);
            }
        }
    }
    for i in 0..=w {
        let mut start = None;
        for y in 0..=h {
            let edge = y < h && (free(i, y) != free(i - 1, y));
            if edge && start.is_none() {
                start = Some(y);
            } else if !edge {
                flush(&mut start, y, i, false, &mut runs);
            }
        }
    }
    if runs.is_empty() {
        return Err(format!("{file}: the map has no free cell: nothing to trace a floor from"));
    }
    if runs.len() > MAX_SEGMENTS {
        return Err(format!(
            "{file}: the floor's outline is {} wall segments, more than a world holds ({MAX_SEGMENTS}): the map is speckled (clean it) or larger than a building (cut it with --window)",
            runs.len() + extra
        ));
    }
    let corner = |c: [i64; 2]| map.world([c[0] as f64 * r, c[1] as f64 * r]);
    let segments: Vec<[P2; 2]> = runs.iter().map(|&(a, b)| [corner(a), corner(b)]).collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for s in &segments {
        for p in s {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    let shift = [MARGIN_M - lo[0], MARGIN_M - lo[1]];
    let size = [hi[0] - lo[0], hi[1] - lo[1]];
    if size[0] + MARGIN_M > WORLD_LIMIT_M || size[1] + MARGIN_M > WORLD_LIMIT_M {
        return Err(format!(
            "{file}: the map's free space spans {:.1} × {:.1} m; a world holds at most {:.0} m a side (the controller's grid is 51.2 m)",
            size[0],
            size[1],
            WORLD_LIMIT_M - MARGIN_M
        ));
    }
    let moved = |p: [f64; 2]| [p[0] + shift[0], p[1] + shift[1]];
    let walls: Vec<[P2; 2]> = segments.iter().map(|s| [moved(s[0]), moved(s[1])]).collect();
    let start = moved([opts.start[0], opts.start[1]]);
    let limit = opts.time_limit_s.unwrap_or_else(|| ((60.0 + 3.0 * (size[0] + size[1])) / 10.0).round() * 10.0);
    let mut world = World {
        name: opts.name.clone(),
        wall_materials: vec![Default::default(); walls.len()],
        walls,
        obstacles: Vec::new(),
        targets: Vec::new(),
        people: Vec::new(),
        start: Start { pose: [start[0], start[1], opts.start[2]], jitter_m: 0.0, jitter_yaw_rad: 0.0 },
        time_limit_s: limit,
        bounds: [[0.0; 2]; 2],
    };
    let mut positions: Vec<P2> = opts.targets.iter().map(|&p| moved(p)).collect();
    if opts.random_targets > 0 {
        if opts.random_targets > MAX_RANDOM_TARGETS {
            return Err(format!("--random-targets {}: at most {MAX_RANDOM_TARGETS}", opts.random_targets));
        }
        world.bounds = world.compute_bounds();
        positions.extend(random_positions(&world, opts)?);
    }
    let Some((&first, rest)) = positions.split_first() else {
        return Err("no target: give --target X,Y (map frame) or --random-targets N".into());
    };
    world.targets.push(Target {
        name: "suitcase".into(),
        shape: Shape::Rect { center: first, size: TARGET_SIZE_M, yaw: 0.0 },
        candidates: rest.to_vec(),
    });
    world.bounds = world.compute_bounds();
    // The format's own checks (start clearance, targets clear of walls, coordinates in range):
    // through the file form, so the world written is the world checked.
    let text = world.to_toml_string();
    let checked = World::from_toml_str(&text, &format!("{} (traced from {file})", opts.name)).map_err(|e| e.to_string())?;
    let segments = checked.walls.len();
    Ok(Traced { world: checked, shift, segments })
}

/// `opts.random_targets` positions drawn from `opts.seed` among the cells a robot reaches from
/// the start at least `min_target_path_m` away where the suitcase stands clear of every wall.
fn random_positions(world: &World, opts: &FromMap) -> Result<Vec<P2>, String> {
    let start = [world.start.pose[0], world.start.pose[1]];
    let reach = ReachMap::new(world, start, REACH_RADIUS_M);
    let mut cells: Vec<P2> = reach
        .reached_within(opts.min_target_path_m, f64::INFINITY)
        .into_iter()
        .map(|(p, _)| p)
        .filter(|&p| world.disc_is_clear(p, TARGET_CLEARANCE_M))
        .collect();
    if cells.len() < opts.random_targets {
        return Err(format!(
            "--random-targets {}: only {} places a robot reaches at least {} m from the start hold a suitcase clear of the walls",
            opts.random_targets,
            cells.len(),
            opts.min_target_path_m
        ));
    }
    // A partial Fisher–Yates shuffle from the seed: the first N are the positions.
    let mut rng = fixed_point::SplitMix64(opts.seed);
    for k in 0..opts.random_targets {
        let j = k + (rng.next_u64() % (cells.len() - k) as u64) as usize;
        cells.swap(k, j);
    }
    cells.truncate(opts.random_targets);
    Ok(cells)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w × h` map of 1 m cells at `origin`, the cells given row by row from the top (`#`
    /// occupied, `.` free, `?` unknown).
    fn map(rows: &[&str], origin: [f64; 3]) -> PriorMap {
        let (w, h) = (rows[0].len(), rows.len());
        let mut cells = vec![Cell3::Unknown; w * h];
        for (r, row) in rows.iter().enumerate() {
            for (x, c) in row.chars().enumerate() {
                cells[(h - 1 - r) * w + x] = match c {
                    '#' => Cell3::Occupied,
                    '.' => Cell3::Free,
                    _ => Cell3::Unknown,
                };
            }
        }
        PriorMap { file: "m.yaml".into(), resolution_m: 1.0, origin, width: w, height: h, cells }
    }

    fn opts(start: [f64; 3], targets: &[[f64; 2]]) -> FromMap {
        FromMap {
            name: "t".into(),
            start,
            targets: targets.to_vec(),
            random_targets: 0,
            seed: 1,
            min_target_path_m: 0.0,
            time_limit_s: None,
            window_m: None,
        }
    }

    fn sorted(walls: &[[P2; 2]]) -> Vec<[[i64; 2]; 2]> {
        let r = |p: P2| [(p[0] * 1000.0).round() as i64, (p[1] * 1000.0).round() as i64];
        let mut v: Vec<_> = walls.iter().map(|s| [r(s[0]), r(s[1])]).collect();
        v.sort();
        v
    }

    #[test]
    fn a_free_room_is_enclosed_by_four_merged_walls_whatever_surrounds_it() {
        // Occupied on two sides, unknown on one, the image's edge on the last: four walls.
        let m = map(&["#####", "#...?", "#...?", "#...?", "....."], [0.0; 3]);
        let t = world_from_map(&m, &opts([2.5, 2.5, 0.0], &[[1.5, 3.5]])).unwrap();
        // Shifted so the free space starts 1 m from the axes: the free box is x 1..4 (and the
        // bottom row x 0..5); the start and the target moved by the same shift.
        assert_eq!(t.shift, [1.0, 1.0]);
        assert_eq!(t.world.start.pose, [3.5, 3.5, 0.0]);
        assert_eq!(t.world.targets[0].shape.center(), [2.5, 4.5]);
        let walls = sorted(&t.world.walls);
        let s = |a: [i64; 2], b: [i64; 2]| [[a[0] * 1000, a[1] * 1000], [b[0] * 1000, b[1] * 1000]];
        let want = {
            let mut v = vec![
                s([1, 1], [6, 1]), // the image's bottom edge under the bottom row
                s([2, 5], [5, 5]), // the occupied top row
                s([1, 2], [2, 2]), // under the occupied corner cell, above the bottom row
                s([5, 2], [6, 2]), // under the unknown column's last cell
                s([2, 2], [2, 5]), // the occupied left column
                s([5, 2], [5, 5]), // the unknown right column
                s([1, 1], [1, 2]), // the bottom row's two ends
                s([6, 1], [6, 2]),
            ];
            v.sort();
            v
        };
        assert_eq!(walls, want);
        assert_eq!(t.segments, 8);
        // The default limit: 60 + 3 (w + h) for the 5 × 4 m floor.
        assert_eq!(t.world.time_limit_s, 90.0);
    }

    #[test]
    fn the_maps_origin_and_yaw_place_the_walls() {
        let rows = ["???", "?.?", "???"];
        let straight = world_from_map(&map(&rows, [10.0, 20.0, 0.0]), &opts([11.5, 21.5, 0.0], &[[11.5, 21.5]]));
        // A one-cell floor cannot hold the start's clearance: the format's own check says so.
        assert!(straight.unwrap_err().contains("start"));
        let rows = ["??????", "?....?", "?....?", "?....?", "?....?", "??????"];
        let m = map(&rows, [10.0, 20.0, std::f64::consts::FRAC_PI_2]);
        // Turned a quarter: the image's x runs along the map's y. The floor's centre is the
        // image point (3, 3), at map (10 − 3, 20 + 3).
        let t = world_from_map(&m, &opts([7.0, 23.0, 0.0], &[[7.0, 22.0]])).unwrap();
        assert_eq!(t.segments, 4);
        let [lo, hi] = t.world.bounds;
        assert!((lo[0] - 1.0).abs() < 1e-9 && (lo[1] - 1.0).abs() < 1e-9 && (hi[0] - 5.0).abs() < 1e-9 && (hi[1] - 5.0).abs() < 1e-9);
        assert_eq!(t.world.start.pose[..2], [3.0, 3.0]);
        // Back to the map frame by the shift.
        let c = t.world.targets[0].shape.center();
        assert_eq!([c[0] - t.shift[0], c[1] - t.shift[1]], [7.0, 22.0]);
    }

    #[test]
    fn a_window_keeps_the_floor_around_the_start() {
        // A 20 × 4 m corridor of 1 m cells; a 6 m window around (10.5, 2) keeps x 7.5..13.5.
        let rows = [
            "?".repeat(22),
            format!("?{}?", ".".repeat(20)).repeat(1),
            format!("?{}?", ".".repeat(20)),
            format!("?{}?", ".".repeat(20)),
            format!("?{}?", ".".repeat(20)),
            "?".repeat(22),
        ];
        let rows: Vec<&str> = rows.iter().map(|s| s.as_str()).collect();
        let m = map(&rows, [0.0; 3]);
        let mut o = opts([10.5, 3.0, 0.0], &[[12.5, 3.0]]);
        let whole = world_from_map(&m, &o).unwrap();
        assert_eq!(whole.world.bounds[1][0] - whole.world.bounds[0][0], 20.0);
        o.window_m = Some(6.0);
        let cut = world_from_map(&m, &o).unwrap();
        // Cells whose centres lie within 3 m of x = 10.5: centres 7.5 … 13.5, seven cells.
        assert_eq!(cut.world.bounds[1][0] - cut.world.bounds[0][0], 7.0);
        assert_eq!(cut.segments, 4);
        o.window_m = Some(f64::NAN);
        assert!(world_from_map(&m, &o).unwrap_err().contains("--window"));
    }

    #[test]
    fn bad_requests_are_errors_naming_the_map() {
        let none = map(&["###", "#?#", "###"], [0.0; 3]);
        assert!(world_from_map(&none, &opts([1.5, 1.5, 0.0], &[[1.5, 1.5]]))
            .unwrap_err()
            .starts_with("m.yaml: the start (1.5, 1.5) is not on a free cell"));
        let one = map(&["???", "?.?", "???"], [0.0; 3]);
        let mut tiny = opts([1.2, 1.2, 0.0], &[[1.5, 1.5]]);
        tiny.window_m = Some(0.1);
        assert!(world_from_map(&one, &tiny).unwrap_err().starts_with("m.yaml: the map has no free cell"));
        let rows = ["??????", "?....?", "?....?", "?....?", "?....?", "??????"];
        let m = map(&rows, [0.0; 3]);
        assert!(world_from_map(&m, &opts([0.5, 0.5, 0.0], &[[3.0, 3.0]])).unwrap_err().contains("not on a free cell"));
        assert!(world_from_map(&m, &opts([f64::NAN, 3.0, 0.0], &[[3.0, 3.0]])).unwrap_err().contains("not on a free cell"));
        assert!(world_from_map(&m, &opts([3.0, 3.0, 0.0], &[])).unwrap_err().contains("no target"));
        // A target in the wall: the format's check names it.
        assert!(world_from_map(&m, &opts([3.0, 3.0, 0.0], &[[1.0, 3.0]])).is_err());
        // Wider than a world may be.
        let mut wide = map(&["?.?"], [0.0; 3]);
        wide.resolution_m = 60.0;
        assert!(world_from_map(&wide, &opts([90.0, 30.0, 0.0], &[[90.0, 30.0]])).unwrap_err().contains("at most 50 m a side"));
    }

    #[test]
    fn a_speckled_map_is_refused_by_its_segment_count() {
        // Free specks every other cell: each one is its own four walls (100 × 100 specks).
        let rows: Vec<String> = (0..200).map(|y| (0..200).map(|x| if x % 2 == 0 && y % 2 == 0 { '.' } else { '#' }).collect()).collect();
        let rows: Vec<&str> = rows.iter().map(|s| s.as_str()).collect();
        let mut m = map(&rows, [0.0; 3]);
        m.resolution_m = 0.1;
        let e = world_from_map(&m, &opts([0.05, 19.95, 0.0], &[[0.05, 19.95]])).unwrap_err();
        assert!(e.starts_with("m.yaml: the floor's outline is 40000 wall segments, more than a world holds (20000)"), "{e}");
    }

    #[test]
    fn random_targets_are_reachable_clear_and_the_seeds_own() {
        let mut rows = vec!["?".repeat(42)];
        for _ in 0..20 {
            rows.push(format!("?{}?", ".".repeat(40)));
        }
        rows.push("?".repeat(42));
        let rows: Vec<&str> = rows.iter().map(|s| s.as_str()).collect();
        let mut m = map(&rows, [0.0; 3]);
        m.resolution_m = 0.25; // a 10 × 5 m room
        let mut o = opts([1.0, 1.0, 0.0], &[]);
        o.random_targets = 12;
        o.min_target_path_m = 3.0;
        let a = world_from_map(&m, &o).unwrap().world;
        let b = world_from_map(&m, &o).unwrap().world;
        assert_eq!(a, b);
        let p = a.targets[0].positions();
        assert_eq!(p.len(), 12);
        let start = [a.start.pose[0], a.start.pose[1]];
        for q in &p {
            assert!(a.disc_is_clear(*q, TARGET_CLEARANCE_M), "{q:?}");
            // 4-connected path ≥ the straight line's Manhattan lower bound… at least 3 m away.
            assert!((q[0] - start[0]).abs() + (q[1] - start[1]).abs() >= 3.0 - 1e-9, "{q:?}");
        }
        o.seed = 2;
        assert_ne!(world_from_map(&m, &o).unwrap().world.targets, a.targets);
        o.random_targets = 100_000;
        assert!(world_from_map(&m, &o).unwrap_err().contains("at most"));
        o.random_targets = 12;
        o.min_target_path_m = 100.0;
        assert!(world_from_map(&m, &o).unwrap_err().contains("only 0 places"));
    }
}
