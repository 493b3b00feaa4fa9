//! Run recordings: `--record FILE.mcap` writes what a run saw and decided to an MCAP file that
//! Foxglove opens without plug-ins.
//!
//! Every message is JSON (`message_encoding = "json"`) with a JSON Schema
//! (`schema_encoding = "jsonschema"`). The schemas are Foxglove's published ones (`foxglove.*`,
//! vendored from the npm package `@foxglove/schemas` 2.1.0, MIT, in `schemas/`), so Foxglove's 3D,
//! Log, Raw Messages and Plot panels show them as they are; only `/lives/status` uses a schema of
//! ours (`lives.Status`), which Foxglove shows in Raw Messages and Plot. Frames follow REP-103:
//! `map` (the world), `base_link` (the robot, x forward, y left), `laser` (the LiDAR, at the
//! robot's centre: an identity transform from `base_link`). Times are the run's clock: virtual
//! time from 0 for simulated runs (`log_time` = `publish_time` = the message's `timestamp`).
//!
//! | topic | schema | frame | when |
//! |---|---|---|---|
//! | `/tf` | `foxglove.FrameTransforms` | `map`→`base_link`→`laser` | every pose |
//! | `/lives/pose` | `foxglove.PoseInFrame` | `map` | every pose |
//! | `/lives/scan` | `foxglove.PointCloud` (x, y, z, label, red, green, blue, alpha) | `laser` | every scan |
//! | `/lives/labels` | `foxglove.PointCloud`, the node's labels on its beam grid | `laser` | bridge, per `Labels` frame |
//! | `/lives/lidar_grid`, `/lives/visual_grid` | `foxglove.Grid` (`occupancy`: int8 −1/0/100), cropped to the known area | `map` | in-process, every second of run time and at the end |
//! | `/lives/nonmap_points` | `foxglove.PointCloud` (x, y, z, hits, rgba) | `map` | with the grids |
//! | `/lives/frontiers` | `foxglove.SceneUpdate`: a sphere per frontier, metadata map/cells | `map` | in-process, every planning step |
//! | `/lives/candidates` | `foxglove.SceneUpdate`: an arrow and a utility text per candidate viewpoint, metadata with the utility terms | `map` | in-process, every planning step |
//! | `/lives/goal` | `foxglove.PoseInFrame` | `map` | every new goal |
//! | `/lives/path` | `foxglove.PosesInFrame` (waypoints, facing along the path) | `map` | every new goal |
//! | `/lives/detection` | `foxglove.SceneUpdate`: where the robot was when the target was detected | `map` | every detection |
//! | `/lives/log` | `foxglove.Log` | — | every mode change, new goal and detection |
//! | `/lives/status` | `lives.Status` (the controller's counters) | — | every status |
//!
//! **API.** A [`Recorder`] is a message-level writer for three callers:
//!
//! - in-process runs (`lives search`, `lives replay`) call [`Recorder::record_controller_tick`]
//!   after every `Controller::tick` with the tick's time, inputs and outputs and the controller:
//!   it records everything above that the controller holds (grids, points, frontiers and
//!   candidates included). `record_search` in the simulated search (`search.rs`) does this.
//! - the bridge (`lives bridge`) sees only protocol messages, so grids, non-map points,
//!   frontiers and candidates are not in its recordings: `SharedRecording` (the link's
//!   `record.rs`) gives the bridge an observer that records pose, scan (with the labels it carries), the node's labels (when the bridge asked
//!   for them), detection, goal, path, status and log.
//! - anything else calls the single-message methods (`record_pose`, `record_scan`, `record_goal`,
//!   `record_status`, `record_detection`, `record_grids`, …) itself.
//!
//! **Written as it goes.** Messages go into MCAP chunks that are closed and written to the file
//! ([`mcap::Writer::flush`]) every [`RecordOptions::flush_every`] of wall time (1 s) and every
//! [`RecordOptions::flush_every_messages`] messages, whichever comes first. Chunks are built in
//! memory and written in one go, so a crash leaves every chunk written before it intact, followed
//! at most by part of the one being written: it loses at most the last second (or the last
//! `flush_every_messages` messages). Such a file has no summary (no footer): streaming readers
//! (`mcap` Python `StreamReader`, Rust `MessageStream`) read it up to where it breaks off.
//! [`Recorder::finish`] writes the summary, after which any reader opens it.
//!
//! Recording only reads: a run is bit-identical with and without it.

use firmware::grid::{beam_angle, mm_to_meters, GridGeometry, PackedGrid};
use firmware::planner::Viewpoint;
use firmware::protocol::{DetectionMsg, GoalMsg, LinkCounters, StatusMsg, WireMode};
use firmware::scan::{BeamLabel, BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use firmware::{Controller, FrontierSet, Inputs, Mode, Outputs, Pose2};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

mod msg;
use msg::*;

pub(crate) mod convert;
use convert::*;

/// The world frame.
pub const FRAME_MAP: &str = "map";
/// The robot frame.
pub const FRAME_BASE: &str = "base_link";
/// The LiDAR frame (at the robot's centre).
pub const FRAME_LASER: &str = "laser";

/// Topic names.
pub mod topics {
    /// `foxglove.FrameTransforms`: map → base_link → laser.
    pub const TF: &str = "/tf";
    /// `foxglove.PoseInFrame`: the robot's pose.
    pub const POSE: &str = "/lives/pose";
    /// `foxglove.PointCloud`: the scan, coloured by label.
    pub const SCAN: &str = "/lives/scan";
    /// `foxglove.PointCloud`: the node's labels on its beam grid (bridge).
    pub const LABELS: &str = "/lives/labels";
    /// `foxglove.Grid`: the LiDAR map.
    pub const LIDAR_GRID: &str = "/lives/lidar_grid";
    /// `foxglove.Grid`: the visual (camera) map.
    pub const VISUAL_GRID: &str = "/lives/visual_grid";
    /// `foxglove.PointCloud`: the pooled non-map points.
    pub const NONMAP: &str = "/lives/nonmap_points";
    /// `foxglove.SceneUpdate`: frontiers of both maps.
    pub const FRONTIERS: &str = "/lives/frontiers";
    /// `foxglove.SceneUpdate`: candidate viewpoints with their utilities.
    pub const CANDIDATES: &str = "/lives/candidates";
    /// `foxglove.PoseInFrame`: the chosen goal.
    pub const GOAL: &str = "/lives/goal";
    /// `foxglove.PosesInFrame`: the goal's path.
    pub const PATH: &str = "/lives/path";
    /// `foxglove.SceneUpdate`: where the target was detected.
    pub const DETECTION: &str = "/lives/detection";
    /// `foxglove.Log`: mode changes, goals, detections.
    pub const LOG: &str = "/lives/log";
    /// `lives.Status`: the controller's counters.
    pub const STATUS: &str = "/lives/status";
}

/// The schema of each topic: (topic, schema name, JSON Schema).
pub(crate) const CHANNELS: &[(&str, &str, &str)] = &[
    (topics::TF, "foxglove.FrameTransforms", include_str!("schemas/FrameTransforms.json")),
    (topics::POSE, "foxglove.PoseInFrame", include_str!("schemas/PoseInFrame.json")),
    (topics::SCAN, "foxglove.PointCloud", include_str!("schemas/PointCloud.json")),
    (topics::LABELS, "foxglove.PointCloud", include_str!("schemas/PointCloud.json")),
    (topics::LIDAR_GRID, "foxglove.Grid", include_str!("schemas/Grid.json")),
    (topics::VISUAL_GRID, "foxglove.Grid", include_str!("schemas/Grid.json")),
    (topics::NONMAP, "foxglove.PointCloud", include_str!("schemas/PointCloud.json")),
    (topics::FRONTIERS, "foxglove.SceneUpdate", include_str!("schemas/SceneUpdate.json")),
    (topics::CANDIDATES, "foxglove.SceneUpdate", include_str!("schemas/SceneUpdate.json")),
    (topics::GOAL, "foxglove.PoseInFrame", include_str!("schemas/PoseInFrame.json")),
    (topics::PATH, "foxglove.PosesInFrame", include_str!("schemas/PosesInFrame.json")),
    (topics::DETECTION, "foxglove.SceneUpdate", include_str!("schemas/SceneUpdate.json")),
    (topics::LOG, "foxglove.Log", include_str!("schemas/Log.json")),
    (topics::STATUS, "lives.Status", include_str!("schemas/lives.Status.json")),
];

/// Why a recording failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum RecordError {
    /// The file could not be created.
    Create {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Writing MCAP records failed (disk full, I/O error).
    Write(mcap::McapError),
    /// A message could not be encoded as JSON.
    Encode(serde_json::Error),
    /// A topic that has no schema here.
    UnknownTopic(String),
    /// The recording was already finished.
    Finished,
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordError::Create { path, source } => write!(f, "cannot create the recording {}: {source}", path.display()),
            RecordError::Write(e) => write!(f, "writing the recording failed: {e}"),
            RecordError::Encode(e) => write!(f, "encoding a recorded message failed: {e}"),
            RecordError::UnknownTopic(t) => write!(f, "no schema for topic `{t}`"),
            RecordError::Finished => f.write_str("the recording is already finished"),
        }
    }
}

impl std::error::Error for RecordError {}

impl From<mcap::McapError> for RecordError {
    fn from(e: mcap::McapError) -> Self {
        RecordError::Write(e)
    }
}

impl From<serde_json::Error> for RecordError {
    fn from(e: serde_json::Error) -> Self {
        RecordError::Encode(e)
    }
}

/// How a recording is written.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    /// Close and write the current chunk after this much wall time (bounds what a crash loses).
    pub flush_every: Duration,
    /// ... and after this many messages.
    pub flush_every_messages: u64,
    /// Record the grids and non-map points this often in run time, microseconds (and at the
    /// end of the search).
    pub grid_period_us: u64,
}

impl Default for RecordOptions {
    /// 1 s of wall time or 256 messages per chunk; grids every 1 s of run time.
    fn default() -> Self {
        RecordOptions { flush_every: Duration::from_secs(1), flush_every_messages: 256, grid_period_us: 1_000_000 }
    }
}

/// What a recording holds.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RecordSummary {
    /// Messages per topic.
    pub messages: BTreeMap<String, u64>,
    /// JSON bytes per topic.
    pub message_bytes: BTreeMap<String, u64>,
    /// Chunks closed and written.
    pub flushes: u64,
}

impl RecordSummary {
    /// All messages.
    pub fn total_messages(&self) -> u64 {
        self.messages.values().sum()
    }
}

/// An MCAP recording being written. See the module docs for topics and API.
pub struct Recorder {
    writer: mcap::Writer<BufWriter<File>>,
    opts: RecordOptions,
    channels: BTreeMap<&'static str, u16>,
    summary: RecordSummary,
    sequence: u32,
    since_flush: u64,
    last_flush: Instant,
    // In-process and bridge bookkeeping.
    last_t_us: u64,
    last_scans: u32,
    last_plans: u32,
    last_grid_us: Option<u64>,
    last_mode: Option<WireMode>,
    last_goal_seq: Option<u32>,
    last_status: Option<(u64, u32)>,
    robot: Option<Pose2>,
    beams: Box<BeamScan>,
    beams_t_us: Option<u64>,
}

impl fmt::Debug for Recorder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Recorder").field("summary", &self.summary).finish_non_exhaustive()
    }
}

impl Recorder {
    /// Creates (replaces) `path` and writes the MCAP header, flushed at once.
    pub fn create(path: &Path, opts: RecordOptions) -> Result<Self, RecordError> {
        let file = File::create(path).map_err(|source| RecordError::Create { path: path.to_path_buf(), source })?;
        // Chunks built in memory and written in one go (`disable_seeking`), zstd-compressed on
        // this thread when built with the `zstd` feature (about 8x smaller; Foxglove and the
        // `mcap` readers read both).
        #[cfg(feature = "zstd")]
        let compression = Some(mcap::Compression::Zstd);
        #[cfg(not(feature = "zstd"))]
        let compression = None;
        let options = mcap::WriteOptions::new()
            .compression(compression)
            .profile("")
            .library(concat!("lives ", env!("CARGO_PKG_VERSION")))
            .disable_seeking(true)
            .chunk_size(Some(4 << 20));
        // Compress on this thread (no worker pool); the option exists with the zstd codec only.
        #[cfg(feature = "zstd")]
        let options = options.compression_threads(0);
        let mut writer = options.create(BufWriter::new(file))?;
        writer.flush()?;
        Ok(Recorder {
            writer,
            opts,
            channels: BTreeMap::new(),
            summary: RecordSummary::default(),
            sequence: 0,
            since_flush: 0,
            last_flush: Instant::now(),
            last_t_us: 0,
            last_scans: 0,
            last_plans: 0,
            last_grid_us: None,
            last_mode: None,
            last_goal_seq: None,
            last_status: None,
            robot: None,
            beams: Box::new(BeamScan::new()),
            beams_t_us: None,
        })
    }

    /// What has been recorded so far.
    pub fn summary(&self) -> &RecordSummary {
        &self.summary
    }

    /// Messages recorded since the last chunk was written to the file: what a crash now would
    /// lose.
    pub fn unflushed_messages(&self) -> u64 {
        self.since_flush
    }

    /// Writes the chunk in progress and the summary (channels, statistics, indexes) and closes
    /// the file.
    pub fn finish(mut self) -> Result<RecordSummary, RecordError> {
        self.writer.finish()?;
        self.summary.flushes += 1;
        Ok(std::mem::take(&mut self.summary))
    }

    fn channel(&mut self, topic: &'static str) -> Result<u16, RecordError> {
        if let Some(&id) = self.channels.get(topic) {
            return Ok(id);
        }
        let (_, name, schema) = CHANNELS.iter().find(|c| c.0 == topic).ok_or_else(|| RecordError::UnknownTopic(topic.to_string()))?;
        let schema_id = self.writer.add_schema(name, "jsonschema", schema.as_bytes())?;
        let id = self.writer.add_channel(schema_id, topic, "json", &BTreeMap::new())?;
        self.channels.insert(topic, id);
        Ok(id)
    }

    /// Records one message on `topic` at `t_us` (run clock, microseconds).
    fn write<M: Serialize>(&mut self, topic: &'static str, t_us: u64, msg: &M) -> Result<(), RecordError> {
        let channel_id = self.channel(topic)?;
        let data = serde_json::to_vec(msg)?;
        let t_ns = t_us.saturating_mul(1000);
        let header = mcap::records::MessageHeader { channel_id, sequence: self.sequence, log_time: t_ns, publish_time: t_ns };
        self.writer.write_to_known_channel(&header, &data)?;
        self.sequence = self.sequence.wrapping_add(1);
        *self.summary.messages.entry(topic.to_string()).or_default() += 1;
        *self.summary.message_bytes.entry(topic.to_string()).or_default() += data.len() as u64;
        self.last_t_us = self.last_t_us.max(t_us);
        self.since_flush += 1;
        if self.since_flush >= self.opts.flush_every_messages || self.last_flush.elapsed() >= self.opts.flush_every {
            self.flush()?;
        }
        Ok(())
    }

    /// Closes the chunk in progress and writes it to the file now.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.writer.flush()?;
        self.summary.flushes += 1;
        self.since_flush = 0;
        self.last_flush = Instant::now();
        Ok(())
    }

    /// The latest time stamp recorded so far, microseconds.
    pub fn last_t_us(&self) -> u64 {
        self.last_t_us
    }

    /// The robot's pose: `/tf` (map → base_link → laser) and `/lives/pose`.
    pub fn record_pose(&mut self, t_us: u64, pose: &Pose2) -> Result<(), RecordError> {
        self.robot = Some(*pose);
        let ts = Time::of(t_us);
        let p = Pose::of(pose);
        let tf = FrameTransforms {
            transforms: [
                FrameTransform {
                    timestamp: ts,
                    parent_frame_id: FRAME_MAP,
                    child_frame_id: FRAME_BASE,
                    translation: p.position,
                    rotation: p.orientation,
                },
                FrameTransform {
                    timestamp: ts,
                    parent_frame_id: FRAME_BASE,
                    child_frame_id: FRAME_LASER,
                    translation: Vec3::ZERO,
                    rotation: Quat::IDENTITY,
                },
            ],
        };
        self.write(topics::TF, t_us, &tf)?;
        self.write(topics::POSE, t_us, &PoseInFrame { timestamp: ts, frame_id: FRAME_MAP, pose: p })
    }

    /// A scan on the core's beam grid (beam `b` at −π + b·2π/897 in the `laser` frame), its points
    /// coloured by label: map blue-grey, non-map orange, unlabelled grey. Beams without a return
    /// are left out.
    pub fn record_scan(&mut self, t_us: u64, scan: &BeamScan) -> Result<(), RecordError> {
        self.record_beams(topics::SCAN, t_us, &scan.ranges_mm, &scan.labels)
    }

    /// A scan as the sensor sent it (any layout): resampled onto the core's beam grid as the core
    /// does, then as [`Recorder::record_scan`]. A scan the core would refuse is not recorded.
    pub fn record_scan_input(&mut self, t_us: u64, scan: &firmware::ScanInput<'_>) -> Result<(), RecordError> {
        if self.beams.resample(scan).is_err() {
            self.beams_t_us = None;
            return Ok(());
        }
        self.beams_t_us = Some(t_us);
        let beams = std::mem::replace(&mut self.beams, Box::new(BeamScan::new()));
        let r = self.record_scan(t_us, &beams);
        self.beams = beams;
        r
    }

    /// The node's labels for the scan recorded at `t_us` by [`Recorder::record_scan_input`]
    /// (`/lives/labels`); labels for another scan are not recorded.
    pub fn record_node_labels(&mut self, t_us: u64, labels: &[BeamLabel]) -> Result<(), RecordError> {
        if self.beams_t_us != Some(t_us) || labels.len() != self.beams.ranges_mm.len() {
            return Ok(());
        }
        let ranges = self.beams.ranges_mm;
        self.record_beams(topics::LABELS, t_us, &ranges, labels)
    }

    fn record_beams(&mut self, topic: &'static str, t_us: u64, ranges_mm: &[u16], labels: &[BeamLabel]) -> Result<(), RecordError> {
        const STRIDE: usize = 17;
        let mut data = Vec::with_capacity(ranges_mm.len() * STRIDE);
        for (b, (&r, &label)) in ranges_mm.iter().zip(labels).enumerate() {
            if r == RANGE_INVALID || r == RANGE_NO_RETURN {
                continue;
            }
            let (m, a) = (mm_to_meters(r).to_num::<f64>(), beam_angle(b).to_radians());
            let rgb = match label {
                BeamLabel::Map => [90, 120, 200],
                BeamLabel::NonMap => [255, 140, 0],
                BeamLabel::Unlabelled => [160, 160, 160],
            };
            data.extend_from_slice(&((m * a.cos()) as f32).to_le_bytes());
            data.extend_from_slice(&((m * a.sin()) as f32).to_le_bytes());
            data.extend_from_slice(&0f32.to_le_bytes());
            data.extend_from_slice(&[label as u8, rgb[0], rgb[1], rgb[2], 255]);
        }
        let msg = PointCloud {
            timestamp: Time::of(t_us),
            frame_id: FRAME_LASER,
            pose: Pose::IDENTITY,
            point_stride: STRIDE as u32,
            fields: &SCAN_FIELDS,
            data: base64(&data),
        };
        self.write(topic, t_us, &msg)
    }

    /// The controller's status (`/lives/status`), and a `/lives/log` line when the mode changed.
    /// A status repeated with the same time and tick count (a retried lockstep batch) is
    /// recorded once.
    pub fn record_status(&mut self, s: &StatusMsg) -> Result<(), RecordError> {
        if self.last_status == Some((s.t_us, s.ticks)) {
            return Ok(());
        }
        self.last_status = Some((s.t_us, s.ticks));
        self.write(topics::STATUS, s.t_us, &Status(s))?;
        if self.last_mode != Some(s.mode) {
            self.last_mode = Some(s.mode);
            self.log(s.t_us, LOG_INFO, format!("mode: {:?}", s.mode))?;
        }
        Ok(())
    }

    /// A goal (`/lives/goal`) and its path (`/lives/path`, each waypoint facing the next, the
    /// last the goal's heading), and a `/lives/log` line; a goal with the `seq` of the last one
    /// recorded is not recorded again.
    pub fn record_goal(&mut self, t_us: u64, g: &GoalMsg) -> Result<(), RecordError> {
        if self.last_goal_seq == Some(g.seq) {
            return Ok(());
        }
        self.last_goal_seq = Some(g.seq);
        let ts = Time::of(t_us);
        let goal = g.pose();
        self.write(topics::GOAL, t_us, &PoseInFrame { timestamp: ts, frame_id: FRAME_MAP, pose: Pose::of(&goal) })?;
        let pts: Vec<[f64; 2]> = g.waypoints().map(|(x, y)| [x.to_num::<f64>(), y.to_num::<f64>()]).collect();
        let theta = goal.theta.to_radians();
        let poses = pts
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let yaw = pts.get(i + 1).map_or(theta, |q| (q[1] - p[1]).atan2(q[0] - p[0]));
                Pose::xy_yaw(p[0], p[1], yaw)
            })
            .collect();
        self.write(topics::PATH, t_us, &PosesInFrame { timestamp: ts, frame_id: FRAME_MAP, poses })?;
        let text = format!(
            "goal #{} at ({:.2}, {:.2}) m facing {:.0}°, utility {:.2}, path {:.1} m ({} waypoints)",
            g.seq,
            goal.x.to_num::<f64>(),
            goal.y.to_num::<f64>(),
            theta.to_degrees(),
            g.utility as f64 / 65536.0,
            firmware::Meters::from_bits(g.path_length_m).to_num::<f64>(),
            pts.len()
        );
        self.log(t_us, LOG_INFO, text)
    }

    /// A detection of the target (`/lives/detection`: a red sphere where the detector placed it,
    /// or at the robot if it did not), and a `/lives/log` warning line.
    pub fn record_detection(&mut self, t_us: u64, d: &DetectionMsg) -> Result<(), RecordError> {
        let robot = self.robot.map(|p| [p.x.to_num::<f64>(), p.y.to_num::<f64>()]);
        let (at, localised) = match d.position {
            Some((x, y)) => (Some([firmware::Meters::from_bits(x).to_num::<f64>(), firmware::Meters::from_bits(y).to_num::<f64>()]), true),
            None => (robot, false),
        };
        let ts = Time::of(t_us);
        let [x, y] = at.unwrap_or([0.0, 0.0]);
        let text = if localised { format!("target at ({x:.2}, {y:.2})") } else { format!("target seen from ({x:.2}, {y:.2})") };
        let entity = SceneEntity {
            timestamp: ts,
            frame_id: FRAME_MAP,
            id: "detection".into(),
            metadata: vec![KeyValue::new("localised", localised.to_string()), KeyValue::new("t_s", format!("{:.3}", t_us as f64 / 1e6))],
            spheres: vec![Sphere {
                pose: Pose::xy_yaw(x, y, 0.0),
                size: Vec3 { x: 0.6, y: 0.6, z: 0.6 },
                color: Color::rgba(1.0, 0.1, 0.1, 0.8),
            }],
            texts: vec![Text::new(Pose::xy_yaw(x, y + 0.5, 0.0), 14.0, Color::rgba(1.0, 0.2, 0.2, 1.0), text.clone())],
            ..SceneEntity::empty()
        };
        self.write(topics::DETECTION, t_us, &SceneUpdate { deletions: vec![], entities: vec![entity] })?;
        self.log(t_us, LOG_WARNING, format!("detection: {text}"))
    }

    /// A line on `/lives/log` (`level`: 1 debug … 5 fatal, as `foxglove.Log`).
    fn log(&mut self, t_us: u64, level: u8, message: String) -> Result<(), RecordError> {
        self.write(topics::LOG, t_us, &Log { timestamp: Time::of(t_us), level, message, name: "lives", file: "", line: 0 })
    }

    /// Both grids (`/lives/lidar_grid`, `/lives/visual_grid`), cropped to the cells either map
    /// knows (nothing if neither knows any), as `int8` ROS occupancy values.
    pub fn record_grids(&mut self, t_us: u64, geom: &GridGeometry, lidar: &PackedGrid, visual: &PackedGrid) -> Result<(), RecordError> {
        let Some([x0, y0, x1, y1]) = known_box(lidar, visual) else { return Ok(()) };
        for (topic, grid) in [(topics::LIDAR_GRID, lidar), (topics::VISUAL_GRID, visual)] {
            let msg = grid_msg(t_us, geom, grid, [x0, y0, x1, y1]);
            self.write(topic, t_us, &msg)?;
        }
        Ok(())
    }

    /// The pooled non-map points (`/lives/nonmap_points`, `map` frame, magenta), with the times
    /// each was hit.
    pub fn record_nonmap(&mut self, t_us: u64, points: &[firmware::nonmap::NonMapPoint]) -> Result<(), RecordError> {
        const STRIDE: usize = 18;
        let mut data = Vec::with_capacity(points.len() * STRIDE);
        for p in points {
            data.extend_from_slice(&p.x.to_num::<f32>().to_le_bytes());
            data.extend_from_slice(&p.y.to_num::<f32>().to_le_bytes());
            data.extend_from_slice(&0f32.to_le_bytes());
            data.extend_from_slice(&p.hits.to_le_bytes());
            data.extend_from_slice(&[230, 40, 200, 255]);
        }
        let msg = PointCloud {
            timestamp: Time::of(t_us),
            frame_id: FRAME_MAP,
            pose: Pose::IDENTITY,
            point_stride: STRIDE as u32,
            fields: &NONMAP_FIELDS,
            data: base64(&data),
        };
        self.write(topics::NONMAP, t_us, &msg)
    }

    /// The frontiers of the last planning step (`/lives/frontiers`): one entity per frontier
    /// (`frontier/<i>`, a sphere at its viewpoint cell sized by its cell count; LiDAR cyan,
    /// visual magenta), replacing the previous set.
    pub fn record_frontiers(&mut self, t_us: u64, geom: &GridGeometry, frontiers: &FrontierSet) -> Result<(), RecordError> {
        let ts = Time::of(t_us);
        let entities = frontiers
            .frontiers()
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let [x, y] = cell_centre(geom, f.anchor);
                let lidar = f.source == firmware::frontier::FrontierSource::Lidar;
                let d = (0.15 + 0.01 * f.cells as f64).min(0.6);
                SceneEntity {
                    timestamp: ts,
                    frame_id: FRAME_MAP,
                    id: format!("frontier/{i}"),
                    metadata: vec![
                        KeyValue::new("map", if lidar { "lidar" } else { "visual" }.to_string()),
                        KeyValue::new("cells", f.cells.to_string()),
                        KeyValue::new("centroid_cell", format!("{},{}", f.centroid.0, f.centroid.1)),
                    ],
                    spheres: vec![Sphere {
                        pose: Pose::xy_yaw(x, y, 0.0),
                        size: Vec3 { x: d, y: d, z: d },
                        color: if lidar { Color::rgba(0.0, 0.8, 0.9, 0.8) } else { Color::rgba(0.8, 0.2, 0.9, 0.8) },
                    }],
                    ..SceneEntity::empty()
                }
            })
            .collect();
        self.write(topics::FRONTIERS, t_us, &SceneUpdate { deletions: vec![Deletion::all(ts)], entities })
    }

    /// The candidate viewpoints of the last planning step with their utilities
    /// (`/lives/candidates`): one entity per candidate (`candidate/<i>`, an arrow where the robot
    /// would stand, facing where it would look, green for high utility to red for low, and a text
    /// with the utility; metadata with every utility term), replacing the previous set.
    pub fn record_candidates(&mut self, t_us: u64, geom: &GridGeometry, candidates: &[Viewpoint]) -> Result<(), RecordError> {
        let ts = Time::of(t_us);
        let (lo, hi) = candidates.iter().fold((i64::MAX, i64::MIN), |(lo, hi), v| (lo.min(v.utility), hi.max(v.utility)));
        let entities = candidates
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let [x, y] = cell_centre(geom, v.cell);
                let u = v.utility as f64 / 65536.0;
                let k = if hi > lo { (v.utility - lo) as f64 / (hi - lo) as f64 } else { 1.0 };
                let pose = Pose::xy_yaw(x, y, v.heading.to_radians());
                SceneEntity {
                    timestamp: ts,
                    frame_id: FRAME_MAP,
                    id: format!("candidate/{i}"),
                    metadata: vec![
                        KeyValue::new("utility", format!("{u:.3}")),
                        KeyValue::new("source", site_name(v.source).to_string()),
                        KeyValue::new("path_m", format!("{:.2}", v.path_length_m().to_num::<f64>())),
                        KeyValue::new("unseen", v.unseen.to_string()),
                        KeyValue::new("surface", v.surface.to_string()),
                        KeyValue::new("frontier_near_path", v.frontier_near_path.to_string()),
                        KeyValue::new("nonmap", v.nonmap.to_string()),
                    ],
                    arrows: vec![Arrow {
                        pose,
                        shaft_length: 0.3,
                        shaft_diameter: 0.04,
                        head_length: 0.12,
                        head_diameter: 0.12,
                        color: Color::rgba(1.0 - k, k, 0.1, 0.9),
                    }],
                    texts: vec![Text::new(Pose::xy_yaw(x, y, 0.0), 10.0, Color::rgba(1.0, 1.0, 1.0, 1.0), format!("{u:.1}"))],
                    ..SceneEntity::empty()
                }
            })
            .collect();
        self.write(topics::CANDIDATES, t_us, &SceneUpdate { deletions: vec![Deletion::all(ts)], entities })
    }

    /// Everything an in-process run's controller holds, after its tick at `t_us` with `inputs`
    /// that answered `out`: pose (when one came), scan (when one was integrated: the core's
    /// resampled, labelled beams), status, mode changes, detection, frontiers and candidates
    /// (after a planning step), goal and path (when a new goal was chosen), and the grids and
    /// non-map points every [`RecordOptions::grid_period_us`] and when the search ends
    /// (target found or exhausted). Call it after every tick.
    pub fn record_controller_tick(&mut self, t_us: u64, inputs: &Inputs<'_>, out: &Outputs, ctrl: &Controller) -> Result<(), RecordError> {
        let geom = ctrl.lidar.geom;
        if let Some(p) = inputs.pose {
            self.record_pose(t_us, &p)?;
        }
        if inputs.scan.is_some() && out.status.scans != self.last_scans {
            self.record_scan(t_us, ctrl.beams())?;
        }
        self.last_scans = out.status.scans;
        self.record_status(&StatusMsg::from_status(t_us, &out.status, LinkCounters::default()))?;
        if let Some(d) = &inputs.detection {
            self.record_detection(t_us, &DetectionMsg::from_detection(t_us, d))?;
        }
        if out.status.plans != self.last_plans {
            self.last_plans = out.status.plans;
            self.record_frontiers(t_us, &geom, &ctrl.frontiers)?;
            self.record_candidates(t_us, &geom, &ctrl.planner.candidates)?;
        }
        if let (true, Some(g)) = (out.new_goal, ctrl.goal()) {
            self.record_goal(t_us, &GoalMsg::from_goal(out.status.goals, g))?;
        }
        let ended = matches!(out.status.mode, Some(Mode::TargetFound | Mode::Exhausted));
        let due = self.last_grid_us.is_none_or(|t| t_us >= t.saturating_add(self.opts.grid_period_us));
        if due || ended {
            self.last_grid_us = Some(t_us);
            self.record_grids(t_us, &geom, &ctrl.lidar.grid, &ctrl.visual.grid)?;
            self.record_nonmap(t_us, ctrl.nonmap.points())?;
        }
        Ok(())
    }
}
