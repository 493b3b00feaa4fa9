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
//! 5. **Ordered for the time to cover** (one robot, [`plan`]): the greedy route's order is
//!    improved by or-opt — a run of 1 to [`OR_OPT_MAX_SEGMENT`] consecutive waypoints moved
//!    elsewhere in the route, kept if the route's *coverage latency* falls: the sum over the
//!    covered cells of the path length (plus [`LEG_OVERHEAD_M`] a leg) to the first waypoint
//!    that covers each. With the target equally likely in any covered cell, that is the
//!    expected time to first cover it (the minimum-latency objective of a search for a
//!    stationary target); greedy coverage per metre is its myopic ratio rule and leaves pockets
//!    the route walks back to at the end (`hallway hard`: the lab's interior, 36 m back from
//!    the storage door; docs/experiments/live-known-map.md). The waypoints are the same.
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

/// Or-opt moves runs of at most this many consecutive waypoints.
pub const OR_OPT_MAX_SEGMENT: usize = 3;
/// The most route orders or-opt evaluates: a bound on the host's work (a route of 100 camera
/// waypoints has 30 000 moves a pass), not a tuned value.
pub const ORDER_MAX_EVALUATIONS: usize = 20_000;

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

    /// Free cells farther than `radius_m` from every occupied cell.
    fn standable(&self, radius_m: f64) -> Vec<bool> {
        let n = self.side;
        let mut ok: Vec<bool> = self.cells.iter().map(|c| *c == Cell3::Free).collect();
        let r = (radius_m / CELL_M).round() as i64;
        for i in 0..n * n {
            if self.cells[i] != Cell3::Occupied {
                continue;
            }
            let (x, y) = ((i % n) as i64, (i / n) as i64);
            for dy in -r..=r {
                for dx in -r..=r {
                    let (qx, qy) = (x + dx, y + dy);
                    if dx * dx + dy * dy <= r * r && qx >= 0 && qy >= 0 && qx < n as i64 && qy < n as i64 {
                        ok[qy as usize * n + qx as usize] = false;
                    }
                }
            }
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

/// A coverage problem over a known building: where the robot can stand, the candidate
/// waypoints and what each sees. Built once; routes for one robot ([`plan`]) or a team
/// ([`Coverage::plan_team`]) are planned on it.
pub struct Coverage<'a> {
    map: &'a KnownGrid<'a>,
    fp: Footprint,
    ok: Vec<bool>,
    /// (cell, heading, free cells seen).
    cands: Vec<(usize, f64, Vec<u32>)>,
    coverable: usize,
    free: usize,
}

impl<'a> Coverage<'a> {
    /// The problem of `map` for a robot of `radius_m` with footprint `fp`; candidates are the
    /// lattice cells reachable from `start` (world x, y).
    pub fn new(map: &'a KnownGrid<'a>, radius_m: f64, start: [f64; 2], fp: Footprint) -> Result<Self, RouteError> {
        let n = map.side;
        let ok = map.standable(radius_m);
        let start_cell = start_cell(map, &ok, start)?;
        let from_start = map.dijkstra(&ok, start_cell);
        let headings: Vec<f64> = match fp {
            Footprint::Camera { .. } => (0..CAMERA_HEADINGS).map(|k| k as f64 * std::f64::consts::TAU / CAMERA_HEADINGS as f64).collect(),
            Footprint::Lidar { .. } => vec![0.0],
        };
        let mut cands: Vec<(usize, f64, Vec<u32>)> = Vec::new();
        for y in (0..n).step_by(LATTICE_CELLS) {
            for x in (0..n).step_by(LATTICE_CELLS) {
                let c = y * n + x;
                if !ok[c] || from_start[c] == u32::MAX {
                    continue;
                }
                for &h in &headings {
                    cands.push((c, h, map.seen_from(c, h, fp)));
                }
            }
        }
        let free = map.cells.iter().filter(|c| **c == Cell3::Free).count();
        let mut coverable = vec![false; n * n];
        for (_, _, s) in &cands {
            for &i in s {
                coverable[i as usize] = true;
            }
        }
        let coverable = coverable.iter().filter(|b| **b).count();
        Ok(Coverage { map, fp, ok, cands, coverable, free })
    }

    /// An empty coverage (no cell covered) to mark and plan with.
    pub fn nothing_covered(&self) -> Vec<bool> {
        vec![false; self.ok.len()]
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
        let (chosen, length_units, covered_n) = self.greedy(starts, speeds, covered)?;
        Ok(chosen.iter().zip(starts).zip(&length_units).map(|((ch, &start), &units)| self.route_of(start, ch, units, covered_n)).collect())
    }

    /// Greedy coverage per metre ([`Coverage::plan_team`]): each robot's (candidate, gain)
    /// list, its path length (units: 5 a cell) and the cells covered in all.
    fn greedy(&self, starts: &[[f64; 2]], speeds: &[f64], covered: &[bool]) -> Result<Greedy, RouteError> {
        let mut covered = covered.to_vec();
        covered.resize(self.ok.len(), false);
        let overhead = (LEG_OVERHEAD_M / CELL_M * 5.0) as u64;
        let mut fields = Vec::with_capacity(starts.len());
        for &s in starts {
            fields.push(self.map.dijkstra(&self.ok, start_cell(self.map, &self.ok, s)?));
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
                let gain = seen.iter().filter(|&&i| !covered[i as usize]).count();
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
            for &i in &self.cands[k].2 {
                covered[i as usize] = true;
            }
            length_units[r] += d;
            chosen[r].push((k, gain));
            fields[r] = self.map.dijkstra(&self.ok, self.cands[k].0);
        }
        let covered_n = covered.iter().filter(|b| **b).count();
        Ok((chosen, length_units, covered_n))
    }

    /// The route of (candidate, gain) list `ch` from `start`, `units` long.
    fn route_of(&self, start: [f64; 2], ch: &[(usize, usize)], units: u64, covered_n: usize) -> Route {
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
    }

    /// One robot's route from `start`: greedy coverage per metre, its order then improved for
    /// the coverage latency ([`Order::improve`]). Returns the route and its latency before and
    /// after (cell-units: cells × path units, 5 a cell).
    pub fn plan_ordered(&self, start: [f64; 2]) -> Result<(Route, u64, u64), RouteError> {
        let (mut chosen, _, covered_n) = self.greedy(&[start], &[1.0], &self.nothing_covered())?;
        let ch = chosen.remove(0);
        let from = start_cell(self.map, &self.ok, start)?;
        let order = Order::new(self, from, &ch.iter().map(|&(k, _)| k).collect::<Vec<_>>());
        let before = order.latency(&order.identity());
        let (perm, after) = order.improve();
        let (gains, units) = order.gains_and_length(&perm);
        let ch: Vec<(usize, usize)> = perm.iter().zip(gains).map(|(&i, g)| (ch[i].0, g)).collect();
        Ok((self.route_of(start, &ch, units, covered_n), before, after))
    }
}

/// Greedy routes: per robot its (candidate, gain) list, per robot its path units, the cells
/// covered in all.
type Greedy = (Vec<Vec<(usize, usize)>>, Vec<u64>, usize);

/// A route's order as a minimum-latency problem: the path length between its waypoints (and
/// from the start) and what each covers, as bits over the cells the route covers.
struct Order {
    /// `dist[a][b]`: path units from waypoint `a` to `b`; index `n` is the start.
    dist: Vec<Vec<u64>>,
    /// Per waypoint, the cells it covers: `words` words each.
    cells: Vec<u64>,
    words: usize,
    n: usize,
    overhead: u64,
}

impl Order {
    fn new(c: &Coverage, start: usize, ks: &[usize]) -> Order {
        let n = ks.len();
        let mut index = vec![u32::MAX; c.ok.len()];
        let mut next = 0u32;
        for &k in ks {
            for &i in &c.cands[k].2 {
                if index[i as usize] == u32::MAX {
                    index[i as usize] = next;
                    next += 1;
                }
            }
        }
        let words = (next as usize).div_ceil(64).max(1);
        let mut cells = vec![0u64; n * words];
        for (w, &k) in ks.iter().enumerate() {
            for &i in &c.cands[k].2 {
                let b = index[i as usize] as usize;
                cells[w * words + b / 64] |= 1 << (b % 64);
            }
        }
        let at = |f: &[u32], k: usize| f[c.cands[k].0] as u64;
        let mut dist = Vec::with_capacity(n + 1);
        for from in ks.iter().map(|&k| c.cands[k].0).chain([start]) {
            let f = c.map.dijkstra(&c.ok, from);
            dist.push(ks.iter().map(|&k| at(&f, k)).collect());
        }
        Order { dist, cells, words, n, overhead: (LEG_OVERHEAD_M / CELL_M * 5.0) as u64 }
    }

    fn identity(&self) -> Vec<usize> {
        (0..self.n).collect()
    }

    /// The coverage latency of visiting the waypoints in `perm`'s order: per waypoint, the
    /// cells it covers first times the path units (with the overhead a leg) to it.
    fn latency(&self, perm: &[usize]) -> u64 {
        let mut covered = vec![0u64; self.words];
        let (mut t, mut prev, mut sum) = (0u64, self.n, 0u64);
        for &w in perm {
            t += self.dist[prev][w].saturating_add(self.overhead);
            let mut new = 0u64;
            for (c, s) in covered.iter_mut().zip(&self.cells[w * self.words..(w + 1) * self.words]) {
                new += (s & !*c).count_ones() as u64;
                *c |= s;
            }
            sum = sum.saturating_add(new.saturating_mul(t));
            prev = w;
        }
        sum
    }

    /// What each waypoint of `perm` covers first, and the path's length (units).
    fn gains_and_length(&self, perm: &[usize]) -> (Vec<usize>, u64) {
        let mut covered = vec![0u64; self.words];
        let (mut units, mut prev, mut gains) = (0u64, self.n, Vec::with_capacity(perm.len()));
        for &w in perm {
            units = units.saturating_add(self.dist[prev][w]);
            let mut new = 0usize;
            for (c, s) in covered.iter_mut().zip(&self.cells[w * self.words..(w + 1) * self.words]) {
                new += (s & !*c).count_ones() as usize;
                *c |= s;
            }
            gains.push(new);
            prev = w;
        }
        (gains, units)
    }

    /// Or-opt from the given order: every run of 1 to [`OR_OPT_MAX_SEGMENT`] waypoints moved to
    /// every other place, in that order, a move kept when it lowers the latency; passes until
    /// one keeps none or [`ORDER_MAX_EVALUATIONS`] orders were evaluated. The order and its
    /// latency.
    fn improve(&self) -> (Vec<usize>, u64) {
        let mut perm = self.identity();
        let mut best = self.latency(&perm);
        let mut evaluations = 1usize;
        loop {
            let mut improved = false;
            for len in 1..=OR_OPT_MAX_SEGMENT.min(self.n.saturating_sub(1)) {
                let mut i = 0;
                while i + len <= perm.len() {
                    for j in 0..=perm.len() - len {
                        if j == i {
                            continue;
                        }
                        if evaluations >= ORDER_MAX_EVALUATIONS {
                            return (perm, best);
                        }
                        let mut moved = perm.clone();
                        let run: Vec<usize> = moved.drain(i..i + len).collect();
                        moved.splice(j..j, run);
                        evaluations += 1;
                        let l = self.latency(&moved);
                        if l < best {
                            (perm, best, improved) = (moved, l, true);
                        }
                    }
                    i += 1;
                }
            }
            if !improved {
                return (perm, best);
            }
        }
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

/// The coverage route of `map` for a robot of `radius_m` starting at `start` (world x, y) with
/// footprint `fp`: greedy coverage per metre, ordered for the coverage latency
/// ([`Coverage::plan_ordered`]).
pub fn plan(map: &KnownGrid, radius_m: f64, start: [f64; 2], fp: Footprint) -> Result<Route, RouteError> {
    let problem = Coverage::new(map, radius_m, start, fp)?;
    Ok(problem.plan_ordered(start)?.0)
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
    fn a_route_covers_both_rooms_and_the_camera_needs_more_waypoints_than_the_lidar() {
        let cells = two_rooms();
        let map = KnownGrid { cells: &cells, side: 200, origin: [0.0, 0.0] };
        let cam = plan(&map, 0.35, [2.0, 2.0], Footprint::Camera { range_m: 4.0, fov_rad: 90f64.to_radians() }).unwrap();
        let lidar = plan(&map, 0.35, [2.0, 2.0], Footprint::Lidar { range_m: 30.0 }).unwrap();
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
        assert_eq!(plan(&map, 0.35, [2.0, 2.0], Footprint::Lidar { range_m: 30.0 }).unwrap(), lidar);
    }

    #[test]
    fn or_opt_moves_a_pocket_forward_when_that_lowers_the_coverage_latency_and_never_raises_it() {
        // Three waypoints as a greedy route left them: `far` (100 units from the start, 50
        // cells), `farther` (120 on, 50 cells), then `pocket` (5 units from the start, 225
        // from `farther` and 100 from `far`, 40 cells).
        let (far, farther, pocket) = (0, 1, 2);
        let mut cells = vec![0u64; 3 * 2];
        let mut set = |w: usize, from: usize, to: usize| (from..to).for_each(|b| cells[w * 2 + b / 64] |= 1 << (b % 64));
        set(far, 0, 50);
        set(farther, 50, 100);
        set(pocket, 100, 140);
        let dist = vec![vec![0, 120, 100], vec![120, 0, 225], vec![100, 225, 0], vec![100, 220, 5]];
        let order = Order { dist, cells, words: 2, n: 3, overhead: 100 };
        let greedy = order.latency(&order.identity());
        // 50 × 200 + 50 × (200 + 220) + 40 × (420 + 325).
        assert_eq!(greedy, 10_000 + 21_000 + 29_800);
        let (perm, latency) = order.improve();
        assert_eq!(perm, vec![pocket, far, farther], "the pocket first: 40 cells 640 units earlier outweigh 100 cells 105 units later");
        assert_eq!(latency, order.latency(&perm));
        assert!(latency < greedy);
        assert_eq!(order.gains_and_length(&perm), (vec![40, 50, 50], 5 + 100 + 120));
    }

    #[test]
    fn the_ordered_route_has_the_greedy_routes_waypoints_and_coverage_and_no_more_latency() {
        let cells = two_rooms();
        let map = KnownGrid { cells: &cells, side: 200, origin: [0.0, 0.0] };
        for fp in [Footprint::Camera { range_m: 4.0, fov_rad: 90f64.to_radians() }, Footprint::Lidar { range_m: 30.0 }] {
            let problem = Coverage::new(&map, 0.35, [2.0, 2.0], fp).unwrap();
            let greedy = problem.plan_team(&[[2.0, 2.0]], &[1.0], &problem.nothing_covered()).unwrap().remove(0);
            let (ordered, before, after) = problem.plan_ordered([2.0, 2.0]).unwrap();
            assert!(after <= before, "{after} > {before}");
            assert_eq!(ordered.covered, greedy.covered);
            let places = |r: &Route| {
                let mut p: Vec<(i64, i64)> =
                    r.waypoints.iter().map(|w| ((w.x * 10.0).round() as i64, (w.y * 10.0).round() as i64)).collect();
                p.sort_unstable();
                p
            };
            assert_eq!(places(&ordered), places(&greedy));
            // Each cell is credited to the first waypoint that covers it, in the new order.
            assert_eq!(ordered.waypoints.iter().map(|w| w.gain).sum::<usize>(), ordered.covered);
            assert_eq!(plan(&map, 0.35, [2.0, 2.0], fp).unwrap(), ordered);
        }
    }

    #[test]
    fn a_start_off_the_map_is_an_error() {
        let cells = two_rooms();
        let map = KnownGrid { cells: &cells, side: 200, origin: [0.0, 0.0] };
        assert_eq!(plan(&map, 0.35, [-5.0, 2.0], Footprint::Lidar { range_m: 30.0 }), Err(RouteError::StartOutside));
    }
}
