//! One robot of a team: its simulator and its own controller core, stepped one tick at a time
//! on the coordinator's order.

use super::{Assignment, Status};
use crate::run::{Answer, Brain, End, InProcess, SimSource, Source};
use crate::search::SearchSpec;
use firmware::Controller;

/// A team robot.
pub struct TeamRobot {
    /// Its index in the team.
    pub id: u32,
    /// The reporting process.
    pub instance: u32,
    /// Its simulator.
    pub source: SimSource,
    /// Its controller.
    pub brain: InProcess,
    /// The epoch of the assignment it follows (0: none yet).
    pub epoch: u32,
    goal_epoch: Option<u32>,
    /// The waypoints of the assignment it follows.
    route_len: usize,
    /// Cells already reported seen.
    reported: Vec<u64>,
    /// Without a known map: the LiDAR grid as the team knows it from this robot (0 unknown, 1
    /// free, 2 occupied), to report what changed.
    lidar_known: Option<Vec<u8>>,
    /// How its run ended (it then idles).
    pub ended: Option<End>,
}

impl TeamRobot {
    /// Robot `id` of a team, searching `spec` (already started where it stands,
    /// [`super::TeamSpec::member`]); the known map, if any, is loaded but no route given (the
    /// coordinator assigns it). With `teammates`, running out of work does not end its run: it
    /// waits, re-planning every `replan_interval`, for a share of what the others have left (a
    /// team of one ends as the single-robot search does). Fails if the spec's model does not
    /// validate.
    pub fn new(id: u32, instance: u32, spec: &SearchSpec, teammates: bool) -> Result<Self, String> {
        let cfg = crate::run::controller_config(&spec.controller, &spec.world, spec.planner.kind());
        let mut ctrl = Box::new(Controller::new(cfg));
        if let (true, Some(blob)) = (spec.classifier(), spec.model) {
            ctrl.set_model(blob).map_err(|e| format!("robot {id}: {e}"))?;
        }
        if let Some(cells) = &spec.prior_map {
            crate::live::load(&mut ctrl, cells);
        }
        let n = firmware::capacity::GRID_CELLS * firmware::capacity::GRID_CELLS;
        Ok(TeamRobot {
            id,
            instance,
            source: spec.sim_source(),
            brain: if teammates { InProcess::waiting(ctrl, cfg.replan_interval_us) } else { InProcess::new(ctrl) },
            epoch: 0,
            goal_epoch: None,
            route_len: 0,
            reported: vec![0; n.div_ceil(64)],
            lidar_known: spec.prior_map.is_none().then(|| vec![0; n]),
            ended: None,
        })
    }

    /// Takes an assignment newer than the one it follows (an older or repeated one is ignored):
    /// the controller's route becomes it, and the goal taken from the old one is dropped.
    pub fn assign(&mut self, a: &Assignment) {
        if a.robot != self.id || a.epoch <= self.epoch {
            return;
        }
        let route = crate::live::coverage::Route {
            waypoints: a.waypoints.iter().map(|w| crate::live::coverage::Waypoint { x: w[0], y: w[1], heading: w[2], gain: 0 }).collect(),
            coverable: 0,
            covered: 0,
            free: 0,
            length_m: 0.0,
        };
        self.route_len = crate::live::give_route(&mut self.brain.ctrl, &route);
        self.epoch = a.epoch;
        self.goal_epoch = None;
    }

    /// Marks the cells the team's cameras saw ([`super::TickMsg::seen`]) seen by this robot's
    /// controller too, and gives it what the team's LiDARs observed
    /// ([`super::TickMsg::lidar`]; a cell its own LiDAR has observed keeps its own evidence).
    pub fn merge(&mut self, seen: &[u32], lidar: &[u32]) {
        let side = firmware::capacity::GRID_CELLS;
        if let Some(known) = self.lidar_known.as_mut() {
            for (x, y, occupied) in lidar.iter().filter_map(|&c| super::unflag_cell(c)) {
                self.brain.ctrl.merge_lidar(x, y, occupied);
                known[y as usize * side + x as usize] = cell_code(self.brain.ctrl.lidar.get(x, y));
            }
        }
        for (x, y, occupied) in seen.iter().filter_map(|&c| super::unflag_cell(c)) {
            self.brain.ctrl.merge_seen(x, y, occupied);
            let i = y as usize * side + x as usize;
            self.reported[i / 64] |= 1 << (i % 64);
        }
    }

    /// Leaves to each teammate the goal it is nearer to than this robot is (as the crow flies;
    /// a tie to the lower index), so two robots never pursue one goal and the nearer one keeps
    /// it (`positions` and `goals` by robot, this robot's own ignored).
    pub fn give_way(&mut self, goals: &[Option<[f64; 2]>], positions: &[Option<[f64; 2]>]) {
        let me = self.brain.ctrl.pose().map(|p| [p.x.to_num::<f64>(), p.y.to_num::<f64>()]);
        let id = self.id as usize;
        let claims: Vec<(firmware::Meters, firmware::Meters)> = goals
            .iter()
            .zip(positions)
            .enumerate()
            .filter(|&(j, _)| j != id)
            .filter_map(|(j, (g, p))| {
                let (g, p) = ((*g)?, (*p)?);
                let theirs = (g[0] - p[0]).hypot(g[1] - p[1]);
                let mine = me.map_or(f64::INFINITY, |m| (g[0] - m[0]).hypot(g[1] - m[1]));
                (theirs < mine || (theirs == mine && j < id)).then_some(g)
            })
            .filter_map(|g| Some((fixed_point::meters_from_f64(g[0])?, fixed_point::meters_from_f64(g[1])?)))
            .collect();
        self.brain.ctrl.set_team_claims(&claims);
    }

    /// Its announcement.
    pub fn hello(&self) -> Status {
        self.status(None, Vec::new())
    }

    /// Steps tick `tick` (sense, think, act) and reports.
    pub fn step(&mut self, tick: u32) -> Status {
        if self.ended.is_none() {
            match self.source.sense(tick) {
                None => self.ended = Some(End::Source),
                Some(frame) => {
                    let Ok(answer) = self.brain.think(&frame);
                    self.after_think(&answer);
                    if let Some(end) = answer.end {
                        self.ended = Some(end);
                        self.source.act(&Answer { acts: vec![crate::run::Act::Stop], ..Answer::default() });
                    } else if !self.source.act(&answer) {
                        self.ended = Some(End::Source);
                    }
                }
            }
        } else {
            // Idle: it stands where it is while the others go on.
            self.source.act(&Answer { acts: vec![crate::run::Act::Stop], ..Answer::default() });
        }
        let seen = self.newly_seen();
        let lidar = self.lidar_changes();
        let mut s = self.status(Some(tick), seen);
        s.lidar = lidar;
        s
    }

    fn after_think(&mut self, answer: &Answer) {
        let Some(out) = self.brain.outputs() else { return };
        if out.goal.is_none() {
            self.goal_epoch = None;
        } else if out.new_goal && answer.end.is_none() {
            self.goal_epoch = Some(self.epoch);
        }
    }

    /// Cells the camera has seen that were not reported yet, within the camera's reach of the
    /// robot.
    fn newly_seen(&mut self) -> Vec<u32> {
        let ctrl = &self.brain.ctrl;
        let Some(pose) = ctrl.pose() else { return Vec::new() };
        let geom = ctrl.lidar.geom;
        let (cx, cy) = geom.cell_of(pose.x, pose.y);
        let r = firmware::grid::GridGeometry::cells(ctrl.config().camera_range_m) + 2;
        let side = firmware::capacity::GRID_CELLS as i32;
        let mut out = Vec::new();
        for y in (cy - r).max(0)..=(cy + r).min(side - 1) {
            for x in (cx - r).max(0)..=(cx + r).min(side - 1) {
                let i = (y * side + x) as usize;
                if ctrl.visual.seen(x, y) && self.reported[i / 64] >> (i % 64) & 1 == 0 {
                    self.reported[i / 64] |= 1 << (i % 64);
                    out.push(super::flag_cell(i, ctrl.visual.get(x, y) == firmware::grid::Cell::Occupied));
                }
            }
        }
        out.sort_unstable();
        out
    }

    /// Without a known map: the LiDAR grid's cells that differ from what the team knows from
    /// this robot (a cell that became unknown again is not reported).
    fn lidar_changes(&mut self) -> Vec<u32> {
        let Some(known) = self.lidar_known.as_mut() else { return Vec::new() };
        let side = firmware::capacity::GRID_CELLS as i32;
        let lidar = &self.brain.ctrl.lidar;
        let mut out = Vec::new();
        for y in 0..side {
            for x in 0..side {
                let i = (y * side + x) as usize;
                let c = cell_code(lidar.get(x, y));
                if c != 0 && c != known[i] {
                    known[i] = c;
                    out.push(super::flag_cell(i, c == 2));
                }
            }
        }
        out.sort_unstable();
        out
    }

    fn status(&self, tick: Option<u32>, seen: Vec<u32>) -> Status {
        let ctrl = &self.brain.ctrl;
        let pose = ctrl.pose().map_or(self.source.start, |p| [p.x.to_num::<f64>(), p.y.to_num::<f64>(), p.theta.to_radians()]);
        let route = &ctrl.planner.route;
        Status {
            robot: self.id,
            instance: self.instance,
            tick,
            pose,
            found: self.ended == Some(End::Found),
            idle: self.ended.is_some(),
            epoch: self.epoch,
            goal_epoch: self.goal_epoch,
            done: (0..self.route_len.min(route.waypoints().len())).filter(|&i| route.is_done(i)).map(|i| i as u16).collect(),
            goal: self.brain.outputs().and_then(|o| o.goal.as_ref()).map(|g| [g.pose.x.to_num::<f64>(), g.pose.y.to_num::<f64>()]),
            seen,
            lidar: Vec::new(),
            path_m: crate::run::round3(self.source.sim.path_length_m()),
        }
    }

    /// The controller (read only).
    pub fn controller(&self) -> &Controller {
        &self.brain.ctrl
    }
}

fn cell_code(c: firmware::grid::Cell) -> u8 {
    match c {
        firmware::grid::Cell::Unknown => 0,
        firmware::grid::Cell::Free => 1,
        firmware::grid::Cell::Occupied => 2,
    }
}
