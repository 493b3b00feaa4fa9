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

use serde::Serialize;
use std::fmt;

mod command;
mod error;
mod read;
mod run;
mod source;
pub use command::*;
pub use error::*;
pub use read::*;
pub use run::*;

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
    /// `range_max` mean "nothing within it"; see [`crate::run::range`]).
    pub range_limits_m: [f64; 2],
    /// Where it came from.
    pub at: Location,
}

/// How many distinct time stamps `scans` hold, and whether they are too few to drive a clock:
/// fewer distinct stamps than half the scans (the CSAIL logs print them with 6 significant
/// digits, i.e. in steps of 10 000 s). Such a log is replayed, and exported, at one scan per
/// [`crate::run::TICK_US`].
pub fn stamps_stand_still(scans: &[ScanRecord]) -> (usize, bool) {
    let distinct = 1 + scans.windows(2).filter(|w| w[1].t_s != w[0].t_s).count();
    (distinct, scans.len() > 1 && 2 * distinct < scans.len())
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
    /// ROS 1 bag (format 2.0).
    Ros1Bag,
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
            LogFormat::Ros1Bag => "ros1-bag",
            LogFormat::Vlp16 => "vlp16",
        })
    }
}

#[cfg(test)]
mod tests;
