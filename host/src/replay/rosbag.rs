//! ROS 2 bags: MCAP (rosbag2's default storage since Iron) and sqlite3 (`.db3`, the default
//! before), with `sensor_msgs/msg/LaserScan`, `nav_msgs/msg/Odometry` and `tf2_msgs/msg/TFMessage`
//! on `/tf` and `/tf_static`, CDR-encoded.
//!
//! Reading happens in two steps:
//!
//! 1. [`read_mcap`] / [`read_db3`] pull the messages of those three types out of the container
//!    in file order, with where each came from ([`Location`]): the byte offset of its MCAP record
//!    (for a message inside a chunk, the chunk's offset) or its `messages` row id. They stop at
//!    the first damaged record or row (the framing after it is lost) and hand back what came
//!    before, plus the error.
//! 2. [`scans_from_messages`] decodes them (CDR, [`super::cdr`]; a message that does not decode
//!    is skipped and counted, the messages around it are used), sorts them by the bag's receive
//!    time, and replays the frame tree: `tf_static` transforms apply to the whole bag,
//!    `tf` transforms and odometry (`header.frame_id` → `child_frame_id`) update their edge as
//!    they arrive. Each scan's pose is the laser frame's pose in the root of its frame tree
//!    (`map` or `odom`), from the latest transforms received before the scan (no interpolation),
//!    projected to the plane: x, y and the yaw of the laser's x axis. A laser mounted upside down
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

/// The first record in `records` (an uncompressed chunk's, starting at byte `at` of the file)
/// that does not parse, described with its byte offset.
fn bad_inner_record(records: &[u8], at: usize) -> Option<String> {
    let mut pos = 0;
    while pos < records.len() {
        if records.len() - pos < 9 {
            return Some(format!("a record header at byte {} is cut off by the end of the chunk", at + pos));
        }
        let op = records[pos];
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(&records[pos + 1..pos + 9]);
        let len = u64::from_le_bytes(len_bytes);
        let left = (records.len() - pos - 9) as u64;
        if len > left {
            return Some(format!(
                "its {} record (opcode 0x{op:02x}) at byte {} of {len} bytes runs past the end of the chunk, {left} bytes left",
                op_name(op),
                at + pos
            ));
        }
        let body = &records[pos + 9..pos + 9 + len as usize];
        if let Err(e) = mcap::parse_record(op, body) {
            return Some(format!("its record at byte {}: {}", at + pos, unparsable(op, body.len(), &e)));
        }
        pos += 9 + len as usize;
    }
    None
}

/// Channel id → (topic, type name, message encoding).
type Channels = HashMap<u16, (String, String, String)>;

/// Reads an MCAP file held in `buf`. Walks the top-level records itself (so damage is located to
/// the byte), lets the `mcap` crate parse each record and decompress chunks (zstd, lz4).
pub fn read_mcap(file: &Path, buf: &[u8]) -> BagContents {
    let mut out = BagContents::default();
    let damage = |offset: usize, reason: String| ReplayError::Mcap { file: file.to_path_buf(), offset: offset as u64, reason };
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
        let record = match mcap::parse_record(op, body) {
            Ok(r) => r,
            Err(e) => {
                out.error = Some(damage(pos, unparsable(op, body.len(), &e)));
                return out;
            }
        };
        let result = match record {
            mcap::records::Record::Chunk { header, data } => match mcap::read::ChunkReader::new(header.clone(), &data) {
                Ok(reader) => {
                    let mut r = Ok(());
                    for (k, inner) in reader.enumerate() {
                        match inner {
                            Ok(rec) => take_record(rec, &mut schemas, &mut channels, &mut out, Location::Offset(pos as u64)),
                            Err(e) => {
                                // Uncompressed records are in the file: name the bad one's byte.
                                let records_at = body_start + 40 + header.compression.len();
                                let detail = match header.compression.is_empty() {
                                    true => bad_inner_record(&data, records_at),
                                    false => None,
                                };
                                r = Err(format!(
                                    "damaged Chunk record: {}",
                                    detail.unwrap_or_else(|| format!(
                                        "after {k} good records (of its {} uncompressed bytes): {e}{}",
                                        header.uncompressed_size,
                                        std::error::Error::source(&e).map(|w| format!(": {w}")).unwrap_or_default()
                                    ))
                                ));
                                break;
                            }
                        }
                    }
                    r
                }
                Err(e) => Err(match missing_codec(&header.compression) {
                    Some(feature) => format!(
                        "chunk compressed with {}, which this `lives` was built without (rebuild with `--features {feature}`, or `ros-bags`)",
                        header.compression
                    ),
                    None => format!("cannot read Chunk record: {e}"),
                }),
            },
            rec => {
                take_record(rec, &mut schemas, &mut channels, &mut out, Location::Offset(pos as u64));
                Ok(())
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
        while let Some(r) = rows.next()? {
            let id: i64 = r.get(0)?;
            let topic_id: i64 = r.get(1)?;
            let t: i64 = r.get(2)?;
            let t_ns = t.max(0) as u64;
            out.saw(t_ns);
            if let Some((name, ty, fmt)) = topics.get(&topic_id) {
                if let (Some(kind), "cdr") = (MsgType::of(ty, name), fmt.as_str()) {
                    let data: Vec<u8> = r.get(3)?;
                    out.messages.push(BagMessage { t_ns, topic: name.clone(), kind, data, at: Location::Row(id) });
                }
            }
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

/// The frame tree: child → (parent, pose of the child in the parent).
#[derive(Default)]
struct FrameTree {
    edges: HashMap<String, (String, Iso)>,
}

/// Frame names without the ROS 1 leading slash.
fn frame(name: &str) -> String {
    name.trim_start_matches('/').to_string()
}

impl FrameTree {
    fn set(&mut self, parent: &str, child: &str, t: &Transform) -> bool {
        match Iso::from(t) {
            Some(iso) if frame(parent) != frame(child) => {
                self.edges.insert(frame(child), (frame(parent), iso));
                true
            }
            _ => false,
        }
    }

    /// The pose of `f` in the root of its tree, the root's name and the number of edges walked;
    /// `None` on a cycle.
    fn resolve(&self, f: &str) -> Option<(Iso, String, usize)> {
        let mut pose = Iso::IDENTITY;
        let mut cur = frame(f);
        for depth in 0..=64 {
            match self.edges.get(&cur) {
                None => return Some((pose, cur, depth)),
                Some((parent, e)) => {
                    pose = e.compose(&pose);
                    cur = parent.clone();
                }
            }
        }
        None
    }
}

/// What the messages gave.
#[derive(Debug, Default)]
pub struct BagScans {
    /// Scans with their laser poses, time order.
    pub scans: Vec<ScanRecord>,
    /// Scans whose frame could not be placed in a tree with a root.
    pub no_pose: usize,
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

/// Decodes the messages (skipping and counting those that do not decode), replays the frame
/// tree and returns every scan with the laser's pose.
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
    let mut bad_transforms = 0usize;
    // tf_static describes the robot's fixed geometry: it holds for the whole bag.
    for (m, d) in &decoded {
        if let (MsgType::TfStatic, Decoded::Tf(ts)) = (m.kind, d) {
            for t in ts {
                out.transforms += 1;
                bad_transforms += !tree.set(&t.header.frame_id, &t.child_frame_id, &t.transform) as usize;
            }
        }
    }
    let mut odom_child: Option<String> = None;
    let mut assumed: Vec<String> = Vec::new();
    for (m, d) in decoded {
        match d {
            Decoded::Tf(ts) if m.kind == MsgType::Tf => {
                for t in &ts {
                    out.transforms += 1;
                    bad_transforms += !tree.set(&t.header.frame_id, &t.child_frame_id, &t.transform) as usize;
                }
            }
            Decoded::Tf(_) => {}
            Decoded::Odom(o) => {
                out.odometry += 1;
                if tree.set(&o.header.frame_id, &o.child_frame_id, &o.pose) {
                    odom_child = Some(frame(&o.child_frame_id));
                } else {
                    bad_transforms += 1;
                }
            }
            Decoded::Scan(s) => {
                let laser = frame(&s.header.frame_id);
                let mut placed = tree.resolve(&laser);
                if let (Some((_, _, 0)), Some(child)) = (&placed, &odom_child) {
                    // The laser's frame is in no transform: assume it sits at the odometry's body
                    // frame (say so once).
                    if !assumed.contains(&laser) {
                        out.warnings.push(format!(
                            "no transform places laser frame `{laser}` (topic {}): assumed mounted at `{child}` with no offset",
                            m.topic
                        ));
                        assumed.push(laser.clone());
                    }
                    placed = tree.resolve(child);
                }
                match placed {
                    Some((pose, _root, depth)) if depth > 0 => out.scans.push(scan_record(&s, &pose, m.t_ns, m.at)),
                    _ => out.no_pose += 1,
                }
            }
        }
    }
    if bad_transforms > 0 {
        out.warnings.push(format!("{bad_transforms} transforms ignored (not finite, zero quaternion, or a frame its own parent)"));
    }
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
        assert!(t.set("odom", "/base_link", &Transform::planar(2.0, 0.0, 0.0)));
        assert!(t.set("base_link", "laser", &Transform::planar(0.0, 1.0, 0.0)));
        let (p, root, depth) = t.resolve("laser").unwrap();
        assert_eq!((root.as_str(), depth), ("odom", 2));
        assert!((p.t[0] - 2.0).abs() < 1e-12 && (p.t[1] - 1.0).abs() < 1e-12);
        assert!(!t.set("a", "a", &Transform::IDENTITY), "a frame cannot be its own parent");
        assert!(t.set("laser", "odom", &Transform::IDENTITY));
        assert_eq!(t.resolve("laser"), None, "cycle");
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
            let Some(ReplayError::Mcap { offset: 8, reason, .. }) = &c.error else { panic!("{codec}: {:?}", c.error) };
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
