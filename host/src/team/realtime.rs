//! A team in real time (feature `ros2`): the coordinator and the robots each keep their own
//! clock, as robots in a building do. No one waits for anyone: every round (a tick's period of
//! wall time, [`RealtimeOptions::period`]) the coordinator takes the statuses that came since
//! the last, decides, and sends an order; every tick a robot takes the orders and assignments
//! that came, thinks, moves and reports. Robots are `lives team --real-time --as-robot I`
//! processes (a simulated robot paced by the wall clock) or real robots on their ROS 2 graphs
//! (`lives ros2 --team-robot I`, [`RobotLink`]).
//!
//! | topic | type | QoS | from → to |
//! |---|---|---|---|
//! | `team/order` | `lives_team/msg/Tick` | reliable, transient local, keep last [`ORDER_DEPTH`] | coordinator → every robot |
//! | `team/robot_I/assignment` | `lives_team/msg/Assignment` | reliable, transient local, keep last 1 | coordinator → robot I |
//! | `team/robot_I/status` | `lives_team/msg/RobotStatus` | reliable, volatile, keep last [`STATUS_DEPTH`] | robot I → coordinator |
//!
//! What changes from lockstep ([`super::dds`]):
//! - An order's `tick` is the coordinator's round; a robot's status carries in `tick` the newest
//!   round it has taken, so the coordinator knows which assignment the robot had heard named.
//! - The seen cells an order relays are the changes of one round: a robot takes every order in
//!   turn (the topic keeps [`ORDER_DEPTH`] of them), and the coordinator merges every status of a
//!   round (the topic keeps [`STATUS_DEPTH`]). A robot that misses orders (a gap in the rounds)
//!   counts them (`orders_missed`); what it misses is only what teammates saw.
//! - **No stale goals**: an order names every robot's newest assignment; a robot that hears its
//!   own named before the assignment itself has arrived drops its goal and holds still until it
//!   has it. The coordinator counts a status whose goal comes from an assignment older than the
//!   one named in the order that robot had taken (`stale_goals`, asserted 0 in the tests).
//! - A robot is lost when no status of it has come for `link_timeout` of wall time; its work is
//!   shared out among the others as in lockstep. A robot stops when told, or when no order has
//!   come for [`super::dds::ORDER_TIMEOUT`].
//! - Time in the result is the coordinator's: rounds × the tick (0.2 s), so with `speedup` the
//!   figures are simulated seconds.

use super::coordinator::Coordinator;
use super::dds::{
    assignment_topic, send, spawn, status_topic, stop_and_reap, take, Bus, DdsOptions, Inbox, JOIN_TIMEOUT, ORDER_TIMEOUT, RESEND,
};
use super::member::TeamMember;
use super::robot::TeamRobot;
use super::{codec, Status, TeamResult, TeamSpec, TickMsg};
use crate::link::ros2::wire::{Qos, Raw, RawCdr};
use crate::run::TICK_US;
use firmware::Controller;
use rustdds::no_key::{DataReader, DataWriter};
use std::time::{Duration, Instant};

/// The orders' topic (real time; lockstep's is `team/tick`).
pub const ORDER_TOPIC: &str = "team/order";
/// Orders the topic keeps for a robot that reads late, and statuses for a coordinator that
/// reads late: at 5 rounds a second, 12.8 s of orders and more than 3 minutes of statuses.
pub const ORDER_DEPTH: i32 = 64;
pub const STATUS_DEPTH: i32 = 1024;

/// How a team runs in real time.
#[derive(Clone, Debug)]
pub struct RealtimeOptions {
    /// The DDS domain, interfaces and the link timeout.
    pub dds: DdsOptions,
    /// Simulated seconds per wall second (1: real time; a simulated team may run faster).
    pub speedup: f64,
    /// Robot `.0`'s process is frozen (SIGSTOP) at the team's time `.1` seconds for `.2` seconds
    /// of wall time, then goes on (SIGCONT): a link that drops and comes back.
    pub pause: Option<(usize, f64, f64)>,
}

impl RealtimeOptions {
    /// The wall time of one tick (0.2 s of simulated time) and of one coordinator round.
    pub fn period(&self) -> Duration {
        Duration::from_secs_f64(TICK_US as f64 / 1e6 / self.speedup)
    }
}

/// The coordinator with simulated robots, each a process of its own (`robot_args(i)`: robot
/// `i`'s arguments to this program): spawns them, coordinates, stops and reaps them.
pub fn run(spec: &TeamSpec, opts: &RealtimeOptions, robot_args: impl Fn(usize) -> Vec<String>) -> Result<TeamResult, String> {
    spec.check()?;
    let mut ends = CoordinatorEnds::open(&opts.dds, spec.robots)?;
    let coord = super::local::coordinator(spec)?.realtime();
    let mut children = spawn(spec.robots, robot_args)?;
    let out = coordinate(spec, coord, opts, &mut ends, &mut children);
    stop_and_reap(&ends.order_w, &mut children);
    out
}

/// The coordinator for robots started elsewhere (real robots running `lives ros2
/// --team-robot I --origin X,Y`): plans on the grid whose lower-left corner is `origin` (the
/// robots' own) and, for a route follower, on `map`; waits for every robot to announce itself,
/// coordinates until the target is found or `spec`'s time limit, and stops them. `spec` gives the
/// planner, the controller's settings and the robots' speeds (`--sim-for I:speed_mps=V`).
pub fn coordinate_external(
    spec: &TeamSpec,
    origin: [f64; 2],
    map: Option<&crate::io::map_file::PriorMap>,
    opts: &RealtimeOptions,
) -> Result<TeamResult, String> {
    spec.check()?;
    if spec.kill.is_some() {
        return Err("--kill cuts the link of a robot this process started: not with robots started elsewhere".into());
    }
    let base = &spec.base;
    let bad = || format!("--origin {},{}: out of the controller's range", origin[0], origin[1]);
    let cfg = firmware::Config {
        origin_x_m: fixed_point::meters_from_f64(origin[0]).ok_or_else(bad)?,
        origin_y_m: fixed_point::meters_from_f64(origin[1]).ok_or_else(bad)?,
        ..crate::run::controller_config(&base.controller, &base.world, base.planner.kind())
    };
    let grid_origin = [cfg.origin_x_m.to_num::<f64>(), cfg.origin_y_m.to_num::<f64>()];
    let cells = map.map(|m| m.to_controller_grid(grid_origin)).transpose().map_err(|e| e.to_string())?.map(std::sync::Arc::new);
    if base.planner.kind().is_coverage() && cells.is_none() {
        return Err(format!("`{}` shares out a coverage route: give the building's map with --map FILE.yaml", base.planner));
    }
    let coord = Coordinator::new(cfg, cells, spec.speeds()?, TICK_US as f64 / 1e6, base.world.time_limit_s).realtime();
    let mut ends = CoordinatorEnds::open(&opts.dds, spec.robots)?;
    let out = coordinate(spec, coord, opts, &mut ends, &mut []);
    stop_and_reap(&ends.order_w, &mut []);
    out
}

/// The coordinator's endpoints.
struct CoordinatorEnds {
    _bus: Bus,
    order_w: DataWriter<Raw, RawCdr>,
    assign_w: Vec<DataWriter<Raw, RawCdr>>,
    status_r: Vec<DataReader<Raw, RawCdr>>,
}

impl CoordinatorEnds {
    fn open(o: &DdsOptions, n: usize) -> Result<Self, String> {
        let bus = Bus::join(o)?;
        let order_w = bus.writer(ORDER_TOPIC, codec::TICK_TYPE, Qos::Durable(ORDER_DEPTH))?;
        let mut assign_w = Vec::new();
        let mut status_r = Vec::new();
        for i in 0..n {
            assign_w.push(bus.writer(&assignment_topic(i), codec::ASSIGNMENT_TYPE, Qos::Latched)?);
            status_r.push(bus.reader(&status_topic(i), codec::STATUS_TYPE, Qos::Reliable(STATUS_DEPTH))?);
        }
        Ok(CoordinatorEnds { _bus: bus, order_w, assign_w, status_r })
    }
}

/// One status for a round out of every status robot `i` sent in it (`got`, in order, not
/// empty): the newest's pose, goal, flags and waypoints done, every status's seen and LiDAR
/// cells (later reports of a LiDAR cell after earlier ones).
fn fold(mut got: Vec<Status>) -> Status {
    let mut newest = got.pop().expect("a status");
    if !got.is_empty() {
        let mut seen: Vec<u32> = got.iter().flat_map(|s| s.seen.iter().copied()).collect();
        seen.extend_from_slice(&newest.seen);
        seen.sort_unstable();
        seen.dedup();
        let mut lidar: Vec<u32> = got.iter().flat_map(|s| s.lidar.iter().copied()).collect();
        lidar.extend_from_slice(&newest.lidar);
        newest.seen = seen;
        newest.lidar = lidar;
    }
    newest
}

/// A robot's last status again, for a round in which nothing came from it: where it was and
/// what it was doing, with no news.
fn quiet(last: &Status) -> Status {
    Status { seen: Vec::new(), lidar: Vec::new(), done: Vec::new(), ..last.clone() }
}

fn coordinate(
    spec: &TeamSpec,
    mut coord: Coordinator,
    opts: &RealtimeOptions,
    ends: &mut CoordinatorEnds,
    children: &mut [Option<std::process::Child>],
) -> Result<TeamResult, String> {
    let n = spec.robots;
    let mut inbox = Inbox::new(&mut ends.status_r);
    let hellos = inbox.join(children)?;
    let mut pending = coord.start(&hellos)?;
    let tick_s = TICK_US as f64 / 1e6;
    let limit_s = spec.base.world.time_limit_s;
    let period = opts.period();
    let mut heard = vec![Instant::now(); n];
    let mut deadline = Instant::now();
    let mut round = 0u32;
    let mut frozen = Frozen::NotYet;
    let out = loop {
        if let Some((r, t)) = spec.kill {
            if round as f64 * tick_s >= t {
                if let Some(mut c) = children.get_mut(r).and_then(Option::take) {
                    // The link is cut: the robot's process dies without a word.
                    let _ = c.kill();
                    let _ = c.wait();
                }
            }
        }
        frozen = pause(opts.pause, frozen, round as f64 * tick_s, children);
        for a in pending.drain(..) {
            let i = a.robot as usize;
            inbox.bytes[i][1] += send(&ends.assign_w[i], &codec::encode_assignment(&a), "an assignment")?;
        }
        let b = send(&ends.order_w, &codec::encode_tick(&coord.tick_msg(round, false)), "an order")?;
        for (i, c) in inbox.bytes.iter_mut().enumerate() {
            if coord.alive(i) {
                c[1] += b;
            }
        }
        // One round: read what comes until the next round is due.
        crate::link::advance_deadline(&mut deadline, period, Instant::now());
        let mut got: Vec<Vec<Status>> = vec![Vec::new(); n];
        loop {
            for (i, g) in got.iter_mut().enumerate() {
                g.extend(inbox.read(i)?.into_iter().filter(|s| s.tick.is_some()));
            }
            let now = Instant::now();
            if now >= deadline {
                break;
            }
            std::thread::sleep((deadline - now).min(Duration::from_millis(2)));
        }
        let busy = Instant::now();
        let mut statuses: Vec<Option<Status>> = Vec::with_capacity(n);
        for (i, g) in got.into_iter().enumerate() {
            if g.is_empty() {
                // Nothing this round: where it last said, unless lost or silent too long.
                let silent = !coord.alive(i) || heard[i].elapsed() > opts.dds.link_timeout;
                statuses.push(if silent { None } else { coord.last_status(i).map(quiet) });
                continue;
            }
            heard[i] = Instant::now();
            for s in &g {
                coord.note_stale(i, s);
            }
            let s = fold(g);
            if !coord.alive(i) {
                // A lost robot answers again (its link came back): it is taken in again where it
                // stands, what is left is shared out anew, and its news (a find too) counts.
                pending.extend(coord.rejoin(i, round, s.clone())?);
            }
            statuses.push(Some(s));
        }
        let d = coord.after_tick(round, &statuses)?;
        pending.extend(d.assignments);
        // The coordinator's own planning (1 to 6 s in the built-in buildings) is no robot's
        // silence: the robots' clocks of silence start again after it.
        if busy.elapsed() > period {
            let now = Instant::now();
            heard.iter_mut().for_each(|h| *h = now);
        }
        if d.stop || (round + 1) as f64 * tick_s >= limit_s - 1e-9 {
            break coord.result(spec, "dds-realtime", &inbox.bytes);
        }
        round += 1;
    };
    // A robot still frozen goes on, to be told to stop.
    pause(opts.pause, frozen, f64::INFINITY, children);
    Ok(out)
}

/// Where `--pause` stands.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Frozen {
    NotYet,
    Until(Instant),
    Done,
}

/// Freezes the paused robot's process once the team's time reaches the pause (`now_s`), and
/// lets it go on when its wall time is up (or at the end, `now_s` infinite).
fn pause(p: Option<(usize, f64, f64)>, frozen: Frozen, now_s: f64, children: &[Option<std::process::Child>]) -> Frozen {
    let Some((r, at, wall)) = p else { return frozen };
    let Some(pid) = children.get(r).and_then(Option::as_ref).map(std::process::Child::id) else { return Frozen::Done };
    let signal = |sig: &str| {
        let _ = std::process::Command::new("kill").args(["-s", sig, &pid.to_string()]).status();
    };
    match frozen {
        Frozen::NotYet if now_s >= at && now_s.is_finite() => {
            signal("STOP");
            Frozen::Until(Instant::now() + Duration::from_secs_f64(wall))
        }
        Frozen::Until(t) if Instant::now() >= t || now_s.is_infinite() => {
            signal("CONT");
            Frozen::Done
        }
        f => f,
    }
}

/// What a robot heard from the coordinator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Heard {
    /// No order yet: keep announcing itself.
    Nothing,
    /// Go on: it holds the assignment the newest order names.
    Go,
    /// Its newest assignment is named but has not arrived: hold still, no goal.
    Hold,
    /// Stop: the search is over.
    Stop,
}

/// A robot's endpoints on the team's topics.
struct RobotEnds {
    _bus: Bus,
    status_w: DataWriter<Raw, RawCdr>,
    order_r: DataReader<Raw, RawCdr>,
    assign_r: DataReader<Raw, RawCdr>,
}

impl RobotEnds {
    fn open(o: &DdsOptions, id: usize) -> Result<Self, String> {
        let bus = Bus::join(o)?;
        let status_w = bus.writer(&status_topic(id), codec::STATUS_TYPE, Qos::Reliable(STATUS_DEPTH))?;
        let order_r = bus.reader(ORDER_TOPIC, codec::TICK_TYPE, Qos::Durable(ORDER_DEPTH))?;
        let assign_r = bus.reader(&assignment_topic(id), codec::ASSIGNMENT_TYPE, Qos::Latched)?;
        Ok(RobotEnds { _bus: bus, status_w, order_r, assign_r })
    }
}

/// A robot that has heard no order for this long joins the team's topics again, as a new DDS
/// participant: after a link that stalled (a process frozen, a radio out of range) the old
/// endpoints' reliable streams may wait for messages the other side no longer holds. Longer than
/// the coordinator's longest planning in the built-in buildings (6.5 s, office, three robots),
/// during which no order comes.
pub const REJOIN_AFTER: Duration = Duration::from_secs(10);

/// A robot's end of the team's topics (real time).
pub struct RobotLink {
    id: usize,
    dds: DdsOptions,
    ends: RobotEnds,
    /// The newest round taken (`None`: no order yet).
    pub round: Option<u32>,
    /// The epoch of its own assignment the newest order names.
    named: u32,
    stopped: bool,
    /// Rounds it never got the order of.
    pub orders_missed: u32,
    /// Times it joined the team's topics again ([`REJOIN_AFTER`]).
    pub rejoins: u32,
    heard: Instant,
    opened: Instant,
    last_hello: Option<Instant>,
}

impl RobotLink {
    /// Joins the team as robot `id`.
    pub fn join(o: &DdsOptions, id: usize) -> Result<Self, String> {
        let ends = RobotEnds::open(o, id)?;
        let now = Instant::now();
        Ok(RobotLink {
            id,
            dds: o.clone(),
            ends,
            round: None,
            named: 0,
            stopped: false,
            orders_missed: 0,
            rejoins: 0,
            heard: now,
            opened: now,
            last_hello: None,
        })
    }

    fn take_assignments(&mut self, member: &mut TeamMember, ctrl: &mut Controller) {
        for b in take(&mut self.ends.assign_r) {
            match codec::decode_assignment(&b) {
                Ok(a) => member.assign(ctrl, &a),
                Err(e) => eprintln!("robot {}: an assignment refused: {e}", self.id),
            }
        }
    }

    /// Takes what came from the coordinator since the last call: its assignments, then every
    /// order in turn (what teammates saw merged into `ctrl`, the newest order's goals and
    /// positions left to their robots), and says what to do.
    pub fn poll(&mut self, member: &mut TeamMember, ctrl: &mut Controller) -> Result<Heard, String> {
        self.take_assignments(member, ctrl);
        let mut newest: Option<TickMsg> = None;
        for b in take(&mut self.ends.order_r) {
            let t = match codec::decode_tick(&b) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("robot {}: an order refused: {e}", self.id);
                    continue;
                }
            };
            if t.stop {
                self.stopped = true;
                continue;
            }
            if self.round.is_some_and(|r| t.tick <= r) {
                continue; // a repeat, or older than one taken
            }
            if t.epochs.len() <= self.id {
                return Err(format!("robot {}: the coordinator's team has robots 0 to {} only", self.id, t.epochs.len().max(1) - 1));
            }
            if let Some(r) = self.round {
                self.orders_missed += t.tick - r - 1;
            }
            self.round = Some(t.tick);
            self.heard = Instant::now();
            member.merge(ctrl, &t.seen, &t.lidar);
            self.named = t.epochs.get(self.id).copied().unwrap_or(0);
            newest = Some(t);
        }
        if let Some(t) = &newest {
            member.give_way(ctrl, &t.goals, &t.positions);
        }
        // An assignment that came while the orders were read.
        self.take_assignments(member, ctrl);
        if self.stopped {
            return Ok(Heard::Stop);
        }
        if self.heard.elapsed() > ORDER_TIMEOUT {
            return Err(format!("robot {}: no order from the coordinator for {} s", self.id, ORDER_TIMEOUT.as_secs()));
        }
        if self.round.is_some() && self.heard.elapsed() > REJOIN_AFTER && self.opened.elapsed() > REJOIN_AFTER {
            eprintln!("robot {}: no order for {:.1} s: joining the team's topics again", self.id, self.heard.elapsed().as_secs_f64());
            self.ends = RobotEnds::open(&self.dds, self.id)?;
            self.opened = Instant::now();
            self.rejoins += 1;
        }
        Ok(match self.round {
            None => Heard::Nothing,
            Some(_) if member.epoch < self.named => Heard::Hold,
            Some(_) => Heard::Go,
        })
    }

    /// Announces the robot (`hello`: its status with no tick), at most every [`RESEND`].
    pub fn announce(&mut self, hello: &Status) -> Result<(), String> {
        if self.last_hello.is_none_or(|t| t.elapsed() >= RESEND) {
            send(&self.ends.status_w, &codec::encode_status(hello), "an announcement")?;
            self.last_hello = Some(Instant::now());
        }
        Ok(())
    }

    /// Says on stderr how many orders never came (what teammates saw in those rounds was not
    /// merged) and how often it joined again, if any.
    pub fn say_missed(&self) {
        if self.orders_missed > 0 || self.rejoins > 0 {
            eprintln!(
                "robot {}: orders that never came: {}; times it joined the team's topics again: {}",
                self.id, self.orders_missed, self.rejoins
            );
        }
    }

    /// Reports `s` as the status after the newest round taken.
    pub fn report(&mut self, mut s: Status) -> Result<(), String> {
        s.tick = Some(self.round.unwrap_or(0));
        send(&self.ends.status_w, &codec::encode_status(&s), "a status").map(|_| ())
    }
}

/// A simulated robot as a process of its own, in real time: robot `id` of `spec`, stepping its
/// simulator one tick every [`RealtimeOptions::period`] of wall time.
pub fn sim_robot(spec: &TeamSpec, id: usize, opts: &RealtimeOptions) -> Result<(), String> {
    let mut robot = TeamRobot::of_team(spec, id)?;
    let mut link = RobotLink::join(&opts.dds, id)?;
    let hello = robot.hello();
    let joined = Instant::now();
    loop {
        match link.poll(&mut robot.member, &mut robot.brain.ctrl)? {
            Heard::Stop => return Ok(()),
            Heard::Nothing => {
                if joined.elapsed() > JOIN_TIMEOUT + ORDER_TIMEOUT {
                    return Err(format!("robot {id}: no order from the coordinator"));
                }
                link.announce(&hello)?;
                std::thread::sleep(Duration::from_millis(2));
            }
            _ => break,
        }
    }
    let period = opts.period();
    let mut deadline = Instant::now();
    let mut tick = 0u32;
    loop {
        let s = match link.poll(&mut robot.member, &mut robot.brain.ctrl)? {
            Heard::Stop => {
                link.say_missed();
                return Ok(());
            }
            Heard::Hold => robot.hold(tick),
            Heard::Go | Heard::Nothing => robot.step(tick),
        };
        link.report(s)?;
        tick += 1;
        crate::link::advance_deadline(&mut deadline, period, Instant::now());
        std::thread::sleep(deadline.saturating_duration_since(Instant::now()));
    }
}

/// A robot's controller in a team in real time, as the run loop's brain (`lives ros2
/// --team-robot I`): before each tick it takes what the coordinator sent (and waits for the
/// first order, announcing itself); it holds still while an assignment the coordinator named is
/// on its way; after each tick it reports.
pub struct TeamBrain {
    /// The controller (a team member's: it waits when it has nothing left, [`InProcess::waiting`]).
    pub inner: crate::run::InProcess,
    member: TeamMember,
    link: RobotLink,
    holding: bool,
    start: [f64; 3],
    last_xy: Option<[f64; 2]>,
    path_m: f64,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl TeamBrain {
    /// Joins the team as robot `id` with `inner`'s controller (`known_map`: it holds the
    /// building's map), standing at `start`; `stop` (a signal) ends the wait for the first order.
    pub fn join(
        inner: crate::run::InProcess,
        o: &DdsOptions,
        id: usize,
        known_map: bool,
        start: [f64; 3],
        stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    ) -> Result<Self, String> {
        let link = RobotLink::join(o, id)?;
        let member = TeamMember::new(id as u32, std::process::id(), known_map);
        Ok(TeamBrain { inner, member, link, holding: false, start, last_xy: None, path_m: 0.0, stop })
    }

    /// Says on stderr how many of the coordinator's orders never came, if any.
    pub fn say_missed(&self) {
        self.link.say_missed();
    }

    fn report(&mut self, found: bool, idle: bool) -> Result<(), String> {
        let s = self.member.report(&self.inner.ctrl, self.inner.outputs(), Some(0), self.start, found, idle, self.path_m);
        self.link.report(s)
    }
}

impl crate::run::Brain for TeamBrain {
    type Error = String;

    fn ready(&mut self) -> Result<Option<crate::run::End>, String> {
        let joined = Instant::now();
        loop {
            if self.stop.load(std::sync::atomic::Ordering::Relaxed) {
                return Ok(Some(crate::run::End::Stopped));
            }
            match self.link.poll(&mut self.member, &mut self.inner.ctrl)? {
                Heard::Stop => return Ok(Some(crate::run::End::Stopped)),
                Heard::Nothing => {
                    if joined.elapsed() > JOIN_TIMEOUT + ORDER_TIMEOUT {
                        return Err(format!("robot {}: no order from the coordinator", self.link.id));
                    }
                    let hello = self.member.report(&self.inner.ctrl, None, None, self.start, false, false, 0.0);
                    self.link.announce(&hello)?;
                    std::thread::sleep(Duration::from_millis(5));
                }
                h => {
                    self.holding = h == Heard::Hold;
                    return Ok(None);
                }
            }
        }
    }

    fn think(&mut self, frame: &crate::run::Frame) -> Result<crate::run::Answer, String> {
        let xy = [frame.base_pose[0], frame.base_pose[1]];
        if let Some(p) = self.last_xy.replace(xy) {
            self.path_m += (xy[0] - p[0]).hypot(xy[1] - p[1]);
        }
        if self.holding {
            self.member.drop_goal();
            self.report(false, false)?;
            return Ok(crate::run::Answer { acts: vec![crate::run::Act::Stop], ..Default::default() });
        }
        let Ok(answer) = crate::run::Brain::think(&mut self.inner, frame);
        self.member.answered(self.inner.outputs(), answer.end.is_some());
        self.report(answer.end == Some(crate::run::End::Found), answer.end.is_some())?;
        Ok(answer)
    }
}

/// Robot `id` of a team; a robot is lost to the coordinator after `link_timeout` of silence.
#[derive(Clone, Copy, Debug)]
pub struct TeamSeat {
    pub id: usize,
    pub link_timeout: Duration,
}

/// `lives ros2 --team-robot I`: the controller on the robot's ROS 2 graph (configured by `cfg`
/// and `brain`; `brain.origin` is needed: the team shares one grid), as robot `seat.id` of a team
/// whose coordinator runs elsewhere on the same DDS domain, until the coordinator says stop or
/// the target is found. If the team is lost (no order for too long) the base is stopped.
pub fn ros2_member(
    opts: crate::link::ros2::Ros2Options,
    cfg: firmware::Config,
    brain: crate::link::ros2::Ros2Brain,
    seat: TeamSeat,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<crate::link::ros2::Ros2Run, String> {
    if brain.origin.is_none() {
        return Err(
            "a team shares one grid: give every robot and the coordinator the same --origin X,Y (in the frame the robots share)".into()
        );
    }
    let dds = DdsOptions { domain: opts.domain, localhost_only: opts.localhost_only, link_timeout: seat.link_timeout };
    let started = match crate::link::ros2::start(opts, cfg, &brain, stop.clone()).map_err(|e| e.to_string())? {
        Ok(s) => s,
        Err(run) => return Ok(run),
    };
    let crate::link::ros2::Ros2Started { mut source, ctrl, start, .. } = started;
    let interval = ctrl.config().replan_interval_us;
    let mut team = match TeamBrain::join(crate::run::InProcess::waiting(ctrl, interval), &dds, seat.id, brain.map.is_some(), start, stop) {
        Ok(t) => t,
        Err(e) => {
            source.abort("team", &e);
            return Err(format!("team: {e}"));
        }
    };
    match source.drive(&mut team, |t| &t.inner) {
        Ok(ended) => {
            team.say_missed();
            Ok(source.end(ended, &team.inner.ctrl))
        }
        Err(e) => {
            // The team is gone (no order for too long, a link error): the base stands.
            source.abort("team", &e);
            Err(format!("team: {e}"))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(tick: u32, seen: Vec<u32>, lidar: Vec<u32>, x: f64) -> Status {
        Status {
            robot: 0,
            instance: 1,
            tick: Some(tick),
            pose: [x, 0.0, 0.0],
            found: false,
            idle: false,
            epoch: 1,
            goal_epoch: None,
            done: vec![tick as u16],
            seen,
            goal: None,
            lidar,
            path_m: x,
        }
    }

    /// A round's statuses make one: every seen cell once, every LiDAR report in the order sent
    /// (the coordinator keeps the last of a cell), the newest's pose and waypoints done; a
    /// quiet round repeats the last with no news.
    #[test]
    fn a_rounds_statuses_fold_into_one_and_a_quiet_round_brings_no_news() {
        let f = fold(vec![status(3, vec![5, 9], vec![7], 1.0), status(4, vec![2, 9], vec![7 | super::super::SEEN_OCCUPIED], 2.0)]);
        assert_eq!(f.seen, vec![2, 5, 9]);
        assert_eq!(f.lidar, vec![7, 7 | super::super::SEEN_OCCUPIED]);
        assert_eq!((f.tick, f.pose[0], f.done.clone(), f.path_m), (Some(4), 2.0, vec![4], 2.0));
        let one = status(6, vec![1], vec![3], 4.0);
        assert_eq!(fold(vec![one.clone()]), one);
        let q = quiet(&f);
        assert!(q.seen.is_empty() && q.lidar.is_empty() && q.done.is_empty());
        assert_eq!((q.tick, q.pose), (f.tick, f.pose));
    }
}
