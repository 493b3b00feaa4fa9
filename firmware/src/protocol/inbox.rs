//! Host messages between two ticks, gathered into one tick's [`Inputs`].
//!
//! Messages arrive at the link's pace, the controller ticks at its own. The inbox keeps what the
//! next tick needs: the latest pose, the latest scan (an older one not yet ticked is superseded
//! and counted), the latest detection, the base's blocked flag (a state: it stays until the base
//! reports otherwise) and up to [`MAX_PENDING_COMMANDS`] commands, one per tick, in order (a
//! `Reset` then a `Start` must both happen). A configuration is handed back to the caller, which
//! decides when to apply it.
//!
//! **Scan segments** (protocol v2) are assembled in place, in the same buffer as a whole scan:
//! the first segment of a scan (a new `t_us`, geometry, beam count or labelling) starts a scan of
//! `total_beams` invalid beams (range `0`, unlabelled), and every segment of it copies its beams
//! in and marks them received (a segment that arrives twice, from a retried batch, changes
//! nothing). The scan is complete when every beam has arrived; until then the tick takes it as
//! it is, the missing beams invalid (the core skips them). A complete assembly equals, field for
//! field, the [`ScanMsg`] the segments were cut from.

use crate::controller::{Command, Detection, Inputs};
use crate::protocol::message::{ConfigMsg, Heartbeat, HostToCore, MapRowMsg, RouteMsg, ScanMsg, ScanSegmentMsg, MAX_WIRE_BEAMS};
use crate::scan::{BeamLabel, RANGE_INVALID};
use fixed_point::Pose2;

/// Commands queued between ticks; more are dropped and counted.
pub const MAX_PENDING_COMMANDS: usize = 4;

/// What [`Inbox::accept`] did with a message.
#[derive(Clone, Debug, PartialEq, Eq)]
#[allow(clippy::large_enum_variant)] // no allocator: a map row is handed over inline.
pub enum Accepted {
    /// Stored for the next tick (or a heartbeat noted).
    Stored,
    /// A configuration: the caller applies it (the inbox keeps nothing).
    Config(ConfigMsg),
    /// A row of the prior map: the caller applies it ([`crate::node::apply_map_row`]).
    MapRow(MapRowMsg),
    /// Waypoints of the coverage route: the caller applies them ([`crate::node::apply_route`]).
    Route(RouteMsg),
    /// A `Hello`, which belongs to the [`crate::protocol::Session`]; ignored here.
    NotForInbox,
    /// A scan segment that cannot be part of a scan ([`ScanSegmentMsg::check`]): dropped and
    /// counted in [`Inbox::segments_refused`].
    Refused,
}

/// Words of the received-beams bitmap of an assembly.
const RECEIVED_WORDS: usize = MAX_WIRE_BEAMS.div_ceil(64);

/// Which beams of the scan being assembled have arrived.
#[derive(Clone, Copy, Debug)]
struct Assembly {
    received: [u64; RECEIVED_WORDS],
    beams: u16,
}

/// The next tick's inputs, as they accumulate.
#[derive(Clone, Debug, Default)]
pub struct Inbox {
    pose: Option<Pose2>,
    scan: Option<ScanMsg>,
    /// Set while `scan` is being assembled from segments (`None`: a whole scan, or none).
    assembly: Option<Assembly>,
    detection: Option<Detection>,
    commands: heapless::Deque<Command, MAX_PENDING_COMMANDS>,
    base_blocked: bool,
    last_heartbeat: Option<Heartbeat>,
    /// Scans replaced by a newer one before a tick took them.
    pub scans_superseded: u32,
    /// Commands dropped because [`MAX_PENDING_COMMANDS`] were already waiting.
    pub commands_dropped: u32,
    /// Scan segments taken into a scan (a repeated one included).
    pub segments_accepted: u32,
    /// Scan segments refused: no beams, a bad total, beams out of range, labels miscounted.
    pub segments_refused: u32,
}

impl Inbox {
    /// An empty inbox.
    pub const fn new() -> Self {
        Self {
            pose: None,
            scan: None,
            assembly: None,
            detection: None,
            commands: heapless::Deque::new(),
            base_blocked: false,
            last_heartbeat: None,
            scans_superseded: 0,
            commands_dropped: 0,
            segments_accepted: 0,
            segments_refused: 0,
        }
    }

    /// Drops every input waiting for a tick (pose, scan, detection, commands, base state, last
    /// heartbeat); the counters stay. For a `Reset` from the host.
    pub fn clear_inputs(&mut self) {
        self.forget_readings();
        self.commands.clear();
        self.base_blocked = false;
        self.last_heartbeat = None;
    }

    /// Takes one admitted message.
    pub fn accept(&mut self, msg: HostToCore) -> Accepted {
        match msg {
            HostToCore::Hello(_) => return Accepted::NotForInbox,
            HostToCore::Heartbeat(h) => self.last_heartbeat = Some(h),
            HostToCore::Pose(p) => self.pose = Some(p.pose()),
            HostToCore::Scan(s) => {
                self.assembly = None;
                if self.scan.replace(s).is_some() {
                    self.scans_superseded = self.scans_superseded.wrapping_add(1);
                }
            }
            HostToCore::ScanSegment(seg) => return self.merge(&seg),
            HostToCore::Detection(d) => self.detection = Some(d.detection()),
            HostToCore::Command(c) => {
                if self.commands.push_back(c.into()).is_err() {
                    self.commands_dropped = self.commands_dropped.wrapping_add(1);
                }
            }
            HostToCore::Config(c) => return Accepted::Config(c),
            HostToCore::MapRow(m) => return Accepted::MapRow(m),
            HostToCore::Route(r) => return Accepted::Route(r),
            HostToCore::BaseStatus(b) => self.base_blocked = b.blocked,
        }
        Accepted::Stored
    }

    /// Puts `seg` into the scan being assembled, or starts a new one (see the module docs).
    fn merge(&mut self, seg: &ScanSegmentMsg) -> Accepted {
        if seg.check().is_err() {
            self.segments_refused = self.segments_refused.wrapping_add(1);
            return Accepted::Refused;
        }
        let total = seg.total_beams as usize;
        let same_scan = self.assembly.is_some()
            && self.scan.as_ref().is_some_and(|s| {
                s.t_us == seg.t_us
                    && s.angle_min == seg.angle_min
                    && s.angle_increment == seg.angle_increment
                    && (s.range_min_mm, s.range_max_mm) == (seg.range_min_mm, seg.range_max_mm)
                    && s.ranges_mm.len() == total
                    && s.labels.is_some() == seg.labels.is_some()
            });
        if !same_scan {
            if self.scan.is_some() {
                self.scans_superseded = self.scans_superseded.wrapping_add(1);
            }
            // Reuses the buffer in place (no scan-sized temporary).
            let s = self.scan.get_or_insert_with(ScanMsg::default);
            s.t_us = seg.t_us;
            s.angle_min = seg.angle_min;
            s.angle_increment = seg.angle_increment;
            (s.range_min_mm, s.range_max_mm) = (seg.range_min_mm, seg.range_max_mm);
            s.ranges_mm.clear();
            // Cannot fail: check() bounds total by MAX_WIRE_BEAMS, the capacity.
            let _ = s.ranges_mm.resize(total, RANGE_INVALID);
            if seg.labels.is_some() {
                let l = s.labels.get_or_insert_with(heapless::Vec::new);
                l.clear();
                let _ = l.resize(total, BeamLabel::Unlabelled);
            } else {
                s.labels = None;
            }
            self.assembly = Some(Assembly { received: [0; RECEIVED_WORDS], beams: 0 });
        }
        let (Some(s), Some(a)) = (self.scan.as_mut(), self.assembly.as_mut()) else { return Accepted::Refused };
        let first = seg.first_beam as usize;
        let n = seg.ranges_mm.len();
        // In bounds: check() keeps first + n <= total = the scan's length.
        if let Some(dst) = s.ranges_mm.get_mut(first..first + n) {
            dst.copy_from_slice(&seg.ranges_mm);
        }
        if let (Some(dst), Some(src)) = (s.labels.as_mut().and_then(|l| l.get_mut(first..first + n)), seg.labels.as_ref()) {
            dst.copy_from_slice(src);
        }
        for b in first..first + n {
            let (w, bit) = (b / 64, 1u64 << (b % 64));
            if let Some(word) = a.received.get_mut(w) {
                if *word & bit == 0 {
                    *word |= bit;
                    a.beams = a.beams.saturating_add(1);
                }
            }
        }
        self.segments_accepted = self.segments_accepted.wrapping_add(1);
        Accepted::Stored
    }

    /// The stored scan's beams received and its beam count: `Some((n, n))` for a whole scan or a
    /// complete assembly, `Some((k, n))` with `k < n` for a partial one, `None` without a scan.
    pub fn scan_beams(&self) -> Option<(usize, usize)> {
        let s = self.scan.as_ref()?;
        let n = s.ranges_mm.len();
        Some((self.assembly.map_or(n, |a| a.beams as usize), n))
    }

    /// A scan is stored and every one of its beams arrived.
    pub fn scan_complete(&self) -> bool {
        self.scan_beams().is_some_and(|(k, n)| k == n)
    }

    /// The inputs for the next tick, borrowing the stored scan.
    pub fn inputs(&self) -> Inputs<'_> {
        Inputs {
            pose: self.pose,
            scan: self.scan.as_ref().map(ScanMsg::scan_input),
            detection: self.detection,
            command: self.commands.front().copied(),
            base_blocked: self.base_blocked,
        }
    }

    /// After a tick: forgets the pose, scan and detection it took and the command it ran; keeps
    /// the blocked flag and the other queued commands.
    pub fn ticked(&mut self) {
        self.forget_readings();
        self.commands.pop_front();
    }

    /// Forgets the pose, the scan (and its assembly) and the detection waiting for a tick.
    fn forget_readings(&mut self) {
        self.pose = None;
        self.scan = None;
        self.assembly = None;
        self.detection = None;
    }

    /// The host's last heartbeat.
    pub const fn last_heartbeat(&self) -> Option<Heartbeat> {
        self.last_heartbeat
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::protocol::message::{BaseStatus, DetectionMsg, PoseMsg, WireCommand};

    fn scan(t_us: u64) -> HostToCore {
        let mut m = ScanMsg { t_us, angle_min: 0, angle_increment: 1 << 20, ..Default::default() };
        m.ranges_mm.extend_from_slice(&[1000, 2000, 3000]).unwrap();
        HostToCore::Scan(m)
    }

    #[test]
    fn messages_between_ticks_become_one_tick_of_inputs() {
        let mut inbox = Inbox::new();
        assert_eq!(inbox.accept(HostToCore::Pose(PoseMsg { t_us: 1, x: 65_536, y: -65_536, theta: 1 << 30 })), Accepted::Stored);
        inbox.accept(scan(1));
        inbox.accept(scan(2));
        inbox.accept(HostToCore::Detection(DetectionMsg { t_us: 2, position: None }));
        inbox.accept(HostToCore::Command(WireCommand::Reset));
        inbox.accept(HostToCore::Command(WireCommand::Start));
        inbox.accept(HostToCore::BaseStatus(BaseStatus { blocked: true }));
        assert_eq!(inbox.scans_superseded, 1);

        let i = inbox.inputs();
        assert_eq!(i.pose.unwrap().x.to_bits(), 65_536);
        assert_eq!(i.scan.unwrap().ranges_mm, &[1000, 2000, 3000]);
        assert!(i.detection.is_some() && i.base_blocked);
        assert_eq!(i.command, Some(Command::Reset));

        inbox.ticked();
        let i = inbox.inputs();
        assert!(i.pose.is_none() && i.scan.is_none() && i.detection.is_none());
        assert_eq!(i.command, Some(Command::Start), "the second command runs on the next tick");
        assert!(i.base_blocked, "blocked is a state, it stays");
        inbox.ticked();
        assert_eq!(inbox.inputs().command, None);
    }

    /// A 300-beam labelled scan with distinct ranges and labels.
    fn big_scan(t_us: u64) -> ScanMsg {
        let mut m = ScanMsg { t_us, angle_min: i32::MIN, angle_increment: (u32::MAX / 300) as i32, ..Default::default() };
        let labels = [BeamLabel::Unlabelled, BeamLabel::Map, BeamLabel::NonMap];
        let mut l = heapless::Vec::new();
        for i in 0..300u16 {
            m.ranges_mm.push(if i % 17 == 0 { RANGE_INVALID } else { 500 + 7 * i }).unwrap();
            l.push(labels[(i % 3) as usize]).unwrap();
        }
        m.labels = Some(l);
        m
    }

    #[test]
    fn segments_in_any_order_and_repeated_assemble_into_the_whole_scan() {
        let whole = big_scan(7);
        for per in [1, 16, 32, 64, 128, 299, 300, 1000] {
            let segs: std::vec::Vec<ScanSegmentMsg> = whole.segments(per).collect();
            assert_eq!(segs.len(), 300usize.div_ceil(per.clamp(1, crate::protocol::MAX_SEGMENT_BEAMS)));
            let mut inbox = Inbox::new();
            // Backwards, every segment twice (a retried batch): the same scan.
            for s in segs.iter().rev().chain(segs.iter()) {
                assert_eq!(inbox.accept(HostToCore::ScanSegment(s.clone())), Accepted::Stored);
            }
            assert!(inbox.scan_complete());
            assert_eq!(inbox.scan_beams(), Some((300, 300)));
            assert_eq!(inbox.scan.as_ref(), Some(&whole), "{per} beams per segment");
            assert_eq!(inbox.segments_accepted as usize, 2 * segs.len());
            assert_eq!(inbox.scans_superseded, 0);
        }
        // Unlabelled too.
        let plain = ScanMsg { labels: None, ..big_scan(8) };
        let mut inbox = Inbox::new();
        for s in plain.segments(40) {
            inbox.accept(HostToCore::ScanSegment(s));
        }
        assert_eq!(inbox.scan.as_ref(), Some(&plain));
    }

    #[test]
    fn lost_segments_leave_invalid_beams_and_a_new_scan_supersedes() {
        let whole = big_scan(7);
        let mut inbox = Inbox::new();
        for (i, s) in whole.segments(32).enumerate() {
            if i != 2 {
                inbox.accept(HostToCore::ScanSegment(s));
            }
        }
        assert!(!inbox.scan_complete());
        assert_eq!(inbox.scan_beams(), Some((300 - 32, 300)));
        let input = inbox.inputs().scan.unwrap();
        assert_eq!(input.ranges_mm.len(), 300);
        assert!(input.ranges_mm[64..96].iter().all(|&r| r == RANGE_INVALID), "the lost beams are invalid");
        assert!(input.labels.unwrap()[64..96].iter().all(|&l| l == BeamLabel::Unlabelled));
        assert_eq!(&input.ranges_mm[96..], &whole.ranges_mm[96..]);
        // A segment of another scan (new time) starts over.
        let next = big_scan(8);
        inbox.accept(HostToCore::ScanSegment(next.segments(32).nth(1).unwrap()));
        assert_eq!(inbox.scans_superseded, 1);
        assert_eq!(inbox.scan_beams(), Some((32, 300)));
        assert_eq!(inbox.inputs().scan.unwrap().ranges_mm[32..64], next.ranges_mm[32..64]);
        assert!(inbox.inputs().scan.unwrap().ranges_mm[..32].iter().all(|&r| r == RANGE_INVALID));
        // So does a whole scan; the tick forgets it.
        inbox.accept(HostToCore::Scan(whole.clone()));
        assert!(inbox.scan_complete());
        assert_eq!(inbox.scans_superseded, 2);
        inbox.ticked();
        assert_eq!(inbox.scan_beams(), None);
        assert!(!inbox.scan_complete());
    }

    #[test]
    fn malformed_segments_are_refused_and_counted() {
        let good = big_scan(7).segments(16).nth(3).unwrap();
        let bad = [
            ScanSegmentMsg { ranges_mm: heapless::Vec::new(), labels: None, ..good.clone() },
            ScanSegmentMsg { total_beams: 0, ..good.clone() },
            ScanSegmentMsg { total_beams: (MAX_WIRE_BEAMS + 1) as u16, ..good.clone() },
            ScanSegmentMsg { first_beam: 290, ..good.clone() },
            ScanSegmentMsg { first_beam: u16::MAX, ..good.clone() },
            ScanSegmentMsg { labels: Some(heapless::Vec::from_slice(&[BeamLabel::Map]).unwrap()), ..good.clone() },
        ];
        let mut inbox = Inbox::new();
        for b in bad {
            assert!(b.check().is_err());
            assert_eq!(inbox.accept(HostToCore::ScanSegment(b)), Accepted::Refused);
        }
        assert_eq!((inbox.segments_refused, inbox.segments_accepted), (6, 0));
        assert_eq!(inbox.scan_beams(), None, "nothing was stored");
        assert_eq!(inbox.accept(HostToCore::ScanSegment(good)), Accepted::Stored);
        assert_eq!(inbox.scan_beams(), Some((16, 300)));
    }

    #[test]
    fn commands_beyond_the_queue_are_dropped_and_counted() {
        let mut inbox = Inbox::new();
        for _ in 0..MAX_PENDING_COMMANDS + 2 {
            inbox.accept(HostToCore::Command(WireCommand::Stop));
        }
        assert_eq!(inbox.commands_dropped, 2);
    }
}
