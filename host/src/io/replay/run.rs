//! Running the controller over a log ([`replay_log`]): the options, the grid's placement, the
//! report and its summary line.

use super::source::LogSource;
use super::*;
use crate::run::{drive, round3, Answer, Frame, InProcess};
use firmware::{Config, Controller};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How to replay.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Controller settings (the grid origin is set by [`replay`]).
    pub config: Config,
    /// The int8 classifier blob run on the scans (the logs carry no labels); `None` runs none.
    /// Default: the committed geometric classifier, as `lives search` runs for `lives`.
    pub model: Option<&'static [u8]>,
    /// Record every tick to this MCAP file ([`crate::io::record`], Foxglove's schemas).
    pub record: Option<PathBuf>,
    /// The controller's LiDAR range for this log, metres (`None`: [`CARMEN_MAX_RANGE_M`] for
    /// CARMEN logs, the configuration's range for bags).
    pub max_range_m: Option<f64>,
    /// Whether the controller matches scans against its map (`None`: off, for every format: on
    /// every shared real log the matcher's own error per match is larger than the logged poses'
    /// error, and matching lost walls and drew phantom ones, docs/replay.md "Scan matching").
    pub scan_matching: Option<bool>,
}

/// The options `lives replay` and `lives mapcheck` take: a classifier blob or none, `--set`
/// overrides (`scan_matching` among them decides matching for every format), `--max-range`.
pub fn options(model: Option<&Path>, no_classifier: bool, set: &[String], max_range: Option<f64>) -> Result<ReplayOptions, String> {
    let model = crate::io::model_file::model_option(model, no_classifier)?;
    let mut opts = ReplayOptions { model, ..ReplayOptions::default() };
    for a in set {
        crate::overrides::apply(&mut opts.config, a)?;
        if a.trim_start().starts_with("scan_matching") {
            opts.scan_matching = Some(opts.config.scan_matching);
        }
    }
    if let Some(m) = max_range {
        fixed_point::meters_from_f64(m)
            .filter(|v| *v > opts.config.lidar_min_range_m && m <= 65.0)
            .ok_or_else(|| format!("--max-range {}: expected metres above the minimum range and at most 65", compact(m)))?;
        opts.max_range_m = Some(m);
    }
    Ok(opts)
}

impl Default for ReplayOptions {
    fn default() -> Self {
        ReplayOptions {
            // Real logs: when matching is on, the field matcher (docs/replay.md "Scan matching").
            config: Config { scan_match_field: true, ..Config::DEFAULT },
            model: Some(firmware::classifier::EMBEDDED_GEO_MODEL),
            record: None,
            max_range_m: None,
            scan_matching: None,
        }
    }
}

/// The LiDAR range used for CARMEN logs unless `--max-range` says otherwise: 10 m, the usable
/// range mappers give these SICK LMS logs (gmapping's `maxUrange`): their long readings go through
/// windows and glass, up to the 80 m "no return", and clear free space outside the building.
pub const CARMEN_MAX_RANGE_M: f64 = 10.0;

/// A goal the controller would have sent.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GoalRecord {
    /// Seconds since the first scan.
    pub t_s: f64,
    /// Goal position, metres.
    pub x: f64,
    /// Goal position, metres.
    pub y: f64,
    /// Heading to look along, degrees counter-clockwise from +x.
    pub heading_deg: f64,
    /// What the viewpoint came from (`LidarFrontier`, `VisualFrontier`, `NonMapCluster`, `Here`).
    pub source: String,
    /// Its utility.
    pub utility: f64,
    /// Path length from the robot, metres.
    pub path_m: f64,
    /// Where the robot (laser) was, metres.
    pub robot: [f64; 2],
}

/// Grid cell counts at the end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct GridCounts {
    /// LiDAR-occupied cells.
    pub occupied: u32,
    /// LiDAR-free cells.
    pub free: u32,
    /// Cells the camera has seen.
    pub camera_seen: u32,
}

/// Why scans were not used.
/// What the rolling window's memory did over a replay ([`ReplayReport::window_tiles`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct WindowTiles {
    /// Tiles kept as they left the window.
    pub kept: u32,
    /// Tiles restored as they came back.
    pub restored: u32,
    /// Tiles that left with something observed in them and did not fit.
    pub dropped: u32,
    /// Tiles held at the end (outside the final window).
    pub held: u32,
    /// The most bytes the tiles held took at once.
    pub peak_bytes: u32,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Rejected {
    /// The laser's pose lies outside the controller's 51.2 m window at that moment: it jumped
    /// past the window's edge (the window follows a laser that moves on; see
    /// [`firmware::rolling`]).
    pub outside_grid: u32,
    /// No pose (bag frames not connected) or a non-finite pose.
    pub no_pose: u32,
    /// A scan whose `angle_min` or `angle_increment` is not a finite number.
    pub bad_angles: u32,
    /// Refused by the controller: no beams, too many, a zero increment, labels miscounted, a
    /// `range_max` of 0 or not above `range_min` (by reason in
    /// [`ReplayReport::controller_rejections`]).
    pub controller: u32,
    /// The laser's pose strays far from the rest of the trajectory ([`place_grid`]): it did not
    /// place the grid.
    pub stray_pose: u32,
    /// A bag scan stamped before the first odometry message (the scanner started first): never
    /// placed at the frame tree's origin.
    pub no_odometry_yet: u32,
    /// A bag scan whose nearest odometry is more than [`rosbag::MAX_POSE_AGE_NS`] from its stamp.
    pub stale_pose: u32,
    /// A bag scan stamped before the scan before it.
    pub stamp_backwards: u32,
    /// A bag's point cloud whose frame is tilted more than
    /// [`rosbag::MAX_CLOUD_TILT_DEG`] from level: its cut would be a slanted one.
    pub tilted_cloud: u32,
    /// A bag scan of a second topic in a frame another topic scans (one scanner published
    /// twice): the topic with the most messages is used.
    pub duplicate_topic: u32,
}

/// Bad records skipped, for the report.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SkippedRecords {
    /// How many.
    pub total: u32,
    /// How many by reason (`truncated_line`, `bad_number`, `bad_beam_count`, `count_mismatch`,
    /// `out_of_range`, `extra_fields`, `not_text`, `undecodable_message`).
    pub by_reason: BTreeMap<&'static str, u32>,
    /// The first few, with the file and line, byte offset or row.
    pub first: Vec<String>,
}

impl SkippedRecords {
    fn of(b: &BadRecords) -> Self {
        SkippedRecords { total: b.total, by_reason: b.by_reason.clone(), first: b.first.iter().map(|e| e.to_string()).collect() }
    }
}

/// The machine-readable result (`--json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayReport {
    /// The log.
    pub file: String,
    /// Its format.
    pub format: LogFormat,
    /// Line types or topics used.
    pub sources: Vec<String>,
    /// Scans read from the log.
    pub scans_read: u32,
    /// Scans the controller integrated.
    pub scans_used: u32,
    /// Scans not used.
    pub scans_rejected: u32,
    /// Why.
    pub rejected: Rejected,
    /// The controller's refusals by reason (`empty`, `too_many_beams`, `zero_increment`,
    /// `label_count_mismatch`, `bad_range_limits`).
    pub controller_rejections: BTreeMap<&'static str, u32>,
    /// Bad records skipped (reading went on after each).
    pub skipped_records: SkippedRecords,
    /// Bag transforms (odometry, `tf`) rejected: a jump, a loop of frames, a stamp going
    /// backwards; the scans are placed with the others.
    pub transforms_rejected: rosbag::RejectedTransforms,
    /// Odometry messages read.
    pub odometry: u32,
    /// Time span of the log (everything time-stamped that was read), seconds.
    pub duration_s: f64,
    /// Wall time to read and replay (pictures excluded), seconds.
    pub wall_s: f64,
    /// Of which reading the log.
    pub read_s: f64,
    /// `wall_s / duration_s`.
    pub ratio: f64,
    /// `int8-classifier` or `none`.
    pub labels: String,
    /// Planning steps run.
    pub plans: u32,
    /// Goals it would have sent, in order.
    pub goals: Vec<GoalRecord>,
    /// Goals blacklisted by the controller (no progress towards them: nobody drives).
    pub blacklisted: u32,
    /// Cells at the end.
    pub grid: GridCounts,
    /// Non-map points pooled at the end.
    pub nonmap_points: u32,
    /// Lower-left corner of the grid where it was placed, metres (`Config.origin_x_m/origin_y_m`).
    pub grid_origin: [f64; 2],
    /// Lower-left corner of the grid at the end, metres: where the rolling window had moved it
    /// (the picture and the final grid counts are of this window).
    pub final_grid_origin: [f64; 2],
    /// Times the rolling window moved.
    pub window_shifts: u32,
    /// Tiles of 32 × 32 cells the window's memory kept as they left the window, restored as they
    /// came back, and dropped for want of room (`firmware::rolling::memory`).
    pub window_tiles: WindowTiles,
    /// Grid side, metres.
    pub grid_size_m: f64,
    /// Bounding box of the laser's trajectory `[[min x, min y], [max x, max y]]`, metres (without
    /// stray poses).
    pub trajectory_bounds: [[f64; 2]; 2],
    /// The trajectory does not fit in the grid: the grid was placed on its first pose and the
    /// rolling window followed the laser (what left the window was kept, [`ReplayReport::window_tiles`]).
    pub exceeds_grid: bool,
    /// Scans of more than the core's [`firmware::protocol::MAX_WIRE_BEAMS`] beams, combined on
    /// the way in: `[scans, the most beams combined into one]` (`[0, 1]`: none;
    /// [`crate::run::range::EncodedScan::fitted`]).
    pub beams_combined: [u32; 2],
    /// Assumptions and notes.
    pub warnings: Vec<String>,
    /// The damage reading stopped at (the scans before it were replayed).
    pub error: Option<String>,
    /// The `--record` file, if one was written.
    pub record: Option<RecordInfo>,
    /// What the scan matcher did.
    pub matching: MatchReport,
}

/// What `--record` wrote.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct RecordInfo {
    /// The MCAP file.
    pub file: String,
    /// Messages written.
    pub messages: u64,
    /// The first recording error (recording stops there; the replay does not).
    pub error: Option<String>,
}

/// What the scan matcher did over a replay (`--set scan_matching=true`; off by default): how many scans it matched or refused, and how far its accepted matches moved the
/// odometry's prediction. On a log whose poses are already right (a SLAM-corrected log) every
/// move is an error; on raw odometry they are its corrections.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MatchReport {
    /// Matching was on.
    pub on: bool,
    /// Scans matched (a correction accepted, possibly zero).
    pub matched: u32,
    /// Scans refused: too few returns.
    pub too_few_points: u32,
    /// Scans refused: the best score too low.
    pub low_score: u32,
    /// How far each accepted match moved the pose, millimetres.
    pub shift_mm: crate::run::Summary,
    /// How far each turned it, degrees.
    pub turn_deg: crate::run::Summary,
    /// The accepted matches' score at the prediction and at the match, ‰ of the most possible
    /// (means).
    pub score_per_mille: [f64; 2],
}

/// A laser pose at a log time stamp.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TimedPose {
    /// The scan's time stamp in the log, seconds (as the log prints it, not since the first scan).
    pub t_s: f64,
    /// `[x, y, θ]`, metres and radians.
    pub pose: [f64; 3],
}

/// A finished replay: the report and what a picture needs.
pub struct ReplayRun {
    /// The report.
    pub report: ReplayReport,
    /// The controller at the end.
    pub controller: Box<Controller>,
    /// Laser positions, one per scan used.
    pub trajectory: Vec<[f64; 2]>,
    /// One per scan used: its log time stamp and the laser pose the controller mapped it at
    /// (`[x, y, θ]`, metres and radians, in the log's frame).
    pub poses: Vec<TimedPose>,
    /// First and last laser pose used.
    pub first_pose: [f64; 3],
    /// See `first_pose`.
    pub last_pose: [f64; 3],
    /// Bad records skipped.
    pub bad_records: BadRecords,
    /// The damage reading stopped at, if any.
    pub error: Option<ReplayError>,
}

/// Grid side, metres.
pub fn grid_size_m() -> f64 {
    firmware::capacity::GRID_CELLS as f64 / firmware::capacity::CELLS_PER_METER as f64
}

/// The largest coordinate the core's fixed-point poses hold, metres
/// ([`fixed_point::meters_from_f64`]).
pub const MAX_COORD_M: f64 = 32_767.0;

/// Where the grid goes: the bounds of the laser positions that place it, and the scans whose
/// position does not.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// Bounding box of the positions that place the grid `[[min x, min y], [max x, max y]]`,
    /// metres.
    pub bounds: [[f64; 2]; 2],
    /// Per scan: a stray, whose finite position lies beyond the core's ±[`MAX_COORD_M`], or more
    /// than a grid side ([`grid_size_m`]) outside the box of the middle half of the positions
    /// (their x and y quartiles). Such a position could not share the grid with half of the
    /// trajectory; counted in, one corrupt `x` of `1e9` would move the grid off the trajectory.
    pub stray: Vec<bool>,
}

/// Places the grid on the scans' laser positions, robust to strays (up to a quarter of them):
/// the bounding box of the positions that are finite and not strays. `None` when there is none.
pub fn place_grid(scans: &[ScanRecord]) -> Option<Placement> {
    let finite = |p: &[f64; 3]| p[0].is_finite() && p[1].is_finite();
    let in_range = |p: &[f64; 3]| p[0].abs() <= MAX_COORD_M && p[1].abs() <= MAX_COORD_M;
    let mut xs: Vec<f64> = scans.iter().map(|s| s.pose).filter(in_range).map(|p| p[0]).collect();
    let mut ys: Vec<f64> = scans.iter().map(|s| s.pose).filter(in_range).map(|p| p[1]).collect();
    xs.sort_by(f64::total_cmp);
    ys.sort_by(f64::total_cmp);
    let quartile = |v: &[f64], k: usize| v.get((v.len().saturating_sub(1)) * k / 4).copied();
    let margin = grid_size_m();
    let window = [
        [quartile(&xs, 1).unwrap_or(0.0) - margin, quartile(&ys, 1).unwrap_or(0.0) - margin],
        [quartile(&xs, 3).unwrap_or(0.0) + margin, quartile(&ys, 3).unwrap_or(0.0) + margin],
    ];
    let stray: Vec<bool> = scans
        .iter()
        .map(|s| {
            let p = s.pose;
            finite(&p) && (!in_range(&p) || p[0] < window[0][0] || p[1] < window[0][1] || p[0] > window[1][0] || p[1] > window[1][1])
        })
        .collect();
    let mut it = scans.iter().zip(&stray).filter(|(s, stray)| finite(&s.pose) && !**stray).map(|(s, _)| s.pose);
    let first = it.next()?;
    let mut b = [[first[0], first[1]], [first[0], first[1]]];
    for p in it {
        b[0] = [b[0][0].min(p[0]), b[0][1].min(p[1])];
        b[1] = [b[1][0].max(p[0]), b[1][1].max(p[1])];
    }
    Some(Placement { bounds: b, stray })
}

/// The grid origin (lower-left corner, on the 0.1 m lattice) that centres the grid on `bounds`,
/// kept where the core's fixed-point coordinates hold the whole grid.
pub fn grid_origin(bounds: [[f64; 2]; 2]) -> [f64; 2] {
    let half = grid_size_m() / 2.0;
    let c = [(bounds[0][0] + bounds[1][0]) / 2.0, (bounds[0][1] + bounds[1][1]) / 2.0];
    let (lo, hi) = (-MAX_COORD_M, ((MAX_COORD_M - grid_size_m()) * 10.0).floor() / 10.0);
    [(((c[0] - half) * 10.0).round() / 10.0).clamp(lo, hi), (((c[1] - half) * 10.0).round() / 10.0).clamp(lo, hi)]
}

/// Reads `path` and replays it. Fails when the log cannot be opened, is not a known format, or
/// holds no usable scan before its damage (the damage is then the error).
pub fn replay(path: &Path, opts: &ReplayOptions) -> Result<ReplayRun, ReplayError> {
    let t_start = Instant::now();
    let log = read_log(path)?;
    let read_s = t_start.elapsed().as_secs_f64();
    replay_log(log, opts, t_start, read_s)
}

/// Why a log gave no scan to replay: what became of the ones it had.
fn unplaced_scans(log: &LogData) -> String {
    let stale = format!("with no odometry within {} s", rosbag::MAX_POSE_AGE_NS as f64 / 1e9);
    let counts = [
        (log.unplaced.no_pose, "whose frame no odometry or transform places"),
        (log.unplaced.no_odometry_yet, "stamped before the first odometry"),
        (log.unplaced.stale_pose, stale.as_str()),
        (log.unplaced.scan_stamp_backwards, "stamped before the scan before them"),
        (log.unplaced.tilted_cloud, "point clouds in a frame tilted from level"),
        (log.unplaced.duplicate_topic, "of a second topic in a frame another topic scans"),
    ];
    let said: Vec<String> = counts.iter().filter(|(n, _)| *n > 0).map(|(n, what)| format!("{n} {what}")).collect();
    if said.is_empty() {
        "it has none (FLASER or ROBOTLASER1 lines; LaserScan or PointCloud2 messages; VLP-16 packets)".into()
    } else if log.warnings.is_empty() {
        format!("none could be placed: {}", said.join(", "))
    } else {
        format!("none could be placed: {} ({})", said.join(", "), log.warnings.join("; "))
    }
}

/// Replays a log already read ([`read_log`]); `t_start` is when reading began.
pub fn replay_log(log: LogData, opts: &ReplayOptions, t_start: Instant, read_s: f64) -> Result<ReplayRun, ReplayError> {
    let Some(Placement { bounds, stray }) = place_grid(&log.scans) else {
        if let Some(e) = log.error {
            return Err(e);
        }
        if let Some(s) = log.scans.iter().find(|s| s.pose[0].is_finite() && s.pose[1].is_finite()) {
            let (at, position) = (s.at, [s.pose[0], s.pose[1]]);
            return Err(ReplayError::PosesOutOfRange { file: log.file, scans: log.scans.len(), at, position });
        }
        let why = unplaced_scans(&log);
        let mut bad = log.bad_records;
        return Err(if bad.first.is_empty() {
            ReplayError::NoScans { why, file: log.file }
        } else {
            ReplayError::NoGoodScans { file: log.file, skipped: bad.total, first: Box::new(bad.first.remove(0)) }
        });
    };
    let centred = grid_origin(bounds);
    let size = grid_size_m();
    let exceeds =
        bounds[0][0] < centred[0] || bounds[0][1] < centred[1] || bounds[1][0] >= centred[0] + size || bounds[1][1] >= centred[1] + size;
    // A trajectory that does not fit: the grid starts centred on the first pose that placed it,
    // and the core's rolling window follows the laser from there.
    let first = log.scans.iter().zip(&stray).find(|(s, st)| !**st && s.pose[0].is_finite() && s.pose[1].is_finite());
    let origin = match first {
        Some((s, _)) if exceeds => grid_origin([[s.pose[0], s.pose[1]]; 2]),
        _ => centred,
    };
    let (Some(origin_x_m), Some(origin_y_m)) = (fixed_point::meters_from_f64(origin[0]), fixed_point::meters_from_f64(origin[1])) else {
        return Err(ReplayError::GridOrigin { file: log.file, origin });
    };
    let carmen = matches!(log.format, LogFormat::Carmen | LogFormat::CarmenGzip);
    let max_range = match (opts.max_range_m, carmen) {
        (Some(m), _) => fixed_point::meters_from_f64(m).unwrap_or(opts.config.lidar_max_range_m),
        (None, true) => fixed_point::meters_from_f64(CARMEN_MAX_RANGE_M).unwrap_or(opts.config.lidar_max_range_m),
        (None, false) => opts.config.lidar_max_range_m,
    };
    let scan_matching = opts.scan_matching.unwrap_or(false);
    let cfg = Config { origin_x_m, origin_y_m, lidar_max_range_m: max_range, scan_matching, ..opts.config };
    let mut ctrl = Box::new(Controller::new(cfg));
    if let Some(blob) = opts.model {
        ctrl.set_model(blob).map_err(ReplayError::Model)?;
    }
    let mut recorder = match &opts.record {
        Some(p) => Some(
            crate::io::record::Recorder::create(
                p,
                crate::io::record::RecordOptions { grid_period_us: REPLAY_GRID_PERIOD_US, ..Default::default() },
            )
            .map_err(|e| ReplayError::Record { file: p.clone(), reason: e.to_string() })?,
        ),
        None => None,
    };
    let mut record_error: Option<String> = None;
    // Time stamps that do not advance cannot drive the controller's clock: one scan per tick.
    let (distinct, synthetic_time) = super::stamps_stand_still(&log.scans);
    let mut source = LogSource::new(&log.scans, &stray, synthetic_time);
    let mut goals = Vec::new();
    let mut trajectory = Vec::new();
    let mut poses = Vec::new();
    let (mut first_pose, mut last_pose) = (None, [0.0; 3]);
    let mut outside_grid = 0u32;
    let mut before = (firmware::Status::default(), ctrl.matcher.stats.matched);
    let mut controller_rejections: BTreeMap<&'static str, u32> = BTreeMap::new();
    let (mut shifts, mut turns, mut scores) = (Vec::new(), Vec::new(), [0.0f64; 2]);
    let mut watch = |src: &LogSource<'_>, frame: &Frame, brain: &InProcess, answer: &Answer| {
        let (ctrl, Some(out)) = (&brain.ctrl, brain.outputs()) else { return };
        let (refused_before, matched_before) = before;
        let status = out.status;
        let ms = &ctrl.matcher.stats;
        before = (status, ms.matched);
        if ms.matched > matched_before {
            shifts.push(ms.last_move.dist_mm as f64);
            turns.push(ms.last_move.turn_mdeg as f64 / 1000.0);
            scores[0] += ms.last_predicted_per_mille as f64;
            scores[1] += ms.last_score_per_mille as f64;
        }
        if status.scans_rejected > refused_before.scans_rejected {
            let reason = match status.last_scan_error {
                Some(firmware::ScanError::Empty) => "empty",
                Some(firmware::ScanError::TooManyBeams(_)) => "too_many_beams",
                Some(firmware::ScanError::ZeroIncrement) => "zero_increment",
                Some(firmware::ScanError::LabelCountMismatch { .. }) => "label_count_mismatch",
                Some(firmware::ScanError::BadRangeLimits { .. }) => "bad_range_limits",
                None => "unknown",
            };
            *controller_rejections.entry(reason).or_insert(0) += 1;
        }
        if status.poses_rejected > refused_before.poses_rejected {
            // A jump past the window's edge (in the controller's map frame): the core refused
            // the pose and did not draw the scan.
            outside_grid += 1;
            return;
        }
        if let (Some(rec), None) = (recorder.as_mut(), &record_error) {
            if let Err(e) = rec.record_controller_tick(frame.t_us, &frame.inputs(answer.command), out, ctrl) {
                record_error = Some(e.to_string());
            }
        }
        let s = src.record();
        trajectory.push([s.pose[0], s.pose[1]]);
        let used = ctrl.pose().map_or(s.pose, |p| {
            let (x, y, th) = p.to_f64();
            [x, y, th]
        });
        poses.push(TimedPose { t_s: s.t_s, pose: used });
        first_pose.get_or_insert(s.pose);
        last_pose = s.pose;
        if let (true, Some(g)) = (out.new_goal, &out.goal) {
            goals.push(GoalRecord {
                t_s: round3(frame.t_us as f64 / 1e6),
                x: round3(g.pose.x.to_num::<f64>()),
                y: round3(g.pose.y.to_num::<f64>()),
                heading_deg: round3(g.pose.theta.to_radians().to_degrees()),
                source: format!("{:?}", g.viewpoint.source),
                utility: round3(g.viewpoint.utility as f64 / 65536.0),
                path_m: round3(g.path_length_m.to_num::<f64>()),
                robot: [round3(s.pose[0]), round3(s.pose[1])],
            });
        }
    };
    let mut brain = InProcess::restarting(ctrl, cfg.replan_interval_us);
    let Ok(_) = drive(&mut source, &mut brain, &mut [&mut watch]);
    let LogSource { stray_pose, no_pose, bad_angles, strays, combined_scans, combined_most, .. } = source;
    let mut rejected = Rejected {
        outside_grid,
        no_pose: log.unplaced.no_pose as u32 + no_pose,
        bad_angles,
        stray_pose,
        no_odometry_yet: log.unplaced.no_odometry_yet as u32,
        stale_pose: log.unplaced.stale_pose as u32,
        stamp_backwards: log.unplaced.scan_stamp_backwards as u32,
        tilted_cloud: log.unplaced.tilted_cloud as u32,
        duplicate_topic: log.unplaced.duplicate_topic as u32,
        ..Rejected::default()
    };
    let ctrl = brain.ctrl;
    let status = before.0;
    rejected.controller = status.scans_rejected;
    let record = recorder.zip(opts.record.as_ref()).map(|(rec, path)| {
        let messages = rec.summary().total_messages();
        let finished = rec.finish();
        RecordInfo {
            file: path.display().to_string(),
            messages: finished.as_ref().map_or(messages, |s| s.total_messages()),
            error: record_error.clone().or_else(|| finished.err().map(|e| e.to_string())),
        }
    });
    let wall_s = t_start.elapsed().as_secs_f64();
    let mut grid = GridCounts { occupied: 0, free: 0, camera_seen: 0 };
    let n = firmware::capacity::GRID_CELLS as i32;
    for y in 0..n {
        for x in 0..n {
            match ctrl.lidar.get(x, y) {
                firmware::Cell::Occupied => grid.occupied += 1,
                firmware::Cell::Free => grid.free += 1,
                firmware::Cell::Unknown => {}
            }
            grid.camera_seen += ctrl.visual.seen(x, y) as u32;
        }
    }
    let mut warnings = log.warnings;
    let duration_s = if synthetic_time {
        warnings.push(format!(
            "the log's time stamps do not advance ({distinct} distinct among {} scans): replayed at one scan per {} ms, \
             and the duration is that of the replayed scans",
            log.scans.len(),
            crate::run::TICK_US / 1000
        ));
        (log.scans.len() - 1) as f64 * crate::run::TICK_US as f64 / 1e6
    } else {
        log.span_s.map_or(0.0, |(a, b)| b - a)
    };
    if combined_scans > 0 {
        warnings.push(format!(
            "{combined_scans} scan{} had more beams than the core takes ({}): up to {combined_most} neighbouring beams \
             were combined into one, keeping the nearest return",
            if combined_scans == 1 { "" } else { "s" },
            firmware::protocol::MAX_WIRE_BEAMS
        ));
    }
    if rejected.stray_pose > 0 {
        let more = rejected.stray_pose as usize - strays.len();
        warnings.push(format!(
            "{} whose laser pose strays far from the rest of the trajectory (beyond ±{MAX_COORD_M} m, or more than \
             {size:.1} m outside the middle half of it) did not place the grid and {} not used: {}{}",
            if rejected.stray_pose == 1 { "1 scan".to_string() } else { format!("{} scans", rejected.stray_pose) },
            if rejected.stray_pose == 1 { "was" } else { "were" },
            strays.join(", "),
            if more > 0 { format!(" and {more} more") } else { String::new() }
        ));
    }
    let window = ctrl.lidar.window;
    let final_origin = [round3(ctrl.lidar.geom.origin_x.to_num::<f64>()), round3(ctrl.lidar.geom.origin_y.to_num::<f64>())];
    if exceeds {
        warnings.push(format!(
            "the trajectory ({:.1} × {:.1} m) does not fit the controller's {size:.1} m grid: the grid started on the first \
             pose and its window moved {} time{} to follow the laser, keeping what it left ({} tiles kept, {} restored, \
             {} dropped for want of room); the final grid and picture show the window at the end, lower-left corner ({}, {})",
            bounds[1][0] - bounds[0][0],
            bounds[1][1] - bounds[0][1],
            window.shifts,
            if window.shifts == 1 { "" } else { "s" },
            ctrl.memory.stats.kept,
            ctrl.memory.stats.restored,
            ctrl.memory.stats.dropped,
            compact(final_origin[0]),
            compact(final_origin[1])
        ));
    }
    let unplaced = log.unplaced.total();
    let scans_read = log.scans.len() as u32 + unplaced as u32;
    let scans_rejected = rejected.outside_grid
        + rejected.no_pose
        + rejected.bad_angles
        + rejected.controller
        + rejected.stray_pose
        + rejected.no_odometry_yet
        + rejected.stale_pose
        + rejected.stamp_backwards
        + rejected.tilted_cloud
        + rejected.duplicate_topic;
    let report = ReplayReport {
        file: log.file.display().to_string(),
        format: log.format,
        sources: log.sources,
        scans_read,
        scans_used: status.scans,
        scans_rejected,
        rejected,
        controller_rejections,
        skipped_records: SkippedRecords::of(&log.bad_records),
        transforms_rejected: log.transforms_rejected,
        odometry: log.odometry as u32,
        duration_s: round3(duration_s),
        wall_s: round3(wall_s),
        read_s: round3(read_s),
        ratio: if duration_s > 0.0 { (wall_s / duration_s * 1e4).round() / 1e4 } else { f64::NAN },
        labels: if opts.model.is_some() { "int8-classifier" } else { "none" }.to_string(),
        plans: status.plans,
        goals,
        blacklisted: status.blacklisted,
        grid,
        nonmap_points: ctrl.nonmap.points().len() as u32,
        grid_origin: origin,
        final_grid_origin: final_origin,
        window_shifts: window.shifts,
        window_tiles: WindowTiles {
            kept: ctrl.memory.stats.kept,
            restored: ctrl.memory.stats.restored,
            dropped: ctrl.memory.stats.dropped,
            held: ctrl.memory.tiles() as u32,
            peak_bytes: ctrl.memory.stats.peak_bytes,
        },
        grid_size_m: size,
        trajectory_bounds: bounds.map(|p| p.map(round3)),
        exceeds_grid: exceeds,
        beams_combined: [combined_scans, combined_most as u32],
        warnings,
        error: log.error.as_ref().map(|e| e.to_string()),
        record,
        matching: {
            let ms = &ctrl.matcher.stats;
            let n = shifts.len().max(1) as f64;
            MatchReport {
                on: scan_matching,
                matched: ms.matched,
                too_few_points: ms.too_few_points,
                low_score: ms.low_score,
                shift_mm: crate::run::Summary::of(&shifts),
                turn_deg: crate::run::Summary::of(&turns),
                score_per_mille: [round3(scores[0] / n), round3(scores[1] / n)],
            }
        },
    };
    let first_pose = first_pose.unwrap_or(log.scans[0].pose);
    Ok(ReplayRun { report, controller: ctrl, trajectory, poses, first_pose, last_pose, bad_records: log.bad_records, error: log.error })
}

/// `1 bad record skipped`, `2 bad records skipped`.
pub(super) fn bad_records_skipped(n: u32) -> String {
    format!("{n} bad record{} skipped", if n == 1 { "" } else { "s" })
}

/// The one-line summary `lives replay` prints.
pub fn summary_line(r: &ReplayReport) -> String {
    format!(
        "{} ({}): {} scans read, {} used, {} rejected{}; {:.1} s of log replayed in {:.2} s ({:.2} % of its duration); \
         {} goals; grid {} occupied / {} free cells; labels: {}{}",
        r.file,
        r.format,
        r.scans_read,
        r.scans_used,
        r.scans_rejected,
        match r.skipped_records.total {
            0 => String::new(),
            n => format!(", {}", bad_records_skipped(n)),
        },
        r.duration_s,
        r.wall_s,
        100.0 * r.ratio,
        r.goals.len(),
        r.grid.occupied,
        r.grid.free,
        r.labels,
        match &r.matching {
            m if m.on => format!(
                "; scan matching: {} matched, {} refused, moved {} mm (median; {} at most)",
                m.matched,
                m.low_score + m.too_few_points,
                m.shift_mm.p50.round(),
                m.shift_mm.max.round()
            ),
            _ => String::new(),
        }
    )
}
