//! # The controller as a node on a serial line
//!
//! A [`Node`] sits between a byte stream and the [`Controller`]: bytes in → [`CoreDecoder`] →
//! [`Session`] (the handshake) → [`Inbox`] → one tick's [`crate::Inputs`]; the tick's
//! [`crate::Outputs`] → [`output_messages`] → [`encode`] → bytes out, handed to a `send`
//! callback one frame at a time. It owns no port and reads no clock: the caller moves the bytes
//! and says what time it is. Nothing allocates; a bad frame is dropped and counted by the
//! decoder and never reaches the controller.
//!
//! ## Time modes
//!
//! * **Real time** ([`TimeMode::RealTime`], the deployment): the caller ticks the node at a fixed
//!   rate (the LiDAR's 5 Hz: every 200 ms) with [`Node::tick`], `now_us` read from a monotonic
//!   clock *by the host process* (on an MCU, a hardware timer), never by this crate. Messages are
//!   collected between ticks (the latest pose and scan win); their `t_us` stamps are the host's
//!   and do not drive anything. Host heartbeats are echoed at once, so the echo measures the link.
//! * **Lockstep** ([`TimeMode::Lockstep`], simulation and tests): time is the host's. A batch for
//!   time `t` is a `Pose` and a `Scan` stamped `t` (and optionally `Detection`, `Command`,
//!   `BaseStatus`), closed by a `Heartbeat { t_us: t }` (a heartbeat with neither a pose nor a
//!   scan since the last tick is only a probe, echoed). On that heartbeat the node ticks with
//!   `now_us = t` — the same inputs at the same time as an in-process loop, so the link changes
//!   nothing. It ticks only when both the pose and the scan stamped `t` arrived: a batch that lost
//!   one of them is not ticked (counted in [`NodeCounters::lockstep_incomplete`]) and the host sends
//!   it again. A scan sent in segments (protocol v2) is assembled across the attempts at a batch
//!   (a retry brings the segments again, and the ones lost before fill in); the batch ticks as
//!   soon as the scan is complete — on a clean line at once, so segments change nothing — or, if
//!   beams are still missing, on the [`NodeConfig::lockstep_partial_after`]-th heartbeat closing
//!   it (default 8), with the beams that arrived ([`NodeCounters::lockstep_partial`]): a noisy
//!   line delays a tick by a bounded number of retries and then costs beams, not the tick. A heartbeat for the time already ticked (a retry whose answer was lost) ticks
//!   nothing and sends that tick's outputs again, the goal included; an older one is ignored.
//!   Every host heartbeat is echoed *after* it was handled, so in this mode the echo says "batch
//!   `t` is done" and follows the tick's `Status`: a host that sees the echo without `Status(t)`
//!   knows the batch was incomplete (or its answer lost) and retries at once. A
//!   `Command(Reset)` is applied on arrival, not at a tick: the controller forgets everything but
//!   its configuration and model, and time starts again, so one node serves search after search.
//!
//! In both modes the controller's own watchdog is the node's: no pose or scan for
//! `watchdog_us` (by `now_us`) stops the robot. In lockstep time stands still while no batch
//! arrives, so only the host's link watchdog can notice a pulled cable.
//!
//! ## What the node sends
//!
//! After each tick, once a session is open: `Goal` when its `seq` or path changed since the last
//! one sent, after every `Hello`, on a lockstep repeat, and at least every
//! [`NodeConfig::goal_refresh_us`] while there is one (a lost goal costs at most that long);
//! `Stop` every tick the base must stop; `Status` every tick; `Labels` after every integrated scan
//! if the host's `Hello` asked for them; its own `Heartbeat` when it sent none for
//! [`NodeConfig::heartbeat_interval_us`]. A `Config` is applied when it arrives if the controller
//! is idle, else refused with `Error { ConfigRefused }`; one with a field outside its range
//! ([`crate::Config::validate`]) is refused with `Error { ConfigInvalid { field } }`, and the
//! controller keeps its configuration. Messages before a compatible `Hello` are answered with one
//! `Error` per host heartbeat at most.

use crate::config::ConfigError;
use crate::controller::{Controller, Mode, Outputs, StageObserver, Status};
use crate::knownmap::PriorError;
use crate::protocol::frame::CRC;
use crate::protocol::{
    encode, output_messages, Accepted, Admission, ConfigMsg, CoreDecoder, CoreToHost, ErrorCode, ErrorMsg, Heartbeat, HostToCore, Inbox,
    LabelsMsg, LinkCounters, MapRowMsg, RouteMsg, Session, StatusMsg, WireCommand, MAP_ROW_BYTES, MAX_CORE_TO_HOST_FRAME,
};
use fixed_point::{BinaryAngle, Meters};

/// Who says what time it is (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TimeMode {
    /// The caller ticks the node on its own fixed-rate clock ([`Node::tick`]).
    RealTime,
    /// The node ticks on a host heartbeat closing a batch, at the heartbeat's `t_us`.
    Lockstep,
}

/// The node's settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct NodeConfig {
    /// Who drives time.
    pub time_mode: TimeMode,
    /// The node sends its own `Heartbeat` after this long without sending one (µs).
    pub heartbeat_interval_us: u64,
    /// A goal is sent again after this long even if unchanged (µs).
    pub goal_refresh_us: u64,
    /// Lockstep: a batch whose pose arrived but whose scan (sent in segments) is still missing
    /// beams ticks on this many-th heartbeat closing it, with the beams that arrived (`0` or `1`:
    /// on the first). A complete scan ticks at once.
    pub lockstep_partial_after: u8,
}

impl NodeConfig {
    /// One-second heartbeats and goal refreshes in `time_mode`; a partial scan ticks on the eighth
    /// heartbeat of its batch (on a line that delivers 45 % of the segments per attempt, eight
    /// attempts bring 99 % of them; lockstep time stands still meanwhile, so retries cost wall
    /// time only).
    pub const fn new(time_mode: TimeMode) -> Self {
        Self { time_mode, heartbeat_interval_us: 1_000_000, goal_refresh_us: 1_000_000, lockstep_partial_after: 8 }
    }
}

/// What the node did, beyond the decoder's [`LinkCounters`]. All wrap.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct NodeCounters {
    /// Bytes given to [`Node::receive`].
    pub bytes_received: u64,
    /// Frames handed to `send`.
    pub frames_sent: u32,
    /// Bytes handed to `send`.
    pub bytes_sent: u64,
    /// Controller ticks run.
    pub ticks: u32,
    /// `Goal` frames sent.
    pub goals_sent: u32,
    /// `Error` frames sent.
    pub errors_sent: u32,
    /// Host heartbeats echoed.
    pub heartbeats_echoed: u32,
    /// Own heartbeats sent.
    pub heartbeats_sent: u32,
    /// Configurations applied.
    pub configs_applied: u32,
    /// Configurations refused (controller not idle).
    pub configs_refused: u32,
    /// Configurations refused because a field was out of range ([`crate::Config::validate`]).
    pub configs_invalid: u32,
    /// `Command(Reset)`s applied: the controller cleared and, in lockstep, time started again.
    pub resets: u32,
    /// Lockstep: heartbeats for a new time whose pose or scan was missing, or whose scan was
    /// still missing beams (not ticked).
    pub lockstep_incomplete: u32,
    /// Lockstep: ticks with a scan missing beams (after [`NodeConfig::lockstep_partial_after`]
    /// heartbeats).
    pub lockstep_partial: u32,
    /// Lockstep: heartbeats for the time already ticked (outputs sent again).
    pub lockstep_repeats: u32,
    /// Lockstep: heartbeats older than the last tick (ignored).
    pub lockstep_stale: u32,
    /// Messages that could not be encoded (never expected: every buffer is sized for the worst).
    pub encode_errors: u32,
}

/// The controller's link end: decoder, handshake, inbox and output pacing. About 8 KiB.
pub struct Node {
    cfg: NodeConfig,
    decoder: CoreDecoder,
    session: Session,
    inbox: Inbox,
    tx: [u8; MAX_CORE_TO_HOST_FRAME],
    /// The last tick's time and outputs (sent again on a lockstep repeat).
    last_tick_us: Option<u64>,
    last_out: Option<Outputs>,
    /// Stamps of the pose and scan received since the last tick (lockstep completeness).
    pose_t_us: Option<u64>,
    scan_t_us: Option<u64>,
    /// Lockstep: the time of the batch whose scan is incomplete, and heartbeats that closed it.
    partial_beats: Option<(u64, u8)>,
    /// Fingerprint (CRC of the frame) and time of the last goal sent.
    goal_sent: Option<(u32, u64)>,
    resend_goal: bool,
    hb_seq: u32,
    hb_sent_us: Option<u64>,
    refused_since_beat: bool,
    last_config_error: Option<ConfigError>,
    counters: NodeCounters,
}

impl Node {
    /// A node with no session.
    pub const fn new(cfg: NodeConfig) -> Self {
        Self {
            cfg,
            decoder: CoreDecoder::new(),
            session: Session::new(),
            inbox: Inbox::new(),
            tx: [0; MAX_CORE_TO_HOST_FRAME],
            last_tick_us: None,
            last_out: None,
            pose_t_us: None,
            scan_t_us: None,
            partial_beats: None,
            goal_sent: None,
            resend_goal: false,
            hb_seq: 0,
            hb_sent_us: None,
            refused_since_beat: false,
            last_config_error: None,
            counters: NodeCounters {
                bytes_received: 0,
                frames_sent: 0,
                bytes_sent: 0,
                ticks: 0,
                goals_sent: 0,
                errors_sent: 0,
                heartbeats_echoed: 0,
                heartbeats_sent: 0,
                configs_applied: 0,
                configs_refused: 0,
                configs_invalid: 0,
                resets: 0,
                lockstep_incomplete: 0,
                lockstep_partial: 0,
                lockstep_repeats: 0,
                lockstep_stale: 0,
                encode_errors: 0,
            },
        }
    }

    /// The settings.
    pub const fn config(&self) -> &NodeConfig {
        &self.cfg
    }

    /// The handshake.
    pub const fn session(&self) -> &Session {
        &self.session
    }

    /// The receive counters (decoder and handshake), as reported in `Status`.
    pub const fn link_counters(&self) -> LinkCounters {
        self.session.counters(self.decoder.counters())
    }

    /// The node's own counters.
    pub const fn counters(&self) -> NodeCounters {
        self.counters
    }

    /// Why the last configuration refused as out of range was refused
    /// ([`NodeCounters::configs_invalid`]).
    pub const fn last_config_error(&self) -> Option<ConfigError> {
        self.last_config_error
    }

    /// The inbox (superseded scans, dropped commands).
    pub const fn inbox(&self) -> &Inbox {
        &self.inbox
    }

    /// Time of the last tick.
    pub const fn last_tick_us(&self) -> Option<u64> {
        self.last_tick_us
    }

    /// The port was closed or reopened: drops a partial frame. Session, inbox and controller stay
    /// (the host says `Hello` again after a reconnect; the goal is then sent again).
    pub fn link_reset(&mut self) {
        self.decoder.clear();
    }

    /// Takes bytes from the line. Answers go to `send`, one frame per call. In lockstep a
    /// heartbeat closing a complete batch ticks `ctl`; returns the number of ticks run.
    pub fn receive(&mut self, bytes: &[u8], ctl: &mut Controller, send: impl FnMut(&[u8])) -> u32 {
        self.receive_observed(bytes, ctl, send, &mut ())
    }

    /// [`Node::receive`], telling `obs` where each stage of a tick it runs begins and ends
    /// ([`Controller::tick_observed`]; the MCU's trace image times the stages with it).
    pub fn receive_observed(
        &mut self,
        bytes: &[u8],
        ctl: &mut Controller,
        mut send: impl FnMut(&[u8]),
        obs: &mut impl StageObserver,
    ) -> u32 {
        self.counters.bytes_received = self.counters.bytes_received.wrapping_add(bytes.len() as u64);
        let mut ticks = 0;
        for &b in bytes {
            // A bad frame is counted by the decoder and goes no further.
            if let Some(Ok(msg)) = self.decoder.push(b) {
                ticks += self.handle(msg, ctl, &mut send, obs);
            }
        }
        ticks
    }

    fn handle(&mut self, msg: HostToCore, ctl: &mut Controller, send: &mut impl FnMut(&[u8]), obs: &mut impl StageObserver) -> u32 {
        let is_beat = matches!(msg, HostToCore::Heartbeat(_));
        match self.session.admit(&msg) {
            Admission::Deliver => {}
            Admission::Answer(ack) => {
                self.emit(&CoreToHost::HelloAck(ack), send);
                // A (re)started host knows no goal yet.
                self.resend_goal = true;
                return 0;
            }
            Admission::Refuse(code) => {
                if !self.refused_since_beat {
                    self.emit_error(code, send);
                }
                // At most one error per host heartbeat period.
                self.refused_since_beat = !is_beat;
                return 0;
            }
        }
        if matches!(msg, HostToCore::Command(WireCommand::Reset)) {
            // At once, not at the next tick: a host starting a new search resets first, then
            // configures (refused unless idle) and starts; in lockstep its time starts again.
            ctl.reset();
            self.inbox.clear_inputs();
            self.last_tick_us = None;
            self.last_out = None;
            self.forget_batch();
            // The new search's goals count from 1 again: the first is news, whatever was sent.
            self.goal_sent = None;
            self.resend_goal = true;
            self.counters.resets = self.counters.resets.wrapping_add(1);
            return 0;
        }
        let (beat, pose_t, scan_t) = match &msg {
            HostToCore::Pose(p) => (None, Some(p.t_us), None),
            HostToCore::Scan(s) => (None, None, Some(s.t_us)),
            HostToCore::ScanSegment(s) => (None, None, Some(s.t_us)),
            HostToCore::Heartbeat(h) => (Some(*h), None, None),
            _ => (None, None, None),
        };
        match self.inbox.accept(msg) {
            Accepted::Config(c) => {
                if ctl.mode() != Mode::Idle {
                    self.counters.configs_refused = self.counters.configs_refused.wrapping_add(1);
                    self.emit_error(ErrorCode::ConfigRefused, send);
                } else if let Err(e) = ctl.set_config(c.config()) {
                    // Out of range: the controller keeps the configuration it has.
                    self.counters.configs_invalid = self.counters.configs_invalid.wrapping_add(1);
                    self.last_config_error = Some(e);
                    let field = ConfigMsg::field_index(e.field).unwrap_or(u8::MAX);
                    self.emit_error(ErrorCode::ConfigInvalid { field }, send);
                } else {
                    self.counters.configs_applied = self.counters.configs_applied.wrapping_add(1);
                }
            }
            Accepted::MapRow(m) => {
                if apply_map_row(ctl, &m).is_err() {
                    self.emit_error(ErrorCode::MapRowRefused { y: m.y }, send);
                }
            }
            Accepted::Route(r) => {
                if let Err(index) = apply_route(ctl, &r) {
                    self.emit_error(ErrorCode::RouteRefused { index }, send);
                }
            }
            Accepted::Stored => {
                self.pose_t_us = pose_t.or(self.pose_t_us);
                self.scan_t_us = scan_t.or(self.scan_t_us);
            }
            Accepted::NotForInbox | Accepted::Refused => {}
        }
        let Some(h) = beat else { return 0 };
        let mut ticks = 0;
        if self.cfg.time_mode == TimeMode::Lockstep {
            ticks = self.lockstep_beat(h.t_us, ctl, send, obs);
        }
        // The echo: in lockstep it follows the batch's outputs ("batch t handled").
        self.emit(&CoreToHost::Heartbeat(h), send);
        self.counters.heartbeats_echoed = self.counters.heartbeats_echoed.wrapping_add(1);
        self.hb_sent_us = self.last_tick_us.or(Some(0));
        ticks
    }

    fn lockstep_beat(&mut self, t: u64, ctl: &mut Controller, send: &mut impl FnMut(&[u8]), obs: &mut impl StageObserver) -> u32 {
        match self.last_tick_us {
            Some(last) if t < last => {
                self.counters.lockstep_stale = self.counters.lockstep_stale.wrapping_add(1);
                0
            }
            Some(last) if t == last => {
                self.counters.lockstep_repeats = self.counters.lockstep_repeats.wrapping_add(1);
                self.resend_goal = true;
                if let Some(out) = self.last_out.take() {
                    self.emit_outputs(last, &out, false, ctl, send);
                    self.last_out = Some(out);
                }
                0
            }
            // Nothing since the last tick: a plain heartbeat (a link probe), not a batch.
            _ if self.pose_t_us.is_none() && self.scan_t_us.is_none() => 0,
            _ if self.pose_t_us == Some(t) && self.scan_t_us == Some(t) => {
                if !self.inbox.scan_complete() {
                    let beats = match self.partial_beats {
                        Some((pt, n)) if pt == t => n.saturating_add(1),
                        _ => 1,
                    };
                    if beats < self.cfg.lockstep_partial_after {
                        self.partial_beats = Some((t, beats));
                        self.counters.lockstep_incomplete = self.counters.lockstep_incomplete.wrapping_add(1);
                        return 0;
                    }
                    self.counters.lockstep_partial = self.counters.lockstep_partial.wrapping_add(1);
                }
                self.tick_observed(t, ctl, |f| send(f), obs);
                1
            }
            _ => {
                self.counters.lockstep_incomplete = self.counters.lockstep_incomplete.wrapping_add(1);
                0
            }
        }
    }

    /// Runs one controller tick at `now_us` with what arrived since the last one, and sends its
    /// outputs. Call it at a fixed rate in [`TimeMode::RealTime`]; in lockstep
    /// [`Node::receive`] calls it.
    pub fn tick(&mut self, now_us: u64, ctl: &mut Controller, send: impl FnMut(&[u8])) -> &Outputs {
        self.tick_observed(now_us, ctl, send, &mut ())
    }

    /// Forgets the batch of pose and scan gathered since the last tick (lockstep completeness).
    fn forget_batch(&mut self) {
        self.pose_t_us = None;
        self.scan_t_us = None;
        self.partial_beats = None;
    }

    /// [`Node::tick`], telling `obs` where each stage begins and ends.
    pub fn tick_observed(
        &mut self,
        now_us: u64,
        ctl: &mut Controller,
        mut send: impl FnMut(&[u8]),
        obs: &mut impl StageObserver,
    ) -> &Outputs {
        let scans_before = self.last_out.as_ref().map_or(0, |o| o.status.scans);
        let out = ctl.tick_observed(now_us, &self.inbox.inputs(), obs);
        self.inbox.ticked();
        self.forget_batch();
        self.last_tick_us = Some(now_us);
        self.counters.ticks = self.counters.ticks.wrapping_add(1);
        if self.session.is_open() {
            let scanned = out.status.scans != scans_before;
            self.emit_outputs(now_us, &out, scanned, ctl, &mut send);
            if self.hb_sent_us.is_none_or(|t| now_us.saturating_sub(t) >= self.cfg.heartbeat_interval_us) {
                self.hb_seq = self.hb_seq.wrapping_add(1);
                self.emit(&CoreToHost::Heartbeat(Heartbeat { t_us: now_us, seq: self.hb_seq }), &mut send);
                self.counters.heartbeats_sent = self.counters.heartbeats_sent.wrapping_add(1);
                self.hb_sent_us = Some(now_us);
            }
        }
        self.last_out.insert(out)
    }

    /// Goal (paced), Stop, Status, then Labels (if asked and `scanned`).
    fn emit_outputs(&mut self, now_us: u64, out: &Outputs, scanned: bool, ctl: &Controller, send: &mut impl FnMut(&[u8])) {
        let link = self.link_counters();
        for msg in output_messages(now_us, out, link) {
            if let CoreToHost::Goal(_) = msg {
                self.emit_goal(now_us, &msg, send);
            } else {
                self.emit(&msg, send);
            }
        }
        if scanned && self.session.wants_labels() {
            self.emit(&CoreToHost::Labels(LabelsMsg::from_beams(now_us, ctl.beams())), send);
        }
    }

    fn emit_goal(&mut self, now_us: u64, msg: &CoreToHost, send: &mut impl FnMut(&[u8])) {
        let Ok(frame) = encode(msg, &mut self.tx) else {
            self.counters.encode_errors = self.counters.encode_errors.wrapping_add(1);
            return;
        };
        let print = CRC.checksum(frame);
        let due = match self.goal_sent {
            None => true,
            Some((p, t)) => p != print || now_us.saturating_sub(t) >= self.cfg.goal_refresh_us,
        };
        if due || self.resend_goal {
            send(frame);
            let n = frame.len();
            self.count_sent(n);
            self.counters.goals_sent = self.counters.goals_sent.wrapping_add(1);
            self.goal_sent = Some((print, now_us));
            self.resend_goal = false;
        }
    }

    fn emit_error(&mut self, code: ErrorCode, send: &mut impl FnMut(&[u8])) {
        self.emit(&CoreToHost::Error(ErrorMsg { code }), send);
        self.counters.errors_sent = self.counters.errors_sent.wrapping_add(1);
    }

    fn emit(&mut self, msg: &CoreToHost, send: &mut impl FnMut(&[u8])) {
        match encode(msg, &mut self.tx) {
            Ok(frame) => {
                send(frame);
                let n = frame.len();
                self.count_sent(n);
            }
            Err(_) => self.counters.encode_errors = self.counters.encode_errors.wrapping_add(1),
        }
    }

    fn count_sent(&mut self, n: usize) {
        self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
        self.counters.bytes_sent = self.counters.bytes_sent.wrapping_add(n as u64);
    }

    /// The status the node would report now (the last tick's, or an idle one before any).
    pub fn status_msg(&self, ctl: &Controller) -> StatusMsg {
        let s = match &self.last_out {
            Some(o) => o.status,
            None => Status { mode: Some(ctl.mode()), ..Status::default() },
        };
        StatusMsg::from_status(self.last_tick_us.unwrap_or(0), &s, self.link_counters())
    }
}

/// Applies a row of the prior map to `ctl` ([`HostToCore::MapRow`]; the in-process host
/// loads a map through the same function). A plane shorter than the run is zero beyond its end
/// (the host trims trailing zero bytes). Refused: a row or run outside the map's window.
pub fn apply_map_row(ctl: &mut Controller, m: &MapRowMsg) -> Result<(), PriorError> {
    if m.reset {
        ctl.prior_map_reset(Meters::from_bits(m.origin_x), Meters::from_bits(m.origin_y));
    }
    let (y, x0, n) = (m.y as usize, m.x0 as usize, m.n as usize);
    let mut plane = [0u8; MAP_ROW_BYTES];
    let k = m.occupied.len().min(MAP_ROW_BYTES);
    plane[..k].copy_from_slice(&m.occupied[..k]);
    ctl.prior_map_row(y, x0, &plane, n)?;
    plane = [0u8; MAP_ROW_BYTES];
    let k = m.free.len().min(MAP_ROW_BYTES);
    plane[..k].copy_from_slice(&m.free[..k]);
    ctl.prior_map_free_row(y, x0, &plane, n)
}

/// Applies waypoints of the coverage route to `ctl` ([`HostToCore::Route`]). Refused from the
/// first waypoint that is out of order or past the route's capacity: its index.
pub fn apply_route(ctl: &mut Controller, r: &RouteMsg) -> Result<(), u16> {
    if r.first == 0 {
        ctl.route_clear();
    }
    if r.first as usize != ctl.planner.route.waypoints().len() {
        return Err(r.first);
    }
    for (k, w) in r.waypoints.iter().enumerate() {
        ctl.route_push(Meters::from_bits(w.x), Meters::from_bits(w.y), BinaryAngle(w.heading)).map_err(|_| r.first + k as u16)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
