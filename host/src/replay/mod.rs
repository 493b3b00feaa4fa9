//! Log replay (`lives replay FILE`): the controller run on recorded LiDAR data, with no base to
//! move, to see the maps, labels and goals it would have produced.
//!
//! Formats (detected from the file's first bytes, not its name):
//!
//! | format | reader | |
//! |---|---|---|
//! | CARMEN text log, plain or gzip | [`carmen`] | `FLASER`, `ROBOTLASER1`, `ODOM` |
//! | ROS 2 bag, MCAP | [`rosbag::read_mcap`] | `LaserScan`, `Odometry`, `tf`, `tf_static` (CDR) |
//! | ROS 2 bag, sqlite3 `.db3` | [`rosbag::read_db3`] | the same |
//!
//! A bag directory (`rosbag2_…/` with `metadata.yaml`) is read file by file in name order.
//!
//! Every reader turns its log into [`ScanRecord`]s: the laser's pose in the world frame, the scan
//! in the laser frame with its own first angle and increment, and ranges by the ROS conventions
//! (`+inf` no return, NaN invalid). The core assumes the LiDAR sits at the robot's origin, so
//! replay gives it the laser's pose as the robot pose.
//!
//! [`replay`] then makes a first pass over the poses to centre the controller's 51.2 m grid on the
//! trajectory ([`place_grid`]: a few stray poses, such as one corrupt `x`, neither move it nor
//! are used); a trajectory that does not fit is started with the grid centred on its first pose
//! and the core's rolling window ([`firmware::rolling`]) follows the laser from there. It ticks
//! the controller once per scan
//! at the log's own time stamps, with `Command::Start` on the first tick (and again whenever it
//! reports `Exhausted`, at most once per replan interval, since new scans may open new frontiers),
//! the embedded int8 classifier installed unless told otherwise. Each goal it chooses is recorded
//! with its time.
//!
//! Bad input loses nothing that was good. A bad record whose boundaries are known (a CARMEN line
//! that does not read or holds a NUL, a bag message that does not decode, an MCAP chunk that does
//! not decompress or parse, a sqlite3 row of the wrong column type) is skipped and counted by
//! reason ([`BadRecords`]), and reading goes on. Damage that loses the framing (a truncated or
//! corrupt gzip stream, a cut or unparsable top-level MCAP record, a bad sqlite page) stops reading;
//! everything before it is replayed. Both are reported with the file and the line, byte offset
//! or row.
//!
//! What this module must not do: decide anything the robot does (that is the core's job) or read
//! a clock on the controller's behalf (only the replay's own wall time is measured).

pub mod carmen;
pub mod cdr;
pub mod picture;
pub mod rosbag;

use crate::range::{EncodedScan, RangeLimits};
use firmware::classifier::ModelError;
use firmware::{Command, Config, Controller, Inputs, Mode, Pose2};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `--record`: grids every 10 s of log time (a log replays hundreds of times faster than it was
/// recorded; grids at the live rate of 1 Hz made a 0.8 GB file of the Intel log).
pub const REPLAY_GRID_PERIOD_US: u64 = 10_000_000;

/// Where in a file something came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Location {
    /// A line (1-based) of a text log.
    Line(usize),
    /// A byte offset in a binary file (for a message inside an MCAP chunk, the chunk's offset).
    Offset(u64),
    /// A row id of a sqlite3 bag's `messages` table.
    Row(i64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(n) => write!(f, "line {n}"),
            Location::Offset(o) => write!(f, "byte {o}"),
            Location::Row(r) => write!(f, "messages row {r}"),
        }
    }
}

/// One scan ready for the controller.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanRecord {
    /// The log's time stamp, seconds.
    pub t_s: f64,
    /// The laser's pose in the world frame: x, y (metres), yaw (radians).
    pub pose: [f64; 3],
    /// First beam's angle in the laser frame, radians (counter-clockwise).
    pub angle_min: f64,
    /// Angle between beams, radians (negative: clockwise order).
    pub angle_increment: f64,
    /// Ranges, metres: `+inf` no return, NaN invalid.
    pub ranges_m: Vec<f32>,
    /// The scanner's `range_min` and `range_max`, metres (REP 117: readings at or beyond
    /// `range_max` mean "nothing within it"; see [`crate::range`]).
    pub range_limits_m: [f64; 2],
    /// Where it came from.
    pub at: Location,
}

/// Log formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LogFormat {
    /// CARMEN text log.
    Carmen,
    /// CARMEN text log, gzip-compressed.
    CarmenGzip,
    /// ROS 2 bag, MCAP storage.
    Ros2Mcap,
    /// ROS 2 bag, sqlite3 storage.
    Ros2Sqlite3,
    /// A Velodyne VLP-16 capture: pcap, or raw 1206-byte payloads back to back (docs/vlp16.md).
    Vlp16,
}

impl fmt::Display for LogFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LogFormat::Carmen => "carmen",
            LogFormat::CarmenGzip => "carmen-gzip",
            LogFormat::Ros2Mcap => "ros2-mcap",
            LogFormat::Ros2Sqlite3 => "ros2-sqlite3",
            LogFormat::Vlp16 => "vlp16",
        })
    }
}

/// Why a log could not be read (whole or in part).
#[derive(Debug)]
#[non_exhaustive]
pub enum ReplayError {
    /// The file or directory could not be opened or read.
    Io {
        /// The file.
        file: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not a log replay knows (nor a bag directory with one).
    UnknownFormat {
        /// The file.
        file: PathBuf,
    },
    /// A ROS 1 bag (`#ROSBAG V2.0`), which replay does not read.
    Ros1Bag {
        /// The file.
        file: PathBuf,
    },
    /// The gzip stream is truncated or corrupt.
    Gzip {
        /// The file.
        file: PathBuf,
        /// Complete lines read before it.
        lines: usize,
        /// Compressed bytes consumed when it failed.
        offset: u64,
        /// The decoder's message.
        reason: String,
    },
    /// A log line is not valid text.
    NotText {
        /// The file.
        file: PathBuf,
        /// The line (1-based).
        line: usize,
        /// The first control byte in it (a NUL, ...) and its column (1-based, in bytes); `None`
        /// when the line is not UTF-8.
        control: Option<(usize, u8)>,
    },
    /// A CARMEN line could not be read.
    CarmenLine {
        /// The file.
        file: PathBuf,
        /// The line (1-based).
        line: usize,
        /// Why.
        error: carmen::LineError,
    },
    /// An MCAP record is truncated or damaged.
    Mcap {
        /// The file.
        file: PathBuf,
        /// Byte offset of the record (or of where the file ends).
        offset: u64,
        /// Why.
        reason: String,
    },
    /// An MCAP chunk that does not decompress, or whose records do not parse, skipped (the
    /// records after it are read).
    McapChunk {
        /// The file.
        file: PathBuf,
        /// Byte offset of the Chunk record.
        offset: u64,
        /// Why.
        reason: String,
    },
    /// A `messages` row of a sqlite3 bag whose columns are not of their types, skipped.
    SqliteRow {
        /// The file.
        file: PathBuf,
        /// Its position among the rows in id order (1-based): its id may be what is wrong.
        row: u64,
        /// sqlite's message.
        reason: String,
    },
    /// sqlite could not read the bag.
    Sqlite {
        /// The file.
        file: PathBuf,
        /// The last `messages` row read before the failure.
        after_row: Option<i64>,
        /// sqlite's message.
        reason: String,
    },
    /// A bag message does not decode.
    Message {
        /// The file.
        file: PathBuf,
        /// Where the message is.
        at: Location,
        /// Its topic.
        topic: String,
        /// Why.
        error: cdr::CdrError,
    },
    /// The classifier blob did not validate.
    Model(ModelError),
    /// The `--record` file could not be created.
    Record {
        /// The file.
        file: PathBuf,
        /// Why.
        reason: String,
    },
    /// The log held no scan the controller could use.
    NoScans {
        /// The file.
        file: PathBuf,
    },
    /// The log held no scan the controller could use, and bad records were skipped.
    NoGoodScans {
        /// The file.
        file: PathBuf,
        /// Bad records skipped.
        skipped: u32,
        /// The first of them.
        first: Box<ReplayError>,
    },
    /// Every scan's laser position is beyond the core's fixed-point range (±32 767 m), e.g. a log
    /// in UTM coordinates.
    PosesOutOfRange {
        /// The file.
        file: PathBuf,
        /// Scans read.
        scans: usize,
        /// The first of them.
        at: Location,
        /// Its position, metres.
        position: [f64; 2],
    },
    /// The grid's origin is beyond the core's fixed-point range (±32 767 m).
    GridOrigin {
        /// The file.
        file: PathBuf,
        /// The origin, metres.
        origin: [f64; 2],
    },
}

impl ReplayError {
    /// The reason a skipped bad record is counted under (`--json`'s `skipped_records.by_reason`):
    /// [`carmen::LineError::reason`] for a CARMEN line, `not_text`, `undecodable_message`.
    pub fn reason(&self) -> &'static str {
        match self {
            ReplayError::CarmenLine { error, .. } => error.reason(),
            ReplayError::NotText { .. } => "not_text",
            ReplayError::Message { .. } => "undecodable_message",
            ReplayError::McapChunk { .. } => "damaged_chunk",
            ReplayError::SqliteRow { .. } => "bad_row",
            _ => "damage",
        }
    }
}

/// A number for a message: as Rust prints it below a million, in exponent form above (`1e9`, and
/// `1e300` rather than 301 digits).
pub fn compact(v: f64) -> String {
    if v.is_finite() && v.abs() < 1e6 {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

impl fmt::Display for ReplayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplayError::Io { file, source } => write!(f, "{}: {source}", file.display()),
            ReplayError::UnknownFormat { file } => {
                write!(f, "{}: not a CARMEN log (plain or gzip), an MCAP file, a sqlite3 bag or a VLP-16 capture", file.display())
            }
            ReplayError::Ros1Bag { file } => write!(
                f,
                "{}: a ROS 1 bag, which replay does not read yet: convert it to a ROS 2 bag first (`pip install rosbags`, then \
                 `rosbags-convert --src {} --dst OUT_DIR`) and replay OUT_DIR",
                file.display(),
                file.display()
            ),
            ReplayError::Gzip { file, lines, offset, reason } => {
                write!(f, "{}: gzip stream damaged at compressed byte {offset} (after line {lines}): {reason}", file.display())
            }
            ReplayError::NotText { file, line, control: None } => write!(f, "{}:{line}: not UTF-8 text", file.display()),
            ReplayError::NotText { file, line, control: Some((column, byte)) } => {
                let name = if *byte == 0 { "a NUL byte".to_string() } else { format!("the control byte 0x{byte:02x}") };
                write!(f, "{}:{line}: not text: {name} at column {column}", file.display())
            }
            ReplayError::CarmenLine { file, line, error } => write!(f, "{}:{line}: {error}", file.display()),
            ReplayError::Mcap { file, offset, reason } | ReplayError::McapChunk { file, offset, reason } => {
                write!(f, "{}: byte {offset}: {reason}", file.display())
            }
            ReplayError::SqliteRow { file, row, reason } => {
                write!(f, "{}: messages row {row} (in id order) skipped: {reason}", file.display())
            }
            ReplayError::Sqlite { file, after_row, reason } => match after_row {
                Some(r) => write!(f, "{}: sqlite error after messages row {r}: {reason}", file.display()),
                None => write!(f, "{}: sqlite error before any message: {reason}", file.display()),
            },
            ReplayError::Message { file, at, topic, error } => write!(f, "{}: {at}: message on {topic}: {error}", file.display()),
            ReplayError::Model(e) => write!(f, "classifier model: {e}"),
            ReplayError::Record { file, reason } => write!(f, "{}: cannot record: {reason}", file.display()),
            ReplayError::NoScans { file } => write!(f, "{}: no laser scans to replay", file.display()),
            ReplayError::NoGoodScans { file, skipped, first } => {
                write!(f, "{}: no laser scans to replay: {}, the first {first}", file.display(), bad_records_skipped(*skipped))
            }
            ReplayError::PosesOutOfRange { file, scans, at, position } => write!(
                f,
                "{}: none of the {scans} scans has a laser position within the core's ±32767 m: the first is at ({}, {}) ({at})",
                file.display(),
                compact(position[0]),
                compact(position[1])
            ),
            ReplayError::GridOrigin { file, origin } => write!(
                f,
                "{}: the grid's origin ({}, {}) is beyond the core's ±32767 m",
                file.display(),
                compact(origin[0]),
                compact(origin[1])
            ),
        }
    }
}

impl std::error::Error for ReplayError {}

/// Bad records kept with their errors (all are counted).
pub const BAD_RECORDS_KEPT: usize = 5;

/// Bad records skipped while reading: records whose boundaries are known (a CARMEN line, a bag
/// message) but whose content is not valid. Reading goes on after each.
#[derive(Debug, Default)]
pub struct BadRecords {
    /// How many.
    pub total: u32,
    /// How many by [`ReplayError::reason`].
    pub by_reason: BTreeMap<&'static str, u32>,
    /// The first [`BAD_RECORDS_KEPT`], in the order they were found.
    pub first: Vec<ReplayError>,
}

impl BadRecords {
    /// Counts `e`, keeping it if it is among the first.
    pub fn add(&mut self, e: ReplayError) {
        self.total += 1;
        *self.by_reason.entry(e.reason()).or_insert(0) += 1;
        if self.first.len() < BAD_RECORDS_KEPT {
            self.first.push(e);
        }
    }

    /// Adds those of a later file.
    pub fn append(&mut self, other: BadRecords) {
        self.total += other.total;
        for (reason, n) in other.by_reason {
            *self.by_reason.entry(reason).or_insert(0) += n;
        }
        let room = BAD_RECORDS_KEPT.saturating_sub(self.first.len());
        self.first.extend(other.first.into_iter().take(room));
    }

    /// `2 bad_number, 1 truncated_line`.
    pub fn reasons(&self) -> String {
        self.by_reason.iter().map(|(r, n)| format!("{n} {r}")).collect::<Vec<_>>().join(", ")
    }
}

/// A log read into memory.
#[derive(Debug)]
pub struct LogData {
    /// The file (or bag directory).
    pub file: PathBuf,
    /// Its format.
    pub format: LogFormat,
    /// Scans, time order.
    pub scans: Vec<ScanRecord>,
    /// Odometry messages read.
    pub odometry: usize,
    /// Scans that could not be given a pose (bag frames not connected).
    pub no_pose: usize,
    /// Bag scans stamped before the first odometry.
    pub no_odometry_yet: usize,
    /// Bag scans whose nearest odometry is more than [`rosbag::MAX_POSE_AGE_NS`] away.
    pub stale_pose: usize,
    /// Bag scans stamped before the scan before them.
    pub scan_stamp_backwards: usize,
    /// Bag transforms rejected (the scans are placed without them).
    pub transforms_rejected: rosbag::RejectedTransforms,
    /// Time span of everything time-stamped that was read, seconds.
    pub span_s: Option<(f64, f64)>,
    /// Topics or line types used.
    pub sources: Vec<String>,
    /// Assumptions made, for the user.
    pub warnings: Vec<String>,
    /// Bad records skipped.
    pub bad_records: BadRecords,
    /// The damage reading stopped at.
    pub error: Option<ReplayError>,
}

impl LogData {
    /// Nothing read yet from `file`.
    fn new(file: &Path, format: LogFormat) -> Self {
        LogData {
            file: file.to_path_buf(),
            format,
            scans: Vec::new(),
            odometry: 0,
            no_pose: 0,
            no_odometry_yet: 0,
            stale_pose: 0,
            scan_stamp_backwards: 0,
            transforms_rejected: rosbag::RejectedTransforms::default(),
            span_s: None,
            sources: Vec::new(),
            warnings: Vec::new(),
            bad_records: BadRecords::default(),
            error: None,
        }
    }
}

fn widen(span: &mut Option<(f64, f64)>, t: f64) {
    *span = Some(match *span {
        None => (t, t),
        Some((a, b)) => (a.min(t), b.max(t)),
    });
}

/// Counts the bytes a reader hands out (the compressed offset of a gzip failure).
struct Counting<R> {
    inner: R,
    n: std::rc::Rc<std::cell::Cell<u64>>,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let k = self.inner.read(buf)?;
        self.n.set(self.n.get() + k as u64);
        Ok(k)
    }
}

/// A VLP-16 capture (`host::sensors::vlp16`, default configuration: the ±1° band, 897 beams,
/// 0.3–100 m): one scan per rotation, stamped with the sensor's time. A capture holds no pose:
/// the sensor is placed at the origin facing +x for every scan (a warning says so), which is
/// right for a sensor that stood still.
fn read_vlp16(file: &Path) -> Result<LogData, ReplayError> {
    let cfg = crate::sensors::vlp16::Vlp16Config::default();
    let (_, capture) = crate::sensors::vlp16::read_capture(file, &cfg).map_err(|e| ReplayError::Io {
        file: file.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
    })?;
    let mut log = LogData::new(file, LogFormat::Vlp16);
    log.sources.push("vlp16".to_string());
    log.warnings
        .push("a VLP-16 capture holds no pose: every scan is placed at the origin, facing +x (a sensor that stood still)".to_string());
    for (i, s) in capture.scans.into_iter().chain(capture.partial).enumerate() {
        let t_s = s.stamp_us as f64 / 1e6;
        widen(&mut log.span_s, t_s);
        log.scans.push(ScanRecord {
            t_s,
            pose: [0.0, 0.0, 0.0],
            angle_min: s.angle_min_rad,
            angle_increment: s.angle_increment_rad,
            ranges_m: s.ranges_m,
            range_limits_m: s.range_limits_m,
            at: Location::Line(i + 1),
        });
    }
    if let Some(e) = capture.error {
        log.warnings.push(format!("the capture's reading stopped early: {e}"));
    }
    Ok(log)
}

fn read_carmen(file: &Path, format: LogFormat, bytes: Vec<u8>) -> LogData {
    let mut log = LogData::new(file, format);
    let counter = std::rc::Rc::new(std::cell::Cell::new(0u64));
    let mut reader: Box<dyn BufRead> = match format {
        LogFormat::CarmenGzip => {
            let src = Counting { inner: std::io::Cursor::new(bytes), n: counter.clone() };
            Box::new(std::io::BufReader::new(flate2::read::MultiGzDecoder::new(src)))
        }
        _ => Box::new(std::io::Cursor::new(bytes)),
    };
    let mut line_no = 0usize;
    let mut buf = Vec::new();
    let mut seen = [false; 3];
    loop {
        buf.clear();
        match reader.read_until(b'\n', &mut buf) {
            Ok(0) => break,
            Ok(_) => {}
            // Only the gzip decoder can fail here (plain text is read from memory).
            Err(e) => {
                log.error =
                    Some(ReplayError::Gzip { file: file.to_path_buf(), lines: line_no, offset: counter.get(), reason: e.to_string() });
                break;
            }
        }
        line_no += 1;
        // A NUL (or other control byte) costs its line only, wherever it is in the file.
        if let Some(k) = buf.iter().position(|&b| is_control(b)) {
            log.bad_records.add(ReplayError::NotText { file: file.to_path_buf(), line: line_no, control: Some((k + 1, buf[k])) });
            continue;
        }
        let Ok(text) = std::str::from_utf8(&buf) else {
            log.bad_records.add(ReplayError::NotText { file: file.to_path_buf(), line: line_no, control: None });
            continue;
        };
        match carmen::parse_line(text) {
            Ok(None) => {}
            Ok(Some(rec)) => {
                widen(&mut log.span_s, rec.t_s());
                match rec {
                    carmen::CarmenRecord::Odom { .. } => {
                        log.odometry += 1;
                        seen[2] = true;
                    }
                    carmen::CarmenRecord::Scan(s) => {
                        seen[(s.kind == carmen::LineKind::RobotLaser1) as usize] = true;
                        log.scans.push(ScanRecord {
                            t_s: s.t_s,
                            pose: s.laser_pose,
                            angle_min: s.angle_min,
                            angle_increment: s.angle_increment,
                            ranges_m: s.ranges_m,
                            range_limits_m: [0.0, s.range_max_m],
                            at: Location::Line(line_no),
                        });
                    }
                }
            }
            // The line ends where it ends: skip it and read on.
            Err(error) => log.bad_records.add(ReplayError::CarmenLine { file: file.to_path_buf(), line: line_no, error }),
        }
    }
    for (i, name) in ["FLASER", "ROBOTLASER1", "ODOM"].iter().enumerate() {
        if seen[i] {
            log.sources.push(name.to_string());
        }
    }
    // Logs are written in time order; a stable sort mends small reorderings between line types.
    log.scans.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    log
}

fn read_bag(file: &Path, format: LogFormat, bytes: Option<Vec<u8>>) -> LogData {
    let contents = match (format, bytes) {
        (LogFormat::Ros2Mcap, Some(b)) => rosbag::read_mcap(file, &b),
        _ => rosbag::read_db3(file),
    };
    let mut warnings = Vec::new();
    if !contents.skipped_encodings.is_empty() {
        warnings.push(format!("skipped topics not encoded as CDR: {}", contents.skipped_encodings.join(", ")));
    }
    let mut scans = rosbag::scans_from_messages(file, contents.messages);
    warnings.extend(scans.warnings);
    // Damaged chunks and bad rows first: they come before any message decoding in the file's
    // own order of reading.
    let mut bad_records = contents.bad;
    bad_records.append(std::mem::take(&mut scans.bad_records));
    LogData {
        file: file.to_path_buf(),
        format,
        scans: scans.scans,
        odometry: scans.odometry,
        no_pose: scans.no_pose,
        no_odometry_yet: scans.no_odometry_yet,
        stale_pose: scans.stale_pose,
        scan_stamp_backwards: scans.scan_stamp_backwards,
        transforms_rejected: scans.transforms_rejected,
        span_s: contents.span_ns.map(|(a, b)| (a as f64 / 1e9, b as f64 / 1e9)),
        sources: contents.topics.iter().map(|(t, ty)| format!("{t} ({ty})")).collect(),
        warnings,
        bad_records,
        error: contents.error,
    }
}

fn io_err(file: &Path) -> impl Fn(std::io::Error) -> ReplayError + '_ {
    move |source| ReplayError::Io { file: file.to_path_buf(), source }
}

/// A control byte in a text log: below 0x20 except tab, line feed and carriage return, or DEL.
fn is_control(b: u8) -> bool {
    (b < 0x20 && b != b'\t' && b != b'\n' && b != b'\r') || b == 0x7f
}

/// Whether the first bytes of a file are text, give or take some damage: at most 1 in 64 control
/// bytes other than NUL and fewer NULs than anything else. A NUL or a stray control byte in a
/// CARMEN log costs its line (`read_carmen`), not the file; binary data (about one byte in eight
/// a control byte) is not text.
fn looks_like_text(head: &[u8]) -> bool {
    let nul = head.iter().filter(|&&b| b == 0).count();
    let other = head.iter().filter(|&&b| b != 0 && is_control(b)).count();
    !head.is_empty() && other * 64 <= head.len() && nul * 2 < head.len()
}

/// How a ROS 1 bag (format 2.0) starts.
pub const ROS1_BAG_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// The format of a file from its first bytes (a ROS 1 bag is none of them).
pub fn detect(head: &[u8]) -> Option<LogFormat> {
    if head.starts_with(ROS1_BAG_MAGIC) {
        return None;
    }
    if head.starts_with(&[0x1f, 0x8b]) {
        Some(LogFormat::CarmenGzip)
    } else if head.starts_with(rosbag::MCAP_MAGIC) {
        Some(LogFormat::Ros2Mcap)
    } else if head.starts_with(b"SQLite format 3\0") {
        Some(LogFormat::Ros2Sqlite3)
    } else if crate::sensors::pcap::looks_like_pcap(head) || crate::sensors::vlp16::frames_packet(head) {
        Some(LogFormat::Vlp16)
    } else if looks_like_text(&head[..head.len().min(4096)]) {
        Some(LogFormat::Carmen)
    } else {
        None
    }
}

fn read_one(file: &Path) -> Result<LogData, ReplayError> {
    let bytes = std::fs::read(file).map_err(io_err(file))?;
    let format = detect(&bytes).ok_or_else(|| match bytes.starts_with(ROS1_BAG_MAGIC) {
        true => ReplayError::Ros1Bag { file: file.to_path_buf() },
        false => ReplayError::UnknownFormat { file: file.to_path_buf() },
    })?;
    Ok(match format {
        LogFormat::Carmen | LogFormat::CarmenGzip => read_carmen(file, format, bytes),
        LogFormat::Ros2Mcap => read_bag(file, format, Some(bytes)),
        LogFormat::Ros2Sqlite3 => {
            drop(bytes);
            read_bag(file, format, None)
        }
        LogFormat::Vlp16 => {
            drop(bytes);
            read_vlp16(file)?
        }
    })
}

/// Reads a log file, or a rosbag2 directory (its `.mcap` / `.db3` files in name order, stopping
/// at the first damaged one).
pub fn read_log(path: &Path) -> Result<LogData, ReplayError> {
    if !path.is_dir() {
        return read_one(path);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(io_err(path))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mcap" || e == "db3"))
        .collect();
    files.sort();
    let mut all: Option<LogData> = None;
    for f in files {
        let part = read_one(&f)?;
        let stop = part.error.is_some();
        all = Some(match all.take() {
            None => part,
            Some(mut a) => {
                a.scans.extend(part.scans);
                a.odometry += part.odometry;
                a.no_pose += part.no_pose;
                a.no_odometry_yet += part.no_odometry_yet;
                a.stale_pose += part.stale_pose;
                a.scan_stamp_backwards += part.scan_stamp_backwards;
                let (t, p) = (&mut a.transforms_rejected, part.transforms_rejected);
                t.odometry_jump += p.odometry_jump;
                t.tf_loop += p.tf_loop;
                t.stamp_backwards += p.stamp_backwards;
                t.invalid += p.invalid;
                if let Some((lo, hi)) = part.span_s {
                    widen(&mut a.span_s, lo);
                    widen(&mut a.span_s, hi);
                }
                for s in part.sources {
                    if !a.sources.contains(&s) {
                        a.sources.push(s);
                    }
                }
                a.warnings.extend(part.warnings);
                a.bad_records.append(part.bad_records);
                a.error = part.error;
                a
            }
        });
        if stop {
            break;
        }
    }
    let mut log = all.ok_or_else(|| ReplayError::UnknownFormat { file: path.to_path_buf() })?;
    log.file = path.to_path_buf();
    log.scans.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    Ok(log)
}

/// How to replay.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Controller settings (the grid origin is set by [`replay`]).
    pub config: Config,
    /// The int8 classifier blob run on the scans (the logs carry no labels); `None` runs none.
    /// Default: the committed geometric classifier, as `lives search` runs for `lives`.
    pub model: Option<&'static [u8]>,
    /// Record every tick to this MCAP file ([`crate::record`], Foxglove's schemas).
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
    let model = crate::model::model_option(model, no_classifier)?;
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
            config: Config::DEFAULT,
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
    /// Grid side, metres.
    pub grid_size_m: f64,
    /// Bounding box of the laser's trajectory `[[min x, min y], [max x, max y]]`, metres (without
    /// stray poses).
    pub trajectory_bounds: [[f64; 2]; 2],
    /// The trajectory does not fit in the grid: the grid was placed on its first pose and the
    /// rolling window followed the laser (what left the window is forgotten).
    pub exceeds_grid: bool,
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
    pub shift_mm: crate::link::Summary,
    /// How far each turned it, degrees.
    pub turn_deg: crate::link::Summary,
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

fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// Reads `path` and replays it. Fails when the log cannot be opened, is not a known format, or
/// holds no usable scan before its damage (the damage is then the error).
pub fn replay(path: &Path, opts: &ReplayOptions) -> Result<ReplayRun, ReplayError> {
    let t_start = Instant::now();
    let log = read_log(path)?;
    let read_s = t_start.elapsed().as_secs_f64();
    replay_log(log, opts, t_start, read_s)
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
        let mut bad = log.bad_records;
        return Err(if bad.first.is_empty() {
            ReplayError::NoScans { file: log.file }
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
            crate::record::Recorder::create(
                p,
                crate::record::RecordOptions { grid_period_us: REPLAY_GRID_PERIOD_US, ..Default::default() },
            )
            .map_err(|e| ReplayError::Record { file: p.clone(), reason: e.to_string() })?,
        ),
        None => None,
    };
    let mut record_error: Option<String> = None;
    let t0 = log.scans[0].t_s;
    // Time stamps that do not advance (the CSAIL log prints them with 6 significant digits, i.e.
    // in steps of 10 000 s) cannot drive the controller's clock: replay one scan per tick instead.
    let distinct = 1 + log.scans.windows(2).filter(|w| w[1].t_s != w[0].t_s).count();
    let synthetic_time = log.scans.len() > 1 && 2 * distinct < log.scans.len();
    let mut rejected = Rejected {
        no_pose: log.no_pose as u32,
        no_odometry_yet: log.no_odometry_yet as u32,
        stale_pose: log.stale_pose as u32,
        stamp_backwards: log.scan_stamp_backwards as u32,
        ..Rejected::default()
    };
    let mut goals = Vec::new();
    let mut trajectory = Vec::new();
    let mut poses = Vec::new();
    let (mut first_pose, mut last_pose) = (None, [0.0; 3]);
    let mut last_us = 0u64;
    let mut last_start: Option<u64> = None;
    let mut status = firmware::Status::default();
    let mut strays = Vec::new();
    let mut controller_rejections: BTreeMap<&'static str, u32> = BTreeMap::new();
    let (mut shifts, mut turns, mut scores) = (Vec::new(), Vec::new(), [0.0f64; 2]);
    for (i, s) in log.scans.iter().enumerate() {
        let t_us = if synthetic_time { i as u64 * crate::search::TICK_US } else { ((s.t_s - t0) * 1e6).round().max(0.0) as u64 };
        let now_us = last_us.max(t_us);
        last_us = now_us;
        if stray[i] {
            rejected.stray_pose += 1;
            if strays.len() < BAD_RECORDS_KEPT {
                strays.push(format!("{} at ({}, {})", s.at, compact(s.pose[0]), compact(s.pose[1])));
            }
            continue;
        }
        // A non-finite pose: no pose to map the scan at; non-finite beam angles: no beams.
        let Some(pose) = Pose2::from_f64(s.pose[0], s.pose[1], s.pose[2]) else {
            rejected.no_pose += 1;
            continue;
        };
        let limits = RangeLimits::new(s.range_limits_m[0], s.range_limits_m[1]);
        let Some(encoded) = EncodedScan::new(s.angle_min, s.angle_increment, s.ranges_m.iter().map(|&r| r as f64), &limits) else {
            rejected.bad_angles += 1;
            continue;
        };
        let start = match last_start {
            None => true,
            Some(t) => ctrl.mode() == Mode::Exhausted && now_us.saturating_sub(t) >= cfg.replan_interval_us,
        };
        if start {
            last_start = Some(now_us);
        }
        let inputs = Inputs {
            pose: Some(pose),
            scan: Some(encoded.input(false)),
            detection: None,
            command: start.then_some(Command::Start),
            base_blocked: false,
        };
        let refused_before = status.poses_rejected;
        let scans_refused_before = status.scans_rejected;
        let matched_before = ctrl.matcher.stats.matched;
        let out = ctrl.tick(now_us, &inputs);
        status = out.status;
        let ms = &ctrl.matcher.stats;
        if ms.matched > matched_before {
            shifts.push(ms.last_move.dist_mm as f64);
            turns.push(ms.last_move.turn_mdeg as f64 / 1000.0);
            scores[0] += ms.last_predicted_per_mille as f64;
            scores[1] += ms.last_score_per_mille as f64;
        }
        if status.scans_rejected > scans_refused_before {
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
        if status.poses_rejected > refused_before {
            // A jump past the window's edge (in the controller's map frame): the core refused
            // the pose and did not draw the scan.
            rejected.outside_grid += 1;
            continue;
        }
        if let (Some(rec), None) = (recorder.as_mut(), &record_error) {
            if let Err(e) = rec.record_controller_tick(now_us, &inputs, &out, &ctrl) {
                record_error = Some(e.to_string());
            }
        }
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
                t_s: round3(now_us as f64 / 1e6),
                x: round3(g.pose.x.to_num::<f64>()),
                y: round3(g.pose.y.to_num::<f64>()),
                heading_deg: round3(g.pose.theta.to_radians().to_degrees()),
                source: format!("{:?}", g.viewpoint.source),
                utility: round3(g.viewpoint.utility as f64 / 65536.0),
                path_m: round3(g.path_length_m.to_num::<f64>()),
                robot: [round3(s.pose[0]), round3(s.pose[1])],
            });
        }
    }
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
            crate::search::TICK_US / 1000
        ));
        (log.scans.len() - 1) as f64 * crate::search::TICK_US as f64 / 1e6
    } else {
        log.span_s.map_or(0.0, |(a, b)| b - a)
    };
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
             pose and its window moved {} time{} to follow the laser, forgetting what it left; the final grid and picture \
             show the window at the end, lower-left corner ({}, {})",
            bounds[1][0] - bounds[0][0],
            bounds[1][1] - bounds[0][1],
            window.shifts,
            if window.shifts == 1 { "" } else { "s" },
            compact(final_origin[0]),
            compact(final_origin[1])
        ));
    }
    let unplaced = log.no_pose + log.no_odometry_yet + log.stale_pose + log.scan_stamp_backwards;
    let scans_read = log.scans.len() as u32 + unplaced as u32;
    let scans_rejected = rejected.outside_grid
        + rejected.no_pose
        + rejected.bad_angles
        + rejected.controller
        + rejected.stray_pose
        + rejected.no_odometry_yet
        + rejected.stale_pose
        + rejected.stamp_backwards;
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
        grid_size_m: size,
        trajectory_bounds: bounds.map(|p| p.map(round3)),
        exceeds_grid: exceeds,
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
                shift_mm: crate::link::Summary::of(&shifts),
                turn_deg: crate::link::Summary::of(&turns),
                score_per_mille: [round3(scores[0] / n), round3(scores[1] / n)],
            }
        },
    };
    let first_pose = first_pose.unwrap_or(log.scans[0].pose);
    Ok(ReplayRun { report, controller: ctrl, trajectory, poses, first_pose, last_pose, bad_records: log.bad_records, error: log.error })
}

/// `1 bad record skipped`, `2 bad records skipped`.
fn bad_records_skipped(n: u32) -> String {
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

/// `lives replay FILE` arguments.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// The log: a CARMEN log (plain or .gz), an MCAP or sqlite3 (.db3) ROS 2 bag, or a bag directory.
    pub file: PathBuf,
    /// Write a picture of the maps, labels, trajectory and goals here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Print one JSON object instead of the summary line.
    #[arg(long)]
    pub json: bool,
    /// Do not run a classifier (no map / non-map labels).
    #[arg(long, conflicts_with = "model")]
    pub no_classifier: bool,
    /// The int8 classifier blob to run (docs/model-format.md, either format); without it the
    /// committed geometric classifier (`firmware/model/lives-geo-int8.bin`), as `lives search`.
    #[arg(long, value_name = "BLOB")]
    pub model: Option<PathBuf>,
    /// The controller's LiDAR range, metres: readings at or beyond it, and "no return" readings,
    /// clear cells up to it and mark nothing (default: 10 m for CARMEN logs, the usable range
    /// mappers give them; the core's 30 m for bags).
    #[arg(long, value_name = "METRES")]
    pub max_range: Option<f64>,
    /// Record every tick (pose, scan, labels, grids, frontiers, candidates, goals) to this MCAP
    /// file, which Foxglove opens (docs/recording.md).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,
    /// Override a controller parameter, e.g. `--set replan_interval_s=6` (repeatable;
    /// `lives params` lists them).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
}

/// Runs `lives replay`: exit status 0, 1 when the log is not clean (bad records were skipped, or
/// damage stopped reading: every good scan was replayed and is reported), `Err` (status 2) when
/// nothing could be replayed.
pub fn run_command(args: &ReplayArgs) -> Result<std::process::ExitCode, String> {
    use std::io::Write as _;
    let mut opts = options(args.model.as_deref(), args.no_classifier, &args.set, args.max_range)?;
    opts.record = args.record.clone();
    let run = replay(&args.file, &opts).map_err(|e| e.to_string())?;
    let r = &run.report;
    if let Some(path) = &args.png {
        let name = args.file.file_name().map_or_else(|| r.file.clone(), |n| n.to_string_lossy().into_owned());
        let title = format!(
            "replay {name}: {} scans, {:.0} s of log in {:.1} s, {} goals (dots: goals it would have sent), labels: {}",
            r.scans_used,
            r.duration_s,
            r.wall_s,
            r.goals.len(),
            r.labels
        );
        picture::write_png(&run, path, &title).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    let mut stdout = std::io::stdout();
    if args.json {
        let text = serde_json::to_string_pretty(r).map_err(|e| e.to_string())?;
        let _ = writeln!(stdout, "{text}");
    } else {
        let _ = writeln!(stdout, "{}", summary_line(r));
        for w in &r.warnings {
            eprintln!("warning: {w}");
        }
    }
    let bad = &run.bad_records;
    for e in &bad.first {
        eprintln!("warning: {e} (skipped)");
    }
    if bad.total as usize > bad.first.len() {
        eprintln!("warning: … and {} more", bad_records_skipped(bad.total - bad.first.len() as u32));
    }
    let mut code = std::process::ExitCode::SUCCESS;
    if bad.total > 0 {
        let around = if bad.total == 1 { "it" } else { "them" };
        eprintln!("error: {}: {} ({}); the records around {around} were replayed", r.file, bad_records_skipped(bad.total), bad.reasons());
        code = std::process::ExitCode::from(1);
    }
    if let Some(e) = &run.error {
        eprintln!("error: {e} (reading stopped there; the {} scans before it were replayed)", r.scans_read);
        code = std::process::ExitCode::from(1);
    }
    Ok(code)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_are_detected_from_content() {
        assert_eq!(detect(&[0x1f, 0x8b, 8, 0]), Some(LogFormat::CarmenGzip));
        assert_eq!(detect(b"\x89MCAP0\r\n\x01"), Some(LogFormat::Ros2Mcap));
        assert_eq!(detect(b"SQLite format 3\0rest"), Some(LogFormat::Ros2Sqlite3));
        assert_eq!(detect(&[0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0]), Some(LogFormat::Vlp16), "a pcap");
        assert_eq!(detect(&[0xff, 0xee, 0x10, 0x27]), Some(LogFormat::Vlp16), "a raw VLP-16 payload");
        assert_eq!(detect(b"# CARMEN\nODOM 0 0 0 0 0 0 1 h 1\n"), Some(LogFormat::Carmen));
        assert_eq!(detect(&[0u8, 1, 2, 3]), None);
        assert_eq!(detect(&[0u8; 64]), None, "zeros");
        // Issue 29: one NUL (or a few) in the first 4 KiB no longer makes a log "not a CARMEN log".
        assert_eq!(detect(b"# CARMEN\nODOM 0 0\x00 0 0 0 0 1 h 1\n"), Some(LogFormat::Carmen));
        let mut damaged = b"ODOM 1.0 2.0 0.5 0 0 0 1 h 1\n".repeat(100);
        damaged[40..552].fill(0);
        assert_eq!(detect(&damaged), Some(LogFormat::Carmen), "a zeroed 512-byte block");
        // Binary: about one byte in eight is a control byte.
        let binary: Vec<u8> = (0..4096u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
        assert_eq!(detect(&binary), None);
        // A ROS 1 bag: its connection records are text enough to pass for a CARMEN log.
        let ros1 = [&b"#ROSBAG V2.0\n"[..], &b"op=\x07topic=/scan message_definition=float32 angle_min\n".repeat(60)].concat();
        assert_eq!(detect(&ros1), None);
    }

    #[test]
    fn a_ros1_bag_is_named_and_how_to_convert_it_said() {
        let file = std::env::temp_dir().join(format!("lives-ros1-{}.bag", std::process::id()));
        std::fs::write(&file, [&b"#ROSBAG V2.0\n"[..], &[0u8; 4096][..]].concat()).unwrap();
        let e = read_log(&file).err().expect("refused");
        let _ = std::fs::remove_file(&file);
        assert!(matches!(e, ReplayError::Ros1Bag { .. }), "{e:?}");
        let m = e.to_string();
        assert!(m.starts_with(&format!("{}: a ROS 1 bag", file.display())) && m.contains("rosbags-convert"), "{m}");
    }

    #[test]
    fn the_grid_is_centred_on_the_trajectory() {
        // The intel log's trajectory: centre (3.65, -9.1), the grid 25.6 m to either side of it.
        let o = grid_origin([[-9.2, -22.1], [16.5, 3.9]]);
        assert!((o[0] + grid_size_m() / 2.0 - 3.65).abs() <= 0.05 && (o[1] + grid_size_m() / 2.0 + 9.1).abs() <= 0.05, "{o:?}");
        for v in o {
            assert!(((v * 10.0).round() - v * 10.0).abs() < 1e-9, "on the 0.1 m lattice: {v}");
        }
        // Near the ends of the core's fixed-point range the grid stays inside it.
        assert_eq!(grid_origin([[-32_767.0, 32_767.0], [-32_760.0, 32_767.0]]), [-32_767.0, 32_715.8]);
    }

    fn scan_at(x: f64, y: f64, line: usize) -> ScanRecord {
        ScanRecord {
            t_s: line as f64,
            pose: [x, y, 0.0],
            angle_min: 0.0,
            angle_increment: 0.01,
            ranges_m: vec![1.0],
            range_limits_m: [0.0, 80.0],
            at: Location::Line(line),
        }
    }

    #[test]
    fn stray_poses_do_not_place_the_grid() {
        // A 40 m walk along x, and y between −5 and 5.
        let mut scans: Vec<ScanRecord> = (0..100).map(|i| scan_at(i as f64 * 0.4, (i % 11) as f64 - 5.0, i)).collect();
        let clean = place_grid(&scans).unwrap();
        assert_eq!(clean.bounds, [[0.0, -5.0], [39.6, 5.0]]);
        assert!(clean.stray.iter().all(|s| !s));
        // A corrupt x of 1e9 (beyond the core's range), one of 5 000 m (in range, far from the
        // rest), one just within a grid side of the middle half, and non-finite ones (no pose,
        // not strays).
        scans[10].pose[0] = 1e9;
        scans[20].pose[1] = 5_000.0;
        scans[30].pose[0] = f64::NAN;
        scans[40].pose[1] = f64::INFINITY;
        scans.push(scan_at(29.7 + 51.2, 0.0, 100));
        let p = place_grid(&scans).unwrap();
        let strays: Vec<usize> = p.stray.iter().enumerate().filter(|(_, s)| **s).map(|(i, _)| i).collect();
        assert_eq!(strays, [10, 20]);
        assert_eq!(p.bounds, [[0.0, -5.0], [80.9, 5.0]]);
        // Nothing finite: nothing places the grid.
        assert_eq!(place_grid(&[scan_at(f64::NAN, 0.0, 1)]), None);
        // Only strays beyond the core's range: nothing either.
        assert_eq!(place_grid(&[scan_at(1e9, 0.0, 1), scan_at(-1e9, 0.0, 2)]), None);
    }

    #[test]
    fn huge_numbers_print_compactly() {
        assert_eq!(compact(1e300), "1e300");
        assert_eq!(compact(-1e9), "-1e9");
        assert_eq!(compact(f64::INFINITY), "inf");
        assert_eq!(compact(65.5), "65.5");
        assert_eq!(compact(-16.7655), "-16.7655");
    }
}
