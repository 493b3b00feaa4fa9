//! What `lives mapcheck` reports, and the reference drawn from a log's scans.

use super::*;
use crate::io::replay::{self, ReplayReport, ScanRecord};
use crate::search::SearchResult;
use firmware::Cell;
use serde::Serialize;

/// The relations part of the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelationsReport {
    /// The relations file.
    pub file: String,
    /// Relations in it.
    pub relations: usize,
    /// The poses in the log's lines (for the raw CSAIL log: raw odometry), every scan of the log.
    pub log_poses: RelationStats,
    /// The poses the controller mapped each scan it used at.
    pub controller: RelationStats,
    /// The `--align` poses (e.g. the SLAM-corrected CSAIL poses), when given.
    pub align_poses: Option<RelationStats>,
    /// The same on the relations spanning less than [`SHORT_SPAN_S`] (consecutive stretches:
    /// the odometry's and the matcher's local accuracy).
    pub short: RelationSubset,
    /// ... and on the others (a place revisited minutes later: the map's global consistency).
    pub long: RelationSubset,
}

/// The relation errors on a subset of the relations (by time span).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelationSubset {
    /// Relations in the subset.
    pub relations: usize,
    /// As [`RelationsReport::log_poses`].
    pub log_poses: RelationStats,
    /// As [`RelationsReport::controller`].
    pub controller: RelationStats,
    /// As [`RelationsReport::align_poses`].
    pub align_poses: Option<RelationStats>,
}

/// How the reference was placed in this run's frame (`--reference` with `--align`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Alignment {
    /// The poses file.
    pub file: String,
    /// Poses in it.
    pub poses: usize,
    /// Of which have a pose of this run (the controller's) at their time stamp.
    pub matched: usize,
    /// The transform from this run's frame to the poses' frame `[x, y, θ]` (m, rad).
    pub transform: [f64; 3],
    /// RMS distance between the moved run positions and the matched poses, metres.
    pub rms_m: f64,
    /// The largest, metres.
    pub max_m: f64,
}

/// What the run was scored against.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferenceInfo {
    /// `log-poses` (the log's own scans at its own poses), `other-log` (`--reference`),
    /// `floor-map` (`--floor-map`) or `true-world` (simulation).
    pub kind: String,
    /// The log drawn, for `log-poses` and `other-log`; the map's YAML file for `floor-map`.
    pub file: Option<String>,
    /// Scans (logs) or true positions (simulation) the reference was drawn from; also the
    /// viewpoints of the leak.
    pub viewpoints: usize,
    /// Rays cast per viewpoint for the leak.
    pub rays_per_viewpoint: usize,
    /// `--align`.
    pub alignment: Option<Alignment>,
}

/// `lives mapcheck --json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapcheckReport {
    /// The log, or `world apartment easy lives seed 1`.
    pub subject: String,
    /// The reference.
    pub reference: ReferenceInfo,
    /// Lower-left corner of the grid, metres.
    pub grid_origin: [f64; 2],
    /// Cell side, metres.
    pub cell_m: f64,
    /// Grid side, metres.
    pub grid_size_m: f64,
    /// The controller's clearing range (its LiDAR range), metres: the reference's range and the
    /// leak's ray length.
    pub clearing_range_m: f64,
    /// The figures.
    pub map: MapScores,
    /// The log's own rays scored the same way (a log against its own poses or a floor map):
    /// what the data itself leaks (see [`OwnRays`]).
    pub own_rays: Option<OwnRays>,
    /// `--relations`.
    pub relations: Option<RelationsReport>,
    /// The replay (logs).
    pub replay: Option<ReplayReport>,
    /// The search (simulation).
    pub search: Option<SearchResult>,
}

/// Draws the plain projection of `scans` (each at its pose, moved by `to_grid` into the grid's
/// world frame) into `reference`: every return in `[min_range, max_range)` marks its cell, and each
/// scan's position becomes a viewpoint. `origin` is the grid's lower-left corner.
pub fn project_scans(reference: &mut Reference, scans: &[&ScanRecord], to_grid: &Rigid, origin: [f64; 2], min_range: f64, max_range: f64) {
    let c = cell_m();
    for s in scans {
        let pose = compose(to_grid, &s.pose);
        if !pose.iter().all(|v| v.is_finite()) {
            continue;
        }
        reference.viewpoints.push([(pose[0] - origin[0]) / c, (pose[1] - origin[1]) / c]);
        reference.reach_m.push(reach(s));
        for (i, &r) in s.ranges_m.iter().enumerate() {
            let r = r as f64;
            if !(r.is_finite() && r >= min_range && r < max_range) {
                continue;
            }
            let a = pose[2] + s.angle_min + i as f64 * s.angle_increment;
            let p = [pose[0] + r * a.cos(), pose[1] + r * a.sin()];
            reference.mark((p[0] - origin[0]) / c, (p[1] - origin[1]) / c);
        }
    }
}

/// The leak of the log's own rays: every cell a beam crossed on its way to its return (or out to
/// the clearing range when it returned nothing) free, every return's cell occupied, no evidence,
/// scored against the same reference. A free cell of this map that leaks is a cell some beam
/// crossed although every viewpoint's view of it meets a reference wall first: a beam that passed
/// where another scan saw a surface (a door, a person, glass, a chair since moved) or, against a
/// floor map, through a wall the map draws. No grid built from these rays can avoid such a leak
/// without refusing what its beams saw, so this is the floor the reference sets for the figure.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OwnRays {
    /// Cells the rays crossed (free in this map).
    pub free_cells: u64,
    /// Of which leak.
    pub leak_cells: u64,
    /// `leak_cells / free_cells`.
    pub free_space_leak: Option<f64>,
    /// Leak cells of the controller's grid that are leak cells of this map too.
    pub grid_leaks_shared: u64,
    /// Reference walls the grid lost (no occupied cell within 0.2 m).
    pub lost_walls: u64,
    /// Of which the log's own beams crossed in more scans than they ended in: a surface that
    /// was there for a while (a person, a door, a chair since moved) or that beams pass (glass),
    /// which an occupancy map lets go.
    pub lost_walls_seen_through: u64,
    /// For comparison, every reference wall cell inside the grid (lost or not) that the log's
    /// beams crossed in more scans than they ended in.
    pub walls_seen_through: u64,
}

/// The log's own rays ([`own_rays_map`]): the map, and per cell (row-major) the scans whose
/// returns ended in it and the scans whose beams crossed it without one ending there.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnRaysMap {
    /// Every crossed cell free, every return's cell occupied.
    pub grid: MapGrid,
    /// Scans with a return in the cell.
    pub hit_scans: Vec<u32>,
    /// Scans whose beams crossed the cell and none ended in it.
    pub crossed_scans: Vec<u32>,
}

/// The map of the log's own rays ([`OwnRays`]) on an `n`-cell grid, by the core's range rule: a
/// return below the scan's `range_max` and the clearing range `max_range` ends in an occupied cell
/// and frees the cells before it; `+inf` and readings at or beyond `range_max` free cells out to
/// the nearer of `range_max` and `max_range`, a return beyond `max_range` out to `max_range`;
/// NaN, `-inf` and readings below `min_range` or the scan's `range_min` draw nothing. Unlike the
/// core's grid, nothing stops a ray: no evidence, every beam counted. Per cell it counts the
/// scans that hit it and those that crossed it without hitting it (the core's rule: one update
/// per cell per scan, the hit first).
pub fn own_rays_map(n: i32, scans: &[&ScanRecord], to_grid: &Rigid, origin: [f64; 2], min_range: f64, max_range: f64) -> OwnRaysMap {
    let c = cell_m();
    let mut g = MapGrid::new(n);
    let area = (n * n) as usize;
    let (mut hit_scans, mut crossed_scans) = (vec![0u32; area], vec![0u32; area]);
    // The last scan (1-based) that hit or crossed each cell.
    let (mut last_hit, mut last_cross) = (vec![0u32; area], vec![0u32; area]);
    let mut hits = Vec::new();
    let mut crossed = Vec::new();
    let inside = |x: i64, y: i64| x >= 0 && y >= 0 && x < n as i64 && y < n as i64;
    let index = |x: i64, y: i64| (y * n as i64 + x) as usize;
    for (k, s) in scans.iter().enumerate() {
        let scan = k as u32 + 1;
        crossed.clear();
        let pose = compose(to_grid, &s.pose);
        if !pose.iter().all(|v| v.is_finite()) {
            continue;
        }
        let o = [(pose[0] - origin[0]) / c, (pose[1] - origin[1]) / c];
        let [scan_min, scan_max] = s.range_limits_m;
        let scan_max = if scan_max > 0.0 { scan_max } else { f64::INFINITY };
        for (i, &r) in s.ranges_m.iter().enumerate() {
            let r = r as f64;
            if r.is_nan() || r < min_range || r < scan_min {
                continue;
            }
            // As the core: nothing within the scan's range_max clears out to the nearer of it
            // and the clearing range; a return beyond the clearing range clears to it.
            let ret = r < scan_max && r < max_range;
            let a = pose[2] + s.angle_min + i as f64 * s.angle_increment;
            let d = [a.cos(), a.sin()];
            let len = if ret { r } else { scan_max.min(max_range) } / c;
            let end = ((o[0] + len * d[0]).floor() as i64, (o[1] + len * d[1]).floor() as i64);
            walk_ray(o, d, len, |x, y| {
                if ret && (x, y) == end {
                    return false;
                }
                if inside(x, y) {
                    if g.get(x as i32, y as i32) == Cell::Unknown {
                        g.set(x as i32, y as i32, Cell::Free);
                    }
                    let i = index(x, y);
                    if last_cross[i] != scan {
                        last_cross[i] = scan;
                        crossed.push(i);
                    }
                }
                true
            });
            if ret && inside(end.0, end.1) {
                hits.push(end);
                let i = index(end.0, end.1);
                if last_hit[i] != scan {
                    last_hit[i] = scan;
                    hit_scans[i] += 1;
                }
            }
        }
        for &i in &crossed {
            if last_hit[i] != scan {
                crossed_scans[i] += 1;
            }
        }
    }
    for (x, y) in hits {
        g.set(x as i32, y as i32, Cell::Occupied);
    }
    OwnRaysMap { grid: g, hit_scans, crossed_scans }
}

/// How far a scan's scanner sees: its `range_max` (a limit that is not a positive number: no
/// limit).
pub fn reach(s: &ScanRecord) -> f64 {
    let m = s.range_limits_m[1];
    if m > 0.0 {
        m
    } else {
        f64::INFINITY
    }
}

/// The scans of a log that draw a reference: finite poses that are not strays
/// ([`replay::place_grid`]).
pub(super) fn drawable(scans: &[ScanRecord]) -> Vec<&ScanRecord> {
    let stray = replay::place_grid(scans).map(|p| p.stray).unwrap_or_default();
    scans
        .iter()
        .enumerate()
        .filter(|(i, s)| s.pose.iter().all(|v| v.is_finite()) && !stray.get(*i).copied().unwrap_or(false))
        .map(|(_, s)| s)
        .collect()
}
