//! What can go wrong reading a log ([`ReplayError`]), and the bad records a log skips ([`BadRecords`]).

use super::*;
use firmware::classifier::ModelError;
use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

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
    /// A log line longer than [`super::read::MAX_LINE_BYTES`] (its bytes are not kept).
    LineTooLong {
        /// The file.
        file: PathBuf,
        /// The line (1-based).
        line: usize,
        /// Its length in bytes.
        bytes: usize,
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
    /// A record of an MCAP file or a ROS 1 bag is truncated or damaged.
    Bag {
        /// The file.
        file: PathBuf,
        /// Byte offset of the record (or of where the file ends).
        offset: u64,
        /// Why.
        reason: String,
    },
    /// A chunk of an MCAP file or a ROS 1 bag that does not decompress, or whose records do not
    /// parse, skipped (the records after it are read).
    BagChunk {
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
        /// What became of the scans it had (none, or why each was not placed).
        why: String,
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
            ReplayError::LineTooLong { .. } => "line_too_long",
            ReplayError::Message { .. } => "undecodable_message",
            ReplayError::BagChunk { .. } => "damaged_chunk",
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
                write!(
                    f,
                    "{}: not a CARMEN log (plain or gzip), a ROS 2 bag (MCAP or sqlite3), a ROS 1 bag or a VLP-16 capture",
                    file.display()
                )
            }
            ReplayError::Gzip { file, lines, offset, reason } => {
                write!(f, "{}: gzip stream damaged at compressed byte {offset} (after line {lines}): {reason}", file.display())
            }
            ReplayError::NotText { file, line, control: None } => write!(f, "{}:{line}: not UTF-8 text", file.display()),
            ReplayError::NotText { file, line, control: Some((column, byte)) } => {
                let name = if *byte == 0 { "a NUL byte".to_string() } else { format!("the control byte 0x{byte:02x}") };
                write!(f, "{}:{line}: not text: {name} at column {column}", file.display())
            }
            ReplayError::LineTooLong { file, line, bytes } => write!(
                f,
                "{}:{line}: a line of {bytes} bytes, longer than a log line may be ({} bytes; a CARMEN scan of 1 081 readings is about 10 kB)",
                file.display(),
                super::read::MAX_LINE_BYTES
            ),
            ReplayError::CarmenLine { file, line, error } => write!(f, "{}:{line}: {error}", file.display()),
            ReplayError::Bag { file, offset, reason } | ReplayError::BagChunk { file, offset, reason } => {
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
            ReplayError::NoScans { file, why } => write!(f, "{}: no laser scans to replay: {why}", file.display()),
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
