//! `lives bridge`: the host side of the serial link.
//!
//! The bridge's session (`Bridge`) drives a base: the simulator's ([`super::Source::Sim`], whose
//! run is the run loop with the node as its brain, `super::sim_bridge`) or a robot's behind the
//! base adapter ([`super::Source::Robot`], whose loop is `super::robot`). Each tick it
//! sends the robot's pose, the LiDAR scan, a detection (if any) and the base's state as frames;
//! it drives the base with the goals that come back and stops it on `Stop`. It opens the session
//! with `Hello` (sent again every `hello_interval` until a `HelloAck`, whose version it checks),
//! sends `Reset` (each run is a new search: the node clears its maps and, in lockstep, starts
//! its time again) and the controller's configuration for the world, then `Start`.
//!
//! **Time.** In [`TimeMode::Lockstep`] the simulator waits for the node: batch `t` (the tick's
//! frames closed by `Heartbeat { t_us: t }`) is sent, and the tick is done when `Status(t)` and
//! the echo of that heartbeat are back (and, while exploring, the goal the status counts). A batch
//! with no echo after `retry_timeout`, or an echo without its `Status` (the node did not get the
//! whole batch, or its answer was damaged), is sent again, byte for byte: the node ticks a time
//! once, so a retry never changes the run. With a clean link the run is the in-process
//! [`crate::search::run`] tick for tick. In [`TimeMode::RealTime`] the bridge sends a batch every
//! `period` of wall time (closed by a heartbeat, so a node started in lockstep ticks it too),
//! moves the base for that period, and applies goals as they arrive.
//!
//! **Link loss.** No frame from the node for `watchdog`, or the port failing, is a lost link: the
//! base is stopped at once, the session is closed, and the bridge keeps reopening the port (when it
//! has a path) and saying `Hello`. When the node answers again the search resumes: the node sends
//! its goal again after every `Hello`, and the bridge applies it.
//!
//! **Health** ([`LinkStats`]): frames and bytes each way, frames rejected by the decoder (by
//! cause), batch retries, `Hello`s, losses, reconnections, and the round-trip time of heartbeat
//! echoes.

use super::{Link, Summary, TimeMode};
use crate::run::TICK_US;
use crate::search::SearchResult;
use firmware::protocol::{
    encode, ConfigMsg, CoreToHost, DetectionMsg, ErrorCode, GoalMsg, Heartbeat, Hello, HostDecoder, HostToCore, IncompatiblePeer,
    LinkCounters, PoseMsg, Role, ScanMsg, StatusMsg, WireCommand, WireMode, MAX_FRAME_LEN,
};
use firmware::BinaryAngle;
use std::collections::VecDeque;
use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Heartbeat sequence numbers of the bridge start here (the node's own count from 1).
pub(super) const SEQ_BASE: u32 = 0x8000_0000;

/// Lockstep: a batch the node echoes at least this many times in a row, for at least
/// [`NOT_TICKING_FOR`], without ticking it, while it sends statuses of other times, is an error
/// ([`BridgeError::NotLockstep`]), not a retry for ever.
pub const NOT_TICKING_ECHOES: u32 = 20;

/// See [`NOT_TICKING_ECHOES`]: long enough for a node in real time to show its own ticks.
pub const NOT_TICKING_FOR: Duration = Duration::from_secs(2);

/// What the bridge drives: the simulator's base or a robot's (through the adapter). The bridge's
/// session calls [`Base::stop_base`] when the link to the node is lost.
pub trait Base {
    /// Seconds since the run started (simulated, or wall time for a robot).
    fn time_s(&self) -> f64;
    /// The base's pose `[x, y, yaw]`, map frame, metres and radians.
    fn pose(&self) -> [f64; 3];
    /// Drive along `path` and turn to `final_yaw` at its end.
    fn set_path(&mut self, path: &[[f64; 2]], final_yaw: Option<f64>);
    /// Stop now (the link to the node was lost).
    fn stop_base(&mut self);
}

/// How the bridge runs.
#[derive(Clone, Debug)]
pub struct BridgeOptions {
    /// Lockstep (the simulator waits for the node) or real time.
    pub mode: TimeMode,
    /// Ask the node for per-scan labels (`Labels` frames, for logging).
    pub want_labels: bool,
    /// No frame from the node for this long: the link is lost and the base stops.
    pub watchdog: Duration,
    /// Lockstep: a batch without an answer after this long is sent again.
    pub retry_timeout: Duration,
    /// `Hello` is sent again after this long without a `HelloAck`.
    pub hello_interval: Duration,
    /// Real time: tick period.
    pub period: Duration,
    /// Heartbeat probes (with the configuration in the first three) before `Start`: they measure
    /// the link's round trip with no tick in it.
    pub setup_probes: u32,
    /// Back-off between reopen attempts of a failed port.
    pub reconnect_every: Duration,
    /// Give up after this much wall time (outcome `stopped`).
    pub max_wall: Option<Duration>,
    /// No `HelloAck` this long after the start: no node is answering ([`BridgeError::NoSession`]).
    /// Only the first session: a link lost later is reopened for as long as it takes.
    pub first_hello_timeout: Option<Duration>,
    /// Ticks done, for a watcher (tests, progress bars).
    pub progress: Option<Arc<AtomicU32>>,
    /// Send each scan as segments of this many beams (`ScanSegment` frames, at most
    /// [`firmware::protocol::MAX_SEGMENT_BEAMS`]) instead of one `Scan` frame: for a noisy line,
    /// where a 2.7 kB scan frame rarely arrives whole but 80-byte segments mostly do. `0`: whole
    /// scans.
    pub scan_segment_beams: usize,
    /// Sees each tick's pose, scan and detection and every message from the node (recordings:
    /// `host::link::record::SharedRecording`). It cannot change the run.
    pub observer: Option<SharedObserver>,
}

/// Watches a bridge run's traffic (see [`BridgeOptions::observer`]).
pub trait BridgeObserver: Send {
    /// The pose, scan and detection of a tick, once per tick (a retried batch is not shown again).
    fn tick(&mut self, pose: &PoseMsg, scan: &ScanMsg, detection: Option<&DetectionMsg>);
    /// A message from the node.
    fn received(&mut self, m: &CoreToHost);
}

/// A [`BridgeObserver`] shared with the caller, who gets it back after the run.
#[derive(Clone)]
pub struct SharedObserver(pub Arc<std::sync::Mutex<dyn BridgeObserver>>);

impl fmt::Debug for SharedObserver {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("SharedObserver")
    }
}

impl BridgeOptions {
    /// Defaults: 1 s watchdog and hello interval, 250 ms retries, 200 ms period.
    pub fn new(mode: TimeMode) -> Self {
        BridgeOptions {
            mode,
            want_labels: false,
            watchdog: Duration::from_secs(1),
            retry_timeout: Duration::from_millis(250),
            hello_interval: Duration::from_secs(1),
            period: Duration::from_micros(TICK_US),
            setup_probes: 20,
            reconnect_every: Duration::from_millis(100),
            max_wall: None,
            first_hello_timeout: Some(Duration::from_secs(15)),
            progress: None,
            scan_segment_beams: 0,
            observer: None,
        }
    }
}

/// Link health.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LinkStats {
    /// Frames written.
    pub frames_sent: u64,
    /// Bytes written.
    pub bytes_sent: u64,
    /// Frames decoded.
    pub frames_received: u64,
    /// Bytes read.
    pub bytes_received: u64,
    /// Frames rejected by the decoder (bad COBS, CRC, body, too long).
    pub rejected: u64,
    /// The decoder's counters by cause.
    pub decoder: LinkCounters,
    /// Lockstep batches sent again.
    pub retries: u64,
    /// `Hello`s sent.
    pub hellos_sent: u64,
    /// Times the link was lost (base stopped).
    pub link_losses: u32,
    /// Read or write failures.
    pub io_errors: u32,
    /// Successful reopenings of a failed port.
    pub reconnects: u32,
    /// `Error` frames from the node.
    pub errors_from_node: u32,
    /// Round trip of heartbeat probes with no tick in between (setup, real time), µs.
    pub link_rtt_us: Summary,
    /// Lockstep: from sending a batch to the echo closing its answer (link + tick), µs.
    pub batch_rtt_us: Summary,
    /// Bytes of the last scan on the wire: its frame, or all its segments' frames.
    pub scan_frame_bytes: usize,
    /// Frames of the last scan: 1, or its segments.
    pub scan_frames: usize,
    /// The node's last status (its own receive counters are in `link`).
    pub node_status: Option<StatusMsg>,
}

/// Something that happened on the link.
#[derive(Clone, Debug, PartialEq)]
pub enum BridgeEventKind {
    /// A `HelloAck` opened (or reopened) the session.
    SessionOpened,
    /// The link was lost and the base stopped.
    LinkLost {
        /// Silence or a port error.
        cause: String,
    },
    /// The port was reopened.
    Reopened,
}

/// A timestamped [`BridgeEventKind`].
#[derive(Clone, Debug)]
pub struct BridgeEvent {
    /// When.
    pub at: Instant,
    /// Simulated time then.
    pub sim_s: f64,
    /// What.
    pub kind: BridgeEventKind,
}

/// Why a bridge run could not happen.
#[derive(Clone, Debug, PartialEq)]
pub enum BridgeError {
    /// The node speaks another protocol version (or refused ours).
    Incompatible(IncompatiblePeer),
    /// Stopped (flag, `max_wall` or `first_hello_timeout`) before a session was opened.
    NoSession,
    /// Lockstep: the node echoed batch `t_us` this many times without ticking it, and sent
    /// statuses of its own times meanwhile: it ticks on its own clock (`lives node` without
    /// `--lockstep`).
    NotLockstep {
        /// The batch's time.
        t_us: u64,
        /// Attempts echoed without a tick.
        echoed: u32,
    },
    /// The robot source could not start (e.g. the base adapter's address is taken).
    Source(String),
    /// `lives` sent unlabelled scans, but the node classified none of them: it runs without a
    /// model (`lives node --no-model`), so it would search as `multisensor`.
    NoClassifier,
    /// The node refused the configuration: a field is outside the range its core works in
    /// (`Error { ConfigInvalid }`), so it would not search with it.
    ConfigInvalid {
        /// The field, as [`firmware::Config`] names it (`#N` for a field number this build does
        /// not know).
        field: String,
        /// Its range as this build's core gives it, if this build refuses the value too.
        allowed: Option<&'static str>,
    },
}

impl BridgeError {
    /// The node's refusal of field number `field` of `config` ([`ConfigMsg::FIELDS`]), with the
    /// range this build's core allows.
    pub(super) fn config_invalid(config: &ConfigMsg, field: u8) -> Self {
        let name = ConfigMsg::FIELDS.get(field as usize).copied();
        let allowed = config.config().validate().err().filter(|e| Some(e.field) == name).map(|e| e.allowed);
        BridgeError::ConfigInvalid { field: name.map_or_else(|| format!("#{field}"), str::to_string), allowed }
    }
}

impl fmt::Display for BridgeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BridgeError::Incompatible(e) => write!(f, "{e}"),
            BridgeError::NoSession => f.write_str(
                "no answer from the node (no HelloAck): is `lives node` (or the MCU image) running on the other end of the port?",
            ),
            BridgeError::NotLockstep { t_us, echoed } => write!(
                f,
                "the node answered the batch at t = {:.1} s {echoed} times without ticking it, and ticks on its own clock: \
                 start it with `lives node --lockstep`, or run the bridge without `--lockstep`",
                *t_us as f64 / 1e6
            ),
            BridgeError::Source(e) => f.write_str(e),
            BridgeError::NoClassifier => f.write_str(
                "the node classified none of the scans: it runs without a classifier model (`lives node --no-model`?); \
                 `--planner lives` needs one (start the node without `--no-model`), or run `--planner lives-gt` on the simulator's labels",
            ),
            BridgeError::ConfigInvalid { field, allowed: Some(allowed) } => {
                write!(f, "the node refused the configuration: `{field}` must be in {allowed}")
            }
            BridgeError::ConfigInvalid { field, allowed: None } => {
                write!(f, "the node refused the configuration: `{field}` is outside the range its core allows")
            }
        }
    }
}

impl std::error::Error for BridgeError {}

/// Scans after which a node expected to classify (`lives` without labels) must have done so.
pub const CLASSIFIER_CHECK_SCANS: u32 = 3;

/// Whether a node that should label the scans itself does: its status reports the classify
/// stage's work (`cost.classify`), which stays 0 while it has no model.
#[derive(Clone, Copy, Debug)]
pub(super) struct ClassifierCheck {
    pub(super) expected: bool,
    pub(super) seen: bool,
}

impl ClassifierCheck {
    pub(super) fn observe(&mut self, s: &StatusMsg) -> Result<(), BridgeError> {
        if self.expected && !self.seen {
            self.seen = s.cost.classify > 0;
            if !self.seen && s.scans >= CLASSIFIER_CHECK_SCANS {
                return Err(BridgeError::NoClassifier);
            }
        }
        Ok(())
    }
}

/// A search run through the link.
pub struct BridgeResult {
    /// As `lives search` reports it (outcome `stopped` if the run was cut short).
    pub result: SearchResult,
    /// Every new goal applied to the base, in order (cell and heading), as
    /// [`crate::search::SearchRun::goals`].
    pub goals: Vec<((i32, i32), BinaryAngle)>,
    /// Every `Goal` frame received (repeats included).
    pub goals_received: Vec<GoalMsg>,
    /// Link health.
    pub stats: LinkStats,
    /// Sessions, losses, reopenings.
    pub events: Vec<BridgeEvent>,
    /// Robot positions, one per tick.
    pub trajectory: Vec<[f64; 2]>,
    /// Wall time of the run.
    pub wall_s: f64,
}

/// The session with the node, generic over the base it drives (the simulator's or a robot's).
pub(super) struct Bridge<'l, B: Base> {
    link: &'l mut dyn Link,
    pub(super) opts: BridgeOptions,
    stop: &'l AtomicBool,
    pub(super) started: Instant,
    pub(super) dec: HostDecoder,
    buf: Vec<u8>,
    enc: Vec<u8>,
    pub(super) st: LinkStats,
    pub(super) link_rtt: Vec<f64>,
    pub(super) batch_rtt: Vec<f64>,
    probes: VecDeque<(u32, u64, Instant, bool)>,
    seq: u32,
    pub(super) events: Vec<BridgeEvent>,
    pub(super) open: bool,
    was_open: bool,
    lost: bool,
    down: bool,
    last_rx: Instant,
    last_hello: Option<Instant>,
    last_reopen: Instant,
    pub(super) incompatible: Option<IncompatiblePeer>,
    /// The field of the configuration the node refused as out of range (`Error { ConfigInvalid }`).
    pub(super) config_invalid: Option<u8>,
    pub(super) sim: B,
    pub(super) goal: Option<GoalMsg>,
    status: Option<StatusMsg>,
    pub(super) goals_received: Vec<GoalMsg>,
    applied_seq: Option<u32>,
    /// The goal the base was driving to when the link was lost.
    interrupted_seq: Option<u32>,
}

impl<'l, B: Base> Bridge<'l, B> {
    /// Fills the run's link statistics from the decoder's counters and the round-trip samples.
    pub(super) fn finish_stats(&mut self) {
        self.st.decoder = self.dec.counters();
        self.st.rejected = self.st.decoder.dropped() as u64;
        self.st.link_rtt_us = Summary::of(&self.link_rtt);
        self.st.batch_rtt_us = Summary::of(&self.batch_rtt);
    }

    /// A bridge on `link` driving `sim`, no session yet.
    pub(super) fn new(link: &'l mut dyn Link, opts: &BridgeOptions, stop: &'l AtomicBool, sim: B) -> Self {
        Bridge {
            link,
            opts: opts.clone(),
            stop,
            started: Instant::now(),
            dec: HostDecoder::new(),
            buf: vec![0u8; 16384],
            enc: vec![0u8; MAX_FRAME_LEN],
            st: LinkStats::default(),
            link_rtt: Vec::new(),
            batch_rtt: Vec::new(),
            probes: VecDeque::new(),
            seq: 0,
            events: Vec::new(),
            open: false,
            was_open: false,
            lost: false,
            down: false,
            last_rx: Instant::now(),
            last_hello: None,
            last_reopen: Instant::now(),
            incompatible: None,
            config_invalid: None,
            sim,
            goal: None,
            status: None,
            goals_received: Vec::new(),
            applied_seq: None,
            interrupted_seq: None,
        }
    }

    pub(super) fn frame(&mut self, m: &HostToCore) -> Vec<u8> {
        match encode(m, &mut self.enc) {
            Ok(f) => f.to_vec(),
            Err(e) => panic!("a host message must always fit a frame buffer: {e}"),
        }
    }

    pub(super) fn should_stop(&self) -> bool {
        self.stop.load(Ordering::Relaxed) || self.opts.max_wall.is_some_and(|m| self.started.elapsed() >= m)
    }

    fn event(&mut self, kind: BridgeEventKind) {
        self.events.push(BridgeEvent { at: Instant::now(), sim_s: self.sim.time_s(), kind });
    }

    /// The link is gone: stop the base now, close the session.
    fn lose(&mut self, cause: String) {
        self.open = false;
        if let Some(seq) = self.applied_seq.take() {
            self.interrupted_seq = Some(seq);
        }
        if self.was_open && !self.lost {
            self.lost = true;
            self.sim.stop_base();
            self.st.link_losses += 1;
            self.event(BridgeEventKind::LinkLost { cause });
        }
    }

    pub(super) fn send(&mut self, bytes: &[u8]) -> bool {
        if self.down {
            return false;
        }
        match self.link.write_all(bytes) {
            Ok(()) => {
                self.st.frames_sent += bytes.iter().filter(|&&b| b == 0).count() as u64;
                self.st.bytes_sent += bytes.len() as u64;
                true
            }
            Err(e) => {
                self.st.io_errors += 1;
                self.down = true;
                self.last_reopen = Instant::now();
                self.lose(format!("write failed on {}: {e}", self.link.describe()));
                false
            }
        }
    }

    /// A heartbeat probe at `t_us`; `link_only` if no tick answers it.
    pub(super) fn probe(&mut self, t_us: u64, link_only: bool) -> (u32, Vec<u8>) {
        self.seq = self.seq.wrapping_add(1);
        let seq = SEQ_BASE | (self.seq & !SEQ_BASE);
        if self.probes.len() >= 64 {
            self.probes.pop_front();
        }
        self.probes.push_back((seq, t_us, Instant::now(), link_only));
        (seq, self.frame(&HostToCore::Heartbeat(Heartbeat { t_us, seq })))
    }

    fn handle(&mut self, m: &CoreToHost) {
        if let Some(Ok(mut o)) = self.opts.observer.as_ref().map(|o| o.0.lock()) {
            o.received(m);
        }
        match m {
            CoreToHost::HelloAck(a) => match a.check() {
                Ok(()) => {
                    if !self.open {
                        self.open = true;
                        self.was_open = true;
                        self.lost = false;
                        self.event(BridgeEventKind::SessionOpened);
                    }
                }
                Err(e) => self.incompatible = Some(e),
            },
            CoreToHost::Heartbeat(h) => {
                if let Some(i) = self.probes.iter().position(|p| p.0 == h.seq && p.1 == h.t_us) {
                    if let Some((_, _, sent, link_only)) = self.probes.remove(i) {
                        let us = sent.elapsed().as_secs_f64() * 1e6;
                        if link_only { &mut self.link_rtt } else { &mut self.batch_rtt }.push(us);
                    }
                }
            }
            CoreToHost::Goal(g) => {
                self.goals_received.push(g.clone());
                self.goal = Some(g.clone());
            }
            CoreToHost::Status(s) => {
                self.status = Some(*s);
                self.st.node_status = Some(*s);
            }
            CoreToHost::Error(e) => {
                self.st.errors_from_node += 1;
                if let ErrorCode::ConfigInvalid { field } = e.code {
                    self.config_invalid = Some(field);
                }
            }
            CoreToHost::Stop(_) | CoreToHost::Labels(_) => {}
        }
    }

    /// Reads for up to `wait`, handles what came, watches the link. Returns the messages.
    pub(super) fn poll(&mut self, wait: Duration) -> Vec<CoreToHost> {
        let mut got = Vec::new();
        let now = Instant::now();
        if self.down {
            std::thread::sleep(wait.min(self.opts.reconnect_every));
            if self.last_reopen.elapsed() >= self.opts.reconnect_every {
                self.last_reopen = Instant::now();
                if self.link.reconnect().is_ok() {
                    self.down = false;
                    self.st.reconnects += 1;
                    self.dec.clear();
                    self.last_rx = Instant::now();
                    self.last_hello = None;
                    self.event(BridgeEventKind::Reopened);
                }
            }
        } else {
            // Wake in time for the watchdog.
            let left = (self.last_rx + self.opts.watchdog).saturating_duration_since(now);
            let wait = if self.open && !left.is_zero() { wait.min(left) } else { wait };
            match self.link.read(&mut self.buf, wait) {
                Ok(n) => {
                    self.st.bytes_received += n as u64;
                    let bytes = std::mem::take(&mut self.buf);
                    let msgs: Vec<_> = self.dec.feed(&bytes[..n]).flatten().collect();
                    self.buf = bytes;
                    for m in msgs {
                        self.last_rx = Instant::now();
                        self.st.frames_received += 1;
                        self.handle(&m);
                        got.push(m);
                    }
                }
                Err(e) => {
                    self.st.io_errors += 1;
                    self.down = true;
                    self.last_reopen = Instant::now();
                    self.lose(format!("read failed on {}: {e}", self.link.describe()));
                    std::thread::sleep(wait.min(self.opts.reconnect_every));
                }
            }
        }
        if self.open && self.last_rx.elapsed() >= self.opts.watchdog {
            let cause = format!("no frame from the node for {:?}", self.opts.watchdog);
            self.lose(cause);
        }
        if !self.open && !self.down && self.last_hello.is_none_or(|t| t.elapsed() >= self.opts.hello_interval) {
            let hello = self.frame(&HostToCore::Hello(Hello::new(Role::Simulator, self.opts.want_labels)));
            self.last_hello = Some(Instant::now());
            if self.send(&hello) {
                self.st.hellos_sent += 1;
            }
        }
        got
    }

    /// Until a session is open. `Err` on an incompatible node, or no node answering the first
    /// `Hello`s for [`BridgeOptions::first_hello_timeout`]; `Ok(false)` if told to stop.
    pub(super) fn await_session(&mut self) -> Result<bool, BridgeError> {
        while !self.open {
            if let Some(e) = self.incompatible {
                return Err(BridgeError::Incompatible(e));
            }
            if self.should_stop() {
                return Ok(false);
            }
            if !self.was_open && self.opts.first_hello_timeout.is_some_and(|t| self.started.elapsed() >= t) {
                return Err(BridgeError::NoSession);
            }
            self.poll(Duration::from_millis(20));
        }
        Ok(true)
    }

    /// Opens the session, sends the configuration and then `known` (a known building's map rows
    /// and route, `crate::live`; each copy resets what the last one gave), measures the link.
    /// `Err` if the node refuses the configuration as out of range.
    pub(super) fn setup(&mut self, config: &ConfigMsg, known: &[HostToCore]) -> Result<(), BridgeError> {
        if !self.await_session()? {
            return Err(BridgeError::NoSession);
        }
        // A new search: `Reset` first (the node clears its maps and, in lockstep, starts its time
        // again, whatever it ran before), then the configuration (refused unless idle).
        let mut cfg = self.frame(&HostToCore::Command(WireCommand::Reset));
        cfg.extend(self.frame(&HostToCore::Config(*config)));
        for m in known {
            cfg.extend(self.frame(m));
        }
        for i in 0..self.opts.setup_probes.max(3) {
            let mut bytes = if i < 3 { cfg.clone() } else { Vec::new() };
            let (seq, hb) = self.probe(0, true);
            bytes.extend(hb);
            self.send(&bytes);
            let t0 = Instant::now();
            while t0.elapsed() < self.opts.retry_timeout && !self.should_stop() {
                let got = self.poll(Duration::from_millis(20));
                if got.iter().any(|m| matches!(m, CoreToHost::Heartbeat(h) if h.seq == seq)) {
                    break;
                }
            }
            if let Some(field) = self.config_invalid {
                return Err(BridgeError::config_invalid(config, field));
            }
            if !self.await_session()? {
                return Err(BridgeError::NoSession);
            }
        }
        Ok(())
    }

    /// Drives the base to `g` unless it already is. The goal interrupted by a lost link resumes
    /// from the path segment nearest the robot, not from the path's start (already driven).
    pub(super) fn apply_goal(&mut self, g: &GoalMsg) -> bool {
        if self.applied_seq == Some(g.seq) {
            return false;
        }
        let mut path: Vec<[f64; 2]> = g.waypoints().map(|(x, y)| [x.to_num::<f64>(), y.to_num::<f64>()]).collect();
        if self.interrupted_seq == Some(g.seq) {
            let p = self.sim.pose();
            path = resume_from(&path, [p[0], p[1]]);
        }
        self.sim.set_path(&path, Some(BinaryAngle(g.theta).to_radians()));
        self.applied_seq = Some(g.seq);
        self.interrupted_seq = None;
        true
    }

    /// While exploring, the status counts `goals` goals and the current one has that `seq`: it must
    /// be here (none yet if the count is 0, e.g. exploring without a valid pose).
    pub(super) fn goal_consistent(&self, s: &StatusMsg) -> bool {
        s.mode != WireMode::Exploring || s.goals == 0 || self.goal.as_ref().is_some_and(|g| g.seq == s.goals)
    }
}

/// The rest of `path` for a robot at `p`: from the end of the segment nearest to it.
pub(super) fn resume_from(path: &[[f64; 2]], p: [f64; 2]) -> Vec<[f64; 2]> {
    let seg_dist = |a: [f64; 2], b: [f64; 2]| {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 { (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
        (a[0] + t * dx - p[0]).hypot(a[1] + t * dy - p[1])
    };
    let best = (0..path.len().saturating_sub(1)).min_by(|&i, &j| seg_dist(path[i], path[i + 1]).total_cmp(&seg_dist(path[j], path[j + 1])));
    match best {
        Some(i) => path[i + 1..].to_vec(),
        None => path.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interrupted_path_resumes_past_what_was_driven() {
        let path = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert_eq!(resume_from(&path, [1.0, 0.1]), path[1..].to_vec());
        assert_eq!(resume_from(&path, [2.1, 1.5]), path[2..].to_vec());
        assert_eq!(resume_from(&path, [-1.0, 0.0]), path[1..].to_vec());
        assert_eq!(resume_from(&path[..1], [5.0, 5.0]), path[..1].to_vec());
    }
}
