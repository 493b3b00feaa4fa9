//! MCAP files: the record walk, bounded chunk decompression and the messages of the ROS 2 topics read.

use super::*;
use crate::io::replay::{Location, ReplayError};
use std::collections::HashMap;
use std::path::Path;

/// The MCAP magic, at both ends of the file.
pub const MCAP_MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
pub(super) const OP_FOOTER: u8 = 0x02;

pub(super) fn op_name(op: u8) -> &'static str {
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
pub(super) fn fixed_fields(op: u8) -> Option<(usize, &'static str)> {
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
pub(super) fn reserved(op: u8) -> bool {
    op == 0x00 || (0x10..0x80).contains(&op)
}

/// Why the `mcap` crate could not parse an `op` record of `len` bytes, in the file's terms: what
/// its length should have been at least, or the parser's own words.
pub(super) fn unparsable(op: u8, len: usize, e: &mcap::McapError) -> String {
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
pub(super) fn read_here(op: u8) -> bool {
    matches!(op, 0x01 | 0x03..=0x06)
}

/// Walks the records of a chunk (`records`, uncompressed), handing each that parses to `take`.
/// On the first that does not (its framing or its fields), returns its offset in `records` and
/// why; the records after it are lost (their framing is).
pub(super) fn walk_records<'a>(records: &'a [u8], mut take: impl FnMut(mcap::records::Record<'a>)) -> Result<(), (usize, String)> {
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

/// The uncompressed records of a chunk whose data (`data`, at byte `data_at` of a file of
/// `file_len` bytes) is compressed as `header` says, decompressed with a bound on the output
/// ([`decompress_bounded`]), checked against the chunk's CRC (when it has one).
pub(super) fn chunk_records<'a>(
    header: &mcap::records::ChunkHeader,
    data: &'a [u8],
    data_at: usize,
    file_len: usize,
) -> Result<std::borrow::Cow<'a, [u8]>, String> {
    let codec = match header.compression.as_str() {
        "" => Codec::None,
        "zstd" => Codec::Zstd,
        "lz4" => Codec::Lz4,
        other => return Err(format!("unknown chunk compression {other:?} (MCAP knows zstd and lz4)")),
    };
    let records = decompress_bounded(codec, header.uncompressed_size, data, data_at, file_len)?;
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
pub(super) type Channels = HashMap<u16, (String, String, String)>;

/// Reads an MCAP file held in `buf`. Walks the top-level records itself (so damage is located to
/// the byte), lets the `mcap` crate parse each record and decompress chunks (zstd, lz4).
pub fn read_mcap(file: &Path, buf: &[u8]) -> BagContents {
    let mut out = BagContents::default();
    let damage = |offset: usize, reason: String| ReplayError::Bag { file: file.to_path_buf(), offset: offset as u64, reason };
    let chunk_damage = |offset: usize, reason: String| ReplayError::BagChunk { file: file.to_path_buf(), offset: offset as u64, reason };
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

pub(super) fn take_record(
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
                if Wire::of_encoding(&c.message_encoding).is_none() {
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
                if let (Some(kind), Some(wire)) = (MsgType::of(type_name, topic), Wire::of_encoding(enc)) {
                    let t_ns = header.log_time;
                    out.keep(BagMessage { t_ns, topic: topic.clone(), kind, wire, data: data.into_owned(), at });
                }
            }
        }
        _ => {}
    }
}
