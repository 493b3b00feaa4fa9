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
use crate::protocol::frame::CRC;
use crate::protocol::{
    encode, output_messages, Accepted, Admission, ConfigMsg, CoreDecoder, CoreToHost, ErrorCode, ErrorMsg, Heartbeat, HostToCore, Inbox,
    LabelsMsg, LinkCounters, Session, StatusMsg, WireCommand, MAX_CORE_TO_HOST_FRAME,
};

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
            self.pose_t_us = None;
            self.scan_t_us = None;
            self.partial_beats = None;
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
        self.pose_t_us = None;
        self.scan_t_us = None;
        self.partial_beats = None;
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

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::config::Config;
    use crate::grid::Cell;
    use crate::protocol::{
        AckReason, BaseStatus, ConfigMsg, GoalMsg, Hello, HostDecoder, PoseMsg, Role, ScanMsg, StatusMsg, WireCommand, WireMode,
        MAX_FRAME_LEN, PROTOCOL_VERSION,
    };
    use crate::scan::{BeamLabel, RANGE_NO_RETURN};
    use std::boxed::Box;
    use std::vec::Vec;

    const T: u64 = 200_000;
    /// The robot stands at (25.6 m, 25.6 m), the middle of a grid at the default origin.
    const MID: i32 = 25 * 65_536 + 39_322;

    fn frame(m: &HostToCore) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        encode(m, &mut buf).unwrap().to_vec()
    }

    /// Decodes everything a node sent.
    fn parse(bytes: &[u8]) -> Vec<CoreToHost> {
        let mut d = HostDecoder::new();
        let out: Vec<CoreToHost> = d.feed(bytes).map(|r| r.expect("the node sends valid frames")).collect();
        assert_eq!(d.pending(), 0, "every frame is complete");
        out
    }

    /// A 720-beam scan of a round room of radius 3 m with a doorway (no return) to the east.
    fn scan(t_us: u64, labels: bool) -> HostToCore {
        let n = 720;
        let mut s = ScanMsg { t_us, angle_min: i32::MIN, angle_increment: (u32::MAX / n as u32) as i32, ..Default::default() };
        for i in 0..n {
            let door = (350..370).contains(&i); // ±5° around 0 (beam 360 points forward)
            s.ranges_mm.push(if door { RANGE_NO_RETURN } else { 3000 }).unwrap();
        }
        if labels {
            s.labels = Some((0..n).map(|_| BeamLabel::Map).collect());
        }
        HostToCore::Scan(s)
    }

    fn pose(t_us: u64) -> HostToCore {
        HostToCore::Pose(PoseMsg { t_us, x: MID, y: MID, theta: 0 })
    }

    fn beat(t_us: u64, seq: u32) -> HostToCore {
        HostToCore::Heartbeat(Heartbeat { t_us, seq })
    }

    fn batch(t_us: u64, extra: &[HostToCore]) -> Vec<u8> {
        let mut b = Vec::new();
        for m in extra {
            b.extend(frame(m));
        }
        b.extend(frame(&pose(t_us)));
        b.extend(frame(&scan(t_us, true)));
        b.extend(frame(&beat(t_us, t_us as u32)));
        b
    }

    struct Rig {
        node: Node,
        ctl: Box<Controller>,
    }

    impl Rig {
        fn new(mode: TimeMode) -> Self {
            Rig { node: Node::new(NodeConfig::new(mode)), ctl: Box::new(Controller::new(Config::DEFAULT)) }
        }

        fn rx(&mut self, bytes: &[u8]) -> (u32, Vec<CoreToHost>) {
            let mut out = Vec::new();
            let n = self.node.receive(bytes, &mut self.ctl, |f| out.extend_from_slice(f));
            (n, parse(&out))
        }

        fn tick(&mut self, now_us: u64) -> Vec<CoreToHost> {
            let mut out = Vec::new();
            self.node.tick(now_us, &mut self.ctl, |f| out.extend_from_slice(f));
            parse(&out)
        }

        fn hello(&mut self, want_labels: bool) {
            let (_, out) = self.rx(&frame(&HostToCore::Hello(Hello::new(Role::Simulator, want_labels))));
            assert!(matches!(out[..], [CoreToHost::HelloAck(a)] if a.accepted));
        }
    }

    fn statuses(out: &[CoreToHost]) -> Vec<StatusMsg> {
        out.iter().filter_map(|m| if let CoreToHost::Status(s) = m { Some(*s) } else { None }).collect()
    }

    fn goals(out: &[CoreToHost]) -> Vec<GoalMsg> {
        out.iter().filter_map(|m| if let CoreToHost::Goal(g) = m { Some(g.clone()) } else { None }).collect()
    }

    #[test]
    fn the_node_is_small() {
        // Decoder (one largest frame), inbox (one largest scan), one outgoing frame, last outputs.
        let size = core::mem::size_of::<Node>();
        assert!(size < 10 * 1024, "{size} bytes");
    }

    #[test]
    fn nothing_but_hello_is_acted_on_before_the_handshake() {
        let mut r = Rig::new(TimeMode::Lockstep);
        let (ticks, out) = r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start)]));
        assert_eq!(ticks, 0);
        // One error per heartbeat period, not one per message.
        assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::HandshakeRequired })]);
        assert_eq!(r.node.link_counters().ignored, 4);
        assert_eq!(r.ctl.mode(), Mode::Idle);

        // A host of another version is told why.
        let old = Hello { version: PROTOCOL_VERSION + 1, role: Role::Robot, want_labels: false };
        let (_, out) = r.rx(&frame(&HostToCore::Hello(old)));
        assert!(matches!(out[..], [CoreToHost::HelloAck(a)] if !a.accepted && a.reason == AckReason::VersionMismatch));
        let (_, out) = r.rx(&frame(&beat(0, 1)));
        assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::VersionMismatch { peer: PROTOCOL_VERSION + 1 } })]);
    }

    #[test]
    fn reset_starts_a_new_search_at_once_and_lockstep_time_again() {
        let mut r = Rig::new(TimeMode::Lockstep);
        r.hello(false);
        assert_eq!(r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start)])).0, 1);
        assert_eq!(r.rx(&batch(T, &[])).0, 1);
        // An earlier time is ignored (stale) ...
        assert_eq!(r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start)])).0, 0);
        assert_eq!(r.node.counters().lockstep_stale, 1);
        // ... until a Reset: applied on arrival (the controller idle and empty, a configuration
        // accepted again), and time starts over.
        let (ticks, out) = r.rx(&frame(&HostToCore::Command(WireCommand::Reset)));
        assert_eq!((ticks, out.len()), (0, 0));
        assert_eq!(r.ctl.mode(), Mode::Idle);
        assert_eq!(r.node.counters().resets, 1);
        let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&Config::DEFAULT))));
        assert!(out.is_empty(), "{out:?}");
        assert_eq!(r.node.counters().configs_applied, 1);
        let (ticks, out) = r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start)]));
        assert_eq!(ticks, 1);
        let s = statuses(&out);
        assert_eq!((s[0].t_us, s[0].ticks, s[0].mode), (0, 1, WireMode::Exploring), "a new search: its first tick");
        // Its first goal on its second tick (a planning step spans two).
        let (_, out) = r.rx(&batch(T, &[]));
        assert_eq!(goals(&out)[0].seq, 1);
    }

    #[test]
    fn lockstep_ticks_on_the_heartbeat_closing_a_complete_batch() {
        let mut r = Rig::new(TimeMode::Lockstep);
        r.hello(false);
        let (ticks, out) = r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start)]));
        assert_eq!(ticks, 1);
        assert_eq!(r.ctl.mode(), Mode::Exploring);
        // A planning step spans two ticks: the first finds the path distances, no goal yet.
        assert!(goals(&out).is_empty(), "{out:?}");
        assert_eq!(statuses(&out)[0].t_us, 0);
        assert_eq!(statuses(&out)[0].mode, WireMode::Exploring);
        assert_eq!(out.last(), Some(&CoreToHost::Heartbeat(Heartbeat { t_us: 0, seq: 0 })));
        // The second: Goal, Status(T), then the echo last.
        let (ticks, out) = r.rx(&batch(T, &[]));
        assert_eq!(ticks, 1);
        let g = goals(&out);
        assert_eq!(g.len(), 1, "{out:?}");
        assert_eq!(g[0].seq, 1);
        assert_eq!(statuses(&out)[0].t_us, T);
        assert_eq!(out.last(), Some(&CoreToHost::Heartbeat(Heartbeat { t_us: T, seq: T as u32 })));

        // The same goal is not sent again on the next tick.
        let (ticks, out) = r.rx(&batch(2 * T, &[]));
        assert_eq!(ticks, 1);
        assert!(goals(&out).is_empty(), "{out:?}");
        assert_eq!(statuses(&out)[0].t_us, 2 * T);

        // A batch that lost its scan is not ticked: echo only, so the host retries.
        let mut b = frame(&pose(3 * T));
        b.extend(frame(&beat(3 * T, 7)));
        let (ticks, out) = r.rx(&b);
        assert_eq!(ticks, 0);
        assert_eq!(out, [CoreToHost::Heartbeat(Heartbeat { t_us: 3 * T, seq: 7 })]);
        assert_eq!(r.node.counters().lockstep_incomplete, 1);
        // The retry ticks.
        let (ticks, out) = r.rx(&batch(3 * T, &[]));
        assert_eq!(ticks, 1);
        assert_eq!(statuses(&out)[0].t_us, 3 * T);

        // A retry of a batch already ticked (its answer was lost): nothing ticks, the outputs,
        // goal included, come again.
        let ticks_before = r.ctl_ticks();
        let (ticks, out) = r.rx(&batch(3 * T, &[]));
        assert_eq!(ticks, 0);
        assert_eq!(r.ctl_ticks(), ticks_before);
        assert_eq!(goals(&out).len(), 1);
        assert_eq!(statuses(&out)[0].t_us, 3 * T);
        assert_eq!(r.node.counters().lockstep_repeats, 1);
        // An old heartbeat is ignored (echoed only).
        let (_, out) = r.rx(&frame(&beat(T, 9)));
        assert_eq!(out.len(), 1);
        assert_eq!(r.node.counters().lockstep_stale, 1);
    }

    impl Rig {
        fn ctl_ticks(&self) -> u32 {
            self.node.last_out.as_ref().map_or(0, |o| o.status.ticks)
        }
    }

    /// A batch with its scan cut into segments of `per` beams, leaving out the segments `lose`.
    fn segmented_batch(t_us: u64, extra: &[HostToCore], per: usize, lose: &[usize]) -> Vec<u8> {
        let mut b = Vec::new();
        for m in extra {
            b.extend(frame(m));
        }
        b.extend(frame(&pose(t_us)));
        let HostToCore::Scan(s) = scan(t_us, true) else { unreachable!() };
        for (i, seg) in s.segments(per).enumerate() {
            if !lose.contains(&i) {
                b.extend(frame(&HostToCore::ScanSegment(seg)));
            }
        }
        b.extend(frame(&beat(t_us, t_us as u32)));
        b
    }

    #[test]
    fn a_scan_in_segments_ticks_exactly_like_the_whole_scan() {
        let mut whole = Rig::new(TimeMode::Lockstep);
        let mut split = Rig::new(TimeMode::Lockstep);
        whole.hello(false);
        split.hello(false);
        for k in 0..6u64 {
            let extra: &[HostToCore] = if k == 0 { &[HostToCore::Command(WireCommand::Start)] } else { &[] };
            let (tw, ow) = whole.rx(&batch(k * T, extra));
            let (ts, os) = split.rx(&segmented_batch(k * T, extra, 16, &[]));
            assert_eq!((tw, ts), (1, 1), "a complete segmented scan ticks at once");
            // Same goals and statuses (the link counters aside: more frames came in).
            assert_eq!(goals(&ow), goals(&os));
            let strip = |v: Vec<StatusMsg>| v.into_iter().map(|s| StatusMsg { link: LinkCounters::default(), ..s }).collect::<Vec<_>>();
            assert_eq!(strip(statuses(&ow)), strip(statuses(&os)));
        }
        assert_eq!(whole.ctl.lidar.grid.count(Cell::Free), split.ctl.lidar.grid.count(Cell::Free));
        assert_eq!(split.node.counters().lockstep_partial, 0);
        assert_eq!(split.node.inbox().segments_accepted, 6 * 45);
    }

    #[test]
    fn a_partial_scan_waits_for_retries_then_ticks_with_what_arrived() {
        let mut r = Rig::new(TimeMode::Lockstep);
        r.node.cfg.lockstep_partial_after = 3;
        r.hello(false);
        let start = [HostToCore::Command(WireCommand::Start)];
        // Segments 3 and 7 lost: no tick on the first two heartbeats (the host retries) ...
        let (ticks, out) = r.rx(&segmented_batch(0, &start, 16, &[3, 7]));
        assert_eq!(ticks, 0);
        assert_eq!(out, [CoreToHost::Heartbeat(Heartbeat { t_us: 0, seq: 0 })]);
        // ... the retry brings segment 3 but loses 7 again ...
        let (ticks, _) = r.rx(&segmented_batch(0, &[], 16, &[7]));
        assert_eq!(ticks, 0);
        assert_eq!(r.node.counters().lockstep_incomplete, 2);
        assert_eq!(r.node.inbox().scan_beams(), Some((720 - 16, 720)), "segment 3 filled in across the attempts");
        // ... and the third heartbeat ticks with the 704 beams that arrived.
        let (ticks, out) = r.rx(&segmented_batch(0, &[], 16, &[7]));
        assert_eq!(ticks, 1);
        assert_eq!(statuses(&out)[0].t_us, 0);
        assert_eq!(statuses(&out)[0].scans, 1);
        assert_eq!(r.node.counters().lockstep_partial, 1);
        assert_eq!(r.ctl.mode(), Mode::Exploring, "the Start of the first attempt was kept");
        // A batch whose retry completes the scan ticks at once, on its second heartbeat.
        let (ticks, _) = r.rx(&segmented_batch(T, &[], 16, &[0]));
        assert_eq!(ticks, 0);
        let (ticks, _) = r.rx(&segmented_batch(T, &[], 16, &[5]));
        assert_eq!(ticks, 1);
        assert_eq!(r.node.counters().lockstep_partial, 1);
        // A heartbeat without the pose never ticks, however often.
        for _ in 0..5 {
            let mut b = Vec::new();
            let HostToCore::Scan(s) = scan(2 * T, true) else { unreachable!() };
            for seg in s.segments(16) {
                b.extend(frame(&HostToCore::ScanSegment(seg)));
            }
            b.extend(frame(&beat(2 * T, 1)));
            assert_eq!(r.rx(&b).0, 0);
        }
    }

    #[test]
    fn real_time_ticks_on_the_callers_clock_with_heartbeats_and_goal_refresh() {
        let mut r = Rig::new(TimeMode::RealTime);
        r.hello(true);
        // Messages never tick in real time; the heartbeat is echoed at once.
        let (ticks, out) = r.rx(&batch(123, &[HostToCore::Command(WireCommand::Start)]));
        assert_eq!(ticks, 0);
        assert_eq!(out, [CoreToHost::Heartbeat(Heartbeat { t_us: 123, seq: 123 })]);

        let mut all = Vec::new();
        let mut t = 0;
        for k in 0..16 {
            t = 5_000_000 + k * T;
            if k < 8 {
                r.rx(&frame(&pose(0)));
                r.rx(&frame(&scan(0, true)));
            }
            all.push(r.tick(t));
        }
        let flat: Vec<CoreToHost> = all.iter().flatten().cloned().collect();
        // Labels after each integrated scan, as asked.
        assert_eq!(flat.iter().filter(|m| matches!(m, CoreToHost::Labels(_))).count(), 8);
        // One goal first, then again only after a second (goal_refresh_us), not every tick.
        let g = goals(&flat);
        assert!((1..=3).contains(&g.len()), "{} goals in 8 ticks", g.len());
        // (A planning step spans two ticks: the first goal comes on the second.)
        assert!(goals(&all[0]).is_empty() && goals(&all[1]).len() == 1 && goals(&all[2]).is_empty());
        // Own heartbeat about once a second (the echo counted as the first).
        let beats = flat.iter().filter(|m| matches!(m, CoreToHost::Heartbeat(_))).count();
        assert!((2..=4).contains(&beats), "{beats} heartbeats in 3.2 s");
        // The watchdog: no pose or scan for over a second stops the robot.
        let last = statuses(all.last().unwrap())[0];
        assert_eq!(last.mode, WireMode::Stopped);
        assert!(all.last().unwrap().iter().any(|m| matches!(m, CoreToHost::Stop(s) if s.mode == WireMode::Stopped)));
        assert_eq!(last.t_us, t);
    }

    #[test]
    fn a_configuration_is_applied_only_when_idle() {
        let mut r = Rig::new(TimeMode::Lockstep);
        r.hello(false);
        let mut cfg = Config::DEFAULT;
        cfg.origin_x_m = Config::mm(1_000);
        cfg.watchdog_us = 2_000_000;
        let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&cfg))));
        assert!(out.is_empty());
        assert_eq!(r.ctl.config().watchdog_us, 2_000_000);
        assert_eq!(r.ctl.lidar.geom.origin_x, Config::mm(1_000), "the maps moved with the origin");
        r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start)]));
        assert_eq!(r.ctl.mode(), Mode::Exploring);

        let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&Config::DEFAULT))));
        assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigRefused })]);
        assert_eq!(r.ctl.config().watchdog_us, 2_000_000);
        assert_eq!(r.node.counters().configs_refused, 1);
    }

    #[test]
    fn a_configuration_out_of_range_is_refused_naming_the_field_and_the_controller_keeps_its_own() {
        let mut r = Rig::new(TimeMode::Lockstep);
        r.hello(false);
        let mut cfg = Config::DEFAULT;
        cfg.watchdog_us = 2_000_000;
        r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&cfg))));
        assert_eq!(*r.ctl.config(), cfg);
        // What once stopped the node (overflow at planner.rs:270 on the first plan): a 5 km robot.
        let bad = Config { robot_radius_m: Config::mm(5_000_000), origin_x_m: Config::mm(2_000), ..cfg };
        let (_, out) = r.rx(&frame(&HostToCore::Config(ConfigMsg::from_config(&bad))));
        let field = ConfigMsg::field_index("robot_radius_m").unwrap();
        assert_eq!(out, [CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigInvalid { field } })]);
        assert_eq!(ConfigMsg::FIELDS[field as usize], "robot_radius_m");
        assert_eq!(*r.ctl.config(), cfg, "the configuration in use stays, origin included");
        assert_eq!(r.node.last_config_error().map(|e| e.field), Some("robot_radius_m"));
        let c = r.node.counters();
        assert_eq!((c.configs_applied, c.configs_invalid, c.configs_refused), (1, 1, 0));
        // And the node searches on with it (its first goal on the second tick).
        let (ticks, _) = r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start)]));
        assert_eq!(ticks, 1);
        assert_eq!(r.ctl.mode(), Mode::Exploring);
        let (_, out) = r.rx(&batch(T, &[]));
        assert_eq!(goals(&out).len(), 1);
    }

    #[test]
    fn set_config_keeps_the_maps_unless_the_origin_moves() {
        let mut ctl = Box::new(Controller::new(Config::DEFAULT));
        let mut node = Node::new(NodeConfig::new(TimeMode::Lockstep));
        node.receive(&frame(&HostToCore::Hello(Hello::new(Role::Simulator, false))), &mut ctl, |_| {});
        node.receive(&batch(0, &[HostToCore::Command(WireCommand::Start)]), &mut ctl, |_| {});
        node.receive(&frame(&HostToCore::Command(WireCommand::Stop)), &mut ctl, |_| {});
        node.receive(&batch(T, &[]), &mut ctl, |_| {});
        assert_eq!(ctl.mode(), Mode::Idle);
        let known = |c: &Controller| c.lidar.grid.count(Cell::Free);
        let before = known(&ctl);
        assert!(before > 0);
        let mut cfg = Config::DEFAULT;
        cfg.switch_margin = Config::weight_milli(1_000);
        ctl.set_config(cfg).unwrap();
        assert_eq!(known(&ctl), before, "same origin: the map stays");
        cfg.origin_y_m = Config::mm(-500);
        ctl.set_config(cfg).unwrap();
        assert_eq!(known(&ctl), 0, "new origin: the map is forgotten");
        assert_eq!(*ctl.config(), cfg);
    }

    #[test]
    fn base_status_and_commands_flow_through() {
        let mut r = Rig::new(TimeMode::Lockstep);
        r.hello(false);
        r.rx(&batch(0, &[HostToCore::Command(WireCommand::Start), HostToCore::BaseStatus(BaseStatus { blocked: true })]));
        assert!(r.node.inbox().inputs().base_blocked);
        let (_, out) = r.rx(&batch(T, &[HostToCore::Command(WireCommand::Stop)]));
        assert_eq!(statuses(&out)[0].mode, WireMode::Idle);
        assert!(out.iter().any(|m| matches!(m, CoreToHost::Stop(s) if s.mode == WireMode::Idle)));
    }

    #[test]
    fn garbage_is_counted_and_never_reaches_the_controller() {
        let mut r = Rig::new(TimeMode::Lockstep);
        r.hello(false);
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut junk = Vec::new();
        for _ in 0..200_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            junk.push((seed >> 24) as u8);
        }
        let good = batch(0, &[HostToCore::Command(WireCommand::Start)]);
        // Damage each byte of the Start frame in turn (the delimiter kept): every copy is dropped.
        let first = good.iter().position(|&x| x == 0).unwrap();
        for i in 0..first {
            let mut b = good[..=first].to_vec();
            b[i] ^= 0x5A;
            if b[i] == 0 {
                b[i] = 1;
            }
            junk.push(0);
            junk.extend_from_slice(&b);
        }
        let (ticks, _) = r.rx(&junk);
        assert_eq!(ticks, 0);
        assert_eq!(r.ctl.mode(), Mode::Idle);
        let c = r.node.link_counters();
        assert!(c.dropped() > first as u32, "{c:?}");
        assert_eq!(c.frames_ok, 1, "only the Hello");
        // And the node still works.
        let (ticks, _) = r.rx(&[&[0u8][..], &good[..]].concat());
        assert_eq!(ticks, 1);
        assert_eq!(r.ctl.mode(), Mode::Exploring);
    }
}
