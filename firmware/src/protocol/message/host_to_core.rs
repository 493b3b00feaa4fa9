//! Host → core messages: pose, scans and their segments, detections, commands, the base's status,
//! the configuration's planner, and [`HostToCore`].

use super::*;
use crate::config::PlannerKind;
use crate::controller::{Command, Detection};
use crate::scan::{BeamLabel, ScanInput, RANGE_LIMIT_MM};
use fixed_point::{BinaryAngle, Meters, Pose2};
use serde::{Deserialize, Serialize};

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

/// Bytes of one plane of a map row: a whole grid row, a bit per cell.
pub const MAP_ROW_BYTES: usize = crate::capacity::GRID_CELLS / 8;

/// A run of cells of one row of the building's prior map (v7, LIVE's known-map mode,
/// [`crate::knownmap`]): cells `x0 .. x0 + n` of row `y` of the map's window, bit `i` (least
/// significant first) of each plane cell `x0 + i`. A cell neither occupied nor free is unknown.
/// The host sends a map as one message per row, before `Start`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MapRowMsg {
    /// Forget the map held before this row (the first row of a new map).
    pub reset: bool,
    /// The map window's lower-left corner, metres as Q16.16 bits (read when `reset`).
    pub origin_x: i32,
    /// See `origin_x`.
    pub origin_y: i32,
    /// Row, from the window's lowest.
    pub y: u16,
    /// First cell.
    pub x0: u16,
    /// Cells.
    pub n: u16,
    /// 1: occupied.
    #[serde(with = "ser::vec")]
    pub occupied: heapless::Vec<u8, MAP_ROW_BYTES>,
    /// 1: free.
    #[serde(with = "ser::vec")]
    pub free: heapless::Vec<u8, MAP_ROW_BYTES>,
}

/// Route waypoints per [`RouteMsg`].
pub const MAX_ROUTE_CHUNK: usize = 32;

/// One waypoint of a coverage route: x, y (metres as Q16.16 bits), heading (binary angle).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct WireWaypoint {
    /// x.
    pub x: i32,
    /// y.
    pub y: i32,
    /// Heading.
    pub heading: i32,
}

/// A run of waypoints of the coverage route (v7, LIVE's waypoint manager,
/// [`crate::planner::coverage`]): waypoints `first ..` of the route. `first == 0` starts a new
/// route; otherwise `first` must be the number the core holds (a chunk out of order is refused).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RouteMsg {
    /// Index of the first waypoint.
    pub first: u16,
    /// The waypoints.
    #[serde(with = "ser::vec")]
    pub waypoints: heapless::Vec<WireWaypoint, MAX_ROUTE_CHUNK>,
}

/// The planner kind on the wire: [`PlannerKind`] itself (its variant order is the wire's).
pub type WirePlanner = PlannerKind;

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
    /// Tag 9 (v7): a row of the building's prior map.
    MapRow(MapRowMsg),
    /// Tag 10 (v7): waypoints of the coverage route.
    Route(RouteMsg),
}
