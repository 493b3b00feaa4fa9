//! A team of robots sharing one search (issue 32, item 5; `../docs/team.md`).
//!
//! Each robot keeps its own controller core and its own simulator of the same building (same
//! seed: the same targets); a coordinator ([`coordinator`]) assigns the coverage route's
//! waypoints among them by path cost (known-map mode), merges what their cameras have seen,
//! re-assigns a robot's waypoints when it stops answering, and stops everyone when one finds the
//! target. Without a map every robot runs its own planner and the coordinator only merges,
//! times and stops.
//!
//! **Lockstep.** Simulated time is the coordinator's: it sends [`TickMsg`] `k` with the epoch
//! of every robot's newest assignment; a robot steps tick `k` only once it holds that epoch's
//! assignment (so no goal is ever taken from a stale one), then answers with its [`Status`] of
//! tick `k`. A robot that does not answer within the transport's timeout is lost from that tick
//! on. The outcome therefore does not depend on how fast the processes run, and the same team
//! in one process ([`local`]) and as separate processes over DDS (`dds`, feature `ros2`) gives
//! the same result.
//!
//! **Messages** are ROS 2 messages of our own package, `lives_team/msg/…`, in CDR over the same
//! DDS as `lives ros2` ([`codec`]): what crosses the wire is what is counted as bandwidth.

pub mod codec;
pub mod coordinator;
#[cfg(feature = "ros2")]
pub mod dds;
pub mod eval;
pub mod local;
pub mod member;
#[cfg(feature = "ros2")]
pub mod realtime;
pub mod robot;

use crate::search::SearchSpec;
use serde::Serialize;

/// Most robots in a team.
pub const MAX_ROBOTS: usize = 8;

/// Spacing of the robots' starts, metres: robot 0 at the scenario's start, the others on a
/// 0.5 m lattice around it, nearest by path first, at least this far from each other.
pub const START_SPACING_M: f64 = 1.0;
/// Farthest a teammate starts from robot 0, by path, metres.
pub const START_REACH_M: f64 = 4.0;

/// The coordinator's order for tick `tick`.
#[derive(Clone, Debug, PartialEq)]
pub struct TickMsg {
    /// The tick to step.
    pub tick: u32,
    /// Everyone stops (a robot found the target, or the search is over); no step.
    pub stop: bool,
    /// The epoch of each robot's newest assignment (0: none).
    pub epochs: Vec<u32>,
    /// The cells the robots' cameras saw for the first time at the last tick, merged (as
    /// [`Status::seen`]): every robot marks them seen before it steps.
    pub seen: Vec<u32>,
    /// Each robot's goal after the last tick `[x, y]` (`None`: none, or lost): a robot leaves a
    /// teammate's goal to it when the teammate is nearer to it
    /// (`firmware::Controller::set_team_claims`, [`robot::TeamRobot::give_way`]).
    pub goals: Vec<Option<[f64; 2]>>,
    /// Each robot's position after the last tick (`None`: lost).
    pub positions: Vec<Option<[f64; 2]>>,
    /// The cells the robots' LiDARs observed anew (or saw change) at the last tick, without a
    /// known map (as [`Status::lidar`]): every robot takes them as a prior before it steps.
    pub lidar: Vec<u32>,
}

/// In a seen cell's index, the bit that says the camera saw a surface (an occupied cell).
pub const SEEN_OCCUPIED: u32 = 1 << 31;

/// Grid cell `i` (`y · side + x`) as the messages carry it, with [`SEEN_OCCUPIED`] if `occupied`.
pub fn flag_cell(i: usize, occupied: bool) -> u32 {
    i as u32 | if occupied { SEEN_OCCUPIED } else { 0 }
}

/// The grid cell `(x, y)` and the occupied flag of a cell as the messages carry it (`None`: off
/// the grid).
pub fn unflag_cell(c: u32) -> Option<(i32, i32, bool)> {
    let side = firmware::capacity::GRID_CELLS as u32;
    let i = c & !SEEN_OCCUPIED;
    (i < side * side).then(|| ((i % side) as i32, (i / side) as i32, c & SEEN_OCCUPIED != 0))
}

/// A robot's share of the route.
#[derive(Clone, Debug, PartialEq)]
pub struct Assignment {
    /// The robot.
    pub robot: u32,
    /// Increases with every assignment to this robot.
    pub epoch: u32,
    /// Waypoints `[x, y, heading]`, world frame (metres, radians).
    pub waypoints: Vec<[f64; 3]>,
}

/// What a robot reports after a tick (or, with `tick` = `None`, when it joins).
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    /// The robot.
    pub robot: u32,
    /// The reporting process (its id): two processes announcing one robot is an error.
    pub instance: u32,
    /// The tick stepped; `None`: announcing itself.
    pub tick: Option<u32>,
    /// The controller's pose `[x, y, yaw]`.
    pub pose: [f64; 3],
    /// The camera confirmed the target.
    pub found: bool,
    /// Its run ended (a robot with teammates does not end when its planner has nothing left:
    /// it waits for a share of what the others have left).
    pub idle: bool,
    /// The epoch of the assignment it follows.
    pub epoch: u32,
    /// The epoch of the assignment its current goal came from (`None`: no goal).
    pub goal_epoch: Option<u32>,
    /// Indices of its assignment's waypoints done (reached or skipped).
    pub done: Vec<u16>,
    /// Grid cells (`y · side + x`, with [`SEEN_OCCUPIED`] for a surface) its camera saw for the
    /// first time this tick, sorted.
    pub seen: Vec<u32>,
    /// Its goal's position `[x, y]` after the tick.
    pub goal: Option<[f64; 2]>,
    /// Without a known map: grid cells (with [`SEEN_OCCUPIED`] for occupied) its LiDAR grid
    /// holds anew or changed (free ↔ occupied) this tick, not counting what it took from the
    /// team, sorted.
    pub lidar: Vec<u32>,
    /// Distance walked, metres.
    pub path_m: f64,
}

/// A team search.
#[derive(Clone, Debug)]
pub struct TeamSpec {
    /// Robot 0's search (world, scenario, seed, planner, map); the others are copies started
    /// elsewhere ([`starts`]).
    pub base: SearchSpec,
    /// Robots, 1 ..= [`MAX_ROBOTS`].
    pub robots: usize,
    /// Robot `.0`'s link is cut (its process killed) at simulated time `.1` seconds.
    pub kill: Option<(usize, f64)>,
    /// Changes to one robot's simulated robot (`--sim-for I:NAME=VALUE`, applied after the
    /// base's `--sim`): a team of different robots (a faster base, a shorter camera). The
    /// controller's model of that robot follows, as with `--sim`.
    pub sim_for: Vec<(usize, String)>,
}

impl TeamSpec {
    /// A team of `robots` copies of `base`, no link cut.
    pub fn new(base: SearchSpec, robots: usize) -> Self {
        TeamSpec { base, robots, kill: None, sim_for: Vec::new() }
    }

    /// Robot `i`'s search, started at `start`: the base's, with its own `sim_for` changes.
    pub fn member(&self, i: usize, start: [f64; 3]) -> Result<SearchSpec, String> {
        let mut s = robot_spec(&self.base, start);
        for (_, a) in self.sim_for.iter().filter(|(r, _)| *r == i) {
            crate::overrides::apply_sim(&mut s.sim, &mut s.controller, a).map_err(|e| format!("robot {i}: {e}"))?;
        }
        Ok(s)
    }

    /// Checks the team: its size, the robot whose link is cut, the robots `--sim-for` names
    /// and their settings.
    pub fn check(&self) -> Result<(), String> {
        if self.robots == 0 || self.robots > MAX_ROBOTS {
            return Err(format!("--robots {}: 1 to {}", self.robots, MAX_ROBOTS));
        }
        if let Some((r, t)) = self.kill {
            if r >= self.robots || !t.is_finite() || t < 0.0 {
                return Err(format!("--kill {r}@{t}: a robot 0..{} and a time ≥ 0 s", self.robots - 1));
            }
        }
        if let Some((r, a)) = self.sim_for.iter().find(|(r, _)| *r >= self.robots) {
            return Err(format!("--sim-for {r}:{a}: a robot 0..{}", self.robots - 1));
        }
        self.speeds().map(|_| ())
    }

    /// Every robot's top speed, m/s.
    pub fn speeds(&self) -> Result<Vec<f64>, String> {
        (0..self.robots).map(|i| self.member(i, [0.0; 3]).map(|s| s.sim.speed_mps)).collect()
    }
}

/// One robot's part of a team search.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RobotReport {
    pub robot: usize,
    /// Where it started `[x, y, yaw]`.
    pub start: [f64; 3],
    /// Its top speed, m/s.
    pub speed_mps: f64,
    pub path_m: f64,
    /// Route waypoints assigned to it (over every epoch) and done.
    pub waypoints_assigned: usize,
    pub waypoints_done: usize,
    /// It stopped answering (its link was cut) at this time, seconds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lost_s: Option<f64>,
    /// In real time: it answered again after it was lost (`lost_s` is the first loss), at this
    /// time, seconds (the last return), and was taken in again (what was left shared out anew).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rejoined_s: Option<f64>,
    /// Payload bytes it sent (statuses) and received (ticks, assignments), CDR as on the wire.
    pub bytes_up: u64,
    pub bytes_down: u64,
    /// Mean of those, bytes per simulated second.
    pub up_bps: f64,
    pub down_bps: f64,
}

/// What a team search did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TeamResult {
    pub world: String,
    pub scenario: String,
    pub planner: String,
    pub seed: u64,
    pub robots: usize,
    /// `known-map` or `no-map`.
    pub map: String,
    /// `in-process` or `dds`.
    pub transport: String,
    pub found: bool,
    /// When the target was found (the time limit if not), seconds.
    pub time_s: f64,
    pub time_limit_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub found_by: Option<usize>,
    /// `found`, `time-limit`, `exhausted` (every robot idle).
    pub outcome: String,
    pub ticks: u32,
    /// Assignments sent after the first (re-assignments on a lost robot).
    pub reassignments: u32,
    /// Times what was left was shared out again because a robot had done its whole share.
    pub reshares: u32,
    /// Ticks at which a robot's goal came from an assignment older than its newest: must be 0.
    pub stale_goals: u32,
    /// Free cells of the known map no camera has seen, at the start and at the end (known-map).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub entropy_bits: Option<[u32; 2]>,
    /// Cells the cameras saw, merged (known-map or not).
    pub seen_cells: usize,
    pub per_robot: Vec<RobotReport>,
}

/// The robots' starts: robot 0 where `spec`'s simulator starts (the scenario's start with its
/// seeded jitter), each other on the 0.5 m lattice around it: clear of everything by the robot's
/// radius plus 0.15 m, at least [`START_SPACING_M`] from every earlier start and 1 m from every
/// target, within [`START_REACH_M`] of path, nearest by path first (ties by x, then y), facing
/// as robot 0. Fails if the building has no room for `n`.
pub fn starts(spec: &SearchSpec, n: usize) -> Result<Vec<[f64; 3]>, String> {
    let sim = crate::sim::Sim::new(spec.world.clone(), spec.sim.clone(), spec.seed);
    let s0 = sim.pose();
    let r = spec.sim.robot_radius_m;
    let reach = crate::sim::reach::ReachMap::new(&spec.world, [s0[0], s0[1]], r);
    let targets = sim.target_positions();
    let steps = (START_REACH_M / 0.5).ceil() as i64;
    let mut cands: Vec<(f64, [f64; 2])> = Vec::new();
    for iy in -steps..=steps {
        for ix in -steps..=steps {
            let p = [((s0[0] / 0.5).round() + ix as f64) * 0.5, ((s0[1] / 0.5).round() + iy as f64) * 0.5];
            let Some(d) = reach.path_m(p) else { continue };
            if d <= START_REACH_M
                && spec.world.disc_is_clear(p, r + 0.15)
                && targets.iter().all(|t| (t[0] - p[0]).hypot(t[1] - p[1]) >= 1.0)
            {
                cands.push((d, p));
            }
        }
    }
    cands.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1[0].total_cmp(&b.1[0])).then(a.1[1].total_cmp(&b.1[1])));
    let mut out = vec![s0];
    for (_, p) in cands {
        if out.len() == n {
            break;
        }
        if out.iter().all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) >= START_SPACING_M) {
            out.push([p[0], p[1], s0[2]]);
        }
    }
    if out.len() < n {
        return Err(format!("{}: room for {} robots near the start, not {n}", spec.world_name, out.len()));
    }
    Ok(out)
}

/// Robot `i`'s search: `spec` with the world's start moved to `start` (no jitter).
pub fn robot_spec(spec: &SearchSpec, start: [f64; 3]) -> SearchSpec {
    let mut s = spec.clone();
    s.world.start = crate::sim::Start { pose: start, jitter_m: 0.0, jitter_yaw_rad: 0.0 };
    s
}

impl TeamResult {
    /// The human-readable summary: the outcome, then a line per robot.
    pub fn summary(&self) -> String {
        let r = self;
        let mut s = format!(
            "{} {} {} {} seed {} · {} robots ({}, {}): {}",
            if r.found { "FOUND" } else { "NOT FOUND" },
            r.world,
            r.scenario,
            r.planner,
            r.seed,
            r.robots,
            r.map,
            r.transport,
            if r.found {
                format!("by robot {} in {:.1} s", r.found_by.unwrap_or(0), r.time_s)
            } else {
                format!("{} ({:.0} s)", r.outcome, r.time_s)
            },
        );
        s += &format!(", {} re-assignments, {} re-shares, {} stale goals", r.reassignments, r.reshares, r.stale_goals);
        for p in &r.per_robot {
            s += &format!(
                "\n  robot {}: start ({:.1}, {:.1}), {:.2} m/s, path {:.1} m, waypoints {}/{}{}, {:.0} B/s up, {:.0} B/s down",
                p.robot,
                p.start[0],
                p.start[1],
                p.speed_mps,
                p.path_m,
                p.waypoints_done,
                p.waypoints_assigned,
                p.lost_s.map_or(String::new(), |t| format!(", link lost at {t:.1} s"))
                    + &p.rejoined_s.map_or(String::new(), |t| format!(", back at {t:.1} s")),
                p.up_bps,
                p.down_bps
            );
        }
        s
    }
}
