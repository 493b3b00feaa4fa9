//! A robot's side of a team, whatever its body: the state a team member keeps about its
//! controller (which assignment it follows, which seen cells it has reported, what the team
//! knows of its LiDAR grid) and what it does with the coordinator's messages. A simulated robot
//! ([`super::robot::TeamRobot`]) and a real one on its ROS 2 graph (`lives ros2 --team-robot`,
//! [`super::realtime`]) share it.

use super::{Assignment, Status};
use firmware::{Controller, Outputs};

/// One robot's team state.
pub struct TeamMember {
    /// Its index in the team.
    pub id: u32,
    /// The reporting process.
    pub instance: u32,
    /// The epoch of the assignment it follows (0: none yet).
    pub epoch: u32,
    goal_epoch: Option<u32>,
    /// Holding still without a goal ([`TeamMember::drop_goal`]) until the controller answers again.
    holding: bool,
    /// The waypoints of the assignment it follows.
    route_len: usize,
    /// Cells already reported seen.
    reported: Vec<u64>,
    /// Without a known map: the LiDAR grid as the team knows it from this robot (0 unknown, 1
    /// free, 2 occupied), to report what changed.
    lidar_known: Option<Vec<u8>>,
}

impl TeamMember {
    /// Robot `id`, reporting as process `instance`; `known_map`: the team searches a known map
    /// (no LiDAR cells are exchanged).
    pub fn new(id: u32, instance: u32, known_map: bool) -> Self {
        let n = firmware::capacity::GRID_CELLS * firmware::capacity::GRID_CELLS;
        TeamMember {
            id,
            instance,
            epoch: 0,
            goal_epoch: None,
            holding: false,
            route_len: 0,
            reported: vec![0; n.div_ceil(64)],
            lidar_known: (!known_map).then(|| vec![0; n]),
        }
    }

    /// Takes an assignment newer than the one it follows (an older or repeated one is ignored):
    /// the controller's route becomes it, and the goal taken from the old one is dropped.
    pub fn assign(&mut self, ctrl: &mut Controller, a: &Assignment) {
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
        self.route_len = crate::live::give_route(ctrl, &route);
        self.epoch = a.epoch;
        self.goal_epoch = None;
    }

    /// Marks the cells the team's cameras saw ([`super::TickMsg::seen`]) seen by this robot's
    /// controller too, and gives it what the team's LiDARs observed
    /// ([`super::TickMsg::lidar`]; a cell its own LiDAR has observed keeps its own evidence).
    pub fn merge(&mut self, ctrl: &mut Controller, seen: &[u32], lidar: &[u32]) {
        let side = firmware::capacity::GRID_CELLS;
        if let Some(known) = self.lidar_known.as_mut() {
            for (x, y, occupied) in lidar.iter().filter_map(|&c| super::unflag_cell(c)) {
                ctrl.merge_lidar(x, y, occupied);
                known[y as usize * side + x as usize] = cell_code(ctrl.lidar.get(x, y));
            }
        }
        for (x, y, occupied) in seen.iter().filter_map(|&c| super::unflag_cell(c)) {
            ctrl.merge_seen(x, y, occupied);
            let i = y as usize * side + x as usize;
            self.reported[i / 64] |= 1 << (i % 64);
        }
    }

    /// Leaves to each teammate the goal it is nearer to than this robot is (as the crow flies;
    /// a tie to the lower index), so two robots never pursue one goal and the nearer one keeps
    /// it (`positions` and `goals` by robot, this robot's own ignored).
    pub fn give_way(&self, ctrl: &mut Controller, goals: &[Option<[f64; 2]>], positions: &[Option<[f64; 2]>]) {
        let me = ctrl.pose().map(|p| [p.x.to_num::<f64>(), p.y.to_num::<f64>()]);
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
        ctrl.set_team_claims(&claims);
    }

    /// After the controller answered a tick (`out`: its outputs; `ended`: the run ends with
    /// this answer): a new goal comes from the assignment it follows.
    pub fn answered(&mut self, out: Option<&Outputs>, ended: bool) {
        self.holding = false;
        let Some(out) = out else { return };
        if out.goal.is_none() {
            self.goal_epoch = None;
        } else if out.new_goal && !ended {
            self.goal_epoch = Some(self.epoch);
        }
    }

    /// Its goal was dropped without the controller's say (the base holds still for an
    /// assignment on its way): reported as no goal until the controller answers again.
    pub fn drop_goal(&mut self) {
        self.goal_epoch = None;
        self.holding = true;
    }

    /// The status after tick `tick` (`None`: announcing itself), with the cells its camera saw
    /// for the first time and, without a map, the LiDAR cells that changed. `out`: the
    /// controller's last outputs (its goal); `fallback` is the pose to report before the
    /// controller has one; `found`, `idle` and `path_m` are the body's.
    #[allow(clippy::too_many_arguments)]
    pub fn report(
        &mut self,
        ctrl: &Controller,
        out: Option<&Outputs>,
        tick: Option<u32>,
        fallback: [f64; 3],
        found: bool,
        idle: bool,
        path_m: f64,
    ) -> Status {
        let (seen, lidar) = if tick.is_some() { (self.newly_seen(ctrl), self.lidar_changes(ctrl)) } else { (Vec::new(), Vec::new()) };
        let pose = ctrl.pose().map_or(fallback, |p| [p.x.to_num::<f64>(), p.y.to_num::<f64>(), p.theta.to_radians()]);
        let route = &ctrl.planner.route;
        Status {
            robot: self.id,
            instance: self.instance,
            tick,
            pose,
            found,
            idle,
            epoch: self.epoch,
            goal_epoch: self.goal_epoch,
            done: (0..self.route_len.min(route.waypoints().len())).filter(|&i| route.is_done(i)).map(|i| i as u16).collect(),
            goal: out.filter(|_| !self.holding).and_then(|o| o.goal.as_ref()).map(|g| [g.pose.x.to_num::<f64>(), g.pose.y.to_num::<f64>()]),
            seen,
            lidar,
            path_m: crate::run::round3(path_m),
        }
    }

    /// Cells the camera has seen that were not reported yet, within the camera's reach of the
    /// robot.
    fn newly_seen(&mut self, ctrl: &Controller) -> Vec<u32> {
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
    fn lidar_changes(&mut self, ctrl: &Controller) -> Vec<u32> {
        let Some(known) = self.lidar_known.as_mut() else { return Vec::new() };
        let side = firmware::capacity::GRID_CELLS as i32;
        let lidar = &ctrl.lidar;
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
}

fn cell_code(c: firmware::grid::Cell) -> u8 {
    match c {
        firmware::grid::Cell::Unknown => 0,
        firmware::grid::Cell::Free => 1,
        firmware::grid::Cell::Occupied => 2,
    }
}
