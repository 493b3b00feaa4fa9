//! The messages of both directions and their conversions to and from the core's types.
//!
//! Every message is a plain value type (integers, fixed-point bits, `heapless` vectors) with a
//! serde derive; postcard turns it into bytes (see `docs/protocol.md` for the byte layout of every
//! field). Distances travel as the bits of [`Meters`] (Q16.16, so `1.0 m` is `65536`), angles as
//! the bits of a [`BinaryAngle`] (2³² per turn), times as microseconds, ranges as millimetres.
//!
//! **Versioning.** A change to any message here (a field added, removed, re-typed or re-ordered,
//! a variant added or moved) bumps [`PROTOCOL_VERSION`]; the golden-byte tests in
//! `protocol/golden.rs` fail until it is bumped and the goldens are renewed. [`Hello`] and
//! [`HelloAck`] are *frozen*: variant 0 of their enum, the same fields, in every version, so a peer
//! of any version can read the other's version and say why it refuses.
//!
//! **Conversions** borrow or copy, never allocate: [`ScanMsg::scan_input`] lends the message's own
//! vectors to the core as a [`ScanInput`]; [`ScanMsg::from_scan_input`] refuses a scan of more than
//! [`MAX_WIRE_BEAMS`] beams with [`WireError::TooManyBeams`]. [`ScanMsg::segments`] cuts a scan
//! into [`ScanSegmentMsg`]s of at most [`MAX_SEGMENT_BEAMS`] beams for a noisy line (protocol v2);
//! the core's [`crate::protocol::Inbox`] puts them back together.

pub use super::config_msg::{BudgetsMsg, ConfigMsg};
use crate::capacity::{BEAMS, MAX_PATH_WAYPOINTS};
use crate::config::PlannerKind;
use crate::controller::{Command, Detection, Mode, Outputs, StageCost, Status};
use crate::planner::Goal;
use crate::scan::{BeamLabel, BeamScan, ScanError, ScanInput, RANGE_LIMIT_MM};
use fixed_point::{BinaryAngle, Meters, Pose2};
use serde::{Deserialize, Serialize};

/// The protocol version both peers must speak. Bumped by any change to any message.
///
/// * v1: the first release.
/// * v2: `HostToCore::ScanSegment` (tag 8): a scan may cross in segments; the configuration
///   carries `gaze` and `gaze_min_gain`, the status the gaze heading and its stage cost.
/// * v3: the configuration carries `nonmap_view_cap`.
/// * v4: the configuration carries `nonmap_drop_vacated`.
/// * v5: `ErrorCode::ConfigInvalid`: a configuration outside the core's ranges is refused, naming
///   the field; `Command(Reset)` is applied on arrival (a new search, lockstep time from 0).
/// * v6: scans and scan segments carry their sensor's `range_min_mm` and `range_max_mm` (REP 117:
///   a reading at or beyond `range_max` is "no return" and clears no farther than it);
///   `WireScanError::BadRangeLimits`. The configuration carries
///   `scan_matching` (after `budgets`).
pub const PROTOCOL_VERSION: u16 = 6;

/// Most beams one scan carries, whole ([`ScanMsg`]) or in segments ([`ScanSegmentMsg`]): a 360°
/// scan at 0.33° (1091 beams) fits. Larger scans are refused ([`WireError::TooManyBeams`]).
/// Below the core's own limit ([`crate::capacity::MAX_INPUT_BEAMS`]), so every scan that crosses
/// the wire is one the core takes.
pub const MAX_WIRE_BEAMS: usize = 1100;

/// Most beams one [`ScanSegmentMsg`] carries. A segment of `n` labelled beams is a frame of about
/// `28 + 3n` bytes (`28 + 2n` unlabelled): 16 beams make 76 bytes, which survive a line that
/// corrupts 1 % of its bytes about half the time (0.99⁷⁶ ≈ 0.47), where a whole 897-beam scan
/// (2.7 kB) never does.
pub const MAX_SEGMENT_BEAMS: usize = 128;

/// Most waypoints in a [`GoalMsg`] path (the planner's [`MAX_PATH_WAYPOINTS`]).
pub const MAX_WIRE_WAYPOINTS: usize = MAX_PATH_WAYPOINTS;

/// Labels in a [`LabelsMsg`]: one per beam of the core's beam grid ([`BEAMS`]).
pub const MAX_WIRE_LABELS: usize = BEAMS;

// ---------------------------------------------------------------------------------------------
// Worst-case serialised sizes (postcard bytes, before CRC and COBS).

/// Bytes of a postcard varint holding `v`.
pub const fn varint_len(mut v: u64) -> usize {
    let mut n = 1;
    while v >= 0x80 {
        v >>= 7;
        n += 1;
    }
    n
}

const U32_MAX_LEN: usize = varint_len(u32::MAX as u64); // 5 (also any zigzag i32)
const U64_MAX_LEN: usize = varint_len(u64::MAX); // 10 (also any zigzag i64)

/// Largest [`HostToCore`] message: a [`ScanMsg`] of [`MAX_WIRE_BEAMS`] beams with labels
/// (tag, `t_us`, two angles, the two range limits, length + 2 bytes per range, `Some` + length +
/// 1 byte per label).
pub const MAX_HOST_TO_CORE_LEN: usize = 1
    + U64_MAX_LEN
    + 2 * U32_MAX_LEN
    + 2 * varint_len(u16::MAX as u64)
    + varint_len(MAX_WIRE_BEAMS as u64)
    + 2 * MAX_WIRE_BEAMS
    + 1
    + varint_len(MAX_WIRE_BEAMS as u64)
    + MAX_WIRE_BEAMS;

/// Largest [`GoalMsg`] message (64 waypoints, every field at its widest).
pub const MAX_GOAL_LEN: usize = 1
    + U32_MAX_LEN
    + 3 * U32_MAX_LEN
    + U64_MAX_LEN
    + varint_len(MAX_WIRE_WAYPOINTS as u64)
    + MAX_WIRE_WAYPOINTS * 2 * U32_MAX_LEN
    + U32_MAX_LEN;

/// Largest [`LabelsMsg`] message.
pub const MAX_LABELS_LEN: usize = 1 + U64_MAX_LEN + varint_len(MAX_WIRE_LABELS as u64) + MAX_WIRE_LABELS;

/// Largest [`CoreToHost`] message: the larger of [`MAX_GOAL_LEN`] and [`MAX_LABELS_LEN`] (every
/// other core-to-host message is smaller: a status is at most ~180 bytes).
pub const MAX_CORE_TO_HOST_LEN: usize = if MAX_GOAL_LEN > MAX_LABELS_LEN { MAX_GOAL_LEN } else { MAX_LABELS_LEN };

// ---------------------------------------------------------------------------------------------
// Handshake (frozen).

/// What kind of host is on the other end (logged; every role is accepted).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Role {
    /// A bridge to a real robot (ROS or a serial driver).
    Robot,
    /// The host simulator.
    Simulator,
    /// A replay of a recorded run.
    Replay,
}

/// The host's opening message. Frozen in every protocol version.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Hello {
    /// The host's [`PROTOCOL_VERSION`].
    pub version: u16,
    /// What the host is.
    pub role: Role,
    /// Ask the core to send a [`LabelsMsg`] after every scan it integrates (for logging).
    pub want_labels: bool,
}

impl Hello {
    /// A hello in this build's protocol version.
    pub const fn new(role: Role, want_labels: bool) -> Self {
        Self { version: PROTOCOL_VERSION, role, want_labels }
    }
}

/// Why a [`Hello`] was accepted or refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum AckReason {
    /// Same protocol version: the session is open.
    Compatible,
    /// Different protocol version: the core ignores everything but a new `Hello`.
    VersionMismatch,
}

/// The core's answer to a [`Hello`]. Frozen in every protocol version.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HelloAck {
    /// The core's [`PROTOCOL_VERSION`].
    pub version: u16,
    /// Whether the session is open.
    pub accepted: bool,
    /// Why.
    pub reason: AckReason,
}

impl HelloAck {
    /// The core's answer to `hello`: accepted if and only if the versions are equal.
    pub const fn answer(hello: &Hello) -> Self {
        if hello.version == PROTOCOL_VERSION {
            Self { version: PROTOCOL_VERSION, accepted: true, reason: AckReason::Compatible }
        } else {
            Self { version: PROTOCOL_VERSION, accepted: false, reason: AckReason::VersionMismatch }
        }
    }

    /// The host's check of the answer: `Ok` only if the core accepted and speaks this build's
    /// version.
    pub const fn check(&self) -> Result<(), IncompatiblePeer> {
        if self.accepted && self.version == PROTOCOL_VERSION {
            Ok(())
        } else {
            Err(IncompatiblePeer { ours: PROTOCOL_VERSION, theirs: self.version })
        }
    }
}

/// The peer speaks another protocol version (or refused ours). Its `Display` says what to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct IncompatiblePeer {
    /// This build's version.
    pub ours: u16,
    /// The peer's version.
    pub theirs: u16,
}

impl core::fmt::Display for IncompatiblePeer {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.ours == self.theirs {
            write!(f, "the peer refused protocol v{} although it speaks it", self.ours)
        } else {
            write!(f, "incompatible protocol: this side speaks v{}, the peer v{}; build both from the same release", self.ours, self.theirs)
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Shared.

/// A liveness beacon, sent by both sides about once a second.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Heartbeat {
    /// Sender's clock, microseconds.
    pub t_us: u64,
    /// Sender's heartbeat counter (wraps).
    pub seq: u32,
}

/// A controller mode on the wire (mirrors [`Mode`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum WireMode {
    /// [`Mode::Idle`].
    Idle,
    /// [`Mode::Exploring`].
    Exploring,
    /// [`Mode::TargetFound`].
    TargetFound,
    /// [`Mode::Exhausted`].
    Exhausted,
    /// [`Mode::Stopped`].
    Stopped,
}

impl From<Mode> for WireMode {
    fn from(m: Mode) -> Self {
        match m {
            Mode::Idle => Self::Idle,
            Mode::Exploring => Self::Exploring,
            Mode::TargetFound => Self::TargetFound,
            Mode::Exhausted => Self::Exhausted,
            Mode::Stopped => Self::Stopped,
        }
    }
}

impl From<WireMode> for Mode {
    fn from(m: WireMode) -> Self {
        match m {
            WireMode::Idle => Self::Idle,
            WireMode::Exploring => Self::Exploring,
            WireMode::TargetFound => Self::TargetFound,
            WireMode::Exhausted => Self::Exhausted,
            WireMode::Stopped => Self::Stopped,
        }
    }
}

/// Why a wire value could not be built from a core value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WireError {
    /// The scan has more than [`MAX_WIRE_BEAMS`] beams (the count is given), in one message or
    /// in segments: decimate it on the host.
    TooManyBeams(usize),
    /// The label slice's length differs from the range slice's.
    LabelCountMismatch,
}

/// Why a [`ScanSegmentMsg`] cannot be part of a scan (the core counts and drops it; see
/// [`crate::protocol::Inbox::segments_refused`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SegmentError {
    /// No beams in the segment.
    Empty,
    /// `total_beams` is 0 or above [`MAX_WIRE_BEAMS`].
    BadTotal,
    /// The segment's beams do not lie within `0..total_beams`.
    OutOfRange,
    /// The labels' count differs from the ranges'.
    LabelCountMismatch,
}

// ---------------------------------------------------------------------------------------------
// Host → core.

/// The robot's pose in the world frame (REP-103).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct PoseMsg {
    /// When the pose was valid, host clock, microseconds.
    pub t_us: u64,
    /// x, metres as Q16.16 bits.
    pub x: i32,
    /// y, metres as Q16.16 bits.
    pub y: i32,
    /// Heading, binary angle (2³² per turn, counter-clockwise).
    pub theta: i32,
}

impl PoseMsg {
    /// The wire form of `pose`, stamped `t_us`.
    pub const fn from_pose(t_us: u64, pose: &Pose2) -> Self {
        Self { t_us, x: pose.x.to_bits(), y: pose.y.to_bits(), theta: pose.theta.0 }
    }

    /// The core's pose.
    pub const fn pose(&self) -> Pose2 {
        Pose2::new(Meters::from_bits(self.x), Meters::from_bits(self.y), BinaryAngle(self.theta))
    }
}

/// A LiDAR scan as the sensor produced it (any beam count up to [`MAX_WIRE_BEAMS`], its own field
/// of view), ranges in millimetres (`0` invalid, `65535` no return; see [`crate::scan`]).
/// `Default` is an empty scan with the widest limits (0 and [`RANGE_LIMIT_MM`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScanMsg {
    /// When the scan was taken, host clock, microseconds.
    pub t_us: u64,
    /// Angle of the first beam in the robot frame, binary angle.
    pub angle_min: i32,
    /// Angle between consecutive beams, binary angle (negative for clockwise sensors).
    pub angle_increment: i32,
    /// The sensor's minimum range, millimetres ([`ScanInput::range_min_mm`]).
    pub range_min_mm: u16,
    /// The sensor's maximum range, millimetres ([`ScanInput::range_max_mm`]).
    pub range_max_mm: u16,
    /// One range per beam, millimetres. On the wire: a length, then 2 bytes little-endian each.
    #[serde(with = "ser::ranges")]
    pub ranges_mm: heapless::Vec<u16, MAX_WIRE_BEAMS>,
    /// Optional labels, one per beam (ground truth from a simulator, or an upstream classifier):
    /// one byte each, `0` unlabelled, `1` map, `2` non-map.
    #[serde(with = "ser::opt_labels")]
    pub labels: Option<heapless::Vec<BeamLabel, MAX_WIRE_BEAMS>>,
}

impl Default for ScanMsg {
    fn default() -> Self {
        Self {
            t_us: 0,
            angle_min: 0,
            angle_increment: 0,
            range_min_mm: 0,
            range_max_mm: RANGE_LIMIT_MM,
            ranges_mm: heapless::Vec::new(),
            labels: None,
        }
    }
}

impl ScanMsg {
    /// Copies a scan into its wire form; refuses more than [`MAX_WIRE_BEAMS`] beams.
    pub fn from_scan_input(t_us: u64, scan: &ScanInput<'_>) -> Result<Self, WireError> {
        let n = scan.ranges_mm.len();
        let ranges_mm = heapless::Vec::from_slice(scan.ranges_mm).map_err(|_| WireError::TooManyBeams(n))?;
        let labels = match scan.labels {
            None => None,
            Some(l) if l.len() != n => return Err(WireError::LabelCountMismatch),
            Some(l) => Some(heapless::Vec::from_slice(l).map_err(|_| WireError::TooManyBeams(n))?),
        };
        Ok(Self {
            t_us,
            angle_min: scan.angle_min.0,
            angle_increment: scan.angle_increment.0,
            range_min_mm: scan.range_min_mm,
            range_max_mm: scan.range_max_mm,
            ranges_mm,
            labels,
        })
    }

    /// The scan as the core takes it, borrowing this message's vectors.
    pub fn scan_input(&self) -> ScanInput<'_> {
        ScanInput {
            angle_min: BinaryAngle(self.angle_min),
            angle_increment: BinaryAngle(self.angle_increment),
            ranges_mm: &self.ranges_mm,
            labels: self.labels.as_deref(),
            range_min_mm: self.range_min_mm,
            range_max_mm: self.range_max_mm,
        }
    }

    /// This scan cut into segments of `beams_per_segment` beams (clamped to
    /// `1..=`[`MAX_SEGMENT_BEAMS`]; the last one may be shorter), in beam order, one message at a
    /// time (nothing is allocated). Put back together by the core, they are this scan exactly.
    /// An empty scan has no segments.
    pub fn segments(&self, beams_per_segment: usize) -> Segments<'_> {
        Segments { scan: self, per: beams_per_segment.clamp(1, MAX_SEGMENT_BEAMS), next: 0 }
    }
}

/// The segments of a [`ScanMsg`] (see [`ScanMsg::segments`]).
pub struct Segments<'a> {
    scan: &'a ScanMsg,
    per: usize,
    next: usize,
}

impl Iterator for Segments<'_> {
    type Item = ScanSegmentMsg;

    fn next(&mut self) -> Option<ScanSegmentMsg> {
        let total = self.scan.ranges_mm.len();
        if self.next >= total {
            return None;
        }
        let first = self.next;
        let end = total.min(first + self.per);
        self.next = end;
        // Cannot fail: end - first <= per <= MAX_SEGMENT_BEAMS, and total <= MAX_WIRE_BEAMS < 2^16.
        let ranges_mm = heapless::Vec::from_slice(&self.scan.ranges_mm[first..end]).unwrap_or_default();
        let labels = self.scan.labels.as_ref().map(|l| heapless::Vec::from_slice(l.get(first..end).unwrap_or(&[])).unwrap_or_default());
        Some(ScanSegmentMsg {
            t_us: self.scan.t_us,
            angle_min: self.scan.angle_min,
            angle_increment: self.scan.angle_increment,
            range_min_mm: self.scan.range_min_mm,
            range_max_mm: self.scan.range_max_mm,
            total_beams: total as u16,
            first_beam: first as u16,
            ranges_mm,
            labels,
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.scan.ranges_mm.len().saturating_sub(self.next).div_ceil(self.per);
        (n, Some(n))
    }
}

impl ExactSizeIterator for Segments<'_> {}

/// A run of consecutive beams of one scan (protocol v2): beams `first_beam ..` of a scan of
/// `total_beams` beams taken at `t_us`. Each segment carries the whole scan's geometry, so it can
/// be placed on its own; the core assembles the segments of one scan (same `t_us`, geometry,
/// beam count and labelling) into the [`ScanMsg`] they were cut from. Beams whose segment was
/// lost stay invalid (range `0`), which the core skips: a partial scan still updates the maps
/// with what arrived.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScanSegmentMsg {
    /// When the scan was taken, host clock, microseconds: names the scan the segment belongs to.
    pub t_us: u64,
    /// Angle of the scan's first beam (beam 0, not this segment's), binary angle.
    pub angle_min: i32,
    /// Angle between consecutive beams, binary angle.
    pub angle_increment: i32,
    /// The scan's minimum range, millimetres.
    pub range_min_mm: u16,
    /// The scan's maximum range, millimetres.
    pub range_max_mm: u16,
    /// Beams in the whole scan (`1 ..= 1100`).
    pub total_beams: u16,
    /// Index in the scan of this segment's first beam.
    pub first_beam: u16,
    /// Ranges of beams `first_beam ..`, millimetres, 2 bytes little-endian each.
    #[serde(with = "ser::ranges")]
    pub ranges_mm: heapless::Vec<u16, MAX_SEGMENT_BEAMS>,
    /// Labels of the same beams, if the scan is labelled (all its segments are, or none).
    #[serde(with = "ser::opt_labels")]
    pub labels: Option<heapless::Vec<BeamLabel, MAX_SEGMENT_BEAMS>>,
}

impl ScanSegmentMsg {
    /// Whether the segment can be part of a scan: at least one beam, a total within
    /// [`MAX_WIRE_BEAMS`], its beams within the total, as many labels as ranges.
    pub fn check(&self) -> Result<(), SegmentError> {
        let n = self.ranges_mm.len();
        if n == 0 {
            return Err(SegmentError::Empty);
        }
        let total = self.total_beams as usize;
        if total == 0 || total > MAX_WIRE_BEAMS {
            return Err(SegmentError::BadTotal);
        }
        if self.first_beam as usize + n > total {
            return Err(SegmentError::OutOfRange);
        }
        if self.labels.as_ref().is_some_and(|l| l.len() != n) {
            return Err(SegmentError::LabelCountMismatch);
        }
        Ok(())
    }
}

/// A detection of the target by the camera's detector.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct DetectionMsg {
    /// When the image was taken, host clock, microseconds.
    pub t_us: u64,
    /// Where the target was seen (world frame, metres as Q16.16 bits), if localised.
    pub position: Option<(i32, i32)>,
}

impl DetectionMsg {
    /// The wire form of `d`, stamped `t_us`.
    pub fn from_detection(t_us: u64, d: &Detection) -> Self {
        Self { t_us, position: d.position.map(|(x, y)| (x.to_bits(), y.to_bits())) }
    }

    /// The core's detection.
    pub fn detection(&self) -> Detection {
        Detection { position: self.position.map(|(x, y)| (Meters::from_bits(x), Meters::from_bits(y))) }
    }
}

/// An operator command (mirrors [`Command`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum WireCommand {
    /// [`Command::Start`].
    Start,
    /// [`Command::Stop`].
    Stop,
    /// [`Command::Reset`].
    Reset,
}

impl From<Command> for WireCommand {
    fn from(c: Command) -> Self {
        match c {
            Command::Start => Self::Start,
            Command::Stop => Self::Stop,
            Command::Reset => Self::Reset,
        }
    }
}

impl From<WireCommand> for Command {
    fn from(c: WireCommand) -> Self {
        match c {
            WireCommand::Start => Self::Start,
            WireCommand::Stop => Self::Stop,
            WireCommand::Reset => Self::Reset,
        }
    }
}

/// The base's state, sent when it changes (and may be repeated).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct BaseStatus {
    /// The base cannot follow the path (an obstacle in the way).
    pub blocked: bool,
}

/// The planner kind on the wire (mirrors [`PlannerKind`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum WirePlanner {
    /// [`PlannerKind::Lives`].
    Lives,
    /// [`PlannerKind::Multisensor`].
    Multisensor,
    /// [`PlannerKind::Nearest`].
    Nearest,
    /// [`PlannerKind::ExploreLite`].
    ExploreLite,
    /// [`PlannerKind::Rrt`].
    Rrt,
    /// [`PlannerKind::LivesGreedy`].
    LivesGreedy,
    /// [`PlannerKind::LivesNoNonMap`].
    LivesNoNonMap,
}

impl From<PlannerKind> for WirePlanner {
    fn from(p: PlannerKind) -> Self {
        match p {
            PlannerKind::Lives => Self::Lives,
            PlannerKind::Multisensor => Self::Multisensor,
            PlannerKind::Nearest => Self::Nearest,
            PlannerKind::ExploreLite => Self::ExploreLite,
            PlannerKind::Rrt => Self::Rrt,
            PlannerKind::LivesGreedy => Self::LivesGreedy,
            PlannerKind::LivesNoNonMap => Self::LivesNoNonMap,
        }
    }
}

impl From<WirePlanner> for PlannerKind {
    fn from(p: WirePlanner) -> Self {
        match p {
            WirePlanner::Lives => Self::Lives,
            WirePlanner::Multisensor => Self::Multisensor,
            WirePlanner::Nearest => Self::Nearest,
            WirePlanner::ExploreLite => Self::ExploreLite,
            WirePlanner::Rrt => Self::Rrt,
            WirePlanner::LivesGreedy => Self::LivesGreedy,
            WirePlanner::LivesNoNonMap => Self::LivesNoNonMap,
        }
    }
}

/// Everything the host sends. The variant order is the wire tag (0, 1, 2, …): append only, and
/// bump [`PROTOCOL_VERSION`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)] // no allocator: a scan is carried inline.
pub enum HostToCore {
    /// Tag 0 (frozen): open a session.
    Hello(Hello),
    /// Tag 1: liveness.
    Heartbeat(Heartbeat),
    /// Tag 2: the robot's pose.
    Pose(PoseMsg),
    /// Tag 3: a LiDAR scan.
    Scan(ScanMsg),
    /// Tag 4: a target detection.
    Detection(DetectionMsg),
    /// Tag 5: start, stop, reset.
    Command(WireCommand),
    /// Tag 6: a new configuration.
    Config(ConfigMsg),
    /// Tag 7: the base's state.
    BaseStatus(BaseStatus),
    /// Tag 8 (v2): a run of beams of a LiDAR scan; the core assembles the scan.
    ScanSegment(ScanSegmentMsg),
}

// ---------------------------------------------------------------------------------------------
// Core → host.

/// A goal for the base: where to stand, which way to look, how to get there.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalMsg {
    /// Goals issued so far (the core's `Status::goals`): a new value is a new goal; the same value
    /// again is the same goal, possibly with a re-planned path.
    pub seq: u32,
    /// Goal x, metres as Q16.16 bits.
    pub x: i32,
    /// Goal y, metres as Q16.16 bits.
    pub y: i32,
    /// Goal heading, binary angle.
    pub theta: i32,
    /// The viewpoint's utility, Q16.16 bits.
    pub utility: i64,
    /// Waypoints from (near) the robot to the goal, metres as Q16.16 bits.
    #[serde(with = "ser::vec")]
    pub path: heapless::Vec<(i32, i32), MAX_WIRE_WAYPOINTS>,
    /// Path length, metres as Q16.16 bits.
    pub path_length_m: i32,
}

impl GoalMsg {
    /// The wire form of `g`, numbered `seq`.
    pub fn from_goal(seq: u32, g: &Goal) -> Self {
        let mut path = heapless::Vec::new();
        for &(x, y) in g.path.iter().take(MAX_WIRE_WAYPOINTS) {
            // Cannot fail: both capacities are MAX_PATH_WAYPOINTS.
            let _ = path.push((x.to_bits(), y.to_bits()));
        }
        Self {
            seq,
            x: g.pose.x.to_bits(),
            y: g.pose.y.to_bits(),
            theta: g.pose.theta.0,
            utility: g.viewpoint.utility,
            path,
            path_length_m: g.path_length_m.to_bits(),
        }
    }

    /// The goal pose.
    pub const fn pose(&self) -> Pose2 {
        Pose2::new(Meters::from_bits(self.x), Meters::from_bits(self.y), BinaryAngle(self.theta))
    }

    /// The waypoints in metres.
    pub fn waypoints(&self) -> impl Iterator<Item = (Meters, Meters)> + '_ {
        self.path.iter().map(|&(x, y)| (Meters::from_bits(x), Meters::from_bits(y)))
    }
}

/// Stop the base now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct StopMsg {
    /// The mode that asks for the stop (every mode but exploring does).
    pub mode: WireMode,
}

/// A scan refusal on the wire (mirrors [`ScanError`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum WireScanError {
    /// [`ScanError::Empty`].
    Empty,
    /// [`ScanError::TooManyBeams`].
    TooManyBeams(u32),
    /// [`ScanError::ZeroIncrement`].
    ZeroIncrement,
    /// [`ScanError::LabelCountMismatch`].
    LabelCountMismatch {
        /// Ranges given.
        ranges: u32,
        /// Labels given.
        labels: u32,
    },
    /// [`ScanError::BadRangeLimits`].
    BadRangeLimits {
        /// The scan's `range_min`, millimetres.
        min_mm: u16,
        /// The scan's `range_max`, millimetres.
        max_mm: u16,
    },
}

impl From<ScanError> for WireScanError {
    fn from(e: ScanError) -> Self {
        let n = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
        match e {
            ScanError::Empty => Self::Empty,
            ScanError::TooManyBeams(b) => Self::TooManyBeams(n(b)),
            ScanError::ZeroIncrement => Self::ZeroIncrement,
            ScanError::LabelCountMismatch { ranges, labels } => Self::LabelCountMismatch { ranges: n(ranges), labels: n(labels) },
            ScanError::BadRangeLimits { min_mm, max_mm } => Self::BadRangeLimits { min_mm, max_mm },
        }
    }
}

/// Work per stage (mirrors [`StageCost`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct StageCostMsg {
    /// [`StageCost::classify`].
    pub classify: u32,
    /// [`StageCost::lidar`].
    pub lidar: u32,
    /// [`StageCost::visual`].
    pub visual: u32,
    /// [`StageCost::nonmap`].
    pub nonmap: u32,
    /// [`StageCost::plan`].
    pub plan: u32,
    /// [`StageCost::gaze`] (v2).
    pub gaze: u32,
}

impl From<StageCost> for StageCostMsg {
    fn from(c: StageCost) -> Self {
        Self { classify: c.classify, lidar: c.lidar, visual: c.visual, nonmap: c.nonmap, plan: c.plan, gaze: c.gaze }
    }
}

/// Receive counters: frames decoded, and frames dropped by cause. All wrap at 2³².
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct LinkCounters {
    /// Frames decoded into a message.
    pub frames_ok: u32,
    /// Frames dropped: bad CRC.
    pub crc_errors: u32,
    /// Frames dropped: bad COBS.
    pub cobs_errors: u32,
    /// Frames dropped: CRC fine, message not decodable.
    pub decode_errors: u32,
    /// Frames dropped: longer than the buffer.
    pub overflows: u32,
    /// Messages decoded but not acted on: before the handshake, or from a refused peer (counted
    /// by [`crate::protocol::Session`], always 0 in [`crate::protocol::Decoder::counters`]).
    pub ignored: u32,
}

/// `crc 0, cobs 0, decode 0, too long 0, ignored 0`: why frames were dropped (and messages
/// ignored), for logs.
impl core::fmt::Display for LinkCounters {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "crc {}, cobs {}, decode {}, too long {}, ignored {}",
            self.crc_errors, self.cobs_errors, self.decode_errors, self.overflows, self.ignored
        )
    }
}

impl LinkCounters {
    /// Frames dropped for any cause.
    pub const fn dropped(&self) -> u32 {
        self.crc_errors.wrapping_add(self.cobs_errors).wrapping_add(self.decode_errors).wrapping_add(self.overflows)
    }
}

/// The controller's counters and the link's (mirrors [`Status`] plus [`LinkCounters`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct StatusMsg {
    /// Core clock (the `now_us` of the tick), microseconds.
    pub t_us: u64,
    /// Current mode (`Idle` before the first tick).
    pub mode: WireMode,
    /// [`Status::ticks`].
    pub ticks: u32,
    /// [`Status::scans`].
    pub scans: u32,
    /// [`Status::scans_rejected`].
    pub scans_rejected: u32,
    /// [`Status::poses_rejected`].
    pub poses_rejected: u32,
    /// [`Status::last_scan_error`].
    pub last_scan_error: Option<WireScanError>,
    /// [`Status::plans`].
    pub plans: u32,
    /// [`Status::goals`].
    pub goals: u32,
    /// [`Status::blacklisted`].
    pub blacklisted: u32,
    /// [`Status::retired`].
    pub retired: u32,
    /// [`Status::watchdog_trips`].
    pub watchdog_trips: u32,
    /// [`Status::cost`].
    pub cost: StageCostMsg,
    /// [`Status::overruns`]: lidar, visual, nonmap, plan, classify.
    pub overruns: [u32; 5],
    /// [`Status::heap_overflows`].
    pub heap_overflows: u32,
    /// The core's receive counters.
    pub link: LinkCounters,
    /// [`Status::gaze`] (v2): which way the camera should face while walking, binary angle
    /// (`None`: the direction of travel, or the goal's heading near the goal).
    pub gaze: Option<i32>,
}

impl StatusMsg {
    /// The wire form of `s` at `t_us`, with the core's link counters.
    pub fn from_status(t_us: u64, s: &Status, link: LinkCounters) -> Self {
        Self {
            t_us,
            mode: s.mode.map_or(WireMode::Idle, WireMode::from),
            ticks: s.ticks,
            scans: s.scans,
            scans_rejected: s.scans_rejected,
            poses_rejected: s.poses_rejected,
            last_scan_error: s.last_scan_error.map(WireScanError::from),
            plans: s.plans,
            goals: s.goals,
            blacklisted: s.blacklisted,
            retired: s.retired,
            watchdog_trips: s.watchdog_trips,
            cost: s.cost.into(),
            overruns: s.overruns,
            heap_overflows: s.heap_overflows,
            link,
            gaze: s.gaze.map(|h| h.0),
        }
    }
}

/// The labels of the core's last integrated scan, on its beam grid (beam `b` at
/// −π + b·2π/[`BEAMS`] in the robot frame). Sent only to a host whose [`Hello`] asked for them.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LabelsMsg {
    /// Core clock of the tick that integrated the scan, microseconds.
    pub t_us: u64,
    /// One byte per beam: `0` unlabelled, `1` map, `2` non-map.
    #[serde(with = "ser::vec")]
    pub labels: heapless::Vec<BeamLabel, MAX_WIRE_LABELS>,
}

impl LabelsMsg {
    /// The labels of `beams` at `t_us`.
    pub fn from_beams(t_us: u64, beams: &BeamScan) -> Self {
        let mut labels = heapless::Vec::new();
        // Cannot fail: both sizes are BEAMS.
        let _ = labels.extend_from_slice(&beams.labels);
        Self { t_us, labels }
    }
}

/// Why the core did not act on a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ErrorCode {
    /// A message other than `Hello` arrived before a `Hello` was accepted.
    HandshakeRequired,
    /// The host's `Hello` was refused: it speaks protocol `peer`, the core [`PROTOCOL_VERSION`].
    /// Everything but a new `Hello` is ignored.
    VersionMismatch {
        /// The host's version.
        peer: u16,
    },
    /// A configuration arrived while the controller was not idle (stop it first).
    ConfigRefused,
    /// A configuration was refused because a field is outside the range the core works in
    /// ([`crate::Config::validate`]); the controller keeps its configuration (v5).
    ConfigInvalid {
        /// The field: its index in [`ConfigMsg::FIELDS`] (wire order).
        field: u8,
    },
}

/// The core refused a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ErrorMsg {
    /// Why.
    pub code: ErrorCode,
}

/// Everything the core sends. The variant order is the wire tag: append only, and bump
/// [`PROTOCOL_VERSION`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(clippy::large_enum_variant)] // no allocator: labels and paths are carried inline.
pub enum CoreToHost {
    /// Tag 0 (frozen): the answer to `Hello`.
    HelloAck(HelloAck),
    /// Tag 1: liveness.
    Heartbeat(Heartbeat),
    /// Tag 2: the goal being pursued.
    Goal(GoalMsg),
    /// Tag 3: stop the base.
    Stop(StopMsg),
    /// Tag 4: counters.
    Status(StatusMsg),
    /// Tag 5: per-beam labels of the last integrated scan (only if asked for).
    Labels(LabelsMsg),
    /// Tag 6: a message was refused.
    Error(ErrorMsg),
}

/// The messages one tick's [`Outputs`] produce, in order: the goal (whenever there is one), a
/// stop (whenever the controller asks for one), the status (always). Built one at a time, so
/// no more than one message is alive. The caller may drop or rate-limit any of them (say, send
/// a goal only when its `seq` or path changed).
pub struct OutputMessages<'a> {
    now_us: u64,
    outputs: &'a Outputs,
    link: LinkCounters,
    next: u8,
}

/// The messages for one tick's `outputs` at `now_us` (see [`OutputMessages`]).
pub fn output_messages(now_us: u64, outputs: &Outputs, link: LinkCounters) -> OutputMessages<'_> {
    OutputMessages { now_us, outputs, link, next: 0 }
}

impl Iterator for OutputMessages<'_> {
    type Item = CoreToHost;

    fn next(&mut self) -> Option<CoreToHost> {
        loop {
            let step = self.next;
            self.next = self.next.saturating_add(1);
            match step {
                0 => {
                    if let Some(g) = &self.outputs.goal {
                        return Some(CoreToHost::Goal(GoalMsg::from_goal(self.outputs.status.goals, g)));
                    }
                }
                1 => {
                    if self.outputs.stop {
                        let mode = self.outputs.status.mode.map_or(WireMode::Idle, WireMode::from);
                        return Some(CoreToHost::Stop(StopMsg { mode }));
                    }
                }
                2 => return Some(CoreToHost::Status(StatusMsg::from_status(self.now_us, &self.outputs.status, self.link))),
                _ => return None,
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Serde helpers: heapless vectors without the `heapless/serde` feature, fixed-width ranges, and
// beam labels as one byte.

impl Serialize for BeamLabel {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(*self as u8)
    }
}

impl<'de> Deserialize<'de> for BeamLabel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match u8::deserialize(d)? {
            0 => Ok(BeamLabel::Unlabelled),
            1 => Ok(BeamLabel::Map),
            2 => Ok(BeamLabel::NonMap),
            v => Err(serde::de::Error::invalid_value(serde::de::Unexpected::Unsigned(v as u64), &"a beam label 0, 1 or 2")),
        }
    }
}

mod ser {
    //! `#[serde(with = …)]` modules. Each reads a sequence into a `heapless::Vec`, refusing one
    //! longer than the capacity before reading past it (bounded work, no allocation).
    use core::marker::PhantomData;
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    struct SeqVisitor<T, E, const N: usize>(PhantomData<fn() -> (T, E)>);

    impl<'de, T, E, const N: usize> Visitor<'de> for SeqVisitor<T, E, N>
    where
        E: Deserialize<'de> + Into<T>,
    {
        type Value = heapless::Vec<T, N>;

        fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            write!(f, "a sequence of at most {N} elements")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            if let Some(n) = seq.size_hint() {
                if n > N {
                    return Err(A::Error::invalid_length(n, &self));
                }
            }
            let mut out = heapless::Vec::new();
            while let Some(e) = seq.next_element::<E>()? {
                if out.push(e.into()).is_err() {
                    return Err(A::Error::invalid_length(N + 1, &self));
                }
            }
            Ok(out)
        }
    }

    /// A range as two little-endian bytes (postcard would spend 3 bytes on values ≥ 16384).
    struct LeU16(u16);

    impl<'de> Deserialize<'de> for LeU16 {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            <[u8; 2]>::deserialize(d).map(|b| LeU16(u16::from_le_bytes(b)))
        }
    }

    impl From<LeU16> for u16 {
        fn from(v: LeU16) -> u16 {
            v.0
        }
    }

    pub mod vec {
        //! Any `heapless::Vec<T, N>` as a postcard sequence (length, then the elements).
        use super::*;

        pub fn serialize<S: Serializer, T: Serialize, const N: usize>(v: &heapless::Vec<T, N>, s: S) -> Result<S::Ok, S::Error> {
            s.collect_seq(v.iter())
        }

        pub fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(d: D) -> Result<heapless::Vec<T, N>, D::Error> {
            d.deserialize_seq(SeqVisitor::<T, T, N>(PhantomData))
        }
    }

    pub mod ranges {
        //! `heapless::Vec<u16, N>` as a length, then 2 bytes little-endian per element.
        use super::*;

        pub fn serialize<S: Serializer, const N: usize>(v: &heapless::Vec<u16, N>, s: S) -> Result<S::Ok, S::Error> {
            s.collect_seq(v.iter().map(|r| r.to_le_bytes()))
        }

        pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<heapless::Vec<u16, N>, D::Error> {
            d.deserialize_seq(SeqVisitor::<u16, LeU16, N>(PhantomData))
        }
    }

    pub mod opt_labels {
        //! `Option<heapless::Vec<T, N>>`: postcard's option tag, then the sequence.
        use super::*;

        struct Seq<'a, T, const N: usize>(&'a heapless::Vec<T, N>);

        impl<T: Serialize, const N: usize> Serialize for Seq<'_, T, N> {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.collect_seq(self.0.iter())
            }
        }

        pub fn serialize<S: Serializer, T: Serialize, const N: usize>(v: &Option<heapless::Vec<T, N>>, s: S) -> Result<S::Ok, S::Error> {
            match v {
                None => s.serialize_none(),
                Some(v) => s.serialize_some(&Seq(v)),
            }
        }

        struct OptVisitor<T, const N: usize>(PhantomData<fn() -> T>);

        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for OptVisitor<T, N> {
            type Value = Option<heapless::Vec<T, N>>;

            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                write!(f, "an optional sequence of at most {N} elements")
            }

            fn visit_none<E: Error>(self) -> Result<Self::Value, E> {
                Ok(None)
            }

            fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
                super::vec::deserialize(d).map(Some)
            }
        }

        pub fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(
            d: D,
        ) -> Result<Option<heapless::Vec<T, N>>, D::Error> {
            d.deserialize_option(OptVisitor::<T, N>(PhantomData))
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::planner::{Site, Viewpoint};
    use crate::scan::RANGE_NO_RETURN;

    #[test]
    fn a_pose_crosses_losslessly() {
        let p = Pose2::new(Meters::from_bits(-1), Meters::from_bits(i32::MAX), BinaryAngle::HALF);
        let m = PoseMsg::from_pose(9, &p);
        assert_eq!((m.t_us, m.x, m.y, m.theta), (9, -1, i32::MAX, i32::MIN));
        assert_eq!(m.pose(), p);
    }

    #[test]
    fn a_scan_is_lent_to_the_core_without_copying() {
        let ranges = [1000u16, 0, RANGE_NO_RETURN, 2500];
        let labels = [BeamLabel::Map, BeamLabel::Unlabelled, BeamLabel::Unlabelled, BeamLabel::NonMap];
        let input = ScanInput {
            angle_min: BinaryAngle::HALF,
            angle_increment: BinaryAngle::from_fraction(1, 4),
            ranges_mm: &ranges,
            labels: Some(&labels),
            range_min_mm: 100,
            range_max_mm: 12_000,
        };
        let m = ScanMsg::from_scan_input(5, &input).unwrap();
        assert_eq!((m.range_min_mm, m.range_max_mm), (100, 12_000));
        let back = m.scan_input();
        assert_eq!(back.ranges_mm.as_ptr(), m.ranges_mm.as_ptr(), "borrowed, not copied");
        assert_eq!((back.angle_min, back.angle_increment), (input.angle_min, input.angle_increment));
        assert_eq!((back.range_min_mm, back.range_max_mm), (100, 12_000));
        assert_eq!((back.ranges_mm, back.labels), (&ranges[..], Some(&labels[..])));
        let mut beams = BeamScan::new();
        assert_eq!(beams.resample(&back), Ok(2));

        let bad = ScanInput { labels: Some(&labels[..3]), ..input };
        assert_eq!(ScanMsg::from_scan_input(5, &bad), Err(WireError::LabelCountMismatch));
    }

    #[test]
    fn enums_map_both_ways() {
        for c in [Command::Start, Command::Stop, Command::Reset] {
            assert_eq!(Command::from(WireCommand::from(c)), c);
        }
        for m in [Mode::Idle, Mode::Exploring, Mode::TargetFound, Mode::Exhausted, Mode::Stopped] {
            assert_eq!(Mode::from(WireMode::from(m)), m);
        }
        for p in PlannerKind::ALL {
            assert_eq!(PlannerKind::from(WirePlanner::from(p)), p);
        }
        let d = Detection { position: Some((Meters::from_bits(3), Meters::from_bits(-4))) };
        assert_eq!(DetectionMsg::from_detection(1, &d).detection(), d);
        assert_eq!(
            WireScanError::from(ScanError::LabelCountMismatch { ranges: 5, labels: 4 }),
            WireScanError::LabelCountMismatch { ranges: 5, labels: 4 }
        );
    }

    fn goal() -> Goal {
        let vp = Viewpoint {
            cell: (10, 20),
            heading: BinaryAngle::QUARTER,
            source: Site::LidarFrontier,
            utility: -123_456,
            path_units: 50,
            unseen: 1,
            surface: 0,
            frontier_near_path: 2,
            nonmap: 3,
        };
        let mut path = heapless::Vec::new();
        path.push((Meters::from_num(1), Meters::from_num(2))).unwrap();
        path.push((Meters::from_num(1), Meters::from_num(3))).unwrap();
        Goal {
            pose: Pose2::new(Meters::from_num(1), Meters::from_num(3), BinaryAngle::QUARTER),
            viewpoint: vp,
            path,
            path_length_m: Meters::from_num(2),
        }
    }

    #[test]
    fn a_tick_becomes_goal_stop_and_status_messages() {
        let mut status = Status { mode: Some(Mode::Exploring), ticks: 10, goals: 4, ..Status::default() };
        let link = LinkCounters { frames_ok: 7, ..LinkCounters::default() };
        let out = Outputs { goal: Some(goal()), new_goal: true, stop: false, status };
        let msgs: std::vec::Vec<_> = output_messages(1_000, &out, link).collect();
        assert_eq!(msgs.len(), 2);
        let CoreToHost::Goal(g) = &msgs[0] else { panic!("{msgs:?}") };
        assert_eq!((g.seq, g.pose(), g.utility), (4, goal().pose, -123_456));
        assert_eq!(g.waypoints().collect::<std::vec::Vec<_>>(), goal().path.to_vec());
        let CoreToHost::Status(s) = &msgs[1] else { panic!("{msgs:?}") };
        assert_eq!((s.t_us, s.mode, s.ticks, s.goals, s.link), (1_000, WireMode::Exploring, 10, 4, link));

        status.mode = Some(Mode::TargetFound);
        status.last_scan_error = Some(ScanError::Empty);
        let out = Outputs { goal: None, new_goal: false, stop: true, status };
        let msgs: std::vec::Vec<_> = output_messages(2_000, &out, link).collect();
        assert_eq!(msgs[0], CoreToHost::Stop(StopMsg { mode: WireMode::TargetFound }));
        let CoreToHost::Status(s) = &msgs[1] else { panic!("{msgs:?}") };
        assert_eq!(s.last_scan_error, Some(WireScanError::Empty));
        assert_eq!(msgs.len(), 2);
    }

    #[test]
    fn labels_of_the_beam_grid() {
        let mut beams = BeamScan::new();
        beams.labels[3] = BeamLabel::NonMap;
        let m = LabelsMsg::from_beams(8, &beams);
        assert_eq!(m.labels.len(), BEAMS);
        assert_eq!((m.labels[3], m.labels[4]), (BeamLabel::NonMap, BeamLabel::Unlabelled));
    }

    #[test]
    fn worst_case_sizes() {
        assert_eq!(MAX_HOST_TO_CORE_LEN, 3332);
        assert_eq!(MAX_GOAL_LEN, 677);
        assert_eq!(MAX_LABELS_LEN, 910);
        assert_eq!((varint_len(0), varint_len(127), varint_len(128), varint_len(u64::MAX)), (1, 1, 2, 10));
    }
}
