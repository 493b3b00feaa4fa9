//! Coverage routes over a known building: LIVE's central server (issue 32; the paper's §II and
//! Fig. 1a: "global path plans are generated for Lidar CPP").
//!
//! A route is a list of waypoints (a place to stand and a heading) that together cover every
//! coverable free cell of the prior map with a sensor's footprint, in the order that covers the
//! most per metre walked from the robot's start:
//!
//! 1. **Where the robot can stand**: free cells farther than the robot's radius from every
//!    occupied cell, connected to the start (8-connected).
//! 2. **Candidates**: those cells on a lattice of [`LATTICE_CELLS`] (0.5 m); for the camera,
//!    each with [`CAMERA_HEADINGS`] headings.
//! 3. **What each sees**: rays from the cell over the footprint, stopped by occupied and
//!    unknown cells — the camera's cone (its range and field of view: the controller's camera),
//!    or the LiDAR's: all round, out to its range (the controller's clearing range,
//!    `lidar_max_range_m`). The paper says only that the LiDAR's field of view is far wider than
//!    the camera's; a first reading, a 6 m × 6 m square (the rolling local costmap of the ROS
//!    navigation tutorials), made LiDAR routes longer than camera routes (174–317 m in the
//!    built-in worlds), the opposite of the paper's Table I (docs/live.md).
//! 4. **Greedy coverage per metre**: from the start, then from each waypoint chosen, the
//!    candidate with the most cells not yet covered per metre of path to it (Dijkstra over where
//!    the robot can stand, steps 5 and 7 for 0.1 m and its diagonal, as the core's; plus
//!    [`LEG_OVERHEAD_M`] a leg), until none adds [`MIN_GAIN_CELLS`]. The first form — a greedy
//!    set cover ordered as the shortest tour (nearest neighbour and 2-opt), coverage path
//!    planning's usual objective — left the target unseen by the LiDAR in every `apartment hard`
//!    and `office hard` trial (docs/experiments/live-known-map.md): a search wants the building
//!    covered early, not the shortest tour.
//!
//! LiDAR waypoints face the way the route arrives at them (a route follower walks on); camera
//! waypoints face their cone. Everything is deterministic: ties go to the lower index.

use crate::io::map_file::Cell3;
use std::collections::BinaryHeap;

/// Candidate spacing, cells (0.5 m).
pub const LATTICE_CELLS: usize = 5;
/// Camera headings tried per candidate.
pub const CAMERA_HEADINGS: usize = 8;
/// The least a waypoint must add to the coverage, cells (0.25 m²).
pub const MIN_GAIN_CELLS: usize = 25;
/// Added to every leg's path length when rating a candidate (turning, stopping): a candidate
/// next to the robot is not worth an infinite rate.
pub const LEG_OVERHEAD_M: f64 = 2.0;

const CELL_M: f64 = 0.1;

/// A sensor's footprint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Footprint {
    /// The camera: a cone of `range_m` and `fov_rad`, looking along the waypoint's heading.
    Camera { range_m: f64, fov_rad: f64 },
    /// The LiDAR: all round, out to `range_m`.
    Lidar { range_m: f64 },
}

/// A known building on the controller's grid.
#[derive(Clone, Debug)]
pub struct KnownGrid<'a> {
    /// Cells, row by row from the lowest y, `side` a side.
    pub cells: &'a [Cell3],
    /// Cells per side.
    pub side: usize,
    /// World coordinates of the lower-left corner.
    pub origin: [f64; 2],
}

/// One waypoint of a route, world coordinates.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Waypoint {
    pub x: f64,
    pub y: f64,
    /// Heading, radians.
    pub heading: f64,
    /// Cells it was chosen for (new coverage).
    pub gain: usize,
}

/// A route and what it covers.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Route {
    pub waypoints: Vec<Waypoint>,
    /// Free cells any candidate sees.
    pub coverable: usize,
    /// Of those, covered by the route.
    pub covered: usize,
    /// Free cells of the map.
    pub free: usize,
    /// Path length of the route from the start, metres.
    pub length_m: f64,
}

/// Why no route.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RouteError {
    /// The start is outside the grid or not near any cell the robot can stand on.
    StartOutside,
}

impl std::fmt::Display for RouteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RouteError::StartOutside => f.write_str("the robot's start is not on the map's free space (within 1 m)"),
        }
    }
}

/// The clearances a route keeps, as the controller's planner does: waypoints stand `keep_m`
/// from every occupied cell (`robot_radius_m`); the robot may pass as close as `least_m`
/// (`lethal_radius_m`, when below `keep_m`: the planner's narrow band, docs/experiments/
/// soft-clearance.md), so a room behind a door the map draws narrow is still on the route.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearance {
    /// Where waypoints may stand, metres.
    pub keep_m: f64,
    /// Where the robot may pass, metres (at `keep_m` or above: where waypoints stand).
    pub least_m: f64,
}

impl Clearance {
    /// The controller's clearances in `cfg`.
    pub fn of(cfg: &firmware::Config) -> Self {
        Clearance { keep_m: cfg.robot_radius_m.to_num::<f64>(), least_m: cfg.lethal_radius_m.to_num::<f64>() }
    }

    /// One clearance for standing and passing.
    pub fn uniform(radius_m: f64) -> Self {
        Clearance { keep_m: radius_m, least_m: radius_m }
    }
}

impl KnownGrid<'_> {
    fn at(&self, x: i64, y: i64) -> Cell3 {
        if x < 0 || y < 0 || x >= self.side as i64 || y >= self.side as i64 {
            return Cell3::Unknown;
        }
        self.cells[y as usize * self.side + x as usize]
    }

    fn cell_of(&self, p: [f64; 2]) -> (i64, i64) {
        (((p[0] - self.origin[0]) / CELL_M).floor() as i64, ((p[1] - self.origin[1]) / CELL_M).floor() as i64)
    }

    fn centre(&self, i: usize) -> [f64; 2] {
        let (x, y) = (i % self.side, i / self.side);
        [self.origin[0] + (x as f64 + 0.5) * CELL_M, self.origin[1] + (y as f64 + 0.5) * CELL_M]
    }

    /// Free cells farther than `radius_m` (rounded to whole cells) from every occupied cell.
    fn standable(&self, radius_m: f64) -> Vec<bool> {
        let r = (radius_m / CELL_M).round();
        self.clear_of(r * r)
    }

    /// Free cells with no occupied cell within `r2` squared cells (centre to centre).
    fn clear_of(&self, r2: f64) -> Vec<bool> {
        let n = self.side;
        let mut ok: Vec<bool> = self.cells.iter().map(|c| *c == Cell3::Free).collect();
        let r = r2.max(0.0).sqrt().ceil() as i64;
        for i in 0..n * n {
            if self.cells[i] != Cell3::Occupied {
                continue;
            }
            let (x, y) = ((i % n) as i64, (i / n) as i64);
            for dy in -r..=r {
                for dx in -r..=r {
                    let (qx, qy) = (x + dx, y + dy);
                    if ((dx * dx + dy * dy) as f64) <= r2 && qx >= 0 && qy >= 0 && qx < n as i64 && qy < n as i64 {
                        ok[qy as usize * n + qx as usize] = false;
                    }
                }
            }
        }
        ok
    }

    /// Where a robot of `clearance` may pass: [`KnownGrid::standable`] at `keep_m`, and, when
    /// `least_m` is below it, also every free cell whose centre is farther than exactly `least_m`
    /// from every occupied cell's centre (the controller's rule, `firmware::planner::reach`).
    fn passable(&self, clearance: Clearance, standable: &[bool]) -> Vec<bool> {
        if clearance.least_m.partial_cmp(&clearance.keep_m) != Some(std::cmp::Ordering::Less) {
            return standable.to_vec();
        }
        let least = clearance.least_m.max(0.0) / CELL_M;
        let mut ok = self.clear_of(least * least);
        for (pass, &stand) in ok.iter_mut().zip(standable) {
            *pass |= stand;
        }
        ok
    }

    /// Path distance (steps 5 straight, 7 diagonal, no corner cutting) from `from` to every
    /// cell of `ok`.
    fn dijkstra(&self, ok: &[bool], from: usize) -> Vec<u32> {
        let n = self.side as i64;
        let mut dist = vec![u32::MAX; ok.len()];
        let mut heap = BinaryHeap::new();
        dist[from] = 0;
        heap.push(std::cmp::Reverse((0u32, from)));
        while let Some(std::cmp::Reverse((d, i))) = heap.pop() {
            if d > dist[i] {
                continue;
            }
            let (x, y) = (i as i64 % n, i as i64 / n);
            for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
                let (qx, qy) = (x + dx, y + dy);
                if qx < 0 || qy < 0 || qx >= n || qy >= n {
                    continue;
                }
                let q = (qy * n + qx) as usize;
                let diagonal = dx != 0 && dy != 0;
                if !ok[q] || (diagonal && (!ok[(y * n + qx) as usize] || !ok[(qy * n + x) as usize])) {
                    continue;
                }
                let nd = d + if diagonal { 7 } else { 5 };
                if nd < dist[q] {
                    dist[q] = nd;
                    heap.push(std::cmp::Reverse((nd, q)));
                }
            }
        }
        dist
    }

    /// The free cells seen from cell `c` facing `heading` (radians) with `fp`, sorted.
    fn seen_from(&self, c: usize, heading: f64, fp: Footprint) -> Vec<u32> {
        let n = self.side as i64;
        let (x0, y0) = ((c as i64) % n, (c as i64) / n);
        let mut ends = Vec::new();
        match fp {
            Footprint::Camera { range_m, fov_rad } => {
                let r = range_m / CELL_M;
                let rays = ((fov_rad * r).ceil() as usize + 1).max(2);
                for k in 0..rays {
                    let a = heading - fov_rad / 2.0 + fov_rad * k as f64 / (rays - 1) as f64;
                    ends.push((x0 + (r * a.cos()).round() as i64, y0 + (r * a.sin()).round() as i64));
                }
            }
            Footprint::Lidar { range_m } => {
                let r = range_m / CELL_M;
                let rays = (std::f64::consts::TAU * r).ceil() as usize;
                for k in 0..rays {
                    let a = std::f64::consts::TAU * k as f64 / rays as f64;
                    ends.push((x0 + (r * a.cos()).round() as i64, y0 + (r * a.sin()).round() as i64));
                }
            }
        }
        let mut seen = Vec::new();
        for (ex, ey) in ends {
            for (x, y) in line((x0, y0), (ex, ey)) {
                match self.at(x, y) {
                    Cell3::Free => seen.push((y * n + x) as u32),
                    Cell3::Occupied | Cell3::Unknown => break,
                }
            }
        }
        seen.sort_unstable();
        seen.dedup();
        seen
    }
}

/// Bresenham's line from `a` to `b`, both ends included.
fn line(a: (i64, i64), b: (i64, i64)) -> impl Iterator<Item = (i64, i64)> {
    let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
    let (sx, sy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
    let (mut x, mut y, mut err, mut done) = (a.0, a.1, dx + dy, false);
    std::iter::from_fn(move || {
        if done {
            return None;
        }
        let p = (x, y);
        if p == b {
            done = true;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
        Some(p)
    })
}

/// A set of cells as runs of consecutive indices (`[start, end)`): what a waypoint sees is a
/// few runs a grid row, so an open hall's thousands of candidates, each seeing up to π·300² cells
/// of a 30 m LiDAR, hold kilobytes each instead of a megabyte.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Spans(Vec<(u32, u32)>);

impl Spans {
    /// The runs of `sorted` (ascending, no duplicates).
    pub fn of(sorted: &[u32]) -> Spans {
        let mut runs: Vec<(u32, u32)> = Vec::new();
        for &i in sorted {
            match runs.last_mut() {
                Some(r) if r.1 == i => r.1 = i + 1,
                _ => runs.push((i, i + 1)),
            }
        }
        runs.shrink_to_fit();
        Spans(runs)
    }

    /// The cells, ascending.
    pub fn cells(&self) -> impl Iterator<Item = u32> + '_ {
        self.0.iter().flat_map(|&(a, b)| a..b)
    }
}

/// A coverage problem over a known building: where the robot can stand, the candidate
/// waypoints and what each sees. Built once; routes for one robot ([`plan`]) or a team
/// ([`Coverage::plan_team`]) are planned on it.
pub struct Coverage<'a> {
    map: &'a KnownGrid<'a>,
    fp: Footprint,
    /// Where the robot may pass (waypoints stand only where `keep_m` is kept).
    pass: Vec<bool>,
    /// (cell, heading, free cells seen).
    cands: Vec<(usize, f64, Spans)>,
    coverable: usize,
    free: usize,
}

impl<'a> Coverage<'a> {
    /// The problem of `map` for a robot of `clearance` with footprint `fp`; candidates are the
    /// lattice cells that keep `clearance.keep_m`, reachable from `start` (world x, y) where the
    /// robot may pass.
    pub fn new(map: &'a KnownGrid<'a>, clearance: Clearance, start: [f64; 2], fp: Footprint) -> Result<Self, RouteError> {
        let n = map.side;
        let ok = map.standable(clearance.keep_m);
        let pass = map.passable(clearance, &ok);
        let start_cell = start_cell(map, &pass, start)?;
        let from_start = map.dijkstra(&pass, start_cell);
        let headings: Vec<f64> = match fp {
            Footprint::Camera { .. } => (0..CAMERA_HEADINGS).map(|k| k as f64 * std::f64::consts::TAU / CAMERA_HEADINGS as f64).collect(),
            Footprint::Lidar { .. } => vec![0.0],
        };
        let mut cands: Vec<(usize, f64, Spans)> = Vec::new();
        for y in (0..n).step_by(LATTICE_CELLS) {
            for x in (0..n).step_by(LATTICE_CELLS) {
                let c = y * n + x;
                if !ok[c] || from_start[c] == u32::MAX {
                    continue;
                }
                for &h in &headings {
                    cands.push((c, h, Spans::of(&map.seen_from(c, h, fp))));
                }
            }
        }
        let free = map.cells.iter().filter(|c| **c == Cell3::Free).count();
        let mut coverable = vec![false; n * n];
        for (_, _, s) in &cands {
            for i in s.cells() {
                coverable[i as usize] = true;
            }
        }
        let coverable = coverable.iter().filter(|b| **b).count();
        Ok(Coverage { map, fp, pass, cands, coverable, free })
    }

    /// An empty coverage (no cell covered) to mark and plan with.
    pub fn nothing_covered(&self) -> Vec<bool> {
        vec![false; self.pass.len()]
    }

    /// Marks in `covered` what the footprint sees from waypoint `w` (a waypoint a robot reached:
    /// its cells need no other robot).
    pub fn cover(&self, covered: &mut [bool], w: &Waypoint) {
        let (x, y) = self.map.cell_of([w.x, w.y]);
        if x < 0 || y < 0 || x >= self.map.side as i64 || y >= self.map.side as i64 {
            return;
        }
        let c = y as usize * self.map.side + x as usize;
        for i in self.map.seen_from(c, w.heading, self.fp) {
            if let Some(b) = covered.get_mut(i as usize) {
                *b = true;
            }
        }
    }

    /// Routes for a team whose robots stand at `starts` (world x, y) and walk at `speeds`
    /// (m/s), covering what `covered` does not: greedy coverage per metre as [`plan`], and the
    /// next waypoint always goes to the robot whose route takes least time so far (length over
    /// speed; ties to the lower index), so the routes end about together. A robot that cannot
    /// add [`MIN_GAIN_CELLS`] from where its route is stops taking waypoints. One start gives
    /// [`plan`]'s route.
    pub fn plan_team(&self, starts: &[[f64; 2]], speeds: &[f64], covered: &[bool]) -> Result<Vec<Route>, RouteError> {
        let mut covered = covered.to_vec();
        covered.resize(self.pass.len(), false);
        let overhead = (LEG_OVERHEAD_M / CELL_M * 5.0) as u64;
        let mut fields = Vec::with_capacity(starts.len());
        for &s in starts {
            fields.push(self.map.dijkstra(&self.pass, start_cell(self.map, &self.pass, s)?));
        }
        let mut length_units = vec![0u64; starts.len()];
        let mut open = vec![true; starts.len()];
        let mut chosen: Vec<Vec<(usize, usize)>> = vec![Vec::new(); starts.len()];
        // The robot whose route takes least time and can still add.
        let speed = |r: usize| speeds.get(r).copied().unwrap_or(1.0);
        while let Some(r) = (0..starts.len())
            .filter(|&r| open[r])
            .min_by(|&a, &b| (length_units[a] as f64 / speed(a)).total_cmp(&(length_units[b] as f64 / speed(b))).then(a.cmp(&b)))
        {
            let mut best: Option<(u64, u64, usize, usize)> = None; // (gain·K / cost, cost, index, gain)
            for (k, (c, _, seen)) in self.cands.iter().enumerate() {
                let d = fields[r][*c];
                if d == u32::MAX {
                    continue;
                }
                let gain = seen.cells().filter(|&i| !covered[i as usize]).count();
                if gain < MIN_GAIN_CELLS {
                    continue;
                }
                let rate = ((gain as u64) << 20) / (d as u64 + overhead);
                if best.is_none_or(|b| rate > b.0) {
                    best = Some((rate, d as u64, k, gain));
                }
            }
            let Some((_, d, k, gain)) = best else {
                open[r] = false;
                continue;
            };
            for i in self.cands[k].2.cells() {
                covered[i as usize] = true;
            }
            length_units[r] += d;
            chosen[r].push((k, gain));
            fields[r] = self.map.dijkstra(&self.pass, self.cands[k].0);
        }
        let covered_n = covered.iter().filter(|b| **b).count();
        Ok(chosen
            .iter()
            .zip(starts)
            .zip(&length_units)
            .map(|((ch, &start), &units)| {
                let mut waypoints = Vec::with_capacity(ch.len());
                let mut prev = start;
                for &(k, gain) in ch {
                    let p = self.map.centre(self.cands[k].0);
                    let heading = match self.fp {
                        Footprint::Camera { .. } => self.cands[k].1,
                        Footprint::Lidar { .. } if (p[0] - prev[0]).hypot(p[1] - prev[1]) > 1e-9 => (p[1] - prev[1]).atan2(p[0] - prev[0]),
                        Footprint::Lidar { .. } => 0.0,
                    };
                    waypoints.push(Waypoint { x: p[0], y: p[1], heading, gain });
                    prev = p;
                }
                Route { waypoints, coverable: self.coverable, covered: covered_n, free: self.free, length_m: units as f64 * CELL_M / 5.0 }
            })
            .collect())
    }
}

/// The cell of `start`, or the nearest cell the robot can stand on within 1 m (it may start
/// close to a wall).
fn start_cell(map: &KnownGrid, ok: &[bool], start: [f64; 2]) -> Result<usize, RouteError> {
    let n = map.side;
    let (sx, sy) = map.cell_of(start);
    (0..=10i64)
        .flat_map(|r| (-r..=r).flat_map(move |dy| (-r..=r).map(move |dx| (dx, dy))))
        .map(|(dx, dy)| (sx + dx, sy + dy))
        .find(|&(x, y)| x >= 0 && y >= 0 && x < n as i64 && y < n as i64 && ok[y as usize * n + x as usize])
        .map(|(x, y)| y as usize * n + x as usize)
        .ok_or(RouteError::StartOutside)
}

/// The coverage route of `map` for a robot of `clearance` starting at `start` (world x, y) with
/// footprint `fp`.
pub fn plan(map: &KnownGrid, clearance: Clearance, start: [f64; 2], fp: Footprint) -> Result<Route, RouteError> {
    let problem = Coverage::new(map, clearance, start, fp)?;
    let mut routes = problem.plan_team(&[start], &[1.0], &problem.nothing_covered())?;
    Ok(routes.remove(0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two 8 × 8 m rooms side by side joined by a 1 m door, walled all round, on a 200-cell grid.
    fn two_rooms() -> Vec<Cell3> {
        let n = 200;
        let mut c = vec![Cell3::Unknown; n * n];
        for y in 10..=90 {
            for x in 10..=170 {
                let wall = y == 10 || y == 90 || x == 10 || x == 170 || (x == 90 && !(45..55).contains(&y));
                c[y * n + x] = if wall { Cell3::Occupied } else { Cell3::Free };
            }
        }
        c
    }

    #[test]
    fn a_door_narrower_than_the_clearance_is_on_the_route_only_with_a_least_clearance_below_it() {
        // The two rooms with a door of six free cells (y 46..=51, 0.6 m; jambs at y 45 and 52):
        // its middle cells are 0.3 m from a jamb, inside 0.35 m, outside 0.25 m.
        let mut cells = two_rooms();
        for y in 40..60 {
            cells[y * 200 + 90] = if (46..52).contains(&y) { Cell3::Free } else { Cell3::Occupied };
        }
        let map = KnownGrid { cells: &cells, side: 200, origin: [0.0, 0.0] };
        let fp = Footprint::Lidar { range_m: 30.0 };
        let shut = plan(&map, Clearance::uniform(0.35), [2.0, 2.0], fp).unwrap();
        assert!(shut.waypoints.iter().all(|w| w.x < 9.0), "{:?}", shut.waypoints);
        let band = plan(&map, Clearance { keep_m: 0.35, least_m: 0.25 }, [2.0, 2.0], fp).unwrap();
        assert!(band.waypoints.iter().any(|w| w.x > 9.1), "the second room is visited: {:?}", band.waypoints);
        // Waypoints still keep the full clearance: none stands in the doorway.
        assert!(band.waypoints.iter().all(|w| (w.x - 9.05).abs() > 0.3), "{:?}", band.waypoints);
        assert!(band.covered > shut.covered, "{} vs {}", band.covered, shut.covered);
        // A least clearance at or above the kept one changes nothing.
        assert_eq!(plan(&map, Clearance { keep_m: 0.35, least_m: 0.5 }, [2.0, 2.0], fp).unwrap(), shut);
    }

    #[test]
    fn spans_hold_a_sorted_set_as_runs() {
        let cells = [0u32, 1, 2, 5, 7, 8, 100];
        let s = Spans::of(&cells);
        assert_eq!(s.0, vec![(0, 3), (5, 6), (7, 9), (100, 101)]);
        assert_eq!(s.cells().collect::<Vec<_>>(), cells);
        assert_eq!(Spans::of(&[]).cells().count(), 0);
    }

    #[test]
    fn a_route_covers_both_rooms_and_the_camera_needs_more_waypoints_than_the_lidar() {
        let cells = two_rooms();
        let map = KnownGrid { cells: &cells, side: 200, origin: [0.0, 0.0] };
        let cam =
            plan(&map, Clearance::uniform(0.35), [2.0, 2.0], Footprint::Camera { range_m: 4.0, fov_rad: 90f64.to_radians() }).unwrap();
        let lidar = plan(&map, Clearance::uniform(0.35), [2.0, 2.0], Footprint::Lidar { range_m: 30.0 }).unwrap();
        for r in [&cam, &lidar] {
            assert!(r.covered as f64 >= 0.97 * r.coverable as f64, "{} of {}", r.covered, r.coverable);
            assert!(r.coverable as f64 >= 0.95 * r.free as f64, "{} of {}", r.coverable, r.free);
            // Both rooms are visited: waypoints on each side of the wall at x = 9 m.
            assert!(r.waypoints.iter().any(|w| w.x < 9.0) && r.waypoints.iter().any(|w| w.x > 9.1));
        }
        assert!(cam.waypoints.len() > lidar.waypoints.len(), "{} vs {}", cam.waypoints.len(), lidar.waypoints.len());
        // The tour starts near the start: the first waypoint is in the first room.
        assert!(cam.waypoints[0].x < 9.0 && lidar.waypoints[0].x < 9.0);
        // Deterministic.
        assert_eq!(plan(&map, Clearance::uniform(0.35), [2.0, 2.0], Footprint::Lidar { range_m: 30.0 }).unwrap(), lidar);
    }

    #[test]
    fn a_start_off_the_map_is_an_error() {
        let cells = two_rooms();
        let map = KnownGrid { cells: &cells, side: 200, origin: [0.0, 0.0] };
        assert_eq!(plan(&map, Clearance::uniform(0.35), [-5.0, 2.0], Footprint::Lidar { range_m: 30.0 }), Err(RouteError::StartOutside));
    }
}
