//! Golden traces: a recorded host → core byte stream, replayed through the core anywhere.
//!
//! A trace is what a host wrote to the controller's serial line during a run (`lives trace
//! record`, in lockstep: `Hello`, configuration, then per tick a batch of pose, scan, base status
//! and detection frames closed by a heartbeat), cut into the records the host wrote, each with
//! the simulated time of its last heartbeat. [`Trace::replay`] feeds the records one by one to a
//! lockstep [`Node`] and reports, per record, a CRC-32C of every byte the node sent back: the
//! digests of two replays are equal exactly when the cores answered byte for byte the same.
//!
//! ## Format (all integers little-endian)
//!
//! | bytes | field |
//! |---|---|
//! | 8 | magic `LIVESTRC` |
//! | 4 | version ([`VERSION`]) |
//! | 4 | flags ([`FLAG_EMBEDDED_MODEL`]: the run used the classifier, install the embedded model) |
//! | 4 | record count |
//! | per record: 8 | `t_us`: time of the last heartbeat written so far (0 before the first) |
//! | 4 | length `n` (1 ..= [`MAX_RECORD`]) |
//! | `n` | the bytes, as written to the line |

use crate::classifier::{ModelError, EMBEDDED_MODEL};
use crate::controller::Controller;
use crate::node::{Node, TimeMode};

/// The digest: CRC-32C (Castagnoli). Not the frames' own CRC-32 (ISO-HDLC): every frame ends in
/// that CRC of its body, and a CRC over a message followed by its own CRC is the same constant for
/// every message of a given length, so it would not see the content.
pub const DIGEST: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// The first 8 bytes of a trace.
pub const MAGIC: [u8; 8] = *b"LIVESTRC";
/// The format version this code reads and writes.
pub const VERSION: u32 = 1;
/// Flag: install [`EMBEDDED_MODEL`] before the replay (the recorded scans carry no labels).
pub const FLAG_EMBEDDED_MODEL: u32 = 1;
/// Longest record (bytes).
pub const MAX_RECORD: usize = 1 << 16;
/// Bytes before the first record.
pub const HEADER_LEN: usize = 20;
/// Bytes before each record's payload.
pub const RECORD_HEADER_LEN: usize = 12;

/// Why a trace cannot be replayed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceError {
    /// Shorter than its header.
    TooShort,
    /// Not a trace (wrong magic).
    BadMagic,
    /// Written by another version of this format.
    Version(u32),
    /// Flags this code does not know.
    UnknownFlags(u32),
    /// Record `index` is cut off, empty or longer than [`MAX_RECORD`].
    BadRecord {
        /// Which record.
        index: u32,
    },
    /// Bytes after the last record.
    TrailingBytes,
    /// A record's time is earlier than the one before it.
    TimeGoesBack {
        /// Which record.
        index: u32,
    },
    /// The embedded model the trace asks for does not validate.
    Model(ModelError),
    /// The node is not in lockstep (a trace's ticks are its heartbeats).
    NotLockstep,
}

impl core::fmt::Display for TraceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            TraceError::TooShort => write!(f, "not a trace: shorter than the {HEADER_LEN}-byte header"),
            TraceError::BadMagic => write!(f, "not a trace: the file does not start with `LIVESTRC`"),
            TraceError::Version(v) => write!(f, "trace format version {v}, this build reads version {VERSION}"),
            TraceError::UnknownFlags(x) => write!(f, "trace flags {x:#x} unknown to this build"),
            TraceError::BadRecord { index } => write!(f, "trace record {index} is cut off, empty or longer than {MAX_RECORD} bytes"),
            TraceError::TrailingBytes => write!(f, "bytes after the last trace record"),
            TraceError::TimeGoesBack { index } => write!(f, "trace record {index} is older than the record before it"),
            TraceError::Model(e) => write!(f, "the embedded model does not validate: {e:?}"),
            TraceError::NotLockstep => write!(f, "a trace is replayed by a lockstep node"),
        }
    }
}

/// One record: what the host wrote in one go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record<'a> {
    /// Time of the last heartbeat written so far (µs).
    pub t_us: u64,
    /// The bytes.
    pub bytes: &'a [u8],
}

/// What the node answered to one record.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Digest {
    /// The record's index.
    pub record: u32,
    /// The record's time.
    pub t_us: u64,
    /// Controller ticks the record caused (0 or 1).
    pub ticks: u32,
    /// Bytes the node sent.
    pub len: u32,
    /// [`DIGEST`] (CRC-32C) of those bytes, in order.
    pub crc: u32,
}

/// A validated trace (borrowed bytes).
#[derive(Clone, Copy, Debug)]
pub struct Trace<'a> {
    flags: u32,
    records: u32,
    body: &'a [u8],
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

impl<'a> Trace<'a> {
    /// Checks the header and every record.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, TraceError> {
        match Self::parse_prefix(bytes)? {
            (trace, None) => Ok(trace),
            (_, Some(e)) => Err(e),
        }
    }

    /// Checks the header, then the records as far as they are good: the trace of the good
    /// records before the first bad one (cut off, empty, too long, older than the one before),
    /// and that record's error (or [`TraceError::TrailingBytes`] after a good last record). A
    /// bad header is an error: nothing can be read.
    pub fn parse_prefix(bytes: &'a [u8]) -> Result<(Self, Option<TraceError>), TraceError> {
        if bytes.len() < HEADER_LEN {
            return Err(TraceError::TooShort);
        }
        if bytes[..8] != MAGIC {
            return Err(TraceError::BadMagic);
        }
        let version = u32_at(bytes, 8).ok_or(TraceError::TooShort)?;
        if version != VERSION {
            return Err(TraceError::Version(version));
        }
        let flags = u32_at(bytes, 12).ok_or(TraceError::TooShort)?;
        if flags & !FLAG_EMBEDDED_MODEL != 0 {
            return Err(TraceError::UnknownFlags(flags));
        }
        let records = u32_at(bytes, 16).ok_or(TraceError::TooShort)?;
        let body = &bytes[HEADER_LEN..];
        let mut trace = Trace { flags, records, body };
        let mut at = 0;
        let mut last_t = 0;
        for index in 0..records {
            let bad = match trace.record_at(at) {
                None => Some(TraceError::BadRecord { index }),
                Some((r, _)) if r.t_us < last_t => Some(TraceError::TimeGoesBack { index }),
                Some((r, next)) => {
                    last_t = r.t_us;
                    at = next;
                    None
                }
            };
            if bad.is_some() {
                return Ok((Trace { flags, records: index, body: &body[..at] }, bad));
            }
        }
        if at != body.len() {
            trace.body = &body[..at];
            return Ok((trace, Some(TraceError::TrailingBytes)));
        }
        Ok((trace, None))
    }

    fn record_at(&self, at: usize) -> Option<(Record<'a>, usize)> {
        let t_us = u64_at(self.body, at)?;
        let n = u32_at(self.body, at + 8)? as usize;
        if n == 0 || n > MAX_RECORD {
            return None;
        }
        let start = at + RECORD_HEADER_LEN;
        let bytes = self.body.get(start..start + n)?;
        Some((Record { t_us, bytes }, start + n))
    }

    /// The flags.
    pub fn flags(&self) -> u32 {
        self.flags
    }

    /// Number of records.
    pub fn len(&self) -> u32 {
        self.records
    }

    /// True if there is no record.
    pub fn is_empty(&self) -> bool {
        self.records == 0
    }

    /// The records, in order.
    pub fn records(&self) -> impl Iterator<Item = Record<'a>> + '_ {
        let mut at = 0;
        (0..self.records).map_while(move |_| {
            let (r, next) = self.record_at(at)?;
            at = next;
            Some(r)
        })
    }

    /// Replays the trace through `node` (lockstep, fresh) and `ctl` (fresh; the embedded model is
    /// installed first if the trace asks for it), calling `each` with every record's digest.
    /// Returns the ticks run.
    pub fn replay(&self, node: &mut Node, ctl: &mut Controller, each: impl FnMut(&Digest)) -> Result<u32, TraceError> {
        self.replay_observed(node, ctl, &mut (), each)
    }

    /// [`Trace::replay`], telling `obs` where each stage of every tick begins and ends (the
    /// MCU's trace image passes [`super::hook::Hooked`] to time them).
    pub fn replay_observed(
        &self,
        node: &mut Node,
        ctl: &mut Controller,
        obs: &mut impl crate::controller::StageObserver,
        mut each: impl FnMut(&Digest),
    ) -> Result<u32, TraceError> {
        if node.config().time_mode != TimeMode::Lockstep {
            return Err(TraceError::NotLockstep);
        }
        if self.flags & FLAG_EMBEDDED_MODEL != 0 {
            ctl.set_model(EMBEDDED_MODEL).map_err(TraceError::Model)?;
        }
        let mut total = 0;
        for (i, r) in self.records().enumerate() {
            let mut crc = DIGEST.digest();
            let mut len = 0u32;
            let ticks = node.receive_observed(
                r.bytes,
                ctl,
                |f| {
                    crc.update(f);
                    len = len.wrapping_add(f.len() as u32);
                },
                obs,
            );
            total += ticks;
            each(&Digest { record: i as u32, t_us: r.t_us, ticks, len, crc: crc.finalize() });
        }
        Ok(total)
    }
}

/// Appends the header of a trace with `records` records to `out` (for writers; see the format).
pub fn write_header(flags: u32, records: u32, mut out: impl FnMut(&[u8])) {
    out(&MAGIC);
    out(&VERSION.to_le_bytes());
    out(&flags.to_le_bytes());
    out(&records.to_le_bytes());
}

/// Appends one record (1 ..= [`MAX_RECORD`] bytes; longer ones must be split by the writer).
pub fn write_record(t_us: u64, bytes: &[u8], mut out: impl FnMut(&[u8])) {
    out(&t_us.to_le_bytes());
    out(&(bytes.len() as u32).to_le_bytes());
    out(bytes);
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::config::Config;
    use crate::node::NodeConfig;
    use crate::protocol::{encode, Heartbeat, Hello, HostToCore, Role, MAX_FRAME_LEN};
    use std::boxed::Box;
    use std::string::ToString;
    use std::vec;
    use std::vec::Vec;

    fn trace_of(flags: u32, records: &[(u64, Vec<u8>)]) -> Vec<u8> {
        let mut out = Vec::new();
        write_header(flags, records.len() as u32, |b| out.extend_from_slice(b));
        for (t, r) in records {
            write_record(*t, r, |b| out.extend_from_slice(b));
        }
        out
    }

    fn frame(m: &HostToCore) -> Vec<u8> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        encode(m, &mut buf).unwrap().to_vec()
    }

    #[test]
    fn a_trace_round_trips_and_bad_ones_are_refused_with_a_reason() {
        let good = trace_of(0, &[(0, vec![1, 2, 3]), (200_000, vec![4])]);
        let t = Trace::parse(&good).unwrap();
        assert_eq!(t.len(), 2);
        let recs: Vec<_> = t.records().collect();
        assert_eq!(recs, [Record { t_us: 0, bytes: &[1, 2, 3] }, Record { t_us: 200_000, bytes: &[4] }]);

        assert_eq!(Trace::parse(&good[..10]).err(), Some(TraceError::TooShort));
        let mut bad = good.clone();
        bad[0] = b'X';
        assert_eq!(Trace::parse(&bad).err(), Some(TraceError::BadMagic));
        let mut bad = good.clone();
        bad[8] = 9;
        assert_eq!(Trace::parse(&bad).err(), Some(TraceError::Version(9)));
        let mut bad = good.clone();
        bad[12] = 6;
        assert_eq!(Trace::parse(&bad).err(), Some(TraceError::UnknownFlags(6)));
        assert_eq!(Trace::parse(&good[..good.len() - 1]).err(), Some(TraceError::BadRecord { index: 1 }));
        let mut bad = good.clone();
        bad.push(0);
        assert_eq!(Trace::parse(&bad).err(), Some(TraceError::TrailingBytes));
        let back = trace_of(0, &[(5, vec![1]), (4, vec![1])]);
        assert_eq!(Trace::parse(&back).err(), Some(TraceError::TimeGoesBack { index: 1 }));
        let empty_record = trace_of(0, &[(0, vec![])]);
        assert_eq!(Trace::parse(&empty_record).err(), Some(TraceError::BadRecord { index: 0 }));

        // The good records before a bad one still read.
        let (t, e) = Trace::parse_prefix(&good[..good.len() - 1]).unwrap();
        assert_eq!((t.len(), e), (1, Some(TraceError::BadRecord { index: 1 })));
        assert_eq!(t.records().collect::<Vec<_>>(), [Record { t_us: 0, bytes: &[1, 2, 3] }]);
        let (t, e) = Trace::parse_prefix(&back).unwrap();
        assert_eq!((t.len(), e), (1, Some(TraceError::TimeGoesBack { index: 1 })));
        let mut trailing = good.clone();
        trailing.push(0);
        let (t, e) = Trace::parse_prefix(&trailing).unwrap();
        assert_eq!((t.len(), t.records().count(), e), (2, 2, Some(TraceError::TrailingBytes)));
        assert_eq!(Trace::parse_prefix(&good[..10]).err(), Some(TraceError::TooShort));
        assert!(TraceError::BadMagic.to_string().contains("LIVESTRC"));
    }

    #[test]
    fn replay_digests_what_the_node_sends() {
        let mut hello = frame(&HostToCore::Hello(Hello::new(Role::Simulator, false)));
        hello.extend(frame(&HostToCore::Heartbeat(Heartbeat { t_us: 0, seq: 7 })));
        let bytes = trace_of(0, &[(0, hello)]);
        let t = Trace::parse(&bytes).unwrap();
        let mut ctl = Box::new(Controller::new(Config::DEFAULT));
        let mut node = Node::new(NodeConfig::new(TimeMode::Lockstep));
        let mut seen = Vec::new();
        assert_eq!(t.replay(&mut node, &mut ctl, |d| seen.push(*d)), Ok(0));
        assert_eq!(seen.len(), 1);
        // A HelloAck and the heartbeat's echo.
        let mut sent = Vec::new();
        let mut node2 = Node::new(NodeConfig::new(TimeMode::Lockstep));
        let mut ctl2 = Box::new(Controller::new(Config::DEFAULT));
        node2.receive(t.records().next().unwrap().bytes, &mut ctl2, |f| sent.extend_from_slice(f));
        assert_eq!(seen[0].len as usize, sent.len());
        assert_eq!(seen[0].crc, DIGEST.checksum(&sent));
        assert!(sent.iter().filter(|&&b| b == 0).count() == 2);

        let mut rt = Node::new(NodeConfig::new(TimeMode::RealTime));
        assert_eq!(t.replay(&mut rt, &mut ctl, |_| {}).err(), Some(TraceError::NotLockstep));
    }
}
