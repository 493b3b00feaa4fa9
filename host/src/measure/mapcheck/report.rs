//! What `lives mapcheck` reports, and the reference drawn from a log's scans.

use super::*;
use crate::io::replay::{self, ReplayReport, ScanRecord};
use crate::search::SearchResult;
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
