//! The team's coordinator: LIVE's central server for several robots. It plans the coverage
//! route's waypoints among the robots by path cost ([`crate::live::coverage::Coverage::plan_team`]),
//! merges what their cameras have seen, notes which waypoints they have done, re-plans what is
//! left among the robots still answering when one stops answering or has done its whole share,
//! and stops everyone when one finds the target. It never reads a clock: a robot is lost when the transport says its status for a
//! tick did not come.

use super::{Assignment, RobotReport, Status, TeamResult, TickMsg};
use crate::io::map_file::Cell3;
use crate::live::coverage::{Coverage, KnownGrid, Waypoint};
use std::sync::Arc;

/// What the coordinator decided after a tick.
#[derive(Clone, Debug, Default)]
pub struct Decision {
    /// New assignments to send before the next tick.
    pub assignments: Vec<Assignment>,
    /// The search is over: stop everyone.
    pub stop: bool,
}

/// The coordinator.
pub struct Coordinator {
    cfg: firmware::Config,
    cells: Option<Arc<Vec<Cell3>>>,
    tick_s: f64,
    limit_s: f64,
    /// Each robot's top speed, m/s (one per robot: the team's size): routes are shared out by
    /// time, not length.
    speeds: Vec<f64>,
    routes: Vec<Vec<Waypoint>>,
    epochs: Vec<u32>,
    alive: Vec<bool>,
    last: Vec<Option<Status>>,
    /// Waypoints any robot has done (over every epoch): what they cover needs no one else.
    done: Vec<Waypoint>,
    done_now: Vec<Vec<bool>>,
    seen: Vec<bool>,
    /// Cells seen at the last tick, for every robot.
    relay: Vec<u32>,
    /// LiDAR cells observed at the last tick, for every robot (no map).
    relay_lidar: Vec<u32>,
    found_by: Option<usize>,
    last_tick: u32,
    reports: Vec<RobotReport>,
    reassignments: u32,
    reshares: u32,
    stale_goals: u32,
    entropy_start: Option<u32>,
    /// Real time ([`Coordinator::realtime`]): for each robot, the rounds at which its epochs were
    /// first named, `(round, epoch)` in order.
    named: Option<Vec<Vec<(u32, u32)>>>,
    /// The round whose order names the next assignments.
    next_round: u32,
}

impl Coordinator {
    /// A coordinator for robots of top speeds `speeds` (m/s, one per robot) and controller
    /// configuration `cfg` (robot 0's; the planner decides whether there is a route to share:
    /// `live`, `visual-cpp` and `lidar-cpp` with a known map), ticking every `tick_s` until
    /// `limit_s`.
    pub fn new(cfg: firmware::Config, cells: Option<Arc<Vec<Cell3>>>, speeds: Vec<f64>, tick_s: f64, limit_s: f64) -> Self {
        let side = firmware::capacity::GRID_CELLS;
        let n = speeds.len();
        let reports =
            speeds.iter().enumerate().map(|(robot, &speed_mps)| RobotReport { robot, speed_mps, ..RobotReport::default() }).collect();
        Coordinator {
            cfg,
            cells,
            tick_s,
            limit_s,
            speeds,
            routes: vec![Vec::new(); n],
            epochs: vec![0; n],
            alive: vec![true; n],
            last: vec![None; n],
            done: Vec::new(),
            done_now: vec![Vec::new(); n],
            seen: vec![false; side * side],
            relay: Vec::new(),
            relay_lidar: Vec::new(),
            found_by: None,
            last_tick: 0,
            reports,
            reassignments: 0,
            reshares: 0,
            stale_goals: 0,
            entropy_start: None,
            named: None,
            next_round: 0,
        }
    }

    /// The coordinator of a team in real time ([`super::realtime`]): statuses come when they
    /// come, and a robot reports with `tick` the newest order it had taken. A status that lags
    /// behind an assignment the robot has not heard of yet is not stale; a goal from an
    /// assignment older than the one the robot had heard named is ([`Coordinator::note_stale`]).
    pub fn realtime(self) -> Self {
        let n = self.n();
        Coordinator { named: Some(vec![Vec::new(); n]), ..self }
    }

    /// Real time: counts `s` (robot `i`'s) if its goal comes from an assignment older than the
    /// one named in the order it had taken (`s.tick`).
    pub fn note_stale(&mut self, i: usize, s: &Status) {
        let (Some(named), Some(round), Some(goal)) = (&self.named, s.tick, s.goal_epoch) else { return };
        let current = named.get(i).and_then(|h| h.iter().rev().find(|(r, _)| *r <= round)).map_or(0, |&(_, e)| e);
        if goal < current {
            self.stale_goals += 1;
        }
    }

    /// The team's size.
    fn n(&self) -> usize {
        self.speeds.len()
    }

    /// Takes the robots' announcements (one per robot, in order) and plans the first
    /// assignments from where they stand.
    pub fn start(&mut self, hellos: &[Status]) -> Result<Vec<Assignment>, String> {
        if hellos.len() != self.n() {
            return Err(format!("{} robots announced, {} expected", hellos.len(), self.n()));
        }
        for (i, h) in hellos.iter().enumerate() {
            if h.robot as usize != i {
                return Err(format!("robot {} announced in place of robot {i}", h.robot));
            }
            self.reports[i].start = h.pose;
            self.last[i] = Some(h.clone());
        }
        self.entropy_start = self.entropy();
        self.plan(&(0..self.n()).collect::<Vec<_>>())
    }

    /// Plans what is left among `robots` from their last poses: their new assignments.
    fn plan(&mut self, robots: &[usize]) -> Result<Vec<Assignment>, String> {
        let Some(cells) = &self.cells else { return Ok(Vec::new()) };
        let Some(fp) = crate::live::footprint(self.cfg.planner, &self.cfg) else { return Ok(Vec::new()) };
        if robots.is_empty() {
            return Ok(Vec::new());
        }
        let map = KnownGrid {
            cells,
            side: firmware::capacity::GRID_CELLS,
            origin: [self.cfg.origin_x_m.to_num::<f64>(), self.cfg.origin_y_m.to_num::<f64>()],
        };
        let starts: Vec<[f64; 2]> = robots.iter().map(|&r| self.last[r].as_ref().map_or([0.0; 2], |s| [s.pose[0], s.pose[1]])).collect();
        let problem =
            Coverage::new(&map, crate::live::coverage::Clearance::of(&self.cfg), starts[0], fp).map_err(|e| format!("coverage: {e}"))?;
        let mut covered = problem.nothing_covered();
        for w in &self.done {
            problem.cover(&mut covered, w);
        }
        let speeds: Vec<f64> = robots.iter().map(|&r| self.speeds[r]).collect();
        let routes = problem.plan_team(&starts, &speeds, &covered).map_err(|e| format!("coverage: {e}"))?;
        let mut out = Vec::new();
        for (&r, route) in robots.iter().zip(routes) {
            let wps: Vec<Waypoint> = route.waypoints.into_iter().take(firmware::capacity::MAX_ROUTE_WAYPOINTS).collect();
            self.epochs[r] += 1;
            if let Some(h) = self.named.as_mut().and_then(|n| n.get_mut(r)) {
                h.push((self.next_round, self.epochs[r]));
            }
            self.reports[r].waypoints_assigned += wps.len();
            self.done_now[r] = vec![false; wps.len()];
            out.push(Assignment { robot: r as u32, epoch: self.epochs[r], waypoints: wps.iter().map(|w| [w.x, w.y, w.heading]).collect() });
            self.routes[r] = wps;
        }
        Ok(out)
    }

    /// The order for tick `tick`.
    pub fn tick_msg(&self, tick: u32, stop: bool) -> TickMsg {
        TickMsg {
            tick,
            stop,
            epochs: self.epochs.clone(),
            goals: (0..self.n()).map(|i| if self.alive[i] { self.last[i].as_ref().and_then(|s| s.goal) } else { None }).collect(),
            positions: (0..self.n())
                .map(|i| if self.alive[i] { self.last[i].as_ref().map(|s| [s.pose[0], s.pose[1]]) } else { None })
                .collect(),
            seen: self.relay.clone(),
            lidar: self.relay_lidar.clone(),
        }
    }

    /// Robot `r`'s last status taken (its announcement before the first).
    pub fn last_status(&self, r: usize) -> Option<&Status> {
        self.last.get(r)?.as_ref()
    }

    /// Whether robot `r` still answers.
    pub fn alive(&self, r: usize) -> bool {
        self.alive[r]
    }

    /// Takes the statuses of tick `tick` (`None`: robot `i` did not answer, or was already
    /// lost) and decides.
    pub fn after_tick(&mut self, tick: u32, statuses: &[Option<Status>]) -> Result<Decision, String> {
        self.last_tick = tick;
        self.next_round = tick + 1;
        self.relay.clear();
        self.relay_lidar.clear();
        let mut lost_now = Vec::new();
        for (i, s) in statuses.iter().enumerate().take(self.n()) {
            let Some(s) = s else {
                if self.alive[i] {
                    self.alive[i] = false;
                    // The first loss (in real time a robot may come back and be lost again).
                    self.reports[i].lost_s.get_or_insert(crate::run::round3(tick as f64 * self.tick_s));
                    lost_now.push(i);
                }
                continue;
            };
            if !self.alive[i] {
                continue;
            }
            if self.named.is_none() && (s.goal_epoch.is_some_and(|e| e != self.epochs[i]) || s.epoch != self.epochs[i]) {
                self.stale_goals += 1;
            }
            // Waypoints done are indices into the assignment the status follows: one the robot
            // has not taken yet (real time) says nothing about the newest.
            let done: &[u16] = if s.epoch == self.epochs[i] { &s.done } else { &[] };
            for &d in done {
                let d = d as usize;
                if d < self.routes[i].len() && !self.done_now[i][d] {
                    self.done_now[i][d] = true;
                    self.done.push(self.routes[i][d]);
                    self.reports[i].waypoints_done += 1;
                }
            }
            for &c in &s.seen {
                if let Some(b) = self.seen.get_mut((c & !super::SEEN_OCCUPIED) as usize) {
                    if !*b {
                        *b = true;
                        self.relay.push(c);
                    }
                }
            }
            self.relay_lidar.extend_from_slice(&s.lidar);
            self.reports[i].path_m = s.path_m;
            if s.found && self.found_by.is_none() {
                self.found_by = Some(i);
            }
            self.last[i] = Some(s.clone());
        }
        self.relay.sort_unstable();
        // One report a cell: the last robot's (in robot order) wins.
        self.relay_lidar.reverse();
        self.relay_lidar.sort_by_key(|c| c & !super::SEEN_OCCUPIED);
        self.relay_lidar.dedup_by_key(|c| *c & !super::SEEN_OCCUPIED);
        let survivors: Vec<usize> = (0..self.n()).filter(|&i| self.alive[i]).collect();
        let mut decision = Decision::default();
        // A robot that has done every waypoint of its share (a non-empty one: an empty share
        // means nothing was left to give it) takes part of what the others have left.
        let finished = survivors
            .iter()
            .any(|&i| !self.routes[i].is_empty() && self.done_now[i].iter().all(|&d| d) && self.last[i].as_ref().is_some_and(|s| !s.idle));
        if !lost_now.is_empty() && !survivors.is_empty() {
            decision.assignments = self.plan(&survivors)?;
            self.reassignments += decision.assignments.len() as u32;
        } else if finished {
            decision.assignments = self.plan(&survivors)?;
            self.reshares += 1;
        }
        let all_idle = survivors.iter().all(|&i| self.last[i].as_ref().is_some_and(|s| s.idle));
        decision.stop = self.found_by.is_some() || all_idle;
        Ok(decision)
    }

    /// Real time: robot `i`, lost, answers again with `s` in round `round` (before
    /// [`Coordinator::after_tick`] takes that round's statuses, `s` among them): it is taken in
    /// again where it stands, and what is left is shared out anew among every robot answering
    /// (their new assignments, named from the next round). Nothing for a robot not lost.
    pub fn rejoin(&mut self, i: usize, round: u32, s: Status) -> Result<Vec<Assignment>, String> {
        if i >= self.n() || self.alive[i] {
            return Ok(Vec::new());
        }
        self.alive[i] = true;
        self.next_round = round + 1;
        self.reports[i].rejoined_s = Some(crate::run::round3(round as f64 * self.tick_s));
        self.reports[i].path_m = s.path_m;
        self.last[i] = Some(s);
        let answering: Vec<usize> = (0..self.n()).filter(|&r| self.alive[r]).collect();
        let a = self.plan(&answering)?;
        self.reassignments += a.len() as u32;
        Ok(a)
    }

    /// Free cells of the known map no camera has seen (`None` without a map).
    fn entropy(&self) -> Option<u32> {
        let cells = self.cells.as_ref()?;
        Some(cells.iter().zip(&self.seen).filter(|(c, s)| **c == Cell3::Free && !**s).count() as u32)
    }

    /// The result, once the search is over: `bytes[i]` are robot `i`'s payload bytes sent and
    /// received over `transport`.
    pub fn result(&self, spec: &super::TeamSpec, transport: &str, bytes: &[[u64; 2]]) -> TeamResult {
        let base = &spec.base;
        let found = self.found_by.is_some();
        let outcome = if found {
            "found"
        } else if (self.last_tick + 1) as f64 * self.tick_s >= self.limit_s - 1e-9 {
            "time-limit"
        } else {
            "exhausted"
        };
        let mut per_robot = self.reports.clone();
        for (r, b) in per_robot.iter_mut().zip(bytes) {
            (r.bytes_up, r.bytes_down) = (b[0], b[1]);
        }
        let end_s = ((self.last_tick + 1) as f64 * self.tick_s).min(self.limit_s);
        for r in &mut per_robot {
            let s = if r.rejoined_s.is_some() { end_s } else { r.lost_s.unwrap_or(end_s) }.max(self.tick_s);
            r.up_bps = crate::run::round3(r.bytes_up as f64 / s);
            r.down_bps = crate::run::round3(r.bytes_down as f64 / s);
        }
        TeamResult {
            world: base.world_name.clone(),
            scenario: base.scenario_label().to_string(),
            planner: base.planner.to_string(),
            seed: base.seed,
            robots: self.n(),
            map: if self.cells.is_some() { "known-map" } else { "no-map" }.to_string(),
            transport: transport.to_string(),
            found,
            time_s: if found { crate::run::round3(self.last_tick as f64 * self.tick_s) } else { self.limit_s },
            time_limit_s: self.limit_s,
            found_by: self.found_by,
            outcome: outcome.to_string(),
            ticks: self.last_tick + 1,
            reassignments: self.reassignments,
            reshares: self.reshares,
            stale_goals: self.stale_goals,
            entropy_bits: self.entropy_start.zip(self.entropy()).map(|(a, b)| [a, b]),
            seen_cells: self.seen.iter().filter(|b| **b).count(),
            per_robot,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::capacity::GRID_CELLS;

    /// A 30 × 6 m corridor of free cells walled round, at the grid's origin.
    fn corridor() -> Arc<Vec<Cell3>> {
        let mut cells = vec![Cell3::Unknown; GRID_CELLS * GRID_CELLS];
        for y in 0..=60 {
            for x in 0..=300 {
                let wall = x == 0 || y == 0 || x == 300 || y == 60;
                cells[y * GRID_CELLS + x] = if wall { Cell3::Occupied } else { Cell3::Free };
            }
        }
        Arc::new(cells)
    }

    /// `visual-cpp` at the grid's origin: the camera's footprint (the LiDAR's would cover the
    /// corridor from one waypoint).
    fn camera_route_cfg() -> firmware::Config {
        let mut cfg = firmware::Config::DEFAULT.with_planner(firmware::PlannerKind::VisualCoverage);
        cfg.origin_x_m = firmware::Meters::ZERO;
        cfg.origin_y_m = firmware::Meters::ZERO;
        cfg
    }

    fn status(robot: u32, tick: Option<u32>, at: [f64; 2], epoch: u32, done: Vec<u16>) -> Status {
        Status {
            robot,
            instance: 1,
            tick,
            pose: [at[0], at[1], 0.0],
            found: false,
            idle: false,
            epoch,
            goal_epoch: None,
            done,
            seen: Vec::new(),
            goal: None,
            lidar: Vec::new(),
            path_m: 0.0,
        }
    }

    #[test]
    fn a_faster_robot_gets_a_longer_share() {
        let cfg = camera_route_cfg();
        let hellos = [status(0, None, [15.0, 3.0], 0, vec![]), status(1, None, [15.5, 3.0], 0, vec![])];
        let length = |a: &Assignment, from: [f64; 2]| {
            let mut prev = from;
            a.waypoints.iter().fold(0.0, |l, w| {
                let d = (w[0] - prev[0]).hypot(w[1] - prev[1]);
                prev = [w[0], w[1]];
                l + d
            })
        };
        let same = Coordinator::new(cfg, Some(corridor()), vec![0.5, 0.5], 0.2, 100.0).start(&hellos).unwrap();
        let fast = Coordinator::new(cfg, Some(corridor()), vec![0.5, 1.5], 0.2, 100.0).start(&hellos).unwrap();
        let (s0, s1) = (length(&same[0], [15.0, 3.0]), length(&same[1], [15.5, 3.0]));
        let (f0, f1) = (length(&fast[0], [15.0, 3.0]), length(&fast[1], [15.5, 3.0]));
        assert!(f1 > f0 && f1 / f0 > s1 / s0, "equal speeds {s0:.1} / {s1:.1} m, robot 1 three times faster {f0:.1} / {f1:.1} m");
        assert!(fast.iter().all(|a| !a.waypoints.is_empty()), "both robots have a share");
    }

    /// In real time a status may lag behind a new assignment the robot has not heard of: not
    /// stale. A goal from an assignment older than the one named in the round the robot had
    /// taken is; and waypoints reported done against a replaced assignment are not credited.
    #[test]
    fn in_real_time_only_a_goal_older_than_what_the_robot_had_heard_named_is_stale() {
        let cfg = camera_route_cfg();
        let (a, b) = ([2.0, 3.0], [28.0, 3.0]);
        let mut c = Coordinator::new(cfg, Some(corridor()), vec![0.5, 0.5], 0.2, 100.0).realtime();
        let first = c.start(&[status(0, None, a, 0, vec![]), status(1, None, b, 0, vec![])]).unwrap();
        let n0 = first[0].waypoints.len();
        let with_goal = |robot, round, epoch, goal_epoch, done| Status { goal_epoch, ..status(robot, Some(round), a, epoch, done) };
        // Round 0 names epoch 1 for both.
        c.note_stale(0, &with_goal(0, 0, 1, Some(1), vec![]));
        assert_eq!(c.stale_goals, 0);
        // Robot 0 finishes its share in round 3: epoch 2 is planned, named from round 4 on.
        let all0: Vec<u16> = (0..n0 as u16).collect();
        let d = c.after_tick(3, &[Some(with_goal(0, 3, 1, Some(1), all0.clone())), Some(status(1, Some(3), b, 1, vec![]))]).unwrap();
        assert!(d.assignments.iter().all(|x| x.epoch == 2), "{d:?}");
        let done_before = c.reports[0].waypoints_done;
        // Robot 0 still on epoch 1 in round 3 (it has not taken round 4): lagging, not stale;
        // its epoch-1 waypoints are not credited to epoch 2.
        let lag = with_goal(0, 3, 1, Some(1), vec![0]);
        c.note_stale(0, &lag);
        c.after_tick(4, &[Some(lag), Some(status(1, Some(4), b, 2, vec![]))]).unwrap();
        assert_eq!((c.stale_goals, c.reports[0].waypoints_done), (0, done_before));
        // It has taken round 4, which named epoch 2, yet its goal is from epoch 1: stale.
        c.note_stale(0, &with_goal(0, 4, 1, Some(1), vec![]));
        assert_eq!(c.stale_goals, 1);
        // Holding the named epoch with its goal from it, or with no goal: not stale.
        c.note_stale(0, &with_goal(0, 5, 2, Some(2), vec![]));
        c.note_stale(0, &with_goal(0, 5, 1, None, vec![]));
        assert_eq!(c.stale_goals, 1);
    }

    #[test]
    fn a_robot_that_has_done_its_share_takes_part_of_what_is_left() {
        let cfg = camera_route_cfg();
        let (a, b) = ([2.0, 3.0], [28.0, 3.0]);
        let mut c = Coordinator::new(cfg, Some(corridor()), vec![0.5, 0.5], 0.2, 100.0);
        let first = c.start(&[status(0, None, a, 0, vec![]), status(1, None, b, 0, vec![])]).unwrap();
        assert_eq!(first.len(), 2);
        let (n0, n1) = (first[0].waypoints.len(), first[1].waypoints.len());
        assert!(n0 > 0 && n1 > 1, "both robots have a share: {n0}, {n1}");
        // Nothing done yet: no new plan.
        let d = c.after_tick(0, &[Some(status(0, Some(0), a, 1, vec![])), Some(status(1, Some(0), b, 1, vec![]))]).unwrap();
        assert!(d.assignments.is_empty() && !d.stop);
        // Robot 0 has done its whole share, robot 1 none of its: what is left is shared out
        // again, robot 0 gets part of it, and the epochs move on.
        let all0: Vec<u16> = (0..n0 as u16).collect();
        let d = c.after_tick(1, &[Some(status(0, Some(1), a, 1, all0)), Some(status(1, Some(1), b, 1, vec![]))]).unwrap();
        assert_eq!(d.assignments.len(), 2, "{d:?}");
        assert!(d.assignments.iter().all(|x| x.epoch == 2));
        assert!(!d.assignments[0].waypoints.is_empty(), "robot 0 takes part of robot 1's share");
        assert_eq!((c.reshares, c.reassignments), (1, 0));
        // The new shares are not done: no re-plan on the next tick.
        let d = c.after_tick(2, &[Some(status(0, Some(2), a, 2, vec![])), Some(status(1, Some(2), b, 2, vec![]))]).unwrap();
        assert!(d.assignments.is_empty());
        assert_eq!(c.reshares, 1);
    }
}
