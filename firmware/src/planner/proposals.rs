//! Object proposals (Gao et al.): clusters of non-map points whose size fits a search target,
//! each with a viewpoint from which the camera can look at it.
//!
//! 1. **Clusters**: single linkage over the stored non-map points ([`NonMapStore`], already
//!    pooled and filtered by the paper's rules: no points near walls, none the camera has looked
//!    at, none whose place the LiDAR has since seen empty), two points joined when they lie
//!    within [`PROPOSAL_LINK_CELLS`] of each other. Points are swept in order of x (an insertion
//!    sort by cell x: deterministic, and the sweep stops at the link distance), joined with a
//!    union–find over point indices.
//! 2. **Fit**: a cluster is a proposal when its bounding box's longer side is at most
//!    [`PROPOSAL_MAX_EXTENT_CELLS`] (1.2 m: a suitcase, a person, a backpack — not a sofa, a
//!    wall's worth of shelves or a row of desks) and it holds at least [`PROPOSAL_MIN_HITS`]
//!    LiDAR returns (pooled points count the returns merged into them): one stray return is
//!    not an object.
//! 3. **Viewpoint**: on the line from the proposal to the robot at `λ·min(camera range,
//!    distance)` from the proposal (Gao et al.; λ = [`PROPOSAL_LAMBDA_PER_MILLE`] / 1000),
//!    snapped to a reachable cell, facing the proposal.
//! 4. **Ranking**: the LIVES non-map evidence, the LiDAR returns the cluster gathered (more
//!    returns over more scans: more likely a real object), decides which proposals are kept
//!    when there are more than [`MAX_PROPOSALS`]. The classifier's per-point confidence is not
//!    stored by the core (its output is thresholded into a label), so it does not take part:
//!    a simplification of the "point counts, the classifier's confidence".
//!
//! Proposals are not scored by a bonus: they are tasks of the tour ([`super::schedule`]), which
//! orders them with the frontiers so the robot does not visit every chair one by one.

use super::Planner;
use crate::capacity::{MAX_NONMAP_POINTS, MAX_PROPOSALS};
use crate::grid::{LidarGrid, PackedGrid};
use crate::nonmap::NonMapStore;
use fixed_point::{atan2, BinaryAngle};

/// Two non-map points within this many cells (0.3 m, along both axes) are one cluster.
pub const PROPOSAL_LINK_CELLS: i32 = 3;
/// The longest side a proposal's bounding box may have, cells (1.2 m).
pub const PROPOSAL_MAX_EXTENT_CELLS: i32 = 12;
/// The fewest LiDAR returns (summed over the cluster's pooled points) a proposal needs.
pub const PROPOSAL_MIN_HITS: u32 = 4;
/// λ of Gao et al., per mille: the viewpoint stands at λ·min(camera range, distance) from the
/// proposal, on the line to the robot.
pub const PROPOSAL_LAMBDA_PER_MILLE: i64 = 500;

/// One object proposal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Proposal {
    /// The cluster's centre (mean of its points), cell coordinates.
    pub cell: (i32, i32),
    /// Where the robot looks at it from (a reachable cell).
    pub viewpoint: (i32, i32),
    /// Facing the proposal from the viewpoint.
    pub heading: BinaryAngle,
    /// Pooled non-map points in the cluster.
    pub points: u16,
    /// LiDAR returns merged into them: the evidence that ranks proposals.
    pub hits: u32,
    /// The bounding box's longer side, cells.
    pub extent: i32,
}

/// Scratch of the clustering, kept in the planner (no stack arrays of this size on an MCU).
pub struct ProposalScratch {
    order: heapless::Vec<(i32, i32, u16), MAX_NONMAP_POINTS>,
    parent: [u16; MAX_NONMAP_POINTS],
    /// The proposals of the last planning step, best evidence first.
    pub proposals: heapless::Vec<Proposal, MAX_PROPOSALS>,
    /// Clusters found in the last step (proposals or not).
    pub clusters: u32,
}

impl ProposalScratch {
    /// Empty.
    pub const fn new() -> Self {
        Self { order: heapless::Vec::new(), parent: [0; MAX_NONMAP_POINTS], proposals: heapless::Vec::new(), clusters: 0 }
    }

    fn find(&mut self, mut i: u16) -> u16 {
        while self.parent[i as usize] != i {
            let p = self.parent[i as usize];
            self.parent[i as usize] = self.parent[p as usize];
            i = p;
        }
        i
    }
}

impl Default for ProposalScratch {
    fn default() -> Self {
        Self::new()
    }
}

impl Planner {
    /// Finds this step's proposals (into `self.proposals.proposals`) and their viewpoints; needs
    /// the distance field of this step. Returns the work.
    pub(super) fn find_proposals(&mut self, lidar: &LidarGrid, nonmap: &NonMapStore, camera_range_cells: i32, snap: i32) -> u32 {
        let s = &mut self.proposals;
        s.proposals.clear();
        s.order.clear();
        s.clusters = 0;
        let mut work = 0u32;
        for p in nonmap.points() {
            let (x, y) = lidar.geom.cell_of(p.x, p.y);
            if PackedGrid::in_bounds(x, y) {
                // Cannot fail: at most MAX_NONMAP_POINTS points.
                let _ = s.order.push((x, y, p.hits));
            }
        }
        // Insertion sort by (x, y): deterministic, and the store is small.
        let n = s.order.len();
        for i in 1..n {
            let mut j = i;
            while j > 0 && (s.order[j - 1].0, s.order[j - 1].1) > (s.order[j].0, s.order[j].1) {
                s.order.swap(j - 1, j);
                j -= 1;
                work += 1;
            }
        }
        for i in 0..n {
            s.parent[i] = i as u16;
        }
        for i in 0..n {
            let (xi, yi, _) = s.order[i];
            for j in i + 1..n {
                let (xj, yj, _) = s.order[j];
                work += 1;
                if xj - xi > PROPOSAL_LINK_CELLS {
                    break;
                }
                if (yj - yi).abs() <= PROPOSAL_LINK_CELLS {
                    let (a, b) = (s.find(i as u16), s.find(j as u16));
                    if a != b {
                        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
                        s.parent[hi as usize] = lo;
                    }
                }
            }
        }
        // Per root (the smallest index of its cluster): bounds, sums.
        let r_cells = camera_range_cells as i64;
        for root in 0..n {
            if s.find(root as u16) != root as u16 {
                continue;
            }
            s.clusters += 1;
            let (mut x0, mut y0, mut x1, mut y1) = (i32::MAX, i32::MAX, i32::MIN, i32::MIN);
            let (mut sx, mut sy, mut points, mut hits) = (0i64, 0i64, 0u16, 0u32);
            for k in root..n {
                work += 1;
                if s.find(k as u16) != root as u16 {
                    continue;
                }
                let (x, y, h) = s.order[k];
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
                sx += x as i64;
                sy += y as i64;
                points += 1;
                hits += h as u32;
            }
            let extent = (x1 - x0).max(y1 - y0);
            if extent > PROPOSAL_MAX_EXTENT_CELLS || hits < PROPOSAL_MIN_HITS {
                continue;
            }
            let c = ((sx / points as i64) as i32, (sy / points as i64) as i32);
            let prop = Proposal { cell: c, viewpoint: c, heading: BinaryAngle::ZERO, points, hits, extent };
            // Keep the best evidence: insert in order of hits (ties: first found first).
            let at = s.proposals.iter().position(|q| q.hits < hits).unwrap_or(s.proposals.len());
            if at < MAX_PROPOSALS {
                if s.proposals.is_full() {
                    s.proposals.pop();
                }
                let _ = s.proposals.insert(at, prop);
            }
        }
        // Viewpoints, after ranking (only the kept ones).
        let robot = self.robot_cell;
        let mut kept: heapless::Vec<Proposal, MAX_PROPOSALS> = heapless::Vec::new();
        for i in 0..self.proposals.proposals.len() {
            let mut p = self.proposals.proposals[i];
            let v = stand_off(robot, p.cell, r_cells);
            work += ((2 * snap + 1) * (2 * snap + 1)) as u32;
            let Some(v) = self.reachable_near(v, snap) else {
                self.stats.unreachable += 1;
                continue;
            };
            if v == p.cell {
                continue;
            }
            p.viewpoint = v;
            p.heading = atan2(p.cell.1 - v.1, p.cell.0 - v.0);
            let _ = kept.push(p);
        }
        self.proposals.proposals = kept;
        work
    }
}

/// Where to look at `target` from, seen from `robot` (cells): on the line between them at
/// `λ·min(camera range, distance)` from the target (Gao et al.'s proposal viewpoint; LIVE's
/// priority waypoints stand there too).
pub(super) fn stand_off(robot: (i32, i32), target: (i32, i32), range_cells: i64) -> (i32, i32) {
    let (dx, dy) = ((robot.0 - target.0) as i64, (robot.1 - target.1) as i64);
    let d = fixed_point::isqrt_u64((dx * dx + dy * dy) as u64) as i64;
    if d == 0 {
        return robot;
    }
    let stand = PROPOSAL_LAMBDA_PER_MILLE * d.min(range_cells) / 1000;
    ((target.0 as i64 + dx * stand / d) as i32, (target.1 as i64 + dy * stand / d) as i32)
}
