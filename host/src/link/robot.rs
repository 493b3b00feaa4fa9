//! The robot source of the bridge (`lives bridge --source robot`): a real base behind the base
//! adapter ([`super::adapter`], `docs/base-adapter.md`) instead of the simulator.
//!
//! The session with the node is the bridge's own ([`Bridge`]: `Hello`, link watchdog, reopening,
//! health counters); this module supplies the base ([`RobotBase`], which implements [`Base`]) and
//! the real-time loop. A run is a new mission: its first configuration follows a `Reset`, so the
//! node forgets what it mapped before (a link lost and reopened during the run keeps the maps).
//! Each `period` (200 ms) it sends the node, stamped on the bridge's
//! monotonic clock at the time the adapter received them: the base's blocked state, the latest
//! odometry as `Pose`, a `Detection` if the client reported one, and the latest scan if a new one
//! came. Goals from the node go to the client as `goal` lines; the node's `Stop`, a lost link, a
//! stale client and the end of the run go to the client as `stop` lines with their reason.
//!
//! Safety rules (tested in `tests/tests/adapter.rs`):
//! * no goal is forwarded while the client is stale (no valid odometry for the adapter's
//!   watchdog) or the node is not exploring; nothing is sent to the node for a stale client, so
//!   the node's own watchdog stops the search too;
//! * the link to the node lost: `stop` (`link-lost`) at once;
//! * the bridge ending (found, exhausted, told to stop): a final `stop` with the reason, then the
//!   connection is closed. A client that disconnects must stop its base itself (the reference
//!   client does); the bridge then waits for a new client and re-sends the current goal to it.
//!
//! The grid's origin is `RobotSpec::origin` or, by default, the first odometry pose minus half
//! the grid (51.2 m), on the 0.1 m lattice: the search area is centred on where the robot starts.

use super::adapter::{round_to, AdapterConfig, AdapterServer, AdapterStats, Detection, Input, LaserScan, Odometry, StopReason};
use super::bridge::{resume_from, Base, Bridge, BridgeError, BridgeOptions, BridgeResult};
use super::SerialLink;
use super::{Link, Summary, TimeMode};
use crate::io::sensors::vlp16::{PlanarScan, Vlp16Config, Vlp16Udp};
use crate::run::range::{EncodedScan, RangeLimits};
use crate::run::round3;
use crate::search::{PlannerChoice, SearchResult};
use firmware::protocol::{
    BaseStatus, ConfigMsg, CoreToHost, DetectionMsg, GoalMsg, HostToCore, PoseMsg, ScanMsg, StatusMsg, WireCommand, WireMode,
};
use firmware::{BinaryAngle, Config, Meters, Pose2};
use serde_json::{json, Value};
use std::io::Write as _;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Where the robot's scans come from.
#[derive(Clone, Debug, PartialEq)]
pub enum LidarSource {
    /// The client's `scan` messages.
    Adapter,
    /// A Velodyne VLP-16 sending to this UDP address ([`crate::io::sensors::vlp16::Vlp16Udp`]),
    /// mounted level at the robot's origin facing forward; the client's `scan`s are ignored.
    Vlp16Udp(SocketAddr, Vlp16Config),
}

/// The controller's configuration for a real robot (the base adapter's, `lives ros2`'s): the
/// default without scan matching (see [`RobotSpec::new`]); with `--set scan_matching=true`, the
/// field matcher (`scan_match_field`, measured best on real logs: docs/replay.md "Scan matching").
pub const REAL_ROBOT_CONFIG: Config = Config { scan_matching: false, scan_match_field: true, ..Config::DEFAULT };

/// A robot run: where the adapter listens and how the controller is configured.
#[derive(Clone, Debug)]
pub struct RobotSpec {
    /// The adapter's address (keep it on localhost: the interface has no authentication).
    pub listen: SocketAddr,
    /// Where scans come from.
    pub lidar: LidarSource,
    /// The planner the node runs.
    pub planner: PlannerChoice,
    /// The controller's parameters (the grid origin is set from `origin` or the first pose).
    pub controller: Config,
    /// The grid's lower-left corner, map frame, metres; `None`: centred on the first odometry.
    pub origin: Option<[f64; 2]>,
    /// The adapter's tunables.
    pub adapter: AdapterConfig,
    /// Told the address the adapter listens on, once bound (port 0 picks one).
    pub on_listen: Option<SyncSender<SocketAddr>>,
}

impl RobotSpec {
    /// Defaults: adapter scans, the `lives` planner, the default configuration without scan
    /// matching (a real robot's pose is trusted, as a log's is in `lives replay`: on every shared
    /// real log the matcher's own error per match exceeded the poses' error and cost walls,
    /// docs/replay.md "Scan matching"; `--set scan_matching=true` turns it on), origin from the
    /// first pose, the adapter's defaults.
    pub fn new(listen: SocketAddr) -> Self {
        RobotSpec {
            listen,
            lidar: LidarSource::Adapter,
            planner: PlannerChoice::Lives,
            controller: REAL_ROBOT_CONFIG,
            origin: None,
            adapter: AdapterConfig::default(),
            on_listen: None,
        }
    }
}

/// A robot run's result: the bridge's, plus the adapter's counters and timings.
pub struct RobotRun {
    /// As for the simulator (world `robot`; `time_s` is the session's wall time).
    pub bridge: BridgeResult,
    /// The adapter's counters.
    pub adapter: AdapterStats,
    /// From a `Goal` frame decoded to its `goal` line written to the client, µs.
    pub goal_forward_us: Summary,
    /// From the first detection received from the client to `stop` (`target-found`) written, ms.
    pub detection_to_stop_ms: Option<f64>,
    /// From the first odometry to the first goal written to the client, s.
    pub first_goal_s: Option<f64>,
    /// What happened, in order: (seconds since start, text).
    pub log: Vec<(f64, String)>,
}

/// Encodes a planar scan ([`crate::run::range`]: REP 117, its limits travel with it; more than
/// [`firmware::protocol::MAX_WIRE_BEAMS`] ranges are combined to fit).
pub(crate) fn encode_planar(angle_min: f64, angle_increment: f64, ranges: &[f32], limits: RangeLimits) -> Option<EncodedScan> {
    EncodedScan::new(angle_min, angle_increment, ranges.iter().map(|&r| r as f64), &limits)
}

fn encode_laser_scan(s: &LaserScan) -> Option<EncodedScan> {
    encode_planar(s.angle_min, s.angle_increment, &s.ranges, RangeLimits::new(s.range_min, s.range_max))
}

/// A VLP-16 scan: `+inf` fired but no return, NaN nothing fired, within its configured limits.
fn encode_vlp16(s: &PlanarScan) -> Option<EncodedScan> {
    encode_planar(s.angle_min_rad, s.angle_increment_rad, &s.ranges_m, RangeLimits::new(s.range_limits_m[0], s.range_limits_m[1]))
}

/// What the VLP-16 thread hands over.
enum LidarEvent {
    Scan(PlanarScan, Instant),
    Error(String),
}

/// Receives VLP-16 rotations in a thread until `quit`; the newest scans arrive on the channel.
fn spawn_vlp16(
    addr: SocketAddr,
    cfg: Vlp16Config,
    quit: Arc<AtomicBool>,
) -> std::io::Result<(Receiver<LidarEvent>, std::thread::JoinHandle<()>)> {
    let mut udp = Vlp16Udp::bind(addr, cfg)?;
    let (tx, rx) = mpsc::sync_channel(8);
    let handle = std::thread::spawn(move || {
        let mut last_error: Option<String> = None;
        while !quit.load(Ordering::Relaxed) {
            let ev = match udp.recv_scan(Duration::from_millis(100)) {
                Ok(Some(scan)) => {
                    last_error = None;
                    LidarEvent::Scan(scan, Instant::now())
                }
                Ok(None) => continue,
                Err(e) => {
                    let text = e.to_string();
                    std::thread::sleep(Duration::from_millis(100));
                    if last_error.as_ref() == Some(&text) {
                        continue;
                    }
                    last_error = Some(text.clone());
                    LidarEvent::Error(text)
                }
            };
            // A full channel means the loop is behind: drop this one (newer ones follow).
            let _ = tx.try_send(ev);
        }
    });
    Ok((rx, handle))
}

/// The robot's base as the bridge sees it: the adapter's client.
pub(super) struct RobotBase {
    server: AdapterServer,
    started: Instant,
    odom: Option<Odometry>,
    /// The goal `Bridge::apply_goal` is applying (it passes only the path on).
    incoming: Option<GoalMsg>,
    /// The current goal and the path the client was given.
    goal: Option<(GoalMsg, Vec<[f64; 2]>)>,
    /// The client was given the current goal and no stop since.
    driving: bool,
    /// When a `Goal` frame was decoded (for the forwarding latency).
    goal_rx: Option<Instant>,
    forward_us: Vec<f64>,
    first_goal: Option<Instant>,
}

impl RobotBase {
    /// Sends the current goal to the client if it is live.
    fn send_goal(&mut self) {
        let Some((g, path)) = &self.goal else { return };
        if !self.server.live() {
            return;
        }
        let p = g.pose().to_f64();
        let len = Meters::from_bits(g.path_length_m).to_num::<f64>();
        if self.server.send_goal(g.seq, [p.0, p.1, p.2], path, len) {
            self.driving = true;
            self.first_goal.get_or_insert_with(Instant::now);
            if let Some(t) = self.goal_rx.take() {
                self.forward_us.push(t.elapsed().as_secs_f64() * 1e6);
            }
        }
    }

    /// The current goal again, from the path segment nearest the robot (after a stop).
    fn resend_goal(&mut self) {
        let p = Base::pose(self);
        if let Some((_, path)) = &mut self.goal {
            *path = resume_from(path, [p[0], p[1]]);
        }
        self.send_goal();
    }

    fn stop(&mut self, reason: StopReason, detail: &str) {
        self.driving = false;
        self.server.send_stop(reason, detail);
    }
}

impl Base for RobotBase {
    fn time_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }
    fn pose(&self) -> [f64; 3] {
        self.odom.map_or([0.0; 3], |o| [o.x, o.y, o.yaw])
    }
    fn set_path(&mut self, path: &[[f64; 2]], _final_yaw: Option<f64>) {
        // The goal line carries the goal's own yaw (`final_yaw` is that yaw).
        if let Some(g) = self.incoming.take() {
            if self.driving && self.goal.as_ref().is_some_and(|(cur, _)| cur.seq == g.seq) {
                // The client is driving this goal already (the node re-sent it after a Hello).
                return;
            }
            self.goal = Some((g, path.to_vec()));
            self.send_goal();
        }
    }
    fn stop_base(&mut self) {
        self.stop(StopReason::LinkLost, "the serial link to the controller node was lost");
    }
}

fn mode_name(m: WireMode) -> &'static str {
    match m {
        WireMode::Idle => "idle",
        WireMode::Exploring => "exploring",
        WireMode::TargetFound => "target-found",
        WireMode::Exhausted => "exhausted",
        WireMode::Stopped => "stopped",
    }
}

fn stamp(started: Instant, at: Instant) -> u64 {
    at.saturating_duration_since(started).as_micros() as u64
}

/// The grid origin for a robot first seen at `(x, y)`: centred, on the 0.1 m lattice.
fn origin_for(x: f64, y: f64) -> [f64; 2] {
    crate::run::centred_origin([x, y])
}

/// Runs the search of a robot behind the base adapter through the node at the other end of
/// `link`, in real time, until the target is found, the search is exhausted, `stop` is set or
/// `opts.max_wall` passes.
pub fn run_robot(link: &mut dyn Link, spec: RobotSpec, opts: &BridgeOptions, stop: &AtomicBool) -> Result<RobotRun, BridgeError> {
    if opts.mode != TimeMode::RealTime {
        return Err(BridgeError::Source("the robot source runs in real time only (drop --lockstep)".to_string()));
    }
    let server = AdapterServer::bind(spec.listen, spec.adapter.clone())
        .map_err(|e| BridgeError::Source(format!("the base adapter cannot listen on {}: {e}", spec.listen)))?;
    if let (Some(tx), Ok(addr)) = (&spec.on_listen, server.local_addr()) {
        let _ = tx.send(addr);
    }
    let base = RobotBase {
        server,
        started: Instant::now(),
        odom: None,
        incoming: None,
        goal: None,
        driving: false,
        goal_rx: None,
        forward_us: Vec::new(),
        first_goal: None,
    };
    let quit_lidar = Arc::new(AtomicBool::new(false));
    let lidar = match &spec.lidar {
        LidarSource::Adapter => None,
        LidarSource::Vlp16Udp(addr, cfg) => Some(
            spawn_vlp16(*addr, *cfg, quit_lidar.clone())
                .map_err(|e| BridgeError::Source(format!("the VLP-16 cannot listen on UDP {addr}: {e}")))?,
        ),
    };
    let mut b = Bridge::new(link, opts, stop, base);
    let mut log: Vec<(f64, String)> = Vec::new();
    let note = |log: &mut Vec<(f64, String)>, b: &Bridge<'_, RobotBase>, text: String| log.push((b.sim.time_s(), text));

    let mut origin_used = spec.origin;
    let mut config: Option<ConfigMsg> = spec.origin.map(|o| config_msg(&spec, o));
    let mut configured = false;
    let mut need_start = true;
    let mut ticks = 0u32;
    let mut ticks_sent = 0u32;
    let mut blocked_ticks = 0u32;
    let mut next_tick = Instant::now();
    let mut last_beat = Instant::now();
    let mut odom_at: Option<Instant> = None;
    let mut first_odom: Option<Instant> = None;
    let mut scan: Option<(EncodedScan, Instant)> = None;
    let mut scan_new = false;
    let mut detection: Option<(Detection, Instant)> = None;
    let mut first_detection: Option<Instant> = None;
    let mut detection_to_stop_ms = None;
    let mut mode: Option<WireMode> = None;
    let mut last_status: Option<StatusMsg> = None;
    let mut last_node_stop: Option<(WireMode, Instant)> = None;
    let mut driven_m = 0.0;
    let mut outcome = "stopped";
    let mut incompatible = None;
    let mut refused = None;

    'run: loop {
        if b.should_stop() {
            b.sim.stop(StopReason::Shutdown, "the bridge is shutting down");
            break;
        }
        if let Some(e) = b.incompatible {
            b.sim.stop(StopReason::Shutdown, &format!("the controller node is incompatible: {e}"));
            incompatible = Some(e);
            break;
        }
        if let (Some(field), Some(c)) = (b.config_invalid, config) {
            let e = BridgeError::config_invalid(&c, field);
            b.sim.stop(StopReason::Shutdown, &e.to_string());
            refused = Some(e);
            break;
        }

        // The node.
        let wait = next_tick.saturating_duration_since(Instant::now()).min(Duration::from_millis(10));
        for m in b.poll(wait) {
            match m {
                // Not while the controller says the base must stand (its last status).
                CoreToHost::Goal(g) if b.open && !matches!(mode, Some(WireMode::TargetFound | WireMode::Exhausted | WireMode::Stopped)) => {
                    b.sim.goal_rx = Some(Instant::now());
                    b.sim.incoming = Some(g.clone());
                    b.apply_goal(&g);
                    b.sim.incoming = None;
                    // Forwarded now or not at all (then it is re-sent later, not timed).
                    b.sim.goal_rx = None;
                }
                CoreToHost::Stop(s) => {
                    // The node says so every tick while stopped: tell the client on a change of
                    // reason, and again every second.
                    let due = last_node_stop.is_none_or(|(m, t)| m != s.mode || t.elapsed() >= Duration::from_secs(1));
                    if due && !matches!(s.mode, WireMode::TargetFound | WireMode::Exhausted) {
                        last_node_stop = Some((s.mode, Instant::now()));
                        b.sim.stop(StopReason::NodeStopped, &format!("the controller is {}", mode_name(s.mode)));
                    } else {
                        b.sim.driving = false;
                    }
                }
                CoreToHost::Status(s) => {
                    need_start = s.mode == WireMode::Idle;
                    mode = Some(s.mode);
                    last_status = Some(s);
                    match s.mode {
                        WireMode::TargetFound => {
                            b.sim.stop(StopReason::TargetFound, "the controller found the target");
                            detection_to_stop_ms = first_detection.map(|t| t.elapsed().as_secs_f64() * 1e3);
                            outcome = "found";
                            break 'run;
                        }
                        WireMode::Exhausted => {
                            b.sim.stop(StopReason::Exhausted, "nothing left to explore");
                            outcome = "exhausted";
                            break 'run;
                        }
                        WireMode::Exploring => last_node_stop = None,
                        _ => {}
                    }
                }
                _ => {}
            }
        }

        // The client.
        for input in b.sim.server.poll(Duration::from_millis(1)) {
            match input {
                Input::Greeted { peer, client } => {
                    b.sim.driving = false;
                    note(&mut log, &b, format!("client {peer} ({client}) said hello"));
                }
                Input::Odometry(o, at) => {
                    if let Some(p) = b.sim.odom {
                        driven_m += (o.x - p.x).hypot(o.y - p.y);
                    }
                    b.sim.odom = Some(o);
                    odom_at = Some(at);
                    if first_odom.is_none() {
                        first_odom = Some(at);
                        if config.is_none() {
                            let origin = origin_for(o.x, o.y);
                            config = Some(config_msg(&spec, origin));
                            origin_used = Some(origin);
                            note(&mut log, &b, format!("grid origin ({:.1}, {:.1}) from the first odometry", origin[0], origin[1]));
                        }
                    }
                }
                Input::Scan(s, at) => {
                    if spec.lidar == LidarSource::Adapter {
                        if let Some(w) = encode_laser_scan(&s) {
                            scan = Some((w, at));
                            scan_new = true;
                        }
                    }
                }
                Input::Detection(d, at) => {
                    first_detection.get_or_insert(at);
                    detection = Some((d, at));
                }
                Input::Stale => {
                    b.sim.driving = false;
                    note(&mut log, &b, "client stale: no odometry for a watchdog period".to_string());
                }
                Input::ClientGone { cause } => {
                    b.sim.driving = false;
                    note(&mut log, &b, format!("client gone ({cause}): its base is stopped; waiting for a client"));
                }
            }
        }

        // The VLP-16.
        if let Some((rx, _)) = &lidar {
            while let Ok(ev) = rx.try_recv() {
                match ev {
                    LidarEvent::Scan(s, at) => {
                        if let Some(w) = encode_vlp16(&s) {
                            scan = Some((w, at));
                            scan_new = true;
                        }
                    }
                    LidarEvent::Error(e) => note(&mut log, &b, format!("VLP-16: {e}")),
                }
            }
        }

        // A goal to (re)send: exploring, a live client that has not got it.
        if b.open && mode == Some(WireMode::Exploring) && !b.sim.driving && b.sim.goal.is_some() && b.sim.server.live() {
            b.sim.resend_goal();
        }

        if Instant::now() < next_tick {
            continue;
        }
        // A tick.
        ticks += 1;
        super::advance_deadline(&mut next_tick, opts.period, Instant::now());
        if let Some(p) = &opts.progress {
            p.store(ticks, Ordering::Relaxed);
        }
        if b.open {
            if let (false, Some(c)) = (configured, config) {
                // A new mission: `Reset` first (the node forgets the maps of whatever it ran
                // before; a link lost later in this run keeps them), then the configuration. v1 has
                // no acknowledgement of a configuration: three copies.
                let mut bytes = b.frame(&HostToCore::Command(WireCommand::Reset));
                for _ in 0..3 {
                    bytes.extend(b.frame(&HostToCore::Config(c)));
                }
                let (_, hb) = b.probe(stamp(b.started, Instant::now()), true);
                bytes.extend(hb);
                b.send(&bytes);
                configured = true;
                need_start = true;
            } else if let Some(c) = config.filter(|_| configured) {
                let mut batch = Vec::new();
                if need_start {
                    if ticks_sent > 0 {
                        // The node is idle (it restarted, or missed Start): configure it again.
                        batch.extend(b.frame(&HostToCore::Config(c)));
                    }
                    batch.extend(b.frame(&HostToCore::Command(WireCommand::Start)));
                }
                if let (true, Some(o), Some(at)) = (b.sim.server.live(), b.sim.odom, odom_at) {
                    blocked_ticks += o.blocked as u32;
                    batch.extend(b.frame(&HostToCore::BaseStatus(BaseStatus { blocked: o.blocked })));
                    if let Some(pose) = Pose2::from_f64(o.x, o.y, o.yaw) {
                        batch.extend(b.frame(&HostToCore::Pose(PoseMsg::from_pose(stamp(b.started, at), &pose))));
                    }
                    let mut sent_detection = None;
                    if let Some((d, at)) = detection.take() {
                        let position = d.position.and_then(|p| {
                            Some((fixed_point::meters_from_f64(p[0])?.to_bits(), fixed_point::meters_from_f64(p[1])?.to_bits()))
                        });
                        let msg = DetectionMsg { t_us: stamp(b.started, at), position };
                        batch.extend(b.frame(&HostToCore::Detection(msg)));
                        sent_detection = Some(msg);
                    }
                    if let (true, Some((w, at))) = (scan_new, &scan) {
                        let input = w.input(false);
                        if let Ok(msg) = ScanMsg::from_scan_input(stamp(b.started, *at), &input) {
                            if let (Some(Ok(mut obs)), Some(pose)) =
                                (opts.observer.as_ref().map(|o| o.0.lock()), Pose2::from_f64(o.x, o.y, o.yaw))
                            {
                                obs.tick(
                                    &PoseMsg::from_pose(stamp(b.started, odom_at.unwrap_or(*at)), &pose),
                                    &msg,
                                    sent_detection.as_ref(),
                                );
                            }
                            let before = batch.len();
                            batch.extend(b.frame(&HostToCore::Scan(msg)));
                            b.st.scan_frames = 1;
                            b.st.scan_frame_bytes = batch.len() - before;
                        }
                        scan_new = false;
                    }
                }
                if last_beat.elapsed() >= Duration::from_secs(1) {
                    last_beat = Instant::now();
                    let (_, hb) = b.probe(stamp(b.started, last_beat), true);
                    batch.extend(hb);
                }
                if !batch.is_empty() {
                    b.send(&batch);
                }
                ticks_sent += 1;
            }
        }
        if b.sim.server.status_due() {
            let odom_age = odom_at.map(|t| round_to(t.elapsed().as_secs_f64(), 1e3));
            let s = last_status;
            let fields = json!({
                "t": round_to(b.sim.time_s(), 1e3),
                "node": if b.open { "up" } else { "down" },
                "mode": mode.map(mode_name),
                "live": b.sim.server.live(),
                "odometry_age": odom_age,
                "goals": s.map(|s| s.goals),
                "node_ticks": s.map(|s| s.ticks),
                "scans": s.map(|s| s.scans),
                "scans_rejected": s.map(|s| s.scans_rejected),
                "gaze": s.and_then(|s| s.gaze).map(|h| round_to(BinaryAngle(h).to_radians(), 1e6)),
            });
            if let Value::Object(map) = fields {
                b.sim.server.send_status(map);
            }
        }
    }
    b.sim.server.close();
    quit_lidar.store(true, Ordering::Relaxed);
    if let Some((_, handle)) = lidar {
        let _ = handle.join();
    }
    note(&mut log, &b, format!("run ended: {outcome}"));
    if let Some(e) = incompatible {
        return Err(BridgeError::Incompatible(e));
    }
    if let Some(e) = refused {
        return Err(e);
    }

    let found = outcome == "found";
    let session_s = b.sim.time_s();
    let status = b.st.node_status;
    b.finish_stats();
    let result = SearchResult {
        world: "robot".to_string(),
        scenario: "real".to_string(),
        planner: spec.planner.to_string(),
        found,
        time_s: round3(session_s),
        path_m: round3(driven_m),
        ticks,
        time_limit_s: opts.max_wall.map_or(0.0, |d| d.as_secs_f64()),
        outcome: outcome.to_string(),
        goals: status.map_or(0, |s| s.goals),
        blacklisted: status.map_or(0, |s| s.blacklisted),
        blocked: blocked_ticks,
        // The robot sends no labels: the node's classifier labelled the scans if its status ever
        // reported classify work (a node started with `--no-model` reports none).
        labels: if status.is_some_and(|s| s.cost.classify > 0) { "int8-classifier" } else { "none" }.to_string(),
        // What only a simulation knows stays empty: seed 0, no collisions, targets, time
        // breakdown, sightings, simulated robot or oracle. The core's labels stay in the node
        // (the link carries no per-beam labels back), so there is no classifier score either.
        ..SearchResult::default()
    };
    // Every goal the client was given a path for, once per `seq` (as the simulator's decisions).
    let origin = origin_used.map_or([0.0; 2], |o| o);
    let geom = firmware::GridGeometry {
        origin_x: fixed_point::meters_from_f64(origin[0]).unwrap_or_default(),
        origin_y: fixed_point::meters_from_f64(origin[1]).unwrap_or_default(),
    };
    let mut goals: Vec<((i32, i32), BinaryAngle)> = Vec::new();
    let mut last_seq = None;
    for g in &b.goals_received {
        if last_seq != Some(g.seq) {
            last_seq = Some(g.seq);
            goals.push((geom.cell_of(Meters::from_bits(g.x), Meters::from_bits(g.y)), BinaryAngle(g.theta)));
        }
    }
    let first_goal_s = match (first_odom, b.sim.first_goal) {
        (Some(a), Some(g)) => Some(g.saturating_duration_since(a).as_secs_f64()),
        _ => None,
    };
    let adapter = b.sim.server.stats.clone();
    let goal_forward_us = Summary::of(&b.sim.forward_us);
    let bridge = BridgeResult {
        result,
        goals,
        goals_received: std::mem::take(&mut b.goals_received),
        stats: b.st.clone(),
        events: std::mem::take(&mut b.events),
        trajectory: Vec::new(),
        wall_s: b.started.elapsed().as_secs_f64(),
    };
    Ok(RobotRun { bridge, adapter, goal_forward_us, detection_to_stop_ms, first_goal_s, log })
}

fn config_msg(spec: &RobotSpec, origin: [f64; 2]) -> ConfigMsg {
    let cfg = Config {
        origin_x_m: fixed_point::meters_from_f64(origin[0]).unwrap_or_default(),
        origin_y_m: fixed_point::meters_from_f64(origin[1]).unwrap_or_default(),
        ..spec.controller.with_planner(spec.planner.kind())
    };
    ConfigMsg::from_config(&cfg)
}

/// `lives bridge --source robot`'s options (parsed by `cli/bridge.rs`).
pub struct CliOptions {
    /// The serial device of the node.
    pub port: PathBuf,
    /// Its baud rate.
    pub baud: u32,
    /// The planner.
    pub planner: PlannerChoice,
    /// `--set NAME=VALUE` overrides.
    pub set: Vec<String>,
    /// Refused: the robot runs in real time.
    pub lockstep: bool,
    /// One JSON object on stdout.
    pub json: bool,
    /// Record the link's traffic to this MCAP file.
    pub record: Option<PathBuf>,
    /// `--base-listen`.
    pub base_listen: String,
    /// `--lidar`.
    pub lidar: String,
    /// `--origin X,Y`.
    pub origin: Option<String>,
}

/// `--lidar adapter | vlp16-udp[=ADDR]`.
pub fn parse_lidar(s: &str) -> Result<LidarSource, String> {
    match s.split_once('=') {
        None if s == "adapter" => Ok(LidarSource::Adapter),
        None if s == "vlp16-udp" => Ok(LidarSource::Vlp16Udp(SocketAddr::from(([0, 0, 0, 0], 2368)), Vlp16Config::default())),
        Some(("vlp16-udp", addr)) => addr
            .parse()
            .map(|a| LidarSource::Vlp16Udp(a, Vlp16Config::default()))
            .map_err(|e| format!("--lidar vlp16-udp={addr}: not an address like 0.0.0.0:2368 ({e})")),
        _ => Err(format!("--lidar {s}: expected `adapter`, `vlp16-udp` or `vlp16-udp=ADDR`")),
    }
}

/// `--origin X,Y` (metres, finite).
pub fn parse_origin(s: &str) -> Result<[f64; 2], String> {
    let bad = || format!("--origin {s}: expected X,Y in metres, e.g. -20,-25.6");
    let [x, y] = crate::overrides::finite_numbers(s).ok_or_else(bad)?;
    if !(x.abs() <= super::adapter::MAX_COORD_M && y.abs() <= super::adapter::MAX_COORD_M) {
        return Err(bad());
    }
    Ok([x, y])
}

/// Runs `lives bridge --source robot`: prints the result (a line, or JSON) and exits 0 when
/// the target was found, 1 otherwise.
pub fn run_cli(o: CliOptions) -> Result<ExitCode, String> {
    if o.lockstep {
        return Err("--source robot runs in real time: drop --lockstep (and run `lives node` without it)".to_string());
    }
    let listen: SocketAddr = o.base_listen.parse().map_err(|e| format!("--base-listen {}: {e}", o.base_listen))?;
    if !listen.ip().is_loopback() {
        eprintln!("warning: --base-listen {listen} is not a loopback address; the base adapter has no authentication");
    }
    let mut spec = RobotSpec::new(listen);
    spec.planner = o.planner;
    spec.controller = spec.controller.with_planner(o.planner.kind());
    spec.lidar = parse_lidar(&o.lidar)?;
    spec.origin = o.origin.as_deref().map(parse_origin).transpose()?;
    for a in &o.set {
        crate::overrides::apply(&mut spec.controller, a)?;
    }
    let mut link = SerialLink::open(&o.port, o.baud).unwrap_or_else(|e| {
        eprintln!("waiting for {} ({e})", o.port.display());
        SerialLink::by_path(&o.port, o.baud)
    });
    let recording = o.record.as_ref().map(|p| crate::link::record::SharedRecording::create(p)).transpose().map_err(|e| e.to_string())?;
    let opts = BridgeOptions {
        want_labels: recording.is_some(),
        observer: recording.as_ref().map(|r| r.observer()),
        ..BridgeOptions::new(TimeMode::RealTime)
    };
    let (tx, rx) = mpsc::sync_channel(1);
    spec.on_listen = Some(tx);
    let port = o.port.display().to_string();
    std::thread::spawn(move || {
        if let Ok(addr) = rx.recv() {
            eprintln!("lives bridge: base adapter listening on {addr} (docs/base-adapter.md), node on {port}");
        }
    });
    let stop = AtomicBool::new(false);
    let run = run_robot(&mut link, spec, &opts, &stop).map_err(|e| e.to_string())?;
    if let (Some(rec), Some(path)) = (recording, &o.record) {
        rec.finish().map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let r = &run.bridge.result;
    let mut out = std::io::stdout();
    if o.json {
        let v = json!({
            "result": r,
            "link": run.bridge.stats,
            "adapter": run.adapter,
            "goal_forward_us": run.goal_forward_us,
            "detection_to_stop_ms": run.detection_to_stop_ms,
            "first_goal_s": run.first_goal_s,
            "log": run.log,
            "wall_s": run.bridge.wall_s,
        });
        let _ = writeln!(out, "{v}");
    } else {
        let _ = writeln!(out, "{}: {} goals, {:.1} m driven, {:.1} s", r.outcome, r.goals, r.path_m, r.time_s);
        let a = &run.adapter;
        let _ = writeln!(
            out,
            "adapter: {} lines in ({} odometry, {} scans, {} detections, {} errors), {} goals, {} stops, {} status out; {} stale, {} disconnects",
            a.lines, a.odometry, a.scans, a.detections, a.errors, a.goals_sent, a.stops_sent, a.status_sent, a.stale, a.disconnects
        );
        for (t, e) in &run.log {
            let _ = writeln!(out, "  {t:8.3} s  {e}");
        }
    }
    Ok(if r.found { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::protocol::MAX_WIRE_BEAMS;

    #[test]
    fn scans_follow_ros_conventions_and_long_scans_are_combined() {
        let s = LaserScan {
            angle_min: -1.0,
            angle_increment: 0.5,
            range_min: 0.2,
            range_max: 10.0,
            ranges: vec![1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.1, 12.0, 10.0],
        };
        let w = encode_laser_scan(&s).unwrap();
        use firmware::scan::{RANGE_INVALID, RANGE_NO_RETURN};
        // A reading at range_max says "nothing within it" (REP 117 as issue 27 reads it), as +inf does.
        assert_eq!(w.ranges_mm, vec![1000, RANGE_INVALID, RANGE_NO_RETURN, RANGE_INVALID, RANGE_INVALID, RANGE_NO_RETURN, RANGE_NO_RETURN]);
        assert_eq!((w.range_min_mm, w.range_max_mm), (200, 10_000), "the limits travel with the scan");
        assert_eq!(w.angle_increment, BinaryAngle::from_radians(0.5).unwrap());
        let long = LaserScan { ranges: vec![2.0; 2 * MAX_WIRE_BEAMS + 1], angle_increment: 0.001, ..s };
        let w = encode_laser_scan(&long).unwrap();
        assert_eq!((w.ranges_mm.len(), w.combined), (MAX_WIRE_BEAMS - 366, 3));
        assert_eq!(w.angle_increment.0, 3 * BinaryAngle::from_radians(0.001).unwrap().0);
    }

    #[test]
    fn the_grid_is_centred_on_the_first_pose() {
        assert_eq!(origin_for(0.0, 0.0), [-25.6, -25.6]);
        assert_eq!(origin_for(3.04, -1.0), [-22.6, -26.6]);
    }
}
