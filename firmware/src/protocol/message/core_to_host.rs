//! Core → host messages: goals, stops, status with stage costs and link counters, labels, errors,
//! [`CoreToHost`] and the messages of one tick's outputs ([`output_messages`]).

use super::*;
use crate::controller::{Outputs, StageCost, Status};
use crate::planner::Goal;
use crate::scan::{BeamLabel, BeamScan, ScanError};
use fixed_point::{BinaryAngle, Meters, Pose2};
use serde::{Deserialize, Serialize};

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

/// Work per stage on the wire: [`StageCost`] itself (its field order is the wire's).
pub type StageCostMsg = StageCost;

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
    /// [`Status::search_entropy_bits`] (v7).
    pub search_entropy_bits: u32,
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
            cost: s.cost,
            overruns: s.overruns,
            heap_overflows: s.heap_overflows,
            link,
            gaze: s.gaze.map(|h| h.0),
            search_entropy_bits: s.search_entropy_bits,
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
    /// A map row was refused: outside the map's window, or planes shorter than its cells (v7).
    MapRowRefused {
        /// The row.
        y: u16,
    },
    /// Route waypoints were refused: out of order, or past the route's capacity (v7).
    RouteRefused {
        /// The first waypoint refused.
        index: u16,
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
