//! ROS 1 bags, format 2.0 (`rosbag record`; <http://wiki.ros.org/Bags/Format/2.0>): the record
//! walk, chunk decompression (bz2, lz4, none) and the messages of the topics replay reads.
//!
//! A bag is the line `#ROSBAG V2.0`, then records: a `uint32` header length, the header (fields,
//! each a `uint32` length and `name=value`; `op` names the record), a `uint32` data length, the
//! data. Messages (`op` 0x02: `conn`, `time`) and the connections they refer to (0x07: `conn`,
//! `topic`; the data holds `type`, `md5sum`, `message_definition`) sit inside chunks (0x05:
//! `compression`, `size`); the bag header (0x03), index data (0x04) and chunk infos (0x06) are
//! an index replay does not need: it reads the file front to back, so an unindexed bag (a
//! recording that was cut short, `.bag.active`) reads as well.
//!
//! Damage, as for MCAP: a top-level record cut off by the end of the file or with a header that
//! does not parse stops the walk (its length cannot be trusted); what came before is kept and
//! the error names the byte. A chunk whose data does not decompress, or whose records do not
//! parse, is skipped and counted ([`BagContents::bad`]), and the chunks after it are read.
//!
//! We read the format ourselves rather than with the `rosbag` crate (0.6.3): it indexes the
//! file through its header's `index_pos` (a bag cut short has none, and a damaged one slices
//! out of bounds and panics), parses field names with `str::from_utf8_unchecked`, and
//! memory-maps the file.

use super::*;
use crate::io::replay::{Location, ReplayError};
use std::collections::HashMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// How a ROS 1 bag (format 2.0) starts.
pub const ROS1_BAG_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// The longest record header read (its fields are a few short values: `op`, `conn`, `topic`,
/// `time`, `compression`, `size`, counts and offsets).
pub const MAX_HEADER: u64 = 1 << 20;

const OP_MSG_DATA: u8 = 0x02;
const OP_CHUNK: u8 = 0x05;
const OP_CONNECTION: u8 = 0x07;

fn op_name(op: u8) -> &'static str {
    match op {
        0x02 => "message data",
        0x03 => "bag header",
        0x04 => "index data",
        0x05 => "chunk",
        0x06 => "chunk info",
        0x07 => "connection",
        _ => "unknown",
    }
}

/// A record header's fields (`name=value`).
struct Header<'a>(Vec<(&'a [u8], &'a [u8])>);

impl<'a> Header<'a> {
    fn field(&self, name: &str) -> Option<&'a [u8]> {
        self.0.iter().find(|(n, _)| *n == name.as_bytes()).map(|(_, v)| *v)
    }

    fn op(&self) -> Option<u8> {
        match self.field("op") {
            Some([op]) => Some(*op),
            _ => None,
        }
    }

    fn u32_field(&self, name: &str) -> Result<u32, String> {
        match self.field(name) {
            Some(v) if v.len() == 4 => Ok(u32::from_le_bytes([v[0], v[1], v[2], v[3]])),
            Some(v) => Err(format!("its `{name}` field has {} bytes, not 4", v.len())),
            None => Err(format!("it has no `{name}` field")),
        }
    }

    fn text_field(&self, name: &str) -> Result<String, String> {
        self.field(name).map(|v| String::from_utf8_lossy(v).into_owned()).ok_or_else(|| format!("it has no `{name}` field"))
    }
}

/// The `name=value` fields of a record header or of a connection's data.
/// A header's fields: `(name, value)`, in order.
type Fields<'a> = Vec<(&'a [u8], &'a [u8])>;

fn parse_fields(mut b: &[u8]) -> Result<Fields<'_>, String> {
    let mut out = Vec::new();
    let total = b.len();
    while !b.is_empty() {
        let at = total - b.len();
        if b.len() < 4 {
            return Err(format!("a field length cut off at byte {at} of the header ({} of 4 bytes)", b.len()));
        }
        let n = u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize;
        b = &b[4..];
        if n > b.len() {
            return Err(format!("a field of {n} bytes at byte {at} runs past the header's end ({} bytes left)", b.len()));
        }
        let (field, rest) = b.split_at(n);
        b = rest;
        let Some(eq) = field.iter().position(|&c| c == b'=') else {
            return Err(format!("the field at byte {at} has no `=`"));
        };
        out.push((&field[..eq], &field[eq + 1..]));
    }
    Ok(out)
}

/// Connection id → (topic, type name).
type Connections = HashMap<u32, (String, String)>;

/// What the walk has learnt so far: the connections, and the messages whose connection record
/// has not come yet (it was in a damaged chunk; the index section at the end repeats it).
#[derive(Default)]
struct Walk {
    conns: Connections,
    orphans: Vec<(u32, u64, Vec<u8>, Location)>,
}

impl Walk {
    fn push(&self, id: u32, t_ns: u64, data: Vec<u8>, at: Location, out: &mut BagContents) {
        if let Some((topic, type_name)) = self.conns.get(&id) {
            if let Some(kind) = MsgType::of(type_name, topic) {
                out.keep(BagMessage { t_ns, topic: topic.clone(), kind, wire: Wire::Ros1, data, at });
            }
        }
    }
}

/// Takes a connection or message record (inside a chunk or not); `at` is where a message is
/// reported to come from.
fn take(record: Owned, walk: &mut Walk, out: &mut BagContents, at: Location) -> Result<(), String> {
    let rec = record.header();
    match record.op {
        OP_CONNECTION => {
            let id = rec.u32_field("conn")?;
            let topic = rec.text_field("topic")?;
            let data = parse_fields(&record.data).map_err(|e| format!("connection {id} ({topic}): its data: {e}"))?;
            let type_name = data.iter().find(|(n, _)| *n == b"type").map(|(_, v)| String::from_utf8_lossy(v).into_owned());
            let type_name = type_name.ok_or_else(|| format!("connection {id} ({topic}) has no `type`"))?;
            if MsgType::of(&type_name, &topic).is_some() && !out.topics.iter().any(|(t, _)| *t == topic) {
                out.topics.push((topic.clone(), type_name.clone()));
            }
            walk.conns.insert(id, (topic, type_name));
        }
        OP_MSG_DATA => {
            let id = rec.u32_field("conn")?;
            let t_ns = match rec.field("time") {
                Some(v) if v.len() == 8 => {
                    let sec = u32::from_le_bytes([v[0], v[1], v[2], v[3]]) as u64;
                    let nsec = u32::from_le_bytes([v[4], v[5], v[6], v[7]]) as u64;
                    sec * 1_000_000_000 + nsec
                }
                Some(v) => return Err(format!("message data of connection {id}: its `time` field has {} bytes, not 8", v.len())),
                None => return Err(format!("message data of connection {id} has no `time` field")),
            };
            out.saw(t_ns);
            drop(rec);
            match walk.conns.contains_key(&id) {
                true => walk.push(id, t_ns, record.data, at, out),
                false => walk.orphans.push((id, t_ns, record.data, at)),
            }
        }
        _ => {}
    }
    Ok(())
}

/// The records of a chunk's uncompressed data, each handed to [`take`]; on the first that does
/// not parse, its offset in `records` and why (the records after it are lost with their framing).
fn walk_chunk(records: &[u8], walk: &mut Walk, out: &mut BagContents, at: Location) -> Result<(), (u64, String)> {
    let mut inner = Records { r: std::io::Cursor::new(records), pos: 0, len: records.len() as u64, scope: "chunk" };
    loop {
        let pos = inner.pos;
        match inner.next() {
            Ok(Some(record)) => take(record, walk, out, at).map_err(|e| (pos, e))?,
            Ok(None) => return Ok(()),
            Err(e) => return Err((pos, e)),
        }
    }
}

/// Reads a ROS 1 bag (format 2.0) held in `buf` (the fuzz target's way in; `lives replay`
/// streams the file, [`read_bag1_file`]).
pub fn read_bag1(file: &Path, buf: &[u8]) -> BagContents {
    read_bag1_from(file, std::io::Cursor::new(buf), buf.len() as u64)
}

/// Reads a ROS 1 bag file record by record: what is held at once is one chunk (and the messages
/// replay keeps), not the file, so a bag of camera images many times the memory reads too.
pub fn read_bag1_file(file: &Path) -> BagContents {
    let opened = std::fs::File::open(file).and_then(|f| Ok((f.metadata()?.len(), f)));
    match opened {
        Ok((len, f)) => read_bag1_from(file, std::io::BufReader::with_capacity(1 << 16, f), len),
        Err(e) => BagContents {
            error: Some(ReplayError::Bag { file: file.to_path_buf(), offset: 0, reason: format!("cannot read it: {e}") }),
            ..BagContents::default()
        },
    }
}

/// Reads a ROS 1 bag of `len` bytes from `r`.
pub fn read_bag1_from(file: &Path, r: impl Read + Seek, len: u64) -> BagContents {
    let mut out = BagContents::default();
    let mut walk = Walk::default();
    read_records(file, &mut Records { r, pos: 0, len, scope: "file" }, &mut walk, &mut out);
    // Messages whose connection came later (the index section repeats every connection).
    for (id, t_ns, data, at) in std::mem::take(&mut walk.orphans) {
        walk.push(id, t_ns, data, at, &mut out);
    }
    out
}

/// Records read one at a time: the file's top level, or the records of a chunk.
struct Records<R> {
    r: R,
    pos: u64,
    len: u64,
    /// What holds them, for the messages: `file` or `chunk`.
    scope: &'static str,
}

/// A record: its `op`, its header, its data if replay reads it (chunks, connections, messages;
/// the index is stepped over), and where its data starts.
struct Owned {
    op: u8,
    header: Vec<u8>,
    data: Vec<u8>,
    data_at: u64,
}

impl Owned {
    /// Its header's fields (parsed when the record was read, so they parse).
    fn header(&self) -> Header<'_> {
        Header(parse_fields(&self.header).unwrap_or_default())
    }
}

impl<R: Read + Seek> Records<R> {
    fn bytes(&mut self, n: u64, what: &str) -> Result<Vec<u8>, String> {
        let mut v = vec![0u8; n as usize];
        self.r.read_exact(&mut v).map_err(|e| format!("cannot read {what} at byte {}: {e}", self.pos))?;
        self.pos += n;
        Ok(v)
    }

    fn length(&mut self, what: &str) -> Result<u64, String> {
        if self.len - self.pos < 4 {
            return Err(format!(
                "record {what} length cut off: {} of 4 bytes before the end of the {} (truncated)",
                self.len - self.pos,
                self.scope
            ));
        }
        let b = self.bytes(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as u64)
    }

    /// The next record (its header fields checked), or `None` at the end.
    fn next(&mut self) -> Result<Option<Owned>, String> {
        if self.pos >= self.len {
            return Ok(None);
        }
        let header_len = self.length("header")?;
        if header_len > MAX_HEADER {
            return Err(format!(
                "record header of {header_len} bytes is more than a record header holds ({MAX_HEADER}): the length is damaged"
            ));
        }
        if header_len > self.len - self.pos {
            return Err(format!(
                "record header of {header_len} bytes runs past the end of the {}, {} bytes left (truncated)",
                self.scope,
                self.len - self.pos
            ));
        }
        let header = self.bytes(header_len, "a record header")?;
        let op = Header(parse_fields(&header).map_err(|e| format!("record header damaged: {e}"))?).op();
        let data_len = self.length("data")?;
        if data_len > self.len - self.pos {
            return Err(format!(
                "record data of {data_len} bytes runs past the end of the {}, {} bytes left (truncated)",
                self.scope,
                self.len - self.pos
            ));
        }
        let data_at = self.pos;
        let Some(op) = op else { return Err("record header has no one-byte `op` field".into()) };
        let data = match op {
            OP_CHUNK | OP_CONNECTION | OP_MSG_DATA if data_len > MAX_CHUNK_UNCOMPRESSED => {
                return Err(format!("record data of {data_len} bytes is more than this reader holds at once ({MAX_CHUNK_UNCOMPRESSED})"));
            }
            OP_CHUNK | OP_CONNECTION | OP_MSG_DATA => self.bytes(data_len, "a record's data")?,
            _ => {
                self.r.seek(SeekFrom::Current(data_len as i64)).map_err(|e| format!("cannot skip a record's data: {e}"))?;
                self.pos += data_len;
                Vec::new()
            }
        };
        Ok(Some(Owned { op, header, data, data_at }))
    }
}

fn read_records(file: &Path, top: &mut Records<impl Read + Seek>, walk: &mut Walk, out: &mut BagContents) {
    let damage = |offset: u64, reason: String| ReplayError::Bag { file: file.to_path_buf(), offset, reason };
    let chunk_damage = |offset: u64, reason: String| ReplayError::BagChunk { file: file.to_path_buf(), offset, reason };
    let magic = top.bytes(ROS1_BAG_MAGIC.len().min(top.len as usize) as u64, "the first line").unwrap_or_default();
    if magic != ROS1_BAG_MAGIC {
        let mut head = magic;
        head.extend(top.bytes(8.min(top.len - top.pos), "the first line").unwrap_or_default());
        let version = head.strip_prefix(b"#ROSBAG V").map(|v| {
            let line = v.split(|&c| c == b'\n').next().unwrap_or_default();
            String::from_utf8_lossy(&line[..line.len().min(8)]).into_owned()
        });
        let reason = match version {
            Some(v) => format!("ROS bag format {v}; replay reads format 2.0 (convert an older bag with `rosbag fix`)"),
            None => "no `#ROSBAG V2.0` line at the start".into(),
        };
        out.error = Some(damage(0, reason));
        return;
    }
    loop {
        let pos = top.pos;
        let owned = match top.next() {
            Ok(Some(r)) => r,
            Ok(None) => return,
            Err(reason) => {
                out.error = Some(damage(pos, reason));
                return;
            }
        };
        let op = owned.op;
        if op == OP_CHUNK {
            let header = owned.header();
            let chunk = header
                .text_field("compression")
                .and_then(|c| {
                    let codec = match c.as_str() {
                        "none" => Codec::None,
                        "bz2" => Codec::Bz2,
                        "lz4" => Codec::Lz4,
                        other => return Err(format!("unknown chunk compression {other:?} (ROS 1 bags know none, bz2 and lz4)")),
                    };
                    Ok((codec, header.u32_field("size")?))
                })
                .and_then(|(codec, size)| decompress_bounded(codec, size as u64, &owned.data, owned.data_at as usize, top.len as usize));
            match chunk {
                Ok(records) => {
                    if let Err((k, why)) = walk_chunk(&records, walk, out, Location::Offset(pos)) {
                        let reason = format!(
                            "damaged chunk, the rest of it skipped: its record at byte {k} of its {} uncompressed bytes: {why}",
                            records.len()
                        );
                        out.bad.add(chunk_damage(pos, reason));
                    }
                }
                // The chunk's own lengths are intact: skip it, read on after it.
                Err(reason) => out.bad.add(chunk_damage(pos, format!("damaged chunk, skipped: {reason}"))),
            }
        } else if let Err(reason) = take(owned, walk, out, Location::Offset(pos)) {
            // Its lengths are intact: skip it, read on after it.
            out.bad.add(damage(pos, format!("{} record skipped: {reason}", op_name(op))));
        }
    }
}
