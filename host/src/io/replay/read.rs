//! Reading a log into memory: detecting its format, the CARMEN, ROS 2 bag and VLP-16 readers, and
//! the multi-file logs ([`read_log`]).

use super::*;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

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
    /// Scans read but not placed (bag frames not connected, no odometry at their stamp, …).
    pub unplaced: rosbag::Unplaced,
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
            unplaced: rosbag::Unplaced::default(),
            transforms_rejected: rosbag::RejectedTransforms::default(),
            span_s: None,
            sources: Vec::new(),
            warnings: Vec::new(),
            bad_records: BadRecords::default(),
            error: None,
        }
    }
}

pub(super) fn widen(span: &mut Option<(f64, f64)>, t: f64) {
    *span = Some(match *span {
        None => (t, t),
        Some((a, b)) => (a.min(t), b.max(t)),
    });
}

/// Counts the bytes a reader hands out (the compressed offset of a gzip failure).
pub(super) struct Counting<R> {
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

/// A VLP-16 capture (`host::io::sensors::vlp16`, default configuration: the ±1° band, 897 beams,
/// 0.3–100 m): one scan per rotation, stamped with the sensor's time. A capture holds no pose:
/// the sensor is placed at the origin facing +x for every scan (a warning says so), which is
/// right for a sensor that stood still.
pub(super) fn read_vlp16(file: &Path) -> Result<LogData, ReplayError> {
    let cfg = crate::io::sensors::vlp16::Vlp16Config::default();
    let (_, capture) = crate::io::sensors::vlp16::read_capture(file, &cfg).map_err(|e| ReplayError::Io {
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
    // Damage stops the reading: the scans before it are replayed and the exit status says so
    // (1), as for every other format (`lives lidar decode` does the same).
    if let Some(e) = capture.error {
        // The capture's error names the file already; this one does too.
        let e = e.to_string();
        let prefix = format!("{}: ", file.display());
        let e = e.strip_prefix(&prefix).unwrap_or(&e);
        log.error = Some(ReplayError::Io {
            file: file.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("the capture's reading stopped early: {e}")),
        });
    }
    Ok(log)
}

/// The longest log line kept (a CARMEN scan of 1 081 readings is about 10 kB): a longer one is
/// a bad record, skipped without holding it.
pub const MAX_LINE_BYTES: usize = 1 << 20;
/// The most text a gzip-compressed CARMEN log is decompressed to (1 GiB; the largest public
/// CARMEN logs are a few hundred MB): past it reading stops with an error, what came before kept.
pub const MAX_GZIP_TEXT_BYTES: u64 = 1 << 30;

/// Reads one line (through its `\n`) into `buf`, keeping at most `max` bytes of it; returns
/// the line's whole length (0 at the end) and whether it was longer than `max`.
fn read_line_capped(r: &mut dyn BufRead, buf: &mut Vec<u8>, max: usize) -> std::io::Result<(usize, bool)> {
    let (mut total, mut long) = (0usize, false);
    loop {
        let avail = r.fill_buf()?;
        if avail.is_empty() {
            return Ok((total, long));
        }
        let (take, done) = match avail.iter().position(|&b| b == b'\n') {
            Some(i) => (i + 1, true),
            None => (avail.len(), false),
        };
        let room = max.saturating_sub(buf.len());
        long |= take > room;
        buf.extend_from_slice(&avail[..take.min(room)]);
        r.consume(take);
        total += take;
        if done {
            return Ok((total, long));
        }
    }
}

pub(super) fn read_carmen(file: &Path, format: LogFormat, bytes: Vec<u8>) -> LogData {
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
    // For `RAWLASER1` scans: the odometry, the front laser's mount, the scans themselves.
    let mut raw = RawLaser::default();
    let mut text_bytes = 0u64;
    loop {
        buf.clear();
        let long = match read_line_capped(reader.as_mut(), &mut buf, MAX_LINE_BYTES) {
            Ok((0, _)) => break,
            Ok((n, long)) => {
                text_bytes += n as u64;
                long.then_some(n)
            }
            // Only the gzip decoder can fail here (plain text is read from memory).
            Err(e) => {
                log.error =
                    Some(ReplayError::Gzip { file: file.to_path_buf(), lines: line_no, offset: counter.get(), reason: e.to_string() });
                break;
            }
        };
        if format == LogFormat::CarmenGzip && text_bytes > MAX_GZIP_TEXT_BYTES {
            log.error = Some(ReplayError::Gzip {
                file: file.to_path_buf(),
                lines: line_no,
                offset: counter.get(),
                reason: format!(
                    "it decompresses to more than {} MiB of text, more than a log holds (a decompression bomb?): reading stopped",
                    MAX_GZIP_TEXT_BYTES >> 20
                ),
            });
            break;
        }
        line_no += 1;
        if let Some(bytes) = long {
            log.bad_records.add(ReplayError::LineTooLong { file: file.to_path_buf(), line: line_no, bytes });
            continue;
        }
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
                if let Some(t) = rec.stamp() {
                    widen(&mut log.span_s, t);
                }
                match rec {
                    carmen::CarmenRecord::Odom { t_s, pose } => {
                        log.odometry += 1;
                        seen[2] = true;
                        raw.odometry.push((t_s, pose));
                    }
                    carmen::CarmenRecord::Mount { field, value } => raw.mount[field as usize] = value,
                    carmen::CarmenRecord::Raw(s) if s.laser == 1 => raw.scans.push((s, line_no)),
                    carmen::CarmenRecord::Raw(s) => raw.other_lasers[usize::from(s.laser.clamp(2, 4) - 2)] += 1,
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
    raw.place(&mut log, seen[0] || seen[1]);
    // Logs are written in time order; a stable sort mends small reorderings between line types.
    log.scans.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    log
}

/// A CARMEN log's `RAWLASER` lines and what places them.
#[derive(Default)]
struct RawLaser {
    /// `RAWLASER1` scans and their lines.
    scans: Vec<(carmen::RawScan, usize)>,
    /// `ODOM` samples, `(t_s, [x, y, θ])`, in the file's order.
    odometry: Vec<(f64, [f64; 3])>,
    /// The front laser's mount: forward, side (metres), angle (radians) (`PARAM` lines).
    mount: [f64; 3],
    /// `RAWLASER2` … `RAWLASER4` lines (not mapped).
    other_lasers: [usize; 3],
}

impl RawLaser {
    /// Adds the `RAWLASER1` scans to `log`, each at the front laser's pose: the odometry
    /// interpolated to its stamp (as a bag's scans are placed, [`rosbag::FrameTree`]: a scan
    /// before the first odometry or more than [`rosbag::MAX_POSE_AGE_NS`] from it is rejected
    /// and counted, odometry that jumps is rejected) composed with the mount. A log whose front
    /// laser has lines with poses (`FLASER`, `ROBOTLASER1`) maps those: CARMEN's logger writes
    /// each scan as both `ROBOTLASER1` and `RAWLASER1`, and integrated twice every return would
    /// count double; its `RAWLASER1` lines are counted as a duplicate.
    fn place(self, log: &mut LogData, posed: bool) {
        let other: usize = self.other_lasers.iter().sum();
        if other > 0 {
            log.warnings.push(format!(
                "{other} scans of lasers other than the front one (RAWLASER2–4: {} / {} / {}) were not used: their mount on the \
                 robot is not in the log's lines",
                self.other_lasers[0], self.other_lasers[1], self.other_lasers[2]
            ));
        }
        if self.scans.is_empty() {
            return;
        }
        if posed {
            log.unplaced.duplicate_topic += self.scans.len();
            log.warnings.push(format!(
                "{} RAWLASER1 lines repeat the front laser's scans that FLASER / ROBOTLASER1 lines place: not used",
                self.scans.len()
            ));
            return;
        }
        log.sources.push("RAWLASER1".to_string());
        if self.mount == [0.0; 3] {
            log.warnings.push(
                "no robot_frontlaser_offset / _side_offset / _angular_offset PARAM lines (or all 0): the front laser is \
                 taken to sit at the robot's origin, facing forward"
                    .to_string(),
            );
        }
        // The tree's clock: nanoseconds from the log's earliest stamp (CARMEN stamps may be
        // negative).
        let t0 = self.odometry.iter().map(|o| o.0).chain(self.scans.iter().map(|s| s.0.t_s)).fold(f64::INFINITY, f64::min);
        let ns = |t: f64| ((t - t0) * 1e9).round() as u64;
        let mut tree = rosbag::FrameTree::default();
        // In stamp order (a stable sort mends small reorderings, as for the scans).
        let mut odometry = self.odometry;
        odometry.sort_by(|a, b| a.0.total_cmp(&b.0));
        for &(t, [x, y, th]) in &odometry {
            let r = tree.push("odom", "base", ns(t), &cdr::Transform::planar(x, y, th), rosbag::EdgeSource::Odometry("ODOM"));
            log.transforms_rejected.count(r);
        }
        let [fx, fy, fa] = self.mount;
        log.transforms_rejected.count(tree.set_static("base", "laser", &cdr::Transform::planar(fx, fy, fa)));
        let mut unplaced = Vec::new();
        for (s, line) in self.scans {
            match tree.resolve_at("laser", ns(s.t_s)) {
                Ok((pose, _, depth)) if depth > 1 => {
                    log.scans.push(ScanRecord {
                        t_s: s.t_s,
                        pose: [pose.t[0], pose.t[1], pose.yaw()],
                        angle_min: s.angle_min,
                        angle_increment: s.angle_increment,
                        ranges_m: s.ranges_m,
                        range_limits_m: [0.0, s.range_max_m],
                        at: Location::Line(line),
                    });
                    continue;
                }
                Ok(_) => log.unplaced.no_pose += 1,
                Err(e) => log.unplaced.count(e),
            }
            if unplaced.len() < 3 {
                unplaced.push(format!("line {line} ({} s)", s.t_s));
            }
        }
        if !unplaced.is_empty() {
            log.warnings.push(format!(
                "{} RAWLASER1 scans before the first ODOM line, {} more than {} s from the nearest one and {} with no ODOM at all \
                 were not used: first at {}",
                log.unplaced.no_odometry_yet,
                log.unplaced.stale_pose,
                rosbag::MAX_POSE_AGE_NS as f64 / 1e9,
                log.unplaced.no_pose,
                unplaced.join(", ")
            ));
        }
    }
}

pub(super) fn read_bag(file: &Path, format: LogFormat, bytes: Option<Vec<u8>>) -> LogData {
    let contents = match (format, bytes) {
        (LogFormat::Ros2Mcap, Some(b)) => rosbag::read_mcap(file, &b),
        (LogFormat::Ros1Bag, _) => rosbag::read_bag1_file(file),
        _ => rosbag::read_db3(file),
    };
    let mut warnings = Vec::new();
    if !contents.skipped_encodings.is_empty() {
        warnings.push(format!("skipped topics encoded neither as CDR nor as ROS 1: {}", contents.skipped_encodings.join(", ")));
    }
    let mut scans = rosbag::scans_from_messages(file, contents.messages);
    warnings.extend(scans.warnings);
    // Damaged chunks and bad rows first: they come before any message decoding in the file's
    // own order of reading.
    let mut bad_records = contents.bad;
    for (at, topic, error) in contents.bad_clouds {
        bad_records.add(ReplayError::Message { file: file.to_path_buf(), at, topic, error });
    }
    bad_records.append(std::mem::take(&mut scans.bad_records));
    LogData {
        file: file.to_path_buf(),
        format,
        scans: scans.scans,
        odometry: scans.odometry,
        unplaced: scans.unplaced,
        transforms_rejected: scans.transforms_rejected,
        span_s: contents.span_ns.map(|(a, b)| (a as f64 / 1e9, b as f64 / 1e9)),
        sources: contents.topics.iter().map(|(t, ty)| format!("{t} ({ty})")).collect(),
        warnings,
        bad_records,
        error: contents.error,
    }
}

/// The error for a path that is a pipe, a socket or a device rather than a file.
pub(super) fn not_a_regular_file() -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file (a pipe, a socket or a device): give the log as a file")
}

pub(super) fn io_err(file: &Path) -> impl Fn(std::io::Error) -> ReplayError + '_ {
    move |source| ReplayError::Io { file: file.to_path_buf(), source }
}

/// A control byte in a text log: below 0x20 except tab, line feed and carriage return, or DEL.
pub(super) fn is_control(b: u8) -> bool {
    (b < 0x20 && b != b'\t' && b != b'\n' && b != b'\r') || b == 0x7f
}

/// Whether the first bytes of a file are text, give or take some damage: at most 1 in 64 control
/// bytes other than NUL and fewer NULs than anything else. A NUL or a stray control byte in a
/// CARMEN log costs its line (`read_carmen`), not the file; binary data (about one byte in eight
/// a control byte) is not text.
pub(super) fn looks_like_text(head: &[u8]) -> bool {
    let nul = head.iter().filter(|&&b| b == 0).count();
    let other = head.iter().filter(|&&b| b != 0 && is_control(b)).count();
    !head.is_empty() && other * 64 <= head.len() && nul * 2 < head.len()
}

/// The format of a file from its first bytes (any `#ROSBAG V` line is a ROS 1 bag; the reader
/// names a version other than 2.0).
pub fn detect(head: &[u8]) -> Option<LogFormat> {
    if head.starts_with(b"#ROSBAG V") {
        Some(LogFormat::Ros1Bag)
    } else if head.starts_with(&[0x1f, 0x8b]) {
        Some(LogFormat::CarmenGzip)
    } else if head.starts_with(rosbag::MCAP_MAGIC) {
        Some(LogFormat::Ros2Mcap)
    } else if head.starts_with(b"SQLite format 3\0") {
        Some(LogFormat::Ros2Sqlite3)
    } else if crate::io::sensors::pcap::looks_like_pcap(head) || crate::io::sensors::vlp16::frames_packet(head) {
        Some(LogFormat::Vlp16)
    } else if looks_like_text(&head[..head.len().min(4096)]) {
        Some(LogFormat::Carmen)
    } else {
        None
    }
}

/// The first bytes of a zstd frame: rosbag2's file compression (`ros2 bag record
/// --compression-mode file --compression-format zstd`) compresses each whole `.mcap` or `.db3`
/// file (`bag_0.mcap.zstd`).
pub const ZSTD_MAGIC: [u8; 4] = [0x28, 0xB5, 0x2F, 0xFD];

/// A zstd-compressed file decompressed, at most [`rosbag::MAX_CHUNK_RATIO`] times its size:
/// what it held before any damage, and the damage.
#[cfg(feature = "zstd")]
fn unzstd(file: &Path) -> Result<(Vec<u8>, Option<String>), ReplayError> {
    let f = std::fs::File::open(file).map_err(io_err(file))?;
    let limit = f.metadata().map_err(io_err(file))?.len().saturating_mul(rosbag::MAX_CHUNK_RATIO).min(rosbag::MAX_CHUNK_UNCOMPRESSED * 64);
    let mut out = Vec::new();
    let damage = match zstd::stream::read::Decoder::new(f) {
        Ok(d) => match d.take(limit + 1).read_to_end(&mut out) {
            Ok(_) if out.len() as u64 > limit => {
                Some(format!("it decompresses to more than {limit} bytes ({} × its size)", rosbag::MAX_CHUNK_RATIO))
            }
            Ok(_) => None,
            Err(e) => Some(format!("its zstd stream is damaged after {} decompressed bytes: {e}", out.len())),
        },
        Err(e) => return Err(ReplayError::Io { file: file.to_path_buf(), source: e }),
    };
    out.truncate(limit as usize);
    Ok((out, damage))
}

/// A file rosbag2 compressed whole with zstd: its `.mcap` (read from memory) or `.db3` (written
/// to a temporary file for SQLite) decompressed and read as such.
fn read_zstd_file(file: &Path) -> Result<LogData, ReplayError> {
    #[cfg(not(feature = "zstd"))]
    {
        Err(ReplayError::Bag {
            file: file.to_path_buf(),
            offset: 0,
            reason: "compressed with zstd (rosbag2's file compression), which this `lives` was built without (rebuild with `--features zstd`, or `ros-bags`)".into(),
        })
    }
    #[cfg(feature = "zstd")]
    {
        let (bytes, damage) = unzstd(file)?;
        let Some(format) = detect(&bytes) else {
            return Err(match damage {
                Some(reason) => ReplayError::Bag { file: file.to_path_buf(), offset: 0, reason: format!("compressed with zstd: {reason}") },
                None => ReplayError::UnknownFormat { file: file.to_path_buf() },
            });
        };
        let mut log = match format {
            LogFormat::Ros2Mcap => read_bag(file, format, Some(bytes)),
            LogFormat::Ros2Sqlite3 => {
                let tmp = std::env::temp_dir().join(format!(
                    "lives-{}-{}.db3",
                    std::process::id(),
                    file.file_name().unwrap_or_default().to_string_lossy()
                ));
                std::fs::write(&tmp, &bytes).map_err(io_err(&tmp))?;
                drop(bytes);
                let mut log = read_bag(&tmp, format, None);
                let _ = std::fs::remove_file(&tmp);
                log.file = file.to_path_buf();
                log
            }
            LogFormat::Carmen | LogFormat::CarmenGzip => read_carmen(file, format, bytes),
            LogFormat::Ros1Bag | LogFormat::Vlp16 => {
                return Err(ReplayError::Bag {
                    file: file.to_path_buf(),
                    offset: 0,
                    reason: format!("a zstd-compressed {format}: decompress it first (`zstd -d`)"),
                })
            }
        };
        log.warnings.insert(0, format!("decompressed (zstd, rosbag2's file compression) before reading it as {format}"));
        if let Some(d) = damage {
            log.warnings.push(format!("{d}: what came before it was read"));
        }
        Ok(log)
    }
}

pub(super) fn read_one(file: &Path) -> Result<LogData, ReplayError> {
    // A pipe or a device (`/dev/zero`) would be read until memory runs out, or block forever.
    let meta = std::fs::metadata(file).map_err(io_err(file))?;
    if !meta.is_file() {
        return Err(ReplayError::Io { file: file.to_path_buf(), source: not_a_regular_file() });
    }
    // A ROS 1 bag is streamed (camera bags are many gigabytes); the other formats are read whole.
    let mut head = Vec::with_capacity(4096);
    std::fs::File::open(file).and_then(|f| f.take(4096).read_to_end(&mut head)).map_err(io_err(file))?;
    if detect(&head) == Some(LogFormat::Ros1Bag) {
        return Ok(read_bag(file, LogFormat::Ros1Bag, None));
    }
    if head.starts_with(&ZSTD_MAGIC) {
        return read_zstd_file(file);
    }
    let bytes = std::fs::read(file).map_err(io_err(file))?;
    let format = detect(&bytes).ok_or_else(|| ReplayError::UnknownFormat { file: file.to_path_buf() })?;
    Ok(match format {
        LogFormat::Carmen | LogFormat::CarmenGzip => read_carmen(file, format, bytes),
        LogFormat::Ros2Mcap | LogFormat::Ros1Bag => read_bag(file, format, Some(bytes)),
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

/// Reads a log file, or a rosbag2 directory (its `.mcap` / `.db3` files, or their `.zstd`
/// compressions, in name order, stopping at the first damaged one).
pub fn read_log(path: &Path) -> Result<LogData, ReplayError> {
    if !path.is_dir() {
        return read_one(path);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(io_err(path))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| [".mcap", ".db3", ".mcap.zstd", ".db3.zstd"].iter().any(|e| p.to_string_lossy().ends_with(e)))
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
                a.unplaced.add(&part.unplaced);
                a.transforms_rejected.add(&part.transforms_rejected);
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
