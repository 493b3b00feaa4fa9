//! The structured search (`lives`, and its ablation `lives-no-nonmap`): tasks, rooms and a
//! global tour, after Gao et al. (object proposals, room segmentation, a travelling-salesman
//! tour) and FUEL (Zhou et al. 2021: a global tour over frontier clusters, replanned as they
//! change). docs/experiments/structured-search.md says how each choice below was measured.
//!
//! Each planning step ([`Planner::schedule`], on the distance field of
//! [`Planner::prepare`]):
//! 1. **Rooms**: the LiDAR map segmented into rooms, corridors and doorways ([`crate::rooms`]).
//! 2. **Tasks**:
//!    - object proposals ([`super::proposals`]; `lives` only), each looked at from its
//!      viewpoint;
//!    - frontier viewpoints of both maps: at each frontier's (snapped) anchor, the best of the
//!      four headings by the view utility ([`super::view`]), if it offers at least
//!      `gaze_min_gain`; per room only its best by the greedy utility (view gain minus
//!      `w_dist`·path), so the tour orders rooms, not a room's gaps;
//!    - rooms the camera has seen less than half of, with no task inside, looked into from
//!      their most open cell.
//!
//!    A task joins the tour only if its view offers at least 1/[`GAIN_SHARE`] of the best
//!    view's gain; at most [`TOUR_TASKS`]: proposals and rooms first, then frontier tasks by
//!    utility.
//! 3. **Costs**: from the robot, the exact path distance (the step's Dijkstra); between two
//!    tasks, the straight line if every cell on it is reachable, else the distance through the
//!    shortest-path tree rooted at the robot (down both paths to where they meet: an upper bound
//!    that is exact when the paths share their way, as they do through a building's doors);
//!    each leg costs `max(distance, turn)` (FUEL's time lower bound, with a quarter turn worth
//!    [`TURN_UNITS_PER_QUARTER`] of distance).
//! 4. **Tour**: an open asymmetric TSP path from the robot through every task ([`crate::tour`]:
//!    cheapest insertion, 2-opt, Or-opt), warm-started from the last step's tour. Every task is
//!    in one precedence class: Gao et al.'s classes (proposals in reach, the current room, other
//!    rooms, corridors) lost on the development seeds ([`ROOM_PRECEDENCE`],
//!    [`PROPOSAL_PRECEDENCE`] keep them selectable at build time).
//! 5. **Commitment**: the robot goes to the tour's first task. The task being pursued (matched
//!    across steps by its room if the goal lies on the way to the room's task now
//!    ([`Planner::on_the_way`]), or by what it looks at within [`TASK_MATCH_CELLS`]: when the
//!    room's best frontier is not on the way, the goal's own frontier stays a task, so the
//!    commitment is refreshed, not transferred, [`Planner::pursued_frontier`]) stays first
//!    unless the best tour that starts elsewhere is shorter by [`TOUR_SWITCH_UNITS`]: a tour
//!    re-solved from a moving robot otherwise changes its first task every step.

use super::{Planner, Site, Step, Viewpoint, HEADINGS, NARROW_STEP_FACTOR, STEP_STRAIGHT, UNREACHABLE};
use crate::capacity::MAX_TASKS;
use crate::config::{PlannerKind, Weight};
use crate::grid::{Cell, GridGeometry, Line};
use crate::rooms::{Room, RoomKind, Rooms};
use fixed_point::BinaryAngle;

/// Proposals whose viewpoint lies within this many camera ranges of path come first (the
/// others take the class of their room): a near proposal costs little to look at, a far one
/// is ordered with everything else so the robot does not cross the building for every chair.
pub const PROPOSAL_REACH_CAMERA_RANGES: i64 = 1;
/// A quarter turn costs as much as this much path (units of 0.02 m: 0.8 m; Spot turns at about
/// 1 rad/s and walks at about 0.5 m/s).
pub const TURN_UNITS_PER_QUARTER: u32 = 40;
/// The goal being pursued stays first unless a tour starting elsewhere is shorter by this
/// much (units of 0.02 m: 20 m).
pub const TOUR_SWITCH_UNITS: u64 = 1000;
/// A task of the last step and one of this step are the same when their anchors (or the goal's
/// viewpoint and the task's) are within this many cells (1.5 m).
pub const TASK_MATCH_CELLS: i32 = 15;
/// Tasks the tour orders: the proposals, the room tasks, then the frontier tasks of best
/// greedy utility.
pub const TOUR_TASKS: usize = 16;
/// A task's view must offer at least 1/GAIN_SHARE of the best view's gain to join the tour.
pub const GAIN_SHARE: i64 = 2;
/// Tasks of the current room come before those of other rooms (Gao et al.).
pub const ROOM_PRECEDENCE: bool = false;
/// Proposals within reach come before everything else (Gao et al.).
pub const PROPOSAL_PRECEDENCE: bool = false;
/// How far [`room_near`] looks for a labelled cell around an unlabelled one (cells: 0.6 m).
pub const ROOM_SEARCH_CELLS: i32 = 6;
/// Rooms (not yet seen by the camera) that become tasks, at most.
pub const MAX_ROOM_TASKS: usize = 8;
/// Work the tour solver may spend per planning step.
pub const TOUR_WORK_BUDGET: u32 = 2_000_000;
/// Longest walk down the shortest-path tree when costing a pair of tasks, cells per side.
const TREE_WALK_LIMIT: u32 = 4096;

/// The task a step chose, remembered for the next: its viewpoint cell, its anchor, its kind.
pub(crate) type Pursued = ((i32, i32), (i32, i32), TaskKind);

/// What a task is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskKind {
    /// Look at an object proposal.
    Proposal,
    /// Look at a frontier of the LiDAR map.
    LidarFrontier,
    /// Look at a frontier of the camera's map.
    VisualFrontier,
    /// Look into a room the camera has not seen.
    Room,
}

impl TaskKind {
    /// The site kind a goal for it reports.
    pub const fn site(self) -> Site {
        match self {
            TaskKind::Proposal => Site::NonMapCluster,
            TaskKind::LidarFrontier => Site::LidarFrontier,
            TaskKind::VisualFrontier => Site::VisualFrontier,
            TaskKind::Room => Site::Room,
        }
    }
}

/// One task of the tour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Task {
    /// What it looks at: the proposal's centre, the frontier's anchor, the room's most open
    /// cell. Tasks are matched across planning steps by it (a proposal's viewpoint moves with
    /// the robot; what it looks at does not).
    pub anchor: (i32, i32),
    /// Where the robot stands.
    pub cell: (i32, i32),
    /// The room (or corridor) its viewpoint stands in.
    pub room: Option<u8>,
    /// Which way it looks.
    pub heading: BinaryAngle,
    /// What it is.
    pub kind: TaskKind,
    /// Precedence class (lower first).
    pub class: u8,
    /// Path distance from the robot, units of 0.02 m.
    pub path_units: u16,
    /// The view's gain (Q16.16 utility bits) and terms.
    pub view: super::view::View,
    /// Greedy utility (gain − w_dist·path), for choosing which tasks to keep.
    pub utility: i64,
}

impl Task {
    fn viewpoint(&self, utility: i64) -> Viewpoint {
        Viewpoint {
            cell: self.cell,
            heading: self.heading,
            source: self.kind.site(),
            utility,
            path_units: self.path_units,
            unseen: self.view.unseen,
            surface: self.view.surface,
            frontier_near_path: 0,
            nonmap: self.view.nonmap,
        }
    }
}

/// Counters of the last structured step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScheduleStats {
    /// Tasks in the tour, by kind: proposals, LiDAR frontiers, camera frontiers, rooms.
    pub tasks: [u16; 4],
    /// Tasks left out for capacity.
    pub dropped: u16,
    /// Rooms and corridors of the segmentation.
    pub rooms: u16,
    /// The tour's cost, units of 0.02 m.
    pub tour_units: u64,
    /// The solver finished within its budget.
    pub solved: bool,
    /// The goal being pursued was kept by hysteresis over a different first task.
    pub kept: bool,
    /// The goal being pursued was found among this step's tasks.
    pub pursued: bool,
}

/// Whether task `t` looks the way the goal being pursued looks (`goal_heading`), as a task that
/// continues it by place must: a frontier task's view is one of four headings from a viewpoint
/// at the frontier, and a frontier at the goal's viewpoint whose best view now faces another way
/// looks at something else (what the goal looked at has been seen); it is a new choice, not the
/// goal's own frontier (within half a quarter turn). Other kinds, or no heading known: always.
fn looks_alike(t: &Task, goal_heading: Option<BinaryAngle>) -> bool {
    match (t.kind, goal_heading) {
        (TaskKind::LidarFrontier | TaskKind::VisualFrontier, Some(h)) => quarter_turns(t.heading, h) <= 4,
        _ => true,
    }
}

/// Whether a task of kind `k` is a frontier of either map.
fn is_frontier(k: TaskKind) -> bool {
    matches!(k, TaskKind::LidarFrontier | TaskKind::VisualFrontier)
}

/// The match by place: of `tasks`, the one of `kind` that looks the way the goal looks
/// ([`looks_alike`]) whose anchor is nearest `anchor` (or whose viewpoint is nearest
/// `goal_cell`), within [`TASK_MATCH_CELLS`].
fn match_by_place(
    tasks: &[Task],
    kind: TaskKind,
    anchor: (i32, i32),
    goal_cell: (i32, i32),
    heading: Option<BinaryAngle>,
) -> Option<usize> {
    let d2 = |p: (i32, i32), q: (i32, i32)| (p.0 - q.0).pow(2) + (p.1 - q.1).pow(2);
    tasks
        .iter()
        .enumerate()
        .filter(|(_, t)| t.kind == kind && looks_alike(t, heading))
        .map(|(i, t)| (d2(t.anchor, anchor).min(d2(t.cell, goal_cell)), i))
        .filter(|&(d, _)| d <= TASK_MATCH_CELLS * TASK_MATCH_CELLS)
        .min()
        .map(|(_, i)| i)
}

fn quarter_turns(a: BinaryAngle, b: BinaryAngle) -> u32 {
    // |a − b| in units of a quarter turn, rounded up to 1/8 of one.
    let d = (a - b).unsigned_abs() as u64; // 2^32 = a full turn
    ((d * 8 + (1 << 30) - 1) >> 30) as u32
}

impl Planner {
    /// The structured step: returns the goal's viewpoint and the work.
    pub(super) fn schedule(&mut self, step: &Step, current: Option<((i32, i32), BinaryAngle)>) -> (Option<Viewpoint>, u32) {
        let cfg = step.inputs.cfg;
        let mut work = self.rooms.update(step.inputs.lidar);
        let range_cells = GridGeometry::cells(cfg.camera_range_m);
        let w_nonmap = cfg.effective_w_nonmap();
        let lives = cfg.planner == PlannerKind::Lives;
        self.tasks.clear();
        self.sched = ScheduleStats { rooms: self.rooms.rooms().len() as u16, ..ScheduleStats::default() };
        let bl = GridGeometry::cells(cfg.blacklist_radius_m);
        let claim = super::claim_radius(cfg);
        let here = GridGeometry::cells(cfg.goal_tolerance_m) as i64 * STEP_STRAIGHT as i64;
        let pose = step.inputs.pose;
        let robot = step.robot;
        let already_there = |cell: (i32, i32), h: BinaryAngle, d: u16| {
            (cell == robot || (d as i64) <= here) && (h - pose.theta).unsigned_abs() <= cfg.goal_heading_tolerance.unsigned_abs()
        };
        let dist_term =
            |units: u16| (cfg.w_dist_per_m.to_bits() as i64 * units as i64 * (crate::capacity::CELL_MM / STEP_STRAIGHT as i64)) / 1000;

        // Proposals.
        self.task_pool.clear();
        if lives {
            work += self.find_proposals(step.inputs.lidar, step.inputs.nonmap, range_cells, step.snap);
        }
        let reach = (PROPOSAL_REACH_CAMERA_RANGES * range_cells as i64 * STEP_STRAIGHT as i64).min(UNREACHABLE as i64 - 1) as u16;
        for k in 0..self.proposals.proposals.len() {
            let p = self.proposals.proposals[k];
            let d = self.distance(p.viewpoint.0, p.viewpoint.1);
            if d == UNREACHABLE
                || self.is_blacklisted(p.viewpoint, bl)
                || self.is_claimed(p.viewpoint, claim)
                || already_there(p.viewpoint, p.heading, d)
            {
                continue;
            }
            if w_nonmap != Weight::ZERO {
                work += self.visible_nonmap(step.inputs.lidar, step.inputs.nonmap, p.viewpoint, range_cells);
            }
            let (view, w) = self.view(cfg, step.inputs.lidar, step.inputs.visual, p.viewpoint, p.heading, w_nonmap);
            work += w;
            let class = if PROPOSAL_PRECEDENCE && d <= reach { 0 } else { u8::MAX };
            let t = Task {
                anchor: p.cell,
                cell: p.viewpoint,
                room: room_near(&self.rooms, p.viewpoint),
                heading: p.heading,
                kind: TaskKind::Proposal,
                class,
                path_units: d,
                view,
                utility: view.gain - dist_term(d),
            };
            let _ = self.task_pool.push(t);
        }
        let n_props = self.task_pool.len();

        // Frontier viewpoints: the best heading of each.
        let mut unreachable = 0;
        for f in step.inputs.frontiers.frontiers() {
            let Some(c) = self.snap_site(f.anchor, step.snap, &mut work, &mut unreachable) else { continue };
            if self.is_blacklisted(c, bl) || self.is_claimed(c, claim) {
                self.stats.blacklisted += 1;
                continue;
            }
            let (best, d, w) = self.look_from(step, c, w_nonmap, &already_there);
            work += w;
            let Some((view, h)) = best else { continue };
            let kind = match f.source {
                crate::frontier::FrontierSource::Lidar => TaskKind::LidarFrontier,
                crate::frontier::FrontierSource::Visual => TaskKind::VisualFrontier,
            };
            if view.gain < cfg.gaze_min_gain.to_bits() as i64 {
                // Nothing worth a look there (a shadow behind furniture, a sliver).
                continue;
            }
            let t = Task {
                anchor: f.anchor,
                cell: c,
                room: None,
                heading: h,
                kind,
                class: u8::MAX,
                path_units: d,
                view,
                utility: view.gain - dist_term(d),
            };
            let _ = self.task_pool.push(t);
        }
        self.stats.unreachable += unreachable;
        // One frontier task per room: its best view by the greedy utility (the next one appears
        // when the camera has looked or the LiDAR has seen), so the tour orders rooms and the
        // robot does not zigzag between a room's small gaps. Frontiers outside every room (in
        // space the segmentation has not labelled yet) stay tasks of their own.
        let mut best_in_room = [i64::MIN; crate::capacity::MAX_ROOMS + 1];
        for t in self.task_pool[n_props..].iter_mut() {
            t.room = room_near(&self.rooms, t.cell);
            if let Some(r) = t.room {
                let b = &mut best_in_room[r as usize];
                *b = (*b).max(t.utility);
            }
            work += 1;
        }
        // The goal being pursued is refreshed, not transferred: when its region's best frontier
        // does not lie on the way through it ([`Planner::on_the_way`]), the goal's own frontier
        // (matched by place, as [`Planner::find_task`] does) stays a task beside the region's
        // best, so the match by place can continue it.
        let (keep, w) = self.pursued_frontier(n_props, current, &best_in_room);
        work += w;
        let mut taken = [false; crate::capacity::MAX_ROOMS + 1];
        let mut k = 0;
        self.task_pool.retain(|t| {
            k += 1;
            if k <= n_props {
                return true;
            }
            if keep == Some(k - 1) {
                return true;
            }
            match t.room {
                Some(r) if t.utility == best_in_room[r as usize] && !taken[r as usize] => {
                    taken[r as usize] = true;
                    true
                }
                Some(_) => false,
                None => true,
            }
        });
        let n_frontiers = self.task_pool.len() - n_props;

        // Rooms the camera has not seen (no task inside yet).
        work += self.rooms_unseen(step);
        let mut room_tasks = 0;
        for k in 0..self.room_scratch.len() {
            if room_tasks >= MAX_ROOM_TASKS {
                break;
            }
            let anchor = self.room_scratch[k];
            let Some(c) = self.reachable_near(anchor, step.snap) else { continue };
            if self.is_blacklisted(c, bl) || self.is_claimed(c, claim) {
                continue;
            }
            let (best, d, w) = self.look_from(step, c, w_nonmap, &already_there);
            work += w;
            if let Some((view, h)) = best.filter(|(v, _)| v.gain >= cfg.gaze_min_gain.to_bits() as i64) {
                let t = Task {
                    anchor,
                    cell: c,
                    room: room_near(&self.rooms, c),
                    heading: h,
                    kind: TaskKind::Room,
                    class: u8::MAX,
                    path_units: d,
                    view,
                    utility: view.gain - dist_term(d),
                };
                if self.task_pool.push(t).is_ok() {
                    room_tasks += 1;
                }
            }
        }

        // Keep proposals and rooms first, then frontier tasks by utility (stable: frontier order
        // breaks ties).
        let f0 = n_props;
        for i in f0 + 1..f0 + n_frontiers {
            let mut j = i;
            while j > f0 && self.task_pool[j - 1].utility < self.task_pool[j].utility {
                self.task_pool.swap(j - 1, j);
                j -= 1;
                work += 1;
            }
        }
        // Only views worth a tour stop: at least 1/GAIN_SHARE of the best view's gain (a small
        // pocket is not worth visiting first when a large room waits, nor is a chair).
        let best_gain = self.task_pool.iter().map(|t| t.view.gain).max().unwrap_or(0);
        let order = (0..n_props).chain(f0 + n_frontiers..self.task_pool.len()).chain(f0..f0 + n_frontiers);
        for k in order {
            let t = self.task_pool[k];
            if t.view.gain.saturating_mul(GAIN_SHARE) < best_gain {
                self.sched.dropped += 1;
                continue;
            }
            if self.tasks.len() >= TOUR_TASKS || self.tasks.push(t).is_err() {
                self.sched.dropped += 1;
            }
        }

        // Classes: proposals in reach; the current room (the one the goal being pursued lies in,
        // else the robot's own: a robot crossing a doorway keeps its commitment); the rest.
        let current_room = match current {
            Some((c, _)) => room_near(&self.rooms, c),
            None => room_near(&self.rooms, robot),
        };
        for t in self.tasks.iter_mut() {
            if t.class == 0 {
                continue;
            }
            t.class = if ROOM_PRECEDENCE && t.room.is_some() && t.room == current_room { 1 } else { 2 };
        }
        for t in self.tasks.iter() {
            let k = match t.kind {
                TaskKind::Proposal => 0,
                TaskKind::LidarFrontier => 1,
                TaskKind::VisualFrontier => 2,
                TaskKind::Room => 3,
            };
            self.sched.tasks[k] += 1;
        }
        if self.tasks.is_empty() {
            self.last_tour.clear();
            self.last_goal = None;
            return (None, work);
        }

        // The goal being pursued: the task chosen last time, if the controller still pursues it.
        let pursued = match (current, self.last_goal) {
            (Some((c, _)), Some((cell, anchor, kind))) if c == cell => Some((anchor, kind, self.last_goal_room)),
            _ => None,
        };
        let current_task = match pursued {
            Some((a, kind, room)) => {
                let (i, w) = self.find_task(a, kind, room, current);
                work += w;
                i
            }
            None => None,
        };

        // Costs.
        work += self.tour_costs(pose.theta);

        // Warm start: the last tour's tasks, matched by place and kind, the current goal first.
        let mut warm: heapless::Vec<u8, MAX_TASKS> = heapless::Vec::new();
        let near = |a: (i32, i32), b: (i32, i32)| (a.0 - b.0).abs() <= 5 && (a.1 - b.1).abs() <= 5;
        self.sched.pursued = current_task.is_some();
        if let Some(i) = current_task {
            let _ = warm.push(i as u8 + 1);
        }
        for &(c, kind) in self.last_tour.iter() {
            if let Some(i) = self.tasks.iter().position(|t| t.kind == kind && near(t.anchor, c)) {
                let id = i as u8 + 1;
                if !warm.contains(&id) {
                    let _ = warm.push(id);
                }
            }
        }
        work += self.tour.start(&self.problem, &warm);
        let (w, done) = self.tour.step(&self.problem, TOUR_WORK_BUDGET);
        work += w;
        self.sched.solved = done;
        let mut first = self.tour.best().order.first().map(|&i| i as usize - 1);
        let mut cost = self.tour.best().cost;
        // Hysteresis: keep pursuing the current task unless the best tour that starts elsewhere
        // is shorter than the best one that starts with it by [`TOUR_SWITCH_UNITS`], or a task
        // of a lower class (a proposal now in reach) came up.
        if let (Some(cur), Some(f)) = (current_task, first) {
            let cur_class = self.problem.class[cur + 1];
            if cur != f && cur_class <= self.problem.class[f + 1] {
                let free: heapless::Vec<u8, MAX_TASKS> = self.tour.best().order.clone();
                let classes = self.problem.class;
                // The same problem with the pursued task alone in the lowest class.
                for c in self.problem.class[1..=self.tasks.len()].iter_mut() {
                    *c = c.saturating_add(1);
                }
                self.problem.class[cur + 1] = 0;
                work += self.tour.start(&self.problem, &warm);
                let (w, _) = self.tour.step(&self.problem, TOUR_WORK_BUDGET);
                work += w;
                let kept = self.tour.best().cost;
                self.problem.class = classes;
                if kept <= cost.saturating_add(TOUR_SWITCH_UNITS) {
                    first = Some(cur);
                    cost = kept;
                    self.sched.kept = true;
                } else {
                    // Back to the free tour (for the order reported and the next warm start).
                    work += self.tour.start(&self.problem, &free);
                }
            }
        }
        self.sched.tour_units = cost;
        self.last_tour.clear();
        let order: heapless::Vec<u8, MAX_TASKS> = self.tour.best().order.clone();
        for &i in order.iter() {
            let t = self.tasks[i as usize - 1];
            let _ = self.last_tour.push((t.anchor, t.kind));
            self.stats.candidates += 1;
            let _ = self.candidates.push(t.viewpoint(-(cost as i64)));
        }
        self.last_goal = first.map(|i| (self.tasks[i].cell, self.tasks[i].anchor, self.tasks[i].kind));
        self.last_goal_room = first.and_then(|i| self.tasks[i].room);
        (first.map(|i| self.tasks[i].viewpoint(-(cost as i64))), work)
    }

    /// This step's task that continues one of the last step's (`anchor`, `kind`, `room`), with
    /// the work: a room's frontier task is the room's, whichever of its frontiers is best now, if
    /// the goal being pursued lies on the way to it ([`Planner::on_the_way`]); otherwise a
    /// frontier shrinks and its anchor moves as the robot nears it, so the task of the same kind
    /// whose anchor is nearest the last one (or whose viewpoint is the goal's) within
    /// [`TASK_MATCH_CELLS`] and, for a frontier, that looks the way the goal looks
    /// ([`looks_alike`]).
    fn find_task(&self, a: (i32, i32), kind: TaskKind, room: Option<u8>, goal: Option<((i32, i32), BinaryAngle)>) -> (Option<usize>, u32) {
        let goal_heading = goal.map(|(_, h)| h);
        let goal_cell = goal.map_or(a, |(c, _)| c);
        let mut work = 0;
        if let Some(i) = self.tasks.iter().position(|t| room.is_some() && t.room == room && is_frontier(t.kind) && is_frontier(kind)) {
            let (on_the_way, w) = self.continues(goal_cell, goal_heading, &self.tasks[i]);
            work += w;
            if on_the_way {
                return (Some(i), work);
            }
        }
        let i = match_by_place(&self.tasks, kind, a, goal_cell, goal_heading);
        (i, work + self.tasks.len() as u32)
    }

    /// The index in the task pool of the pursued goal's own frontier when the best frontier of
    /// the goal's region (`best_in_room`, pool from `n_props` on) does not lie on the way through
    /// the goal: the pool's frontier of the goal's kind that looks the way the goal looks
    /// ([`looks_alike`]) whose anchor is nearest the goal's last anchor (or whose viewpoint is
    /// the goal's), within [`TASK_MATCH_CELLS`]; `None` if the
    /// region's best is on the way, is that frontier, or there is none. Returns the work.
    fn pursued_frontier(
        &self,
        n_props: usize,
        current: Option<((i32, i32), BinaryAngle)>,
        best_in_room: &[i64; crate::capacity::MAX_ROOMS + 1],
    ) -> (Option<usize>, u32) {
        let (goal, heading, a, kind, room) = match (current, self.last_goal, self.last_goal_room) {
            (Some((c, h)), Some((cell, anchor, kind)), Some(room)) if c == cell && is_frontier(kind) => (cell, h, anchor, kind, room),
            _ => return (None, 0),
        };
        let pool = &self.task_pool[n_props..];
        let mut work = pool.len() as u32;
        let Some(best) = pool.iter().position(|t| is_frontier(t.kind) && t.room == Some(room) && t.utility == best_in_room[room as usize])
        else {
            return (None, work);
        };
        let (on_the_way, w) = self.continues(goal, Some(heading), &pool[best]);
        work += w;
        if on_the_way {
            return (None, work);
        }
        work += pool.len() as u32;
        let own = match_by_place(pool, kind, a, goal, Some(heading));
        (own.filter(|&i| i != best).map(|i| n_props + i), work)
    }

    /// Whether a region's frontier task `t` continues the goal being pursued (its viewpoint
    /// `goal`, its heading): the goal lies on the way to it ([`Planner::on_the_way`]), and a task
    /// standing within [`TASK_MATCH_CELLS`] of the goal looks the way the goal looks
    /// ([`looks_alike`]; at the goal's place a view the other way is a new choice). Returns the
    /// work.
    fn continues(&self, goal: (i32, i32), heading: Option<BinaryAngle>, t: &Task) -> (bool, u32) {
        let near = (t.cell.0 - goal.0).pow(2) + (t.cell.1 - goal.1).pow(2) <= TASK_MATCH_CELLS * TASK_MATCH_CELLS;
        if near && !looks_alike(t, heading) {
            return (false, 1);
        }
        self.on_the_way(goal, t)
    }

    /// Whether the goal being pursued (its viewpoint `goal`) lies on the way to task `t`: going
    /// to `t` through `goal` costs at most 2 · [`TASK_MATCH_CELLS`] more path than going straight
    /// (the step's path distances; goal to task by [`Planner::pair_distance`]). Only then does
    /// `t` inherit the commitment to the goal: hysteresis pays for progress made, and progress
    /// towards the goal is progress towards `t` only if the goal is on its way. A task within
    /// the match radius of the goal always is (triangle inequality); a region's frontier across
    /// the room or behind the robot is not (a hallway open to a room at its full width is one
    /// region, `crate::rooms`). Returns the work.
    pub(crate) fn on_the_way(&self, goal: (i32, i32), t: &Task) -> (bool, u32) {
        let to_goal = self.distance(goal.0, goal.1);
        let to_task = self.distance(t.cell.0, t.cell.1);
        if to_goal == UNREACHABLE || to_task == UNREACHABLE {
            return (false, 1);
        }
        let (between, work) = self.pair_distance(goal, t.cell);
        let slack = 2 * TASK_MATCH_CELLS as u64 * STEP_STRAIGHT as u64;
        (between != u32::MAX && to_goal as u64 + between as u64 <= to_task as u64 + slack, work)
    }

    /// What the camera would gain standing at `c`: the best heading's view
    /// ([`Planner::best_heading`], after collecting the non-map points visible from `c` when
    /// they count), the path distance to `c`, and the work.
    fn look_from(
        &mut self,
        step: &Step,
        c: (i32, i32),
        w_nonmap: Weight,
        already_there: &impl Fn((i32, i32), BinaryAngle, u16) -> bool,
    ) -> (Option<(super::view::View, BinaryAngle)>, u16, u32) {
        let d = self.distance(c.0, c.1);
        let mut work = 0;
        if w_nonmap != Weight::ZERO {
            work += self.visible_nonmap(step.inputs.lidar, step.inputs.nonmap, c, GridGeometry::cells(step.inputs.cfg.camera_range_m));
        }
        let (best, w) = self.best_heading(step, c, d, w_nonmap, already_there);
        (best, d, work + w)
    }

    /// The best of the four headings at `c` by the view's gain, skipping those the robot already
    /// has (standing there); with the work.
    fn best_heading(
        &self,
        step: &Step,
        c: (i32, i32),
        d: u16,
        w_nonmap: Weight,
        already_there: &impl Fn((i32, i32), BinaryAngle, u16) -> bool,
    ) -> (Option<(super::view::View, BinaryAngle)>, u32) {
        let mut best: Option<(super::view::View, BinaryAngle)> = None;
        let mut work = 0;
        for &h in HEADINGS.iter() {
            if already_there(c, h, d) {
                continue;
            }
            let (view, w) = self.view(step.inputs.cfg, step.inputs.lidar, step.inputs.visual, c, h, w_nonmap);
            work += w;
            if best.is_none_or(|(b, _)| view.gain > b.gain) {
                best = Some((view, h));
            }
        }
        (best, work)
    }

    /// Fills the tour problem from the tasks. Returns the work.
    fn tour_costs(&mut self, robot_heading: BinaryAngle) -> u32 {
        let n = self.tasks.len();
        let mut work = 0;
        self.problem.n = n;
        self.problem.class[0] = 0;
        for i in 0..n {
            let t = self.tasks[i];
            self.problem.class[i + 1] = t.class;
            let turn = quarter_turns(robot_heading, t.heading) * TURN_UNITS_PER_QUARTER / 8;
            self.problem.cost[0][i + 1] = (t.path_units as u32).max(turn);
            self.problem.cost[i + 1][0] = u32::MAX;
            self.problem.cost[i + 1][i + 1] = 0;
        }
        for i in 0..n {
            for j in i + 1..n {
                let (a, b) = (self.tasks[i], self.tasks[j]);
                let (d, w) = self.pair_distance(a.cell, b.cell);
                work += w;
                let turn = quarter_turns(a.heading, b.heading) * TURN_UNITS_PER_QUARTER / 8;
                let c = if d == u32::MAX { u32::MAX } else { d.max(turn) };
                self.problem.cost[i + 1][j + 1] = c;
                self.problem.cost[j + 1][i + 1] = c;
            }
        }
        work
    }

    /// Path distance between two reachable cells (units of 0.02 m): the straight line when every
    /// cell on it is reachable, else down the shortest-path tree to where the two paths meet.
    /// `u32::MAX` if either is unreachable. Returns the distance and the work.
    fn pair_distance(&self, a: (i32, i32), b: (i32, i32)) -> (u32, u32) {
        let (da, db) = (self.distance(a.0, a.1), self.distance(b.0, b.1));
        if da == UNREACHABLE || db == UNREACHABLE {
            return (u32::MAX, 1);
        }
        let (dx, dy) = ((a.0 - b.0) as i64, (a.1 - b.1) as i64);
        let euclid = ((fixed_point::isqrt_u64(((dx * dx + dy * dy) as u64) << 16) as i64 * STEP_STRAIGHT as i64) >> 8) as u32;
        let mut work = (dx.abs().max(dy.abs())) as u32;
        // Each cell of the narrow band on the line costs what Dijkstra charges for it.
        let mut narrow = 0u32;
        let clear = Line::new(a.0, a.1, b.0, b.1).all(|(x, y)| match self.reach_kind(x, y) {
            0 => false,
            k => {
                narrow += (k == 2) as u32;
                true
            }
        });
        if clear {
            return (euclid + narrow * (NARROW_STEP_FACTOR - 1) as u32 * STEP_STRAIGHT as u32, work);
        }
        // Walk the farther one down until both stand on the same cell.
        let (mut p, mut q) = (a, b);
        let mut steps = 0;
        while p != q && steps < 2 * TREE_WALK_LIMIT {
            steps += 1;
            let (dp, dq) = (self.distance(p.0, p.1), self.distance(q.0, q.1));
            let moved = if dp >= dq { self.descend(p.0, p.1).map(|c| p = c) } else { self.descend(q.0, q.1).map(|c| q = c) };
            if moved.is_none() {
                break;
            }
        }
        work += steps * 9;
        if p != q {
            return ((da as u32 + db as u32).max(euclid), work);
        }
        let meet = self.distance(p.0, p.1) as u32;
        ((da as u32 - meet) + (db as u32 - meet), work)
    }

    /// Rooms the camera has not seen: their most open cells into `self.room_scratch`, for rooms
    /// (not corridors) with at most half their free cells seen by the camera and no task of the
    /// pool inside. Returns the work.
    fn rooms_unseen(&mut self, step: &Step) -> u32 {
        self.room_scratch.clear();
        let mut work = 0;
        let mut has_task = [false; crate::capacity::MAX_ROOMS];
        for t in self.task_pool.iter() {
            if let Some(r) = self.rooms.room_at(t.cell.0, t.cell.1) {
                has_task[r as usize % crate::capacity::MAX_ROOMS] = true;
            }
            work += 1;
        }
        for r in self.rooms.rooms() {
            if r.kind != RoomKind::Room || has_task[r.id as usize % crate::capacity::MAX_ROOMS] {
                continue;
            }
            let (seen, free, w) = camera_coverage(&self.rooms, r, step);
            work += w;
            if free > 0 && 2 * seen <= free && step.inputs.lidar.get(r.view.0, r.view.1) == Cell::Free {
                let _ = self.room_scratch.push(r.view);
            }
        }
        work
    }
}

/// The room of `c`, or, where the segmentation left `c` unlabelled (a viewpoint next to
/// unknown space: its coarse cell is not free enough), the room of the nearest labelled cell
/// within [`ROOM_SEARCH_CELLS`] (rings of growing Chebyshev radius, scanned in a fixed order).
fn room_near(rooms: &Rooms, c: (i32, i32)) -> Option<u8> {
    if let Some(r) = rooms.room_at(c.0, c.1) {
        return Some(r);
    }
    for r in (2..=ROOM_SEARCH_CELLS).step_by(2) {
        for d in -r..=r {
            for (x, y) in [(c.0 + d, c.1 - r), (c.0 + d, c.1 + r), (c.0 - r, c.1 + d), (c.0 + r, c.1 + d)] {
                if let Some(id) = rooms.room_at(x, y) {
                    return Some(id);
                }
            }
        }
    }
    None
}

/// How much of room `r` the camera has seen: (seen, free) over every other cell of its bounding
/// box in both directions (a quarter sample: the share is what matters), and the work.
fn camera_coverage(rooms: &Rooms, r: &Room, step: &Step) -> (u32, u32, u32) {
    let (x0, y0, x1, y1) = r.bbox;
    let (mut seen, mut free, mut work) = (0, 0, 0);
    for y in (y0..=y1).step_by(2) {
        for x in (x0..=x1).step_by(2) {
            work += 1;
            if rooms.room_at(x, y) != Some(r.id) || step.inputs.lidar.get(x, y) != Cell::Free {
                continue;
            }
            free += 1;
            seen += (step.inputs.visual.get(x, y) != Cell::Unknown) as u32;
        }
    }
    (seen, free, work)
}

#[cfg(test)]
mod tests;
