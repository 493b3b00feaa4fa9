//! `lives ros2`: the controller on a robot's ROS 2 graph (feature `ros2`; `docs/ros2.md`).
//!
//! The graph is a run source ([`Ros2Source`], a [`crate::run::Source`]): scans, odometry,
//! `tf`/`tf_static`, detections and the base's blocked flag come in over DDS and become the
//! run's frames; the controller core runs in this process ([`InProcess`]) and its answers go out
//! as `goal_pose`, `plan`, the two grids, markers and a status topic. Messages are decoded with
//! the bag reader's CDR code and placed with its frame tree ([`crate::io::replay::rosbag`]): a
//! live scan is placed as a recorded one, with the transforms interpolated to its stamp, after
//! the odometry has reached that stamp (as tf2's message filter waits), or within
//! [`Ros2Options::pose_wait`].
//!
//! Time: a frame's time is the scan's header stamp. `--lockstep` answers every scan, in stamp
//! order (a simulator that waits for each answer gets the run `lives search` would make, tick for
//! tick); otherwise a tick takes the newest placed scan every [`Ros2Options::period`].
//!
//! Safety: the controller's `Stop` and the end of a run publish an empty `plan` and a goal at
//! the robot's pose (a "zero goal"); so does odometry older than [`Ros2Options::watchdog`]
//! while a goal is out, with the reason on the status topic. Bad input is counted by name on the
//! status topic and stderr, and dropped; nothing else stops.

mod publish;
mod session;
pub mod wire;

pub use session::{run, start, Ros2Brain, Ros2Run, Ros2Started};

use crate::io::replay::cdr;
use crate::io::replay::rosbag::{
    self, frame, scan_record, EdgeReject, EdgeSource, FrameTree, PoseError, MAX_CLOUD_TILT_DEG, MAX_POSE_AGE_NS,
};
use crate::io::replay::Location;
use crate::link::robot::encode_planar;
use crate::run::range::RangeLimits;
use crate::run::{Answer, Frame, Source};
use firmware::Pose2;
use rustdds::mio1::{Events, Interest, Poll, Token};
use rustdds::no_key::{DataReader, DataWriter};
use rustdds::{DomainParticipant, DomainParticipantBuilder, RTPSEntity, StatusEvented, TopicKind, GUID};
use serde_json::json;
use std::cell::{Cell, RefCell};
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::net::{IpAddr, Ipv4Addr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use wire::{Qos, Raw, RawCdr};

/// How `lives ros2` joins the graph and runs.
#[derive(Clone, Debug)]
pub struct Ros2Options {
    /// The DDS domain (`ROS_DOMAIN_ID`).
    pub domain: u16,
    /// Keep DDS on the loopback interface (`ROS_LOCALHOST_ONLY=1`, or
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` as in Jazzy).
    pub localhost_only: bool,
    /// Topic remappings `from` → `to` (names as in the table of `docs/ros2.md`).
    pub remap: Vec<(String, String)>,
    /// Answer every scan in order (a simulator waiting for each answer) instead of the newest
    /// every period.
    pub lockstep: bool,
    /// The tick period in real time.
    pub period: Duration,
    /// How long a scan waits for the odometry to reach its stamp (and for its frame to appear).
    pub pose_wait: Duration,
    /// Odometry older than this stops the base.
    pub watchdog: Duration,
    /// The grids are published every this much log time (and when the run ends), nanoseconds.
    pub map_period_ns: u64,
    /// Stop after this much wall time.
    pub max_wall: Option<Duration>,
    /// Stop when no scan has arrived for this long (or none since the start).
    pub max_idle: Option<Duration>,
    /// Never end the run: start the search again when it is exhausted (every replanning
    /// interval at most), as `lives replay` does: a robot driven by someone else, a log played.
    pub continuous: bool,
}

impl Default for Ros2Options {
    fn default() -> Self {
        Ros2Options {
            domain: 0,
            localhost_only: false,
            remap: Vec::new(),
            lockstep: false,
            period: Duration::from_millis(200),
            pose_wait: Duration::from_millis(500),
            watchdog: Duration::from_secs(1),
            map_period_ns: 1_000_000_000,
            max_wall: None,
            continuous: false,
            max_idle: None,
        }
    }
}

impl Ros2Options {
    /// The domain and interface choice from the environment, as a ROS 2 node reads them.
    pub fn from_env() -> Result<Self, String> {
        let mut o = Ros2Options::default();
        if let Ok(d) = std::env::var("ROS_DOMAIN_ID") {
            if !d.trim().is_empty() {
                o.domain = d
                    .trim()
                    .parse()
                    .ok()
                    .filter(|&d: &u16| d <= 232)
                    .ok_or_else(|| format!("ROS_DOMAIN_ID `{d}` is not a domain (0-232)"))?;
            }
        }
        o.localhost_only = std::env::var("ROS_LOCALHOST_ONLY").is_ok_and(|v| v == "1")
            || std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").is_ok_and(|v| v.eq_ignore_ascii_case("localhost"));
        Ok(o)
    }

    fn topic(&self, name: &str) -> String {
        self.remap.iter().rev().find(|(f, _)| f.trim_start_matches('/') == name).map_or(name.to_string(), |(_, t)| t.clone())
    }
}

/// The topics, their types and QoS: `(name, ROS type, QoS)`.
pub const SUBSCRIBED: [(&str, &str, Qos); 8] = [
    ("scan", "sensor_msgs/msg/LaserScan", Qos::Sensor),
    // Odometry is published reliable or best effort: a best-effort reader matches both.
    ("odom", "nav_msgs/msg/Odometry", Qos::Sensor),
    ("tf", "tf2_msgs/msg/TFMessage", Qos::Reliable(100)),
    ("tf_static", "tf2_msgs/msg/TFMessage", Qos::Latched),
    ("target", "geometry_msgs/msg/PointStamped", Qos::Reliable(10)),
    ("detections", "vision_msgs/msg/Detection2DArray", Qos::Reliable(10)),
    ("base_blocked", "std_msgs/msg/Bool", Qos::Reliable(10)),
    // A 3D LiDAR's clouds, cut to planar scans (`rosbag::cut`), while no LaserScan comes.
    ("points", "sensor_msgs/msg/PointCloud2", Qos::Sensor),
];

/// What `lives ros2` publishes: `(name, ROS type, QoS)`.
pub const PUBLISHED: [(&str, &str, Qos); 6] = [
    ("goal_pose", "geometry_msgs/msg/PoseStamped", Qos::Reliable(10)),
    ("plan", "nav_msgs/msg/Path", Qos::Reliable(10)),
    ("lives/status", "std_msgs/msg/String", Qos::Reliable(100)),
    ("lives/lidar_map", "nav_msgs/msg/OccupancyGrid", Qos::Latched),
    ("lives/camera_map", "nav_msgs/msg/OccupancyGrid", Qos::Latched),
    ("lives/markers", "visualization_msgs/msg/MarkerArray", Qos::Reliable(10)),
];

const SCAN: usize = 0;
const ODOM: usize = 1;
const TF: usize = 2;
const TF_STATIC: usize = 3;
const TARGET: usize = 4;
const DETECTIONS: usize = 5;
const BLOCKED: usize = 6;
const POINTS: usize = 7;

/// The published topics, in `PUBLISHED`'s order.
#[derive(Clone, Copy)]
enum Out {
    Goal,
    Plan,
    Status,
    LidarMap,
    CameraMap,
    Markers,
}

/// Frames the tree holds at most (a publisher inventing frame names cannot grow it for ever).
pub const MAX_FRAMES: usize = 256;

/// Moving transforms are kept this long behind the newest, nanoseconds (a scan waits 0.5 s at
/// most, and one older than the odometry by more than 0.5 s is stale anyway).
const KEEP_NS: u64 = 10_000_000_000;

/// Placed scans waiting for the controller at most (lockstep only: in real time a tick takes the
/// newest and drops the rest).
const MAX_READY: usize = 256;

/// Why `lives ros2` could not join the graph.
#[derive(Debug)]
pub struct Ros2Error(pub String);

impl std::fmt::Display for Ros2Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// A scan waiting for its pose.
struct Pending {
    scan: cdr::LaserScan,
    t_ns: u64,
    since: Instant,
    /// Cut from a point cloud: refused if its frame is tilted.
    cloud: bool,
}

/// The robot's ROS 2 graph as a run source.
pub struct Ros2Source {
    opts: Ros2Options,
    _dp: DomainParticipant,
    readers: Vec<DataReader<Raw, RawCdr>>,
    writers: Vec<DataWriter<Raw, RawCdr>>,
    topics: Vec<String>,
    reader_topic: HashMap<GUID, String>,
    status_listener: rustdds::DomainParticipantStatusListener,
    poll: Poll,
    events: Events,
    tree: FrameTree,
    pending: VecDeque<Pending>,
    ready: VecDeque<(Frame, String)>,
    last_scan_ns: HashMap<String, u64>,
    detection: bool,
    blocked: bool,
    /// Where the base is now (the newest placed scan's pose) and in which frame.
    pose: Cell<Option<([f64; 3], u64)>>,
    root: RefCell<String>,
    received: RefCell<BTreeMap<&'static str, u64>>,
    rejected: RefCell<BTreeMap<String, u64>>,
    started: Instant,
    next_tick: Instant,
    last_odom: Option<Instant>,
    /// A goal is out (not stopped since).
    driving: Cell<bool>,
    /// The last plan published, poses in the odometry frame: sent again with the next answer
    /// after the watchdog stopped the base (`held`).
    last_plan: RefCell<Vec<cdr::Transform>>,
    /// The watchdog stopped the base while the controller held a goal: the next answer that
    /// brings no new path re-sends `last_plan` if the controller still pursues its goal.
    held: Cell<bool>,
    last_map_ns: Cell<Option<u64>>,
    ticks: Cell<u64>,
    stop: Arc<AtomicBool>,
    /// Wall time from a scan's arrival to its answer's publication, microseconds.
    pub answer_us: RefCell<Vec<f64>>,
    arrived: Cell<Option<Instant>>,
    /// The goals published, `[x, y, yaw]`.
    pub goals: RefCell<Vec<[f64; 3]>>,
}

impl Ros2Source {
    /// Joins domain `opts.domain`: one reader per subscribed topic, one writer per published one.
    pub fn join(opts: Ros2Options, stop: Arc<AtomicBool>) -> Result<Self, Ros2Error> {
        let mut b = DomainParticipantBuilder::new(opts.domain);
        if opts.localhost_only {
            b = b.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        }
        let dp = b.build().map_err(|e| Ros2Error(format!("cannot join DDS domain {}: {e:?}", opts.domain)))?;
        let status_listener = dp.status_listener();
        let sub = dp.create_subscriber(&Qos::Reliable(10).policies()).map_err(|e| Ros2Error(format!("DDS subscriber: {e:?}")))?;
        let publ = dp.create_publisher(&Qos::Reliable(10).policies()).map_err(|e| Ros2Error(format!("DDS publisher: {e:?}")))?;
        let poll = Poll::new().map_err(|e| Ros2Error(format!("poll: {e}")))?;
        let topic = |name: &str, ty: &str, qos: Qos| {
            dp.create_topic(wire::dds_topic(name), wire::dds_type(ty), &qos.policies(), TopicKind::NoKey)
                .map_err(|e| Ros2Error(format!("topic {name}: {e:?}")))
        };
        let mut readers = Vec::new();
        let mut reader_topic = HashMap::new();
        let mut topics = Vec::new();
        for (i, &(name, ty, qos)) in SUBSCRIBED.iter().enumerate() {
            let name = opts.topic(name);
            let topic = topic(&name, ty, qos)?;
            let mut r = sub
                .create_datareader_no_key::<Raw, RawCdr>(&topic, Some(qos.policies()))
                .map_err(|e| Ros2Error(format!("reader {name}: {e:?}")))?;
            poll.registry().register(&mut r, Token(i), Interest::READABLE).map_err(|e| Ros2Error(format!("poll: {e}")))?;
            reader_topic.insert(r.guid(), name.clone());
            readers.push(r);
            topics.push(name);
        }
        let mut writers = Vec::new();
        for (name, ty, qos) in PUBLISHED {
            let name = opts.topic(name);
            let topic = topic(&name, ty, qos)?;
            writers.push(
                publ.create_datawriter_no_key::<Raw, RawCdr>(&topic, Some(qos.policies()))
                    .map_err(|e| Ros2Error(format!("writer {name}: {e:?}")))?,
            );
            topics.push(name);
        }
        let now = Instant::now();
        Ok(Ros2Source {
            opts,
            _dp: dp,
            readers,
            writers,
            topics,
            reader_topic,
            status_listener,
            poll,
            events: Events::with_capacity(64),
            tree: FrameTree::default(),
            pending: VecDeque::new(),
            ready: VecDeque::new(),
            last_scan_ns: HashMap::new(),
            detection: false,
            blocked: false,
            pose: Cell::new(None),
            root: RefCell::new("odom".to_string()),
            received: RefCell::new(BTreeMap::new()),
            rejected: RefCell::new(BTreeMap::new()),
            started: now,
            next_tick: now,
            last_odom: None,
            driving: Cell::new(false),
            last_plan: RefCell::new(Vec::new()),
            held: Cell::new(false),
            last_map_ns: Cell::new(None),
            ticks: Cell::new(0),
            stop,
            answer_us: RefCell::new(Vec::new()),
            arrived: Cell::new(None),
            goals: RefCell::new(Vec::new()),
        })
    }

    /// Counts a rejection by name, says so on stderr and the status topic.
    fn reject(&self, name: &str, detail: String) {
        self.reject_at(name, detail, None)
    }

    /// A scan's rejection: the status message carries its stamp (a player in lockstep waits for
    /// an answer or a rejection of each scan).
    fn reject_scan(&self, name: &str, detail: String, t_ns: u64) {
        self.reject_at(name, detail, Some(t_ns))
    }

    fn reject_at(&self, name: &str, detail: String, t_ns: Option<u64>) {
        let n = {
            let mut r = self.rejected.borrow_mut();
            let n = r.entry(name.to_string()).or_insert(0);
            *n += 1;
            *n
        };
        // The first of a kind, then every hundredth: a flood does not flood the log.
        if n == 1 || n % 100 == 0 {
            eprintln!("lives ros2: rejected ({name}, {n} so far): {detail}");
        }
        let msg = json!({ "kind": "rejection", "name": name, "detail": detail, "stamp_ns": t_ns, "rejected": *self.rejected.borrow() });
        self.write(Out::Status, wire::encode_string(&msg.to_string()));
    }

    fn write(&self, out: Out, data: Vec<u8>) {
        let w = out as usize;
        if let Err(e) = self.writers[w].write(Raw(data), None) {
            eprintln!("lives ros2: publishing on {} failed: {e:?}", self.topics[SUBSCRIBED.len() + w]);
        }
    }

    fn count(&self, topic: &'static str) {
        *self.received.borrow_mut().entry(topic).or_insert(0) += 1;
    }

    /// Takes everything the readers hold and the participant's status events.
    fn take_all(&mut self) {
        while let Some(ev) = self.status_listener.try_recv_status() {
            if let rustdds::DomainParticipantStatusEvent::RemoteWriterQosIncompatible { local_reader, requested_qos, offered_qos, .. } = ev
            {
                let topic = self.reader_topic.get(&local_reader).cloned().unwrap_or_default();
                self.reject(
                    "incompatible-qos",
                    format!(
                        "a publisher on `{topic}` offers {}, this reader needs {}: not matched",
                        qos_words(&offered_qos),
                        qos_words(&requested_qos)
                    ),
                );
            }
        }
        for i in 0..self.readers.len() {
            loop {
                let sample = match self.readers[i].take_next_sample() {
                    Ok(Some(s)) => s.into_value(),
                    Ok(None) => break,
                    Err(e) => {
                        // The reader's next call starts from the next sample; stop here so that
                        // an error that repeats cannot hold the loop.
                        self.reject("malformed", format!("{}: {e:?}", self.topics[i]));
                        break;
                    }
                };
                self.ingest(i, &sample.0);
            }
        }
    }

    /// One message from reader `i`.
    fn ingest(&mut self, i: usize, buf: &[u8]) {
        let wire = cdr::Wire::Cdr;
        let topic = self.topics[i].clone();
        let bad = |s: &Self, e: cdr::CdrError| s.reject("malformed", format!("{topic}: {e}"));
        match i {
            SCAN => match cdr::decode_laser_scan(buf, wire) {
                Ok(s) => {
                    self.count("scan");
                    self.accept_scan(s, &topic, false);
                }
                Err(e) => bad(self, e),
            },
            // A robot with a LaserScan maps it (often made from these very clouds): not cut.
            POINTS if self.received.borrow().contains_key("scan") => self.count("points-superseded"),
            POINTS => match rosbag::cut(buf, wire) {
                Ok(s) => {
                    self.count("points");
                    self.accept_scan(s, &topic, true);
                }
                Err(e) => bad(self, e),
            },
            ODOM => match cdr::decode_odometry(buf, wire) {
                Ok(o) => {
                    self.count("odom");
                    let t = stamp(&o.header);
                    // Frames left empty by the driver: as replay takes them (`odometry_edge`).
                    let (parent, child, filled_in) =
                        self.tree.odometry_edge(&o.header.frame_id, &o.child_frame_id, self.last_scan_ns.keys().map(String::as_str));
                    if filled_in && child.is_empty() {
                        self.reject("odom-unnamed-frame", format!("{topic}: no child frame, and no scan yet says which body it moves"));
                        return;
                    }
                    match self.add_edge(&parent, &child, Some(t), &o.pose, EdgeSource::Odometry(&topic)) {
                        Ok(()) => {}
                        // `tf` carries the same edge (a robot commonly publishes both): not used.
                        Err(EdgeReject::Superseded) => self.count("odom-superseded"),
                        Err(r) => self.reject(
                            edge_reject_name(r),
                            format!("{topic}: {} → {} at {} s", o.header.frame_id, o.child_frame_id, t as f64 / 1e9),
                        ),
                    }
                }
                Err(e) => bad(self, e),
            },
            TF | TF_STATIC => match cdr::decode_tf_message(buf, wire) {
                Ok(ts) => {
                    self.count(if i == TF { "tf" } else { "tf_static" });
                    for t in ts {
                        let at = (i == TF).then(|| stamp(&t.header));
                        if let Err(r) = self.add_edge(&t.header.frame_id, &t.child_frame_id, at, &t.transform, EdgeSource::Tf) {
                            self.reject(edge_reject_name(r), format!("{topic}: {} → {}", t.header.frame_id, t.child_frame_id));
                        }
                    }
                }
                Err(e) => bad(self, e),
            },
            TARGET => match cdr::decode_point_stamped(buf) {
                Ok((_, p)) if p.iter().all(|v| v.is_finite()) => {
                    self.count("target");
                    self.detection = true;
                }
                Ok(_) => self.reject("target-not-finite", format!("{topic}: a target point that is not finite")),
                Err(e) => bad(self, e),
            },
            DETECTIONS => match cdr::decode_detection2d_array(buf) {
                Ok((_, d)) => {
                    self.count("detections");
                    if !d.is_empty() {
                        self.detection = true;
                    }
                }
                Err(e) => bad(self, e),
            },
            BLOCKED => match cdr::decode_bool(buf) {
                Ok(b) => {
                    self.count("base_blocked");
                    self.blocked |= b;
                }
                Err(e) => bad(self, e),
            },
            _ => {}
        }
    }

    /// A scan (or a cloud's cut) in: checked, then waiting for its pose.
    fn accept_scan(&mut self, s: cdr::LaserScan, topic: &str, cloud: bool) {
        self.arrived.set(Some(Instant::now()));
        let t_ns = stamp(&s.header);
        if let Some((name, detail)) = scan_problem(&s) {
            self.reject_scan(name, format!("{topic}: {detail}"), t_ns);
            return;
        }
        let laser = s.header.frame_id.clone();
        if self.last_scan_ns.get(&laser).is_some_and(|&p| t_ns <= p) {
            self.reject_scan(
                "scan-stamp-backwards",
                format!("{topic}: a scan stamped {} s, not after the one before", t_ns as f64 / 1e9),
                t_ns,
            );
            return;
        }
        self.last_scan_ns.insert(laser, t_ns);
        self.pending.push_back(Pending { scan: s, t_ns, since: Instant::now(), cloud });
    }

    /// An edge of the frame tree: a moving one's sample at `t_ns`, or a fixed one (`None`). The
    /// tree holds at most [`MAX_FRAMES`] frames and [`KEEP_NS`] of samples per moving edge.
    fn add_edge(
        &mut self,
        parent: &str,
        child: &str,
        t_ns: Option<u64>,
        t: &cdr::Transform,
        source: EdgeSource<'_>,
    ) -> Result<(), EdgeReject> {
        if self.tree.edges.len() >= MAX_FRAMES && !self.tree.edges.contains_key(frame(child).as_str()) {
            return Err(EdgeReject::TooManyFrames);
        }
        match t_ns {
            Some(at) => self.tree.push(parent, child, at, t, source),
            None => self.tree.set_static(parent, child, t),
        }?;
        if let Some(at) = t_ns {
            self.last_odom = Some(Instant::now());
            self.tree.forget_before(at.saturating_sub(KEEP_NS));
        }
        Ok(())
    }

    /// Whether odometry (or `tf`) came within the watchdog's time (none yet counts as fresh:
    /// nothing has been driven on it).
    pub(super) fn odometry_fresh(&self) -> bool {
        self.last_odom.is_none_or(|t| t.elapsed() < self.opts.watchdog)
    }

    /// Places the scans whose pose is known (or whose wait is over) as frames, in order.
    fn place(&mut self) {
        while let Some(p) = self.pending.front() {
            let laser = p.scan.header.frame_id.clone();
            let waited = p.since.elapsed() >= self.opts.pose_wait;
            let until = self.tree.moving_until(&laser);
            if until.is_none_or(|t| t < p.t_ns) && !waited {
                return;
            }
            let p = self.pending.pop_front().expect("a front");
            let at = p.t_ns as f64 / 1e9;
            if !self.tree.knows(&laser) {
                let wait = self.opts.pose_wait;
                self.reject_scan(
                    "unknown-frame",
                    format!("scan frame `{laser}` is in no transform (tf, tf_static, odom) after {wait:?}"),
                    p.t_ns,
                );
                continue;
            }
            if until.is_none() {
                // Only fixed transforms place it: without odometry it would be drawn at the
                // mount's offset from a made-up origin.
                self.reject_scan("no-odometry-yet", format!("no odometry or tf moves scan frame `{laser}` (scan at {at} s)"), p.t_ns);
                continue;
            }
            match self.tree.resolve_at(&laser, p.t_ns) {
                Ok((pose, _, depth)) if depth > 0 && p.cloud && rosbag::tilted(&pose) => self.reject_scan(
                    "cloud-tilted",
                    format!("a point cloud in frame `{laser}`, tilted more than {MAX_CLOUD_TILT_DEG}° from level (scan at {at} s)"),
                    p.t_ns,
                ),
                Ok((pose, root, depth)) if depth > 0 => {
                    let r = scan_record(&p.scan, &pose, p.t_ns, Location::Offset(0));
                    let Some(pose2) = Pose2::from_f64(r.pose[0], r.pose[1], r.pose[2]) else {
                        self.reject_scan("pose-not-finite", format!("the laser's pose at {at} s is not finite"), p.t_ns);
                        continue;
                    };
                    let limits = RangeLimits::new(r.range_limits_m[0], r.range_limits_m[1]);
                    let Some(scan) = encode_planar(r.angle_min, r.angle_increment, &r.ranges_m, limits) else {
                        self.reject_scan("scan-angle-increment", "beam angles that are not finite".into(), p.t_ns);
                        continue;
                    };
                    let frame = Frame {
                        t_us: p.t_ns / 1000,
                        pose: Some(pose2),
                        base_pose: r.pose,
                        time_s: p.t_ns as f64 / 1e9,
                        scan,
                        labels: false,
                        detection: false,
                        base_blocked: false,
                    };
                    if self.ready.len() >= MAX_READY {
                        // Lockstep with a publisher faster than the controller: the oldest goes.
                        self.ready.pop_front();
                        self.reject("scan-overrun", format!("more than {MAX_READY} placed scans waiting for the controller"));
                    }
                    self.ready.push_back((frame, root));
                }
                Ok(_) | Err(PoseError::NoPose) => {
                    self.reject_scan("unknown-frame", format!("scan frame `{laser}` has no root frame"), p.t_ns)
                }
                Err(PoseError::NoOdometryYet) => {
                    self.reject_scan("no-odometry-yet", format!("a scan stamped {at} s, before the first odometry"), p.t_ns)
                }
                Err(PoseError::Stale) => {
                    let age = MAX_POSE_AGE_NS as f64 / 1e9;
                    self.reject_scan("stale-pose", format!("no odometry within {age} s of the scan stamped {at} s"), p.t_ns)
                }
            }
        }
    }

    fn wait(&mut self, timeout: Duration) {
        let _ = self.poll.poll(&mut self.events, Some(timeout));
        self.take_all();
        self.place();
    }

    /// The rejections so far, by name.
    pub fn rejected(&self) -> BTreeMap<String, u64> {
        self.rejected.borrow().clone()
    }

    /// Messages received so far, by topic.
    pub fn received(&self) -> BTreeMap<&'static str, u64> {
        self.received.borrow().clone()
    }
}

impl Source for Ros2Source {
    fn sense(&mut self, _tick: u32) -> Option<Frame> {
        loop {
            let idle = self.opts.max_idle.is_some_and(|m| self.arrived.get().unwrap_or(self.started).elapsed() >= m);
            if idle || self.stop.load(Ordering::Relaxed) || self.opts.max_wall.is_some_and(|m| self.started.elapsed() >= m) {
                return None;
            }
            // The watchdog: odometry stopped while a goal is out.
            if self.driving.get() && !self.odometry_fresh() {
                self.announce_stop("stale-odometry", &format!("no odometry for {:?}", self.opts.watchdog));
                self.held.set(true);
            }
            let due = self.opts.lockstep || Instant::now() >= self.next_tick;
            if due && !self.ready.is_empty() {
                let (mut frame, root) = if self.opts.lockstep {
                    self.ready.pop_front().expect("not empty")
                } else {
                    // Real time: the newest placed scan; older ones are superseded.
                    let newest = self.ready.pop_back().expect("not empty");
                    self.ready.clear();
                    crate::link::advance_deadline(&mut self.next_tick, self.opts.period, Instant::now());
                    newest
                };
                frame.detection = std::mem::take(&mut self.detection);
                frame.base_blocked = std::mem::take(&mut self.blocked);
                self.pose.set(Some((frame.base_pose, frame.t_us * 1000)));
                *self.root.borrow_mut() = root;
                return Some(frame);
            }
            let wait = if self.opts.lockstep {
                Duration::from_millis(50)
            } else {
                self.next_tick.saturating_duration_since(Instant::now()).clamp(Duration::from_millis(1), Duration::from_millis(50))
            };
            self.wait(wait);
        }
    }

    fn act(&mut self, _answer: &Answer) -> bool {
        // The answer went out in `publish` (the observer), with the status that belongs to it.
        true
    }
}

/// A scan that cannot be used as it is: `(rejection name, detail)`.
fn scan_problem(s: &cdr::LaserScan) -> Option<(&'static str, String)> {
    if s.ranges.is_empty() {
        return Some(("scan-empty", "a scan with no ranges".into()));
    }
    if s.ranges.len() > 1 && !(s.angle_increment.is_finite() && s.angle_increment != 0.0) {
        return Some(("scan-angle-increment", format!("angle_increment {} with {} ranges", s.angle_increment, s.ranges.len())));
    }
    if !s.angle_min.is_finite() {
        return Some(("scan-angle-increment", format!("angle_min {}", s.angle_min)));
    }
    if !s.intensities.is_empty() && s.intensities.len() != s.ranges.len() {
        return Some(("scan-length-mismatch", format!("{} ranges but {} intensities", s.ranges.len(), s.intensities.len())));
    }
    let span = s.angle_increment as f64 * (s.ranges.len() - 1) as f64;
    let declared = s.angle_max as f64 - s.angle_min as f64;
    if s.angle_max.is_finite() && (span - declared).abs() > (s.angle_increment as f64).abs() * 1.5 + 1e-3 {
        return Some((
            "scan-length-mismatch",
            format!("{} ranges at {} rad span {span:.4} rad, angle_max − angle_min is {declared:.4}", s.ranges.len(), s.angle_increment),
        ));
    }
    None
}

/// A header's stamp in nanoseconds, as it is (zero is a simulator's first tick; a stamp before
/// 1970 counts as zero).
fn stamp(h: &cdr::Header) -> u64 {
    (h.stamp.sec as i64 * 1_000_000_000 + h.stamp.nanosec as i64).max(0) as u64
}

/// A QoS's reliability and durability in ROS's words.
fn qos_words(q: &rustdds::QosPolicies) -> String {
    use rustdds::policy::{Durability, Reliability};
    let rel = match q.reliability() {
        Some(Reliability::Reliable { .. }) => "reliable",
        _ => "best effort",
    };
    let dur = match q.durability() {
        Some(Durability::TransientLocal) => "transient local",
        Some(Durability::Transient) => "transient",
        Some(Durability::Persistent) => "persistent",
        _ => "volatile",
    };
    format!("{rel}, {dur}")
}

fn edge_reject_name(r: EdgeReject) -> &'static str {
    match r {
        EdgeReject::Invalid => "pose-not-finite",
        EdgeReject::Loop => "tf-loop",
        EdgeReject::Backwards => "stamp-backwards",
        EdgeReject::Jump => "odometry-jump",
        EdgeReject::Superseded => "superseded",
        EdgeReject::TooManyFrames => "too-many-frames",
    }
}

#[cfg(test)]
mod tests;
