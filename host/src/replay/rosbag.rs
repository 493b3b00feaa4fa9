//! ROS 2 bags: MCAP (rosbag2's default storage since Iron) and sqlite3 (`.db3`, the default
//! before), with `sensor_msgs/msg/LaserScan`, `nav_msgs/msg/Odometry` and `tf2_msgs/msg/TFMessage`
//! on `/tf` and `/tf_static`, CDR-encoded.
//!
//! Reading happens in two steps:
//!
//! 1. [`read_mcap`] / [`read_db3`] pull the messages of those three types out of the container
//!    in file order, with where each came from ([`Location`]): the byte offset of its MCAP record
//!    (for a message inside a chunk, the chunk's offset) or its `messages` row id. A damaged
//!    chunk (its own length intact) or a row of the wrong column type is skipped and counted
//!    ([`BagContents::bad`]); they stop at the first damage that loses the framing (a top-level
//!    record cut off or unparsable, an unreadable sqlite page) and hand back what came before,
//!    plus the error.
//! 2. [`scans_from_messages`] decodes them (CDR, [`super::cdr`]; a message that does not decode
//!    is skipped and counted, the messages around it are used), sorts them by the bag's receive
//!    time, and builds the frame tree: `tf_static` transforms apply to the whole bag, `tf`
//!    transforms and odometry (`header.frame_id` → `child_frame_id`) are samples of their edge at
//!    their header stamps. Each scan's pose is the laser frame's pose in the root of its frame
//!    tree (`map` or `odom`) at the scan's header stamp, the moving edges interpolated to it
//!    (translation linear, rotation shortest arc), projected to the plane: x, y and the yaw of
//!    the laser's x axis. Scans with no odometry at or before their stamp, or none within
//!    [`MAX_POSE_AGE_NS`], are rejected by name, as are transforms that jump, loop or go back in
//!    time. A laser mounted upside down
//!    (its z axis pointing down) sees the world mirrored: its beam angles are negated.
//!
//! Ranges follow REP 117 and the `LaserScan` definition: NaN (invalid) and −inf (too close) are
//! invalid, +inf is "no return", finite readings outside `[range_min, range_max]` are discarded
//! (invalid).
//!
//! What this module must not do: know about the controller or pictures.

use super::cdr::{self, CdrError, Transform};
use super::{BadRecords, Location, ReplayError, ScanRecord};
use std::collections::HashMap;
use std::path::Path;

/// The message types replay uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MsgType {
    /// `sensor_msgs/msg/LaserScan`.
    LaserScan,
    /// `nav_msgs/msg/Odometry`.
    Odometry,
    /// `tf2_msgs/msg/TFMessage` on a `tf` topic.
    Tf,
    /// `tf2_msgs/msg/TFMessage` on a `tf_static` topic.
    TfStatic,
}

impl MsgType {
    /// The type of a topic from its type name and topic name; `None` for types replay ignores.
    pub fn of(type_name: &str, topic: &str) -> Option<MsgType> {
        match type_name {
            "sensor_msgs/msg/LaserScan" => Some(MsgType::LaserScan),
            "nav_msgs/msg/Odometry" => Some(MsgType::Odometry),
            "tf2_msgs/msg/TFMessage" if topic.ends_with("tf_static") => Some(MsgType::TfStatic),
            "tf2_msgs/msg/TFMessage" => Some(MsgType::Tf),
            _ => None,
        }
    }
}

/// One message of a type replay uses, still serialised.
#[derive(Clone, Debug)]
pub struct BagMessage {
    /// The bag's receive time, nanoseconds.
    pub t_ns: u64,
    /// Topic.
    pub topic: String,
    /// Type.
    pub kind: MsgType,
    /// CDR bytes.
    pub data: Vec<u8>,
    /// Where it came from.
    pub at: Location,
}

/// What a container gave: the messages before any damage, the number of messages of all types
/// (for the log's duration), their time span, and the damage.
#[derive(Debug, Default)]
pub struct BagContents {
    /// Messages of the three types, file order.
    pub messages: Vec<BagMessage>,
    /// Earliest and latest receive time of any message, nanoseconds.
    pub span_ns: Option<(u64, u64)>,
    /// Topics that carry a type replay uses, with the type.
    pub topics: Vec<(String, String)>,
    /// Channels skipped because their encoding is not CDR.
    pub skipped_encodings: Vec<String>,
    /// The first damage, after which nothing was read.
    pub error: Option<ReplayError>,
    /// Damage whose extent is known, skipped: a chunk that does not decompress or whose records
    /// do not parse (the records after it are read), a `messages` row of the wrong type.
    pub bad: BadRecords,
}

impl BagContents {
    fn saw(&mut self, t_ns: u64) {
        self.span_ns = Some(match self.span_ns {
            None => (t_ns, t_ns),
            Some((a, b)) => (a.min(t_ns), b.max(t_ns)),
        });
    }
}

/// The MCAP magic, at both ends of the file.
pub const MCAP_MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
const OP_FOOTER: u8 = 0x02;

fn op_name(op: u8) -> &'static str {
    match op {
        0x01 => "Header",
        0x02 => "Footer",
        0x03 => "Schema",
        0x04 => "Channel",
        0x05 => "Message",
        0x06 => "Chunk",
        0x07 => "MessageIndex",
        0x08 => "ChunkIndex",
        0x09 => "Attachment",
        0x0a => "AttachmentIndex",
        0x0b => "Statistics",
        0x0c => "Metadata",
        0x0d => "MetadataIndex",
        0x0e => "SummaryOffset",
        0x0f => "DataEnd",
        _ => "unknown",
    }
}

/// The fixed fields a record's body needs before anything of variable length, by opcode: their
/// size in bytes and what they are.
fn fixed_fields(op: u8) -> Option<(usize, &'static str)> {
    match op {
        0x03 => Some((14, "id and the lengths of name, encoding and data")),
        0x04 => Some((16, "id, schema id and the lengths of topic, encoding and metadata")),
        0x05 => Some((22, "channel id, sequence, log time and publish time")),
        0x06 => Some((40, "start and end time, uncompressed size and CRC, and the lengths of compression and records")),
        _ => None,
    }
}

/// Opcodes no MCAP record has (0x00 and 0x10–0x7f are reserved; 0x80 and up are private
/// records, which are skipped): a record header there means the framing is lost.
fn reserved(op: u8) -> bool {
    op == 0x00 || (0x10..0x80).contains(&op)
}

/// Why the `mcap` crate could not parse an `op` record of `len` bytes, in the file's terms: what
/// its length should have been at least, or the parser's own words.
fn unparsable(op: u8, len: usize, e: &mcap::McapError) -> String {
    match fixed_fields(op) {
        Some((min, what)) if len < min => {
            format!("{} record of {len} bytes is shorter than the {min} bytes of its {what} (a wrong record length)", op_name(op))
        }
        _ => match std::error::Error::source(e) {
            Some(why) => format!("cannot parse {} record of {len} bytes: {e}: {why}", op_name(op)),
            None => format!("cannot parse {} record of {len} bytes: {e}", op_name(op)),
        },
    }
}

/// The records replay reads (Header, Schema, Channel, Message, Chunk); the others (indexes,
/// attachments, metadata, statistics, private records) are stepped over by their length without
/// being parsed. The `mcap` crate's parser panics on some damaged ones (an Attachment whose
/// declared lengths exceed its body: "slice index starts at 34 but ends at 31", found by the
/// fuzzer; `fuzz/corpus/mcap/regression-attachment-slice-panic.mcap`), and replay needs nothing
/// from them.
fn read_here(op: u8) -> bool {
    matches!(op, 0x01 | 0x03..=0x06)
}

/// Walks the records of a chunk (`records`, uncompressed), handing each that parses to `take`.
/// On the first that does not (its framing or its fields), returns its offset in `records` and
/// why; the records after it are lost (their framing is).
fn walk_records<'a>(records: &'a [u8], mut take: impl FnMut(mcap::records::Record<'a>)) -> Result<(), (usize, String)> {
    let mut pos = 0;
    while pos < records.len() {
        if records.len() - pos < 9 {
            return Err((pos, format!("a record header cut off by the end of the chunk ({} of 9 bytes)", records.len() - pos)));
        }
        let op = records[pos];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&records[pos + 1..pos + 9]);
        let len = u64::from_le_bytes(len_bytes);
        let left = (records.len() - pos - 9) as u64;
        if len > left {
            return Err((
                pos,
                format!("its {} record (opcode 0x{op:02x}) of {len} bytes runs past the end of the chunk, {left} bytes left", op_name(op)),
            ));
        }
        let body = &records[pos + 9..pos + 9 + len as usize];
        if read_here(op) {
            match mcap::parse_record(op, body) {
                Ok(rec) => take(rec),
                Err(e) => return Err((pos, unparsable(op, body.len(), &e))),
            }
        }
        pos += 9 + len as usize;
    }
    Ok(())
}

/// The most a chunk may claim to hold uncompressed, whatever the file's size: 1 GiB.
pub const MAX_CHUNK_UNCOMPRESSED: u64 = 1 << 30;
/// The most a chunk may claim to hold uncompressed per byte of the file it is in: 1024 (zstd
/// reaches a few hundred on runs of zeros; rosbag2's chunks of scans reach 3 to 10).
pub const MAX_CHUNK_RATIO: u64 = 1024;

/// The uncompressed records of a chunk whose data (`data`, at byte `data_at` of a file of
/// `file_len` bytes) is compressed as `header` says, decompressed here with a bound on the
/// output: the claimed `uncompressed_size` must be within [`MAX_CHUNK_UNCOMPRESSED`] and
/// [`MAX_CHUNK_RATIO`] × the file's size, the decoder may not write more than it, must write
/// all of it, and the result must match the chunk's CRC (when it has one). Nothing is allocated
/// beyond the claimed size, so damaged compressed bytes cannot make the reader allocate what
/// they like (the `mcap` crate's own chunk reader sized its buffer from the damaged stream).
fn chunk_records<'a>(
    header: &mcap::records::ChunkHeader,
    data: &'a [u8],
    data_at: usize,
    file_len: usize,
) -> Result<std::borrow::Cow<'a, [u8]>, String> {
    let claimed = header.uncompressed_size;
    let limit = MAX_CHUNK_UNCOMPRESSED.min((file_len as u64).saturating_mul(MAX_CHUNK_RATIO));
    if header.compression.is_empty() {
        if claimed != data.len() as u64 {
            return Err(format!("its uncompressed size field says {claimed} bytes, its records take {} (byte {data_at})", data.len()));
        }
    } else if claimed > limit {
        return Err(format!(
            "it claims {claimed} bytes uncompressed from {} compressed, more than this reader allows for a file of {file_len} bytes ({limit}: {MAX_CHUNK_RATIO} × the file's size, at most {MAX_CHUNK_UNCOMPRESSED})",
            data.len()
        ));
    }
    let records: std::borrow::Cow<'a, [u8]> = match header.compression.as_str() {
        "" => std::borrow::Cow::Borrowed(data),
        #[cfg(feature = "zstd")]
        "zstd" => {
            let out = zstd::bulk::decompress(data, claimed as usize).map_err(|e| {
                format!("its zstd data (byte {data_at}, {} bytes) does not decompress to the {claimed} bytes it claims: {e}", data.len())
            })?;
            std::borrow::Cow::Owned(out)
        }
        #[cfg(feature = "lz4")]
        "lz4" => {
            use std::io::Read;
            let mut out = Vec::new();
            let decoder = lz4::Decoder::new(data).map_err(|e| format!("its lz4 data (byte {data_at}) does not start a frame: {e}"))?;
            decoder
                .take(claimed + 1)
                .read_to_end(&mut out)
                .map_err(|e| format!("its lz4 data (byte {data_at}, {} bytes) does not decompress: {e}", data.len()))?;
            std::borrow::Cow::Owned(out)
        }
        other => {
            return Err(match missing_codec(other) {
                Some(feature) => format!(
                "chunk compressed with {other}, which this `lives` was built without (rebuild with `--features {feature}`, or `ros-bags`)"
            ),
                None => format!("unknown chunk compression {other:?} (MCAP knows zstd and lz4)"),
            })
        }
    };
    if records.len() as u64 != claimed {
        return Err(format!("its {} data decompresses to {} bytes, not the {claimed} it claims", header.compression, records.len()));
    }
    if header.uncompressed_crc != 0 {
        let crc = crc32fast::hash(&records);
        if crc != header.uncompressed_crc {
            return Err(format!(
                "its {} bytes of records fail their CRC (0x{crc:08x}, the chunk says 0x{:08x})",
                records.len(),
                header.uncompressed_crc
            ));
        }
    }
    Ok(records)
}

/// Channel id → (topic, type name, message encoding).
type Channels = HashMap<u16, (String, String, String)>;

/// Reads an MCAP file held in `buf`. Walks the top-level records itself (so damage is located to
/// the byte), lets the `mcap` crate parse each record and decompress chunks (zstd, lz4).
pub fn read_mcap(file: &Path, buf: &[u8]) -> BagContents {
    let mut out = BagContents::default();
    let damage = |offset: usize, reason: String| ReplayError::Mcap { file: file.to_path_buf(), offset: offset as u64, reason };
    let chunk_damage = |offset: usize, reason: String| ReplayError::McapChunk { file: file.to_path_buf(), offset: offset as u64, reason };
    if buf.len() < MCAP_MAGIC.len() || &buf[..8] != MCAP_MAGIC {
        out.error = Some(damage(0, "no MCAP magic at the start".into()));
        return out;
    }
    let mut schemas: HashMap<u16, String> = HashMap::new();
    let mut channels: Channels = HashMap::new();
    let mut pos = MCAP_MAGIC.len();
    // The record before `pos` (opcode, offset): the one whose length led here.
    let mut prev: Option<(u8, usize)> = None;
    loop {
        if pos == buf.len() {
            out.error = Some(damage(pos, "file ends without its footer and closing magic (truncated)".into()));
            return out;
        }
        if buf.len() - pos < 9 {
            out.error =
                Some(damage(pos, format!("record header cut off: {} of 9 bytes before the end of the file (truncated)", buf.len() - pos)));
            return out;
        }
        let op = buf[pos];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&buf[pos + 1..pos + 9]);
        let len = u64::from_le_bytes(len_bytes);
        let body_start = pos + 9;
        let left = (buf.len() - body_start) as u64;
        if reserved(op) {
            let culprit = match prev {
                Some((p, at)) => format!("the {} record at byte {at} has a wrong length", op_name(p)),
                None => "the file is damaged".to_string(),
            };
            out.error = Some(damage(
                pos,
                format!("no MCAP record starts here (opcode 0x{op:02x} is reserved; expected one of 0x01-0x0f or a private 0x80-0xff): {culprit}"),
            ));
            return out;
        }
        if len > left {
            out.error = Some(damage(
                pos,
                format!(
                    "{} record (opcode 0x{op:02x}) of {len} bytes runs past the end of the file, {left} bytes left (truncated)",
                    op_name(op)
                ),
            ));
            return out;
        }
        let body = &buf[body_start..body_start + len as usize];
        let next = body_start + len as usize;
        if op == OP_FOOTER {
            if buf.len() - next < 8 || &buf[next..next + 8] != MCAP_MAGIC {
                out.error = Some(damage(next, "no closing magic after the footer".into()));
            }
            return out;
        }
        if !read_here(op) {
            prev = Some((op, pos));
            pos = next;
            continue;
        }
        let record = match mcap::parse_record(op, body) {
            Ok(r) => r,
            Err(e) => {
                out.error = Some(damage(pos, unparsable(op, body.len(), &e)));
                return out;
            }
        };
        let result = match record {
            mcap::records::Record::Chunk { header, data } => {
                match chunk_records(&header, &data, body_start + 40 + header.compression.len(), buf.len()) {
                    Ok(records) => {
                        // Records inside an uncompressed chunk are at known bytes of the file;
                        // inside a compressed one only the chunk's offset means anything.
                        let at = |k: usize| match header.compression.is_empty() {
                            true => format!("byte {}", body_start + 40 + header.compression.len() + k),
                            false => format!("byte {k} of its {} uncompressed bytes", records.len()),
                        };
                        if let Err((k, why)) = walk_records(&records, |rec| {
                            take_record(rec, &mut schemas, &mut channels, &mut out, Location::Offset(pos as u64))
                        }) {
                            out.bad.add(chunk_damage(
                                pos,
                                format!("damaged Chunk record, the rest of it skipped: its record at {}: {why}", at(k)),
                            ));
                        }
                    }
                    // The chunk's own length is intact: skip it, read on after it.
                    Err(reason) => out.bad.add(chunk_damage(pos, format!("damaged Chunk record, skipped: {reason}"))),
                }
                Ok(())
            }
            rec => {
                take_record(rec, &mut schemas, &mut channels, &mut out, Location::Offset(pos as u64));
                Ok::<(), String>(())
            }
        };
        if let Err(reason) = result {
            out.error = Some(damage(pos, reason));
            return out;
        }
        prev = Some((op, pos));
        pos = next;
    }
}

/// The cargo feature a chunk compression needs, if this build lacks it.
fn missing_codec(compression: &str) -> Option<&'static str> {
    match compression {
        "zstd" if !cfg!(feature = "zstd") => Some("zstd"),
        "lz4" if !cfg!(feature = "lz4") => Some("lz4"),
        _ => None,
    }
}

fn take_record(
    rec: mcap::records::Record<'_>,
    schemas: &mut HashMap<u16, String>,
    channels: &mut Channels,
    out: &mut BagContents,
    at: Location,
) {
    use mcap::records::Record;
    match rec {
        Record::Schema { header, .. } => {
            schemas.insert(header.id, header.name);
        }
        Record::Channel(c) => {
            let type_name = schemas.get(&c.schema_id).cloned().unwrap_or_default();
            if MsgType::of(&type_name, &c.topic).is_some() {
                if c.message_encoding != "cdr" {
                    out.skipped_encodings.push(format!("{} ({})", c.topic, c.message_encoding));
                } else if !out.topics.iter().any(|(t, _)| *t == c.topic) {
                    out.topics.push((c.topic.clone(), type_name.clone()));
                }
            }
            channels.insert(c.id, (c.topic, type_name, c.message_encoding));
        }
        Record::Message { header, data } => {
            out.saw(header.log_time);
            if let Some((topic, type_name, enc)) = channels.get(&header.channel_id) {
                if let (Some(kind), "cdr") = (MsgType::of(type_name, topic), enc.as_str()) {
                    out.messages.push(BagMessage { t_ns: header.log_time, topic: topic.clone(), kind, data: data.into_owned(), at });
                }
            }
        }
        _ => {}
    }
}

/// Without the `db3` feature (no SQLite compiled in): the error says how to get it.
#[cfg(not(feature = "db3"))]
pub fn read_db3(file: &Path) -> BagContents {
    BagContents {
        error: Some(ReplayError::Sqlite {
            file: file.to_path_buf(),
            after_row: None,
            reason: "this `lives` was built without sqlite3 bag support (rebuild with `--features db3`, or `ros-bags`)".into(),
        }),
        ..BagContents::default()
    }
}

/// Reads a rosbag2 sqlite3 file (`topics` and `messages` tables), rows in id order.
#[cfg(feature = "db3")]
pub fn read_db3(file: &Path) -> BagContents {
    let mut out = BagContents::default();
    let err =
        |after_row: Option<i64>, e: rusqlite::Error| ReplayError::Sqlite { file: file.to_path_buf(), after_row, reason: e.to_string() };
    let flags = rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY | rusqlite::OpenFlags::SQLITE_OPEN_NO_MUTEX;
    let conn = match rusqlite::Connection::open_with_flags(file, flags) {
        Ok(c) => c,
        Err(e) => {
            out.error = Some(err(None, e));
            return out;
        }
    };
    // A truncated file claims more pages than it has, which sqlite refuses outright; with
    // `writable_schema` it reads the pages that are there (the connection stays read-only), so
    // the rows before the damage can still be replayed.
    if let Err(e) = conn.pragma_update(None, "writable_schema", "ON") {
        out.error = Some(err(None, e));
        return out;
    }
    let mut topics: HashMap<i64, (String, String, String)> = HashMap::new();
    let read_topics = || -> rusqlite::Result<Vec<(i64, String, String, String)>> {
        let mut st = conn.prepare("SELECT id, name, type, serialization_format FROM topics")?;
        let rows = st.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))?;
        rows.collect()
    };
    match read_topics() {
        Ok(rows) => {
            for (id, name, ty, fmt) in rows {
                if MsgType::of(&ty, &name).is_some() {
                    if fmt != "cdr" {
                        out.skipped_encodings.push(format!("{name} ({fmt})"));
                    } else {
                        out.topics.push((name.clone(), ty.clone()));
                    }
                }
                topics.insert(id, (name, ty, fmt));
            }
        }
        Err(e) => {
            out.error = Some(err(None, e));
            return out;
        }
    }
    let mut last_row = None;
    let mut read_messages = || -> rusqlite::Result<()> {
        let mut st = conn.prepare("SELECT id, topic_id, timestamp, data FROM messages ORDER BY id")?;
        let mut rows = st.query([])?;
        let mut n = 0u64;
        // A row's boundaries are sqlite's: a column of the wrong type (a REAL topic id, a TEXT
        // time stamp) costs that row only. What stops reading is sqlite failing to step to the
        // next row (a damaged page).
        while let Some(r) = rows.next()? {
            n += 1;
            let row = || -> rusqlite::Result<(i64, i64, i64)> { Ok((r.get(0)?, r.get(1)?, r.get(2)?)) };
            let (id, topic_id, t) = match row() {
                Ok(v) => v,
                Err(e) => {
                    out.bad.add(ReplayError::SqliteRow { file: file.to_path_buf(), row: n, reason: e.to_string() });
                    continue;
                }
            };
            let t_ns = t.max(0) as u64;
            if let Some((name, ty, fmt)) = topics.get(&topic_id) {
                if let (Some(kind), "cdr") = (MsgType::of(ty, name), fmt.as_str()) {
                    let data: Vec<u8> = match r.get(3) {
                        Ok(d) => d,
                        Err(e) => {
                            out.bad.add(ReplayError::SqliteRow { file: file.to_path_buf(), row: n, reason: e.to_string() });
                            continue;
                        }
                    };
                    out.messages.push(BagMessage { t_ns, topic: name.clone(), kind, data, at: Location::Row(id) });
                }
            }
            out.saw(t_ns);
            last_row = Some(id);
        }
        Ok(())
    };
    if let Err(e) = read_messages() {
        out.error = Some(err(last_row, e));
    }
    out
}

/// A rigid transform in 3D, for walking the frame tree.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Iso {
    t: [f64; 3],
    /// `[x, y, z, w]`, unit.
    q: [f64; 4],
}

impl Iso {
    const IDENTITY: Iso = Iso { t: [0.0; 3], q: [0.0, 0.0, 0.0, 1.0] };

    /// From a message's transform; `None` when it is not finite or the quaternion is zero.
    fn from(t: &Transform) -> Option<Iso> {
        let q = t.rotation;
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
        let finite = t.translation.iter().chain(q.iter()).all(|v| v.is_finite());
        (finite && n > 1e-9).then(|| Iso { t: t.translation, q: [q[0] / n, q[1] / n, q[2] / n, q[3] / n] })
    }

    fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        let [x, y, z, w] = self.q;
        // v + 2w (u × v) + 2 u × (u × v), u = (x, y, z).
        let c1 = [y * v[2] - z * v[1], z * v[0] - x * v[2], x * v[1] - y * v[0]];
        let c2 = [y * c1[2] - z * c1[1], z * c1[0] - x * c1[2], x * c1[1] - y * c1[0]];
        [v[0] + 2.0 * (w * c1[0] + c2[0]), v[1] + 2.0 * (w * c1[1] + c2[1]), v[2] + 2.0 * (w * c1[2] + c2[2])]
    }

    /// `self ∘ other`: `other` expressed in `self`'s parent.
    fn compose(&self, other: &Iso) -> Iso {
        let r = self.rotate(other.t);
        let (a, b) = (self.q, other.q);
        let q = [
            a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1],
            a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0],
            a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3],
            a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2],
        ];
        Iso { t: [self.t[0] + r[0], self.t[1] + r[1], self.t[2] + r[2]], q }
    }
}

/// A scan is placed only if the odometry (the moving edge of its frame chain nearest the laser,
/// e.g. `odom` → `base_link`) has a sample at most this long before its stamp, or brackets the
/// stamp with a sample this close: 0.5 s. Odometry is published at 20–100 Hz; a gap of half a
/// second means the robot's motion during it is unknown.
pub const MAX_POSE_AGE_NS: u64 = 500_000_000;

/// A moving edge (odometry or `tf`) whose translation moves more than this between consecutive
/// samples, plus [`MAX_SPEED_M_S`] times the time between them, has jumped (a corrupt message,
/// an odometry reset): the sample is rejected (`odometry_jump`), the edge keeps its history.
pub const MAX_JUMP_M: f64 = 1.0;

/// The fastest a robot's frame is assumed to move, m/s (with [`MAX_JUMP_M`]).
pub const MAX_SPEED_M_S: f64 = 10.0;

/// One edge of the frame tree: its parent, and the child's pose in it over time (one sample for
/// a `tf_static` edge).
#[derive(Clone, Debug)]
struct Edge {
    parent: String,
    /// From `tf_static`: holds at every time.
    fixed: bool,
    /// `(stamp ns, pose)`, stamps non-decreasing.
    samples: Vec<(u64, Iso)>,
}

/// Why a moving transform was not taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum EdgeReject {
    /// Not finite, a zero quaternion, or a frame its own parent.
    Invalid,
    /// It would close a cycle in the frame tree.
    Loop,
    /// Its stamp is before the edge's previous one.
    Backwards,
    /// Its translation jumped ([`MAX_JUMP_M`], [`MAX_SPEED_M_S`]).
    Jump,
}

/// Why a scan could not be placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PoseError {
    /// Its frame is in no tree with a root (or a cycle).
    NoPose,
    /// The odometry has no sample at or before the scan's stamp.
    NoOdometryYet,
    /// The odometry's nearest sample is more than [`MAX_POSE_AGE_NS`] from the stamp.
    Stale,
}

/// The frame tree: child → edge. Moving edges keep every sample, so a scan is placed with the
/// transforms interpolated to its own stamp.
#[derive(Default)]
struct FrameTree {
    edges: HashMap<String, Edge>,
}

/// Frame names without the ROS 1 leading slash.
fn frame(name: &str) -> String {
    name.trim_start_matches('/').to_string()
}

/// Shortest-arc spherical interpolation between unit quaternions (for a planar pose: yaw
/// interpolated the short way round), `s` in [0, 1].
fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let mut d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    let mut b = b;
    if d < 0.0 {
        d = -d;
        b = b.map(|v| -v);
    }
    let (wa, wb) = if d > 0.9995 {
        (1.0 - s, s)
    } else {
        let th = d.min(1.0).acos();
        let sn = th.sin();
        (((1.0 - s) * th).sin() / sn, (s * th).sin() / sn)
    };
    let q = [0, 1, 2, 3].map(|i| wa * a[i] + wb * b[i]);
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    q.map(|v| v / n)
}

/// `a` and `b` interpolated at `s` in [0, 1]: translation linear, rotation shortest arc.
fn interpolate(a: &Iso, b: &Iso, s: f64) -> Iso {
    Iso { t: [0, 1, 2].map(|i| a.t[i] + (b.t[i] - a.t[i]) * s), q: slerp(a.q, b.q, s) }
}

impl FrameTree {
    /// Would `parent` → `child` close a cycle (is `child` an ancestor of `parent`, or `parent`)?
    fn closes_loop(&self, parent: &str, child: &str) -> bool {
        let mut cur = parent.to_string();
        for _ in 0..=64 {
            if cur == child {
                return true;
            }
            match self.edges.get(&cur) {
                None => return false,
                Some(e) => cur = e.parent.clone(),
            }
        }
        true
    }

    /// A `tf_static` edge: holds at every time, replaces what the edge was.
    fn set_static(&mut self, parent: &str, child: &str, t: &Transform) -> Result<(), EdgeReject> {
        let (parent, child) = (frame(parent), frame(child));
        let iso = Iso::from(t).filter(|_| parent != child).ok_or(EdgeReject::Invalid)?;
        if self.closes_loop(&parent, &child) {
            return Err(EdgeReject::Loop);
        }
        self.edges.insert(child, Edge { parent, fixed: true, samples: vec![(0, iso)] });
        Ok(())
    }

    /// A moving edge's sample at `t_ns` (odometry or `tf`). A new parent for the child starts a
    /// new history.
    fn push(&mut self, parent: &str, child: &str, t_ns: u64, t: &Transform) -> Result<(), EdgeReject> {
        let (parent, child) = (frame(parent), frame(child));
        let iso = Iso::from(t).filter(|_| parent != child).ok_or(EdgeReject::Invalid)?;
        let same_parent = self.edges.get(&child).is_some_and(|e| e.parent == parent);
        if !same_parent && self.closes_loop(&parent, &child) {
            return Err(EdgeReject::Loop);
        }
        if let Some(e) = self.edges.get_mut(&child).filter(|e| e.parent == parent && !e.fixed) {
            let &(t0, last) = e.samples.last().expect("an edge has a sample");
            if t_ns < t0 {
                return Err(EdgeReject::Backwards);
            }
            let moved = ((iso.t[0] - last.t[0]).powi(2) + (iso.t[1] - last.t[1]).powi(2) + (iso.t[2] - last.t[2]).powi(2)).sqrt();
            if moved > MAX_JUMP_M + MAX_SPEED_M_S * (t_ns - t0) as f64 / 1e9 {
                return Err(EdgeReject::Jump);
            }
            e.samples.push((t_ns, iso));
        } else {
            self.edges.insert(child, Edge { parent, fixed: false, samples: vec![(t_ns, iso)] });
        }
        Ok(())
    }

    /// The pose of `f` in the root of its tree at time `t_ns`, the root's name and the number of
    /// edges walked. Moving edges are interpolated to `t_ns` between the samples around it. The
    /// first moving edge from `f` up (the odometry) must have a sample at or before `t_ns`
    /// ([`PoseError::NoOdometryYet`]) and one within [`MAX_POSE_AGE_NS`] of it
    /// ([`PoseError::Stale`]); edges above it (e.g. `map` → `odom`, published slowly) hold their
    /// nearest sample outside the span of their samples.
    fn resolve_at(&self, f: &str, t_ns: u64) -> Result<(Iso, String, usize), PoseError> {
        let mut pose = Iso::IDENTITY;
        let mut cur = frame(f);
        let mut odometry_seen = false;
        for depth in 0..=64 {
            let Some(e) = self.edges.get(&cur) else { return Ok((pose, cur, depth)) };
            let edge = if e.fixed {
                e.samples[0].1
            } else {
                let k = e.samples.partition_point(|s| s.0 <= t_ns);
                let before = k.checked_sub(1).map(|i| e.samples[i]);
                let after = e.samples.get(k).copied();
                if !odometry_seen {
                    odometry_seen = true;
                    let Some((tb, _)) = before else { return Err(PoseError::NoOdometryYet) };
                    let age = after.map_or(t_ns - tb, |(ta, _)| (t_ns - tb).min(ta - t_ns));
                    if age > MAX_POSE_AGE_NS {
                        return Err(PoseError::Stale);
                    }
                }
                match (before, after) {
                    (Some((tb, a)), Some((ta, b))) => interpolate(&a, &b, (t_ns - tb) as f64 / (ta - tb) as f64),
                    (Some((_, a)), None) | (None, Some((_, a))) => a,
                    (None, None) => unreachable!("an edge has a sample"),
                }
            };
            pose = edge.compose(&pose);
            cur = e.parent.clone();
        }
        Err(PoseError::NoPose)
    }
}

/// Moving transforms (odometry, `tf`) rejected, by reason: nothing else is lost with them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RejectedTransforms {
    /// The translation jumped ([`MAX_JUMP_M`] + [`MAX_SPEED_M_S`] × the time since the edge's
    /// previous sample), e.g. odometry 100 m away from the message before.
    pub odometry_jump: u32,
    /// The transform would close a cycle of frames (`a` → `b` → `a`).
    pub tf_loop: u32,
    /// Its header stamp is before the previous one of the same edge.
    pub stamp_backwards: u32,
    /// Not finite, a zero quaternion, or a frame its own parent.
    pub invalid: u32,
}

/// What the messages gave.
#[derive(Debug, Default)]
pub struct BagScans {
    /// Scans with their laser poses, time order.
    pub scans: Vec<ScanRecord>,
    /// Scans whose frame could not be placed in a tree with a root.
    pub no_pose: usize,
    /// Scans stamped before the first odometry sample (e.g. the scanner started first).
    pub no_odometry_yet: usize,
    /// Scans whose nearest odometry sample is more than [`MAX_POSE_AGE_NS`] away.
    pub stale_pose: usize,
    /// Scans whose header stamp is before the previous scan's on the same frame.
    pub scan_stamp_backwards: usize,
    /// Transforms rejected.
    pub transforms_rejected: RejectedTransforms,
    /// Odometry messages.
    pub odometry: usize,
    /// Transforms received (tf and tf_static).
    pub transforms: usize,
    /// Notes for the user (assumptions made).
    pub warnings: Vec<String>,
    /// Messages that did not decode (skipped).
    pub bad_records: BadRecords,
}

enum Decoded {
    Scan(cdr::LaserScan),
    Odom(cdr::Odometry),
    Tf(Vec<cdr::TransformStamped>),
}

/// A header stamp in nanoseconds; `fallback` (the receive time) when the stamp is zero or
/// negative (a bag whose publisher did not stamp).
fn stamp_ns(h: &cdr::Header, fallback: u64) -> u64 {
    let ns = h.stamp.sec as i64 * 1_000_000_000 + h.stamp.nanosec as i64;
    if ns > 0 {
        ns as u64
    } else {
        fallback
    }
}

/// Decodes the messages (skipping and counting those that do not decode), builds the frame tree
/// with every moving transform at its header stamp, and returns every scan with the laser's pose
/// at the scan's header stamp (transforms interpolated to it; receive times where a message has
/// no stamp).
pub fn scans_from_messages(file: &Path, mut messages: Vec<BagMessage>) -> BagScans {
    let mut out = BagScans::default();
    // Receive-time order (a stable sort keeps file order for equal stamps).
    messages.sort_by_key(|m| m.t_ns);
    let mut decoded = Vec::with_capacity(messages.len());
    for m in &messages {
        let d: Result<Decoded, CdrError> = match m.kind {
            MsgType::LaserScan => cdr::decode_laser_scan(&m.data).map(Decoded::Scan),
            MsgType::Odometry => cdr::decode_odometry(&m.data).map(Decoded::Odom),
            MsgType::Tf | MsgType::TfStatic => cdr::decode_tf_message(&m.data).map(Decoded::Tf),
        };
        match d {
            Ok(d) => decoded.push((m, d)),
            Err(error) => out.bad_records.add(ReplayError::Message { file: file.to_path_buf(), at: m.at, topic: m.topic.clone(), error }),
        }
    }
    let mut tree = FrameTree::default();
    let mut rej = RejectedTransforms::default();
    let count = |r: Result<(), EdgeReject>, rej: &mut RejectedTransforms| match r {
        Ok(()) => {}
        Err(EdgeReject::Invalid) => rej.invalid += 1,
        Err(EdgeReject::Loop) => rej.tf_loop += 1,
        Err(EdgeReject::Backwards) => rej.stamp_backwards += 1,
        Err(EdgeReject::Jump) => rej.odometry_jump += 1,
    };
    // tf_static describes the robot's fixed geometry: it holds for the whole bag.
    for (m, d) in &decoded {
        if let (MsgType::TfStatic, Decoded::Tf(ts)) = (m.kind, d) {
            for t in ts {
                out.transforms += 1;
                count(tree.set_static(&t.header.frame_id, &t.child_frame_id, &t.transform), &mut rej);
            }
        }
    }
    // Every moving transform, at its stamp (a scan is placed with samples before and after it).
    let mut odom_child: Option<String> = None;
    for (m, d) in &decoded {
        match d {
            Decoded::Tf(ts) if m.kind == MsgType::Tf => {
                for t in ts {
                    out.transforms += 1;
                    count(tree.push(&t.header.frame_id, &t.child_frame_id, stamp_ns(&t.header, m.t_ns), &t.transform), &mut rej);
                }
            }
            Decoded::Odom(o) => {
                out.odometry += 1;
                let r = tree.push(&o.header.frame_id, &o.child_frame_id, stamp_ns(&o.header, m.t_ns), &o.pose);
                if r.is_ok() && odom_child.is_none() {
                    odom_child = Some(frame(&o.child_frame_id));
                }
                count(r, &mut rej);
            }
            _ => {}
        }
    }
    let mut assumed: Vec<String> = Vec::new();
    let mut last_stamp: HashMap<String, u64> = HashMap::new();
    let mut first_unplaced: Vec<String> = Vec::new();
    for (m, d) in decoded {
        let Decoded::Scan(s) = d else { continue };
        let laser = frame(&s.header.frame_id);
        let t = stamp_ns(&s.header, m.t_ns);
        if last_stamp.get(&laser).is_some_and(|&prev| t < prev) {
            out.scan_stamp_backwards += 1;
            continue;
        }
        last_stamp.insert(laser.clone(), t);
        let mut target = laser.clone();
        if !tree.edges.contains_key(&laser) {
            if let Some(child) = &odom_child {
                // The laser's frame is in no transform: assume it sits at the odometry's body
                // frame (say so once).
                if !assumed.contains(&laser) {
                    out.warnings.push(format!(
                        "no transform places laser frame `{laser}` (topic {}): assumed mounted at `{child}` with no offset",
                        m.topic
                    ));
                    assumed.push(laser.clone());
                }
                target = child.clone();
            }
        }
        match tree.resolve_at(&target, t) {
            Ok((pose, _root, depth)) if depth > 0 => out.scans.push(scan_record(&s, &pose, m.t_ns, m.at)),
            Ok(_) | Err(PoseError::NoPose) => out.no_pose += 1,
            Err(e) => {
                if first_unplaced.len() < 3 {
                    first_unplaced.push(format!("{} ({} s)", m.at, t as f64 / 1e9));
                }
                match e {
                    PoseError::NoOdometryYet => out.no_odometry_yet += 1,
                    _ => out.stale_pose += 1,
                }
            }
        }
    }
    if out.no_odometry_yet + out.stale_pose > 0 {
        out.warnings.push(format!(
            "{} scans stamped before the first odometry and {} whose nearest odometry is more than {} s from their stamp \
             were not used (not placed at the frame tree's origin): first at {}",
            out.no_odometry_yet,
            out.stale_pose,
            MAX_POSE_AGE_NS as f64 / 1e9,
            first_unplaced.join(", ")
        ));
    }
    if out.scan_stamp_backwards > 0 {
        out.warnings.push(format!("{} scans stamped before the scan before them were not used", out.scan_stamp_backwards));
    }
    if rej.invalid > 0 {
        out.warnings.push(format!("{} transforms ignored (not finite, zero quaternion, or a frame its own parent)", rej.invalid));
    }
    if rej.odometry_jump + rej.tf_loop + rej.stamp_backwards > 0 {
        out.warnings.push(format!(
            "transforms rejected: {} odometry_jump (moved more than {MAX_JUMP_M} m + {MAX_SPEED_M_S} m/s since the sample before), \
             {} tf_loop (would close a cycle of frames), {} stamp_backwards; the others were used",
            rej.odometry_jump, rej.tf_loop, rej.stamp_backwards
        ));
    }
    out.transforms_rejected = rej;
    out
}

/// A scan in the replay's terms: the laser's planar pose and ranges by the ROS conventions.
fn scan_record(s: &cdr::LaserScan, pose: &Iso, t_ns: u64, at: Location) -> ScanRecord {
    let x_axis = pose.rotate([1.0, 0.0, 0.0]);
    let z_axis = pose.rotate([0.0, 0.0, 1.0]);
    let yaw = x_axis[1].atan2(x_axis[0]);
    // Upside down: a beam at +a in the laser frame points to −a about the world's z.
    let sign = if z_axis[2] < 0.0 { -1.0 } else { 1.0 };
    // The readings as recorded: the range rule (REP 117) is applied once, with the scan's own
    // limits, when the scan is encoded for the core (`crate::range`).
    let ranges_m = s.ranges.clone();
    ScanRecord {
        t_s: t_ns as f64 / 1e9,
        pose: [pose.t[0], pose.t[1], yaw],
        angle_min: sign * s.angle_min as f64,
        angle_increment: sign * s.angle_increment as f64,
        ranges_m,
        range_limits_m: [s.range_min as f64, s.range_max as f64],
        at,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iso(x: f64, y: f64, yaw: f64) -> Iso {
        Iso::from(&Transform::planar(x, y, yaw)).unwrap()
    }

    #[test]
    fn composing_planar_transforms_matches_se2() {
        // base at (1, 2) facing +y; laser 0.5 m ahead of the base, turned −90°: the laser sits at
        // (1, 2.5) facing +x.
        let p = iso(1.0, 2.0, std::f64::consts::FRAC_PI_2).compose(&iso(0.5, 0.0, -std::f64::consts::FRAC_PI_2));
        assert!((p.t[0] - 1.0).abs() < 1e-12 && (p.t[1] - 2.5).abs() < 1e-12, "{p:?}");
        let x = p.rotate([1.0, 0.0, 0.0]);
        assert!((x[0] - 1.0).abs() < 1e-12 && x[1].abs() < 1e-12);
    }

    #[test]
    fn upside_down_laser_negates_angles_and_ros_ranges_apply() {
        // Rolled by π about x: z points down.
        let flipped = Iso { t: [0.0; 3], q: [1.0, 0.0, 0.0, 0.0] };
        let s = cdr::LaserScan {
            angle_min: -0.5,
            angle_increment: 0.25,
            range_min: 0.2,
            range_max: 10.0,
            ranges: vec![f32::NAN, f32::NEG_INFINITY, f32::INFINITY, 0.1, 10.5, 5.0, 10.0],
            ..Default::default()
        };
        let r = scan_record(&s, &flipped, 2_000_000_000, Location::Row(1));
        assert_eq!((r.angle_min, r.angle_increment), (0.5, -0.25));
        assert_eq!(r.t_s, 2.0);
        // Kept as recorded, with the scan's limits: the range rule is applied when encoding.
        for (a, b) in r.ranges_m.iter().zip(&s.ranges) {
            assert!(a == b || (a.is_nan() && b.is_nan()), "{:?}", r.ranges_m);
        }
        assert_eq!(r.range_limits_m, [0.2f32 as f64, 10.0]);
        let lim = crate::range::RangeLimits::new(r.range_limits_m[0], r.range_limits_m[1]);
        let enc: Vec<u16> = r.ranges_m.iter().map(|&v| crate::range::encode_range(v as f64, &lim)).collect();
        use firmware::scan::{RANGE_INVALID as I, RANGE_NO_RETURN as N};
        assert_eq!(enc, [I, I, N, I, N, 5000, N], "NaN, -inf, +inf, below min, beyond max, a return, at max");
    }

    #[test]
    fn frame_tree_resolves_chains_and_refuses_cycles() {
        let mut t = FrameTree::default();
        assert_eq!(t.push("odom", "/base_link", 1_000, &Transform::planar(2.0, 0.0, 0.0)), Ok(()));
        assert_eq!(t.set_static("base_link", "laser", &Transform::planar(0.0, 1.0, 0.0)), Ok(()));
        let (p, root, depth) = t.resolve_at("laser", 1_000).unwrap();
        assert_eq!((root.as_str(), depth), ("odom", 2));
        assert!((p.t[0] - 2.0).abs() < 1e-12 && (p.t[1] - 1.0).abs() < 1e-12);
        assert_eq!(t.push("a", "a", 1_000, &Transform::IDENTITY), Err(EdgeReject::Invalid), "a frame cannot be its own parent");
        assert_eq!(t.push("laser", "odom", 1_000, &Transform::IDENTITY), Err(EdgeReject::Loop));
        assert_eq!(t.set_static("laser", "odom", &Transform::IDENTITY), Err(EdgeReject::Loop));
        // The tree is as it was: the loop was refused, not half-applied.
        assert_eq!(t.resolve_at("laser", 1_000).unwrap().1, "odom");
    }

    #[test]
    fn moving_edges_interpolate_to_the_stamp_and_refuse_jumps_and_backward_stamps() {
        let mut t = FrameTree::default();
        let s = 1_000_000_000u64;
        // 170° to −170°: the short way round is through 180°, not through 0°.
        t.push("odom", "base", s, &Transform::planar(0.0, 0.0, 170f64.to_radians())).unwrap();
        t.push("odom", "base", s + 100_000_000, &Transform::planar(0.5, 1.0, (-170f64).to_radians())).unwrap();
        let (p, _, _) = t.resolve_at("base", s + 25_000_000).unwrap();
        assert!((p.t[0] - 0.125).abs() < 1e-12 && (p.t[1] - 0.25).abs() < 1e-12, "{p:?}");
        let x = p.rotate([1.0, 0.0, 0.0]);
        assert!((x[1].atan2(x[0]).to_degrees() - 175.0).abs() < 1e-9, "{}", x[1].atan2(x[0]).to_degrees());
        // Before the first sample: no odometry yet. After the last: held up to the age bound.
        assert_eq!(t.resolve_at("base", s - 1), Err(PoseError::NoOdometryYet));
        assert!(t.resolve_at("base", s + 100_000_000 + MAX_POSE_AGE_NS).is_ok());
        assert_eq!(t.resolve_at("base", s + 100_000_001 + MAX_POSE_AGE_NS), Err(PoseError::Stale));
        // A 100 m jump, and a stamp going backwards, are refused; the samples around them stay.
        assert_eq!(t.push("odom", "base", s + 120_000_000, &Transform::planar(100.5, 1.0, 0.0)), Err(EdgeReject::Jump));
        assert_eq!(t.push("odom", "base", s + 50_000_000, &Transform::planar(0.5, 1.0, 0.0)), Err(EdgeReject::Backwards));
        t.push("odom", "base", s + 140_000_000, &Transform::planar(0.6, 1.0, 0.0)).unwrap();
        assert_eq!(t.edges["base"].samples.len(), 3);
        // A gap longer than the bound in the middle: a stamp in it is stale.
        t.push("odom", "base", s + 2_000_000_000, &Transform::planar(2.0, 1.0, 0.0)).unwrap();
        assert_eq!(t.resolve_at("base", s + 1_000_000_000), Err(PoseError::Stale));
        assert!(t.resolve_at("base", s + 1_600_000_000).is_ok());
    }

    #[test]
    fn mcap_without_magic_is_an_error_at_byte_zero() {
        let c = read_mcap(Path::new("x.mcap"), b"not an mcap file");
        assert!(matches!(c.error, Some(ReplayError::Mcap { offset: 0, .. })), "{:?}", c.error);
    }

    /// A build without a codec (the default features) names the feature a compressed chunk
    /// needs; a build with it reports the junk payload as damage instead. `scripts/test.sh` runs
    /// this test both ways.
    #[test]
    fn a_compressed_chunk_names_the_feature_it_needs() {
        for codec in ["zstd", "lz4"] {
            let mut body = Vec::new();
            body.extend_from_slice(&0u64.to_le_bytes()); // message start time
            body.extend_from_slice(&0u64.to_le_bytes()); // message end time
            body.extend_from_slice(&16u64.to_le_bytes()); // uncompressed size
            body.extend_from_slice(&0u32.to_le_bytes()); // uncompressed CRC (0: unchecked)
            body.extend_from_slice(&(codec.len() as u32).to_le_bytes());
            body.extend_from_slice(codec.as_bytes());
            body.extend_from_slice(&4u64.to_le_bytes());
            body.extend_from_slice(b"junk");
            let mut file = MCAP_MAGIC.to_vec();
            file.push(0x06); // Chunk
            file.extend_from_slice(&(body.len() as u64).to_le_bytes());
            file.extend_from_slice(&body);
            let c = read_mcap(Path::new("c.mcap"), &file);
            // The chunk is skipped (its length is intact); the file then ends without a footer.
            let [ReplayError::McapChunk { offset: 8, reason, .. }] = &c.bad.first[..] else { panic!("{codec}: {:?}", c.bad) };
            assert!(matches!(&c.error, Some(ReplayError::Mcap { reason, .. }) if reason.contains("truncated")), "{:?}", c.error);
            // Constant in any one build (both `true` with the default features), not in general.
            #[allow(clippy::needless_bool)]
            let built_with = if codec == "zstd" { cfg!(feature = "zstd") } else { cfg!(feature = "lz4") };
            assert_eq!(reason.contains(&format!("rebuild with `--features {codec}`")), !built_with, "{codec}: {reason}");
            assert!(c.messages.is_empty());
        }
    }

    #[cfg(not(feature = "db3"))]
    #[test]
    fn without_db3_a_sqlite_bag_names_the_feature() {
        let c = read_db3(Path::new("x.db3"));
        let Some(ReplayError::Sqlite { reason, .. }) = &c.error else { panic!("{:?}", c.error) };
        assert!(reason.contains("`--features db3`"), "{reason}");
    }
}
