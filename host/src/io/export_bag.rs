//! `lives export-bag LOG OUT.mcap`: a ROS 2 bag (MCAP, CDR) written from a CARMEN log as a real
//! robot would record it, to check replay on what real bags hold:
//!
//! - `sensor_msgs/msg/LaserScan` on `/scan` (frame `laser`), header-stamped with the log's time
//!   (a log whose stamps stand still, as the CSAIL logs', one scan per 200 ms from its first),
//!   `range_max` as given (default [`DEFAULT_RANGE_MAX_M`]): readings at or beyond it, and the
//!   log's no-return readings, are `+inf` (REP 117); invalid readings are NaN; `range_min`
//!   as given;
//! - `nav_msgs/msg/Odometry` on `/odom` (`odom` → `base_link`) at the log's poses, starting
//!   `--odometry-after` scans after the first (default 3: a real bag's scanner starts before the
//!   odometry), one message per scan at the scan's stamp, received just before it;
//! - `tf2_msgs/msg/TFMessage` on `/tf_static`: `base_link` → `laser` with the mount offset and
//!   yaw given (default 0.1 m, 0.05 m, 90°). The base faces where the log's laser faced and
//!   sits so that the mount puts the laser where the log's laser was; the laser frame is turned
//!   by the mount's yaw and the beam angles are expressed in it, so the world geometry (where
//!   every reading lands) is the log's.
//!
//! The MCAP is uncompressed, one channel per topic, `ros2` profile, `ros2msg` schemas named by
//! type (their definition text left empty: replay and Foxglove go by the name).

use crate::io::replay::cdr::{self, Header, LaserScan, Odometry, Time, Transform, TransformStamped};
use crate::io::replay::{self, LogFormat};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `range_max` of the exported scans unless told: 12 m, an indoor 360° scanner's (RPLIDAR A2/A3).
pub const DEFAULT_RANGE_MAX_M: f32 = 12.0;
/// `range_min` of the exported scans unless told.
pub const DEFAULT_RANGE_MIN_M: f32 = 0.1;

/// How to export.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportOptions {
    /// `range_max`, metres.
    pub range_max_m: f32,
    /// `range_min`, metres.
    pub range_min_m: f32,
    /// Odometry starts this many scans after the first.
    pub odometry_after: usize,
    /// `base_link` → `laser`: x, y (metres), yaw (degrees).
    pub mount: [f64; 3],
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions { range_max_m: DEFAULT_RANGE_MAX_M, range_min_m: DEFAULT_RANGE_MIN_M, odometry_after: 3, mount: [0.1, 0.05, 90.0] }
    }
}

/// What was written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportSummary {
    /// Scans written.
    pub scans: usize,
    /// Odometry messages written.
    pub odometry: usize,
    /// Readings written as `+inf` (no return, or at or beyond `range_max`).
    pub inf_readings: usize,
    /// Readings written in all.
    pub readings: usize,
    /// The log's stamps stood still, so the bag's advance one scan per tick from the first
    /// ([`replay::stamps_stand_still`]).
    pub synthetic_stamps: bool,
}

fn stamp(t_s: f64) -> Time {
    let ns = (t_s * 1e9).round().max(0.0) as u64;
    Time { sec: (ns / 1_000_000_000).min(i32::MAX as u64) as i32, nanosec: (ns % 1_000_000_000) as u32 }
}

/// Exports the CARMEN log `log` to the MCAP bag `out`.
pub fn export(log: &Path, out: &Path, opts: &ExportOptions) -> Result<ExportSummary, String> {
    if !(opts.range_max_m.is_finite() && opts.range_min_m >= 0.0 && opts.range_max_m > opts.range_min_m) {
        return Err(format!("range_max {} must be finite and above range_min {}", opts.range_max_m, opts.range_min_m));
    }
    if !opts.mount.iter().all(|v| v.is_finite()) {
        return Err(format!("mount {:?}: not finite", opts.mount));
    }
    let data = replay::read_log(log).map_err(|e| e.to_string())?;
    if !matches!(data.format, LogFormat::Carmen | LogFormat::CarmenGzip) {
        return Err(format!("{}: a {} file, not a CARMEN log", log.display(), data.format));
    }
    if let Some(e) = &data.error {
        return Err(format!("{e} (the log is damaged: nothing exported)"));
    }
    if data.bad_records.total > 0 {
        eprintln!("warning: {}: {} bad records skipped ({})", log.display(), data.bad_records.total, data.bad_records.reasons());
    }
    let [mx, my, myaw_deg] = opts.mount;
    let myaw = myaw_deg.to_radians();
    let file = std::fs::File::create(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .profile("ros2")
        .create(std::io::BufWriter::new(file))
        .map_err(|e| format!("{}: {e}", out.display()))?;
    let mut channels: BTreeMap<&str, u16> = BTreeMap::new();
    let mut seq = 0u32;
    let mut put = |w: &mut mcap::Writer<_>, topic: &'static str, ty: &str, t_ns: u64, bytes: &[u8]| -> Result<(), String> {
        let id = match channels.get(topic) {
            Some(&id) => id,
            None => {
                let def = crate::io::replay::cdr::ros2msg_definition(ty).unwrap_or_default();
                let schema = w.add_schema(ty, "ros2msg", def.as_bytes()).map_err(|e| e.to_string())?;
                let id = w.add_channel(schema, topic, "cdr", &BTreeMap::new()).map_err(|e| e.to_string())?;
                channels.insert(topic, id);
                id
            }
        };
        seq += 1;
        let header = mcap::records::MessageHeader { channel_id: id, sequence: seq, log_time: t_ns, publish_time: t_ns };
        w.write_to_known_channel(&header, bytes).map_err(|e| e.to_string())
    };
    // A robot's bag has stamps that advance. A log whose stamps stand still (the CSAIL logs) is
    // stamped as replay plays it: one scan per tick from its first stamp.
    let (_, synthetic) = replay::stamps_stand_still(&data.scans);
    let mut summary = ExportSummary { scans: 0, odometry: 0, inf_readings: 0, readings: 0, synthetic_stamps: synthetic };
    let ns = |t_s: f64| (t_s * 1e9).round().max(0.0) as u64;
    let t0 = data.scans.first().map_or(0.0, |s| s.t_s);
    for (i, s) in data.scans.iter().enumerate() {
        let t_s = if synthetic { t0 + i as f64 * crate::run::TICK_US as f64 * 1e-6 } else { s.t_s };
        let t_ns = ns(t_s);
        if i == 0 {
            let tf = cdr::encode_tf_message(&[TransformStamped {
                header: Header { stamp: stamp(t_s), frame_id: "base_link".into() },
                child_frame_id: "laser".into(),
                transform: Transform::planar(mx, my, myaw),
            }]);
            put(&mut w, "/tf_static", "tf2_msgs/msg/TFMessage", t_ns, &tf)?;
        }
        if i >= opts.odometry_after {
            // The base faces where the log's laser faced; the laser sits at the mount offset
            // from it, turned by the mount's yaw (its beams' angles turned back to match).
            let [lx, ly, lth] = s.pose;
            let bth = lth;
            let (sb, cb) = bth.sin_cos();
            let (bx, by) = (lx - (cb * mx - sb * my), ly - (sb * mx + cb * my));
            let odom = cdr::encode_odometry(&Odometry {
                header: Header { stamp: stamp(t_s), frame_id: "odom".into() },
                child_frame_id: "base_link".into(),
                pose: Transform::planar(bx, by, bth),
            });
            put(&mut w, "/odom", "nav_msgs/msg/Odometry", t_ns.saturating_sub(1_000), &odom)?;
            summary.odometry += 1;
        }
        let ranges: Vec<f32> = s
            .ranges_m
            .iter()
            .map(|&r| match r {
                r if r.is_nan() => f32::NAN,
                r if r >= opts.range_max_m => f32::INFINITY,
                r => r,
            })
            .collect();
        summary.inf_readings += ranges.iter().filter(|r| **r == f32::INFINITY).count();
        summary.readings += ranges.len();
        let n = ranges.len();
        let angle_min = s.angle_min - myaw;
        let scan = LaserScan {
            header: Header { stamp: stamp(t_s), frame_id: "laser".into() },
            angle_min: angle_min as f32,
            angle_max: (angle_min + s.angle_increment * (n.max(1) - 1) as f64) as f32,
            angle_increment: s.angle_increment as f32,
            time_increment: 0.0,
            scan_time: 0.0,
            range_min: opts.range_min_m,
            range_max: opts.range_max_m,
            ranges,
            intensities: vec![],
        };
        put(&mut w, "/scan", "sensor_msgs/msg/LaserScan", t_ns, &cdr::encode_laser_scan(&scan))?;
        summary.scans += 1;
    }
    w.finish().map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(summary)
}

/// `lives export-bag` arguments.
#[derive(clap::Args, Debug)]
pub struct ExportBagArgs {
    /// The CARMEN log (plain or .gz).
    pub log: PathBuf,
    /// The MCAP bag to write.
    pub out: PathBuf,
    /// The scans' `range_max`, metres: readings at or beyond it become `+inf`.
    #[arg(long, default_value_t = DEFAULT_RANGE_MAX_M)]
    pub range_max: f32,
    /// The scans' `range_min`, metres.
    #[arg(long, default_value_t = DEFAULT_RANGE_MIN_M)]
    pub range_min: f32,
    /// Odometry starts this many scans after the first.
    #[arg(long, default_value_t = 3)]
    pub odometry_after: usize,
    /// The laser's mount on the base: `X,Y,YAW_DEG`.
    #[arg(long, value_delimiter = ',', num_args = 3, default_values_t = [0.1, 0.05, 90.0], allow_negative_numbers = true)]
    pub mount: Vec<f64>,
}

/// Runs `lives export-bag`.
pub fn run_command(args: &ExportBagArgs) -> Result<std::process::ExitCode, String> {
    let opts = ExportOptions {
        range_max_m: args.range_max,
        range_min_m: args.range_min,
        odometry_after: args.odometry_after,
        mount: [args.mount[0], args.mount[1], args.mount[2]],
    };
    let s = export(&args.log, &args.out, &opts)?;
    println!(
        "{}: {} scans ({} of {} readings +inf), {} odometry messages from scan {} on, laser mounted at ({}, {}) m, {}°",
        args.out.display(),
        s.scans,
        s.inf_readings,
        s.readings,
        s.odometry,
        opts.odometry_after,
        opts.mount[0],
        opts.mount[1],
        opts.mount[2]
    );
    if s.synthetic_stamps {
        println!("the log's time stamps do not advance: the bag's are one scan per {} ms from its first", crate::run::TICK_US / 1000);
    }
    Ok(std::process::ExitCode::SUCCESS)
}
