//! Classic pcap files → UDP datagrams with their byte offsets in the file.
//!
//! Owns the pcap framing (through the `pcap-file` crate) and the link/IP/UDP headers (through
//! `etherparse`); knows nothing about what the datagrams carry. [`PcapStream`] reads any
//! `io::Read` through a window of a few hundred kilobytes (a capture of hours never sits in memory)
//! and gives every record, payload and error its byte offset in the file. A record cut by the end
//! of the file, or with a length no capture could have written, ends the stream with an error
//! naming the file and the record's offset; everything before it has been delivered.

use etherparse::{LaxSlicedPacket, LinuxSllProtocolType, LinuxSllSlice, TransportSlice};
use pcap_file::pcap::PcapParser;
use pcap_file::{DataLink, Endianness, PcapError};
use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// Why a pcap file could not be read (the VLP-16 reader reports each as the
/// [`super::vlp16::CaptureError`] of the same name, which says it in words).
#[derive(Debug)]
#[non_exhaustive]
pub enum CaptureError {
    /// Reading the file.
    Io { path: PathBuf, source: io::Error },
    /// The file is shorter than a pcap file header (24 bytes).
    PcapHeaderTruncated { path: PathBuf, len: u64 },
    /// The file does not start with a pcap magic number.
    NotPcap { path: PathBuf, magic: u32 },
    /// A pcap-ng file (only classic pcap is read).
    PcapNg { path: PathBuf },
    /// The link type is none of Ethernet (1), raw IP (101, 228, 229), Linux cooked (113).
    LinkType { path: PathBuf, link_type: u32 },
    /// The file ends inside a record: its header or data is cut.
    TruncatedRecord { path: PathBuf, offset: u64, needed: u64, available: u64 },
    /// A record header that cannot be right (length above the snapshot length, bad timestamp).
    CorruptRecord { path: PathBuf, offset: u64, reason: String },
}

impl std::fmt::Display for CaptureError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Self::PcapHeaderTruncated { path, len } => {
                write!(f, "{}: {len} bytes, shorter than a pcap file header (24 bytes)", path.display())
            }
            Self::NotPcap { path, magic } => write!(f, "{}: byte 0: magic 0x{magic:08X} is not a pcap file", path.display()),
            Self::PcapNg { path } => {
                write!(f, "{}: byte 0: a pcap-ng file; save it as classic pcap (e.g. `editcap -F pcap`)", path.display())
            }
            Self::LinkType { path, link_type } => {
                write!(f, "{}: byte 20: link type {link_type} is none of Ethernet, raw IP, Linux cooked", path.display())
            }
            Self::TruncatedRecord { path, offset, needed, available } => {
                write!(f, "{}: byte {offset}: truncated pcap record ({needed} bytes needed, {available} left in the file)", path.display())
            }
            Self::CorruptRecord { path, offset, reason } => {
                write!(f, "{}: byte {offset}: corrupt pcap record header: {reason}", path.display())
            }
        }
    }
}

impl std::error::Error for CaptureError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// Length of the classic pcap file header.
pub const FILE_HEADER_LEN: usize = 24;
/// Length of a record header.
pub const RECORD_HEADER_LEN: usize = 16;
/// Largest record a capture may hold whatever its header's snapshot length says (tcpdump's limit).
pub const MAX_RECORD_LEN: u32 = 262_144;
/// Bytes read from the file at a time.
const CHUNK: usize = 256 * 1024;

const MAGICS: [[u8; 4]; 4] = [[0xD4, 0xC3, 0xB2, 0xA1], [0xA1, 0xB2, 0xC3, 0xD4], [0x4D, 0x3C, 0xB2, 0xA1], [0xA1, 0xB2, 0x3C, 0x4D]];
const PCAPNG_MAGIC: [u8; 4] = [0x0A, 0x0D, 0x0D, 0x0A];

/// Whether `bytes` start like a pcap or pcap-ng file.
pub fn looks_like_pcap(bytes: &[u8]) -> bool {
    bytes.len() >= 4 && (MAGICS.iter().any(|m| bytes[..4] == m[..]) || bytes[..4] == PCAPNG_MAGIC)
}

/// What a record holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Frame<'a> {
    /// A UDP datagram (over IPv4 or IPv6), with its payload's offset in the file.
    Udp { dst_port: u16, payload: &'a [u8], payload_offset: u64 },
    /// Anything else that parses (ARP, TCP, a fragment, …).
    Other,
    /// Headers that do not parse.
    Bad(String),
}

/// One record and the byte offset of its header in the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record<'a> {
    pub offset: u64,
    pub frame: Frame<'a>,
}

#[derive(Debug, Clone, Copy)]
enum Link {
    Ethernet,
    Ip,
    LinuxSll,
}

/// The records of a pcap file, read from `R` a chunk at a time.
pub struct PcapStream<R: Read> {
    path: PathBuf,
    reader: R,
    parser: PcapParser,
    link: Link,
    /// A window on the file: `buf[0]` is file byte `base`; `buf[pos..]` is not yet consumed.
    buf: Vec<u8>,
    pos: usize,
    base: u64,
    eof: bool,
    done: bool,
}

impl<R: Read> PcapStream<R> {
    /// Reads and checks the file header; `path` names the file in errors.
    pub fn new(path: &Path, mut reader: R) -> Result<Self, CaptureError> {
        let path_buf = path.to_path_buf();
        let mut head = [0u8; FILE_HEADER_LEN];
        let got = read_full(&mut reader, &mut head).map_err(|source| CaptureError::Io { path: path_buf.clone(), source })?;
        let head = &head[..got];
        if head.len() >= 4 && head[..4] == PCAPNG_MAGIC {
            return Err(CaptureError::PcapNg { path: path_buf });
        }
        if head.len() >= 4 && !MAGICS.iter().any(|m| head[..4] == m[..]) {
            return Err(CaptureError::NotPcap { path: path_buf, magic: u32::from_be_bytes([head[0], head[1], head[2], head[3]]) });
        }
        let (_, parser) = match PcapParser::new(head) {
            Ok(x) => x,
            Err(PcapError::IncompleteBuffer) => return Err(CaptureError::PcapHeaderTruncated { path: path_buf, len: head.len() as u64 }),
            Err(e) => return Err(CaptureError::CorruptRecord { path: path_buf, offset: 0, reason: e.to_string() }),
        };
        let link = match parser.header().datalink {
            DataLink::ETHERNET => Link::Ethernet,
            DataLink::RAW | DataLink::IPV4 | DataLink::IPV6 => Link::Ip,
            DataLink::LINUX_SLL => Link::LinuxSll,
            other => return Err(CaptureError::LinkType { path: path_buf, link_type: u32::from(other) }),
        };
        Ok(Self { path: path_buf, reader, parser, link, buf: Vec::new(), pos: 0, base: FILE_HEADER_LEN as u64, eof: false, done: false })
    }

    fn u32_at(&self, at: usize) -> u32 {
        let b = [self.buf[at], self.buf[at + 1], self.buf[at + 2], self.buf[at + 3]];
        match self.parser.header().endianness {
            Endianness::Big => u32::from_be_bytes(b),
            Endianness::Little => u32::from_le_bytes(b),
        }
    }

    /// Drops the consumed bytes and reads the next chunk (sets `eof` at the end of the file).
    fn fill(&mut self) -> io::Result<()> {
        if self.pos > 0 {
            self.buf.drain(..self.pos);
            self.base += self.pos as u64;
            self.pos = 0;
        }
        let old = self.buf.len();
        self.buf.resize(old + CHUNK, 0);
        let got = read_full(&mut self.reader, &mut self.buf[old..]);
        let n = *got.as_ref().unwrap_or(&0);
        self.buf.truncate(old + n);
        self.eof = n < CHUNK;
        got.map(|_| ())
    }

    fn fail(&mut self, e: CaptureError) -> Option<Result<Record<'_>, CaptureError>> {
        self.done = true;
        Some(Err(e))
    }

    /// The next record; `None` at the end of the file or after an error.
    pub fn next_record(&mut self) -> Option<Result<Record<'_>, CaptureError>> {
        if self.done {
            return None;
        }
        let snaplen = self.parser.header().snaplen.max(MAX_RECORD_LEN);
        loop {
            let rest = self.buf.len() - self.pos;
            if rest == 0 && self.eof {
                self.done = true;
                return None;
            }
            let offset = self.base + self.pos as u64;
            // Lengths first, so that a garbage length is called corrupt rather than truncated.
            let incl = (rest >= RECORD_HEADER_LEN).then(|| self.u32_at(self.pos + 8));
            if let Some(incl) = incl.filter(|&n| n > snaplen) {
                let reason = format!("captured length {incl} is above the snapshot length {snaplen}");
                return self.fail(CaptureError::CorruptRecord { path: self.path.clone(), offset, reason });
            }
            match self.parser.next_raw_packet(&self.buf[self.pos..]) {
                Ok((_, raw)) => {
                    let (incl, orig) = (raw.incl_len, raw.orig_len);
                    let start = self.pos + RECORD_HEADER_LEN;
                    self.pos = start + incl as usize;
                    if incl > orig {
                        // Valid framing, impossible contents: skipped (counted as bad headers).
                        let why = format!("captured length {incl} above the original length {orig}");
                        return Some(Ok(Record { offset, frame: Frame::Bad(why) }));
                    }
                    let frame = frame(self.link, &self.buf[start..self.pos], offset + RECORD_HEADER_LEN as u64);
                    return Some(Ok(Record { offset, frame }));
                }
                Err(PcapError::IncompleteBuffer) if !self.eof => {
                    if let Err(source) = self.fill() {
                        return self.fail(CaptureError::Io { path: self.path.clone(), source });
                    }
                }
                Err(PcapError::IncompleteBuffer) => {
                    let needed = RECORD_HEADER_LEN as u64 + incl.unwrap_or(0) as u64;
                    let (path, available) = (self.path.clone(), rest as u64);
                    return self.fail(CaptureError::TruncatedRecord { path, offset, needed, available });
                }
                Err(e) => {
                    let path = self.path.clone();
                    return self.fail(CaptureError::CorruptRecord { path, offset, reason: e.to_string() });
                }
            }
        }
    }
}

/// Reads until `buf` is full or the end of the input; returns the bytes read.
pub(crate) fn read_full<R: Read>(r: &mut R, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// The headers of one record's `data` (at file offset `data_offset`), parsed leniently: real
/// captures carry wrong IPv4 total lengths (the VLP-16 capture's position packets claim 1234 bytes
/// and carry 540), so the captured bytes bound each layer.
fn frame(link: Link, data: &[u8], data_offset: u64) -> Frame<'_> {
    let sliced = match link {
        Link::Ethernet => LaxSlicedPacket::from_ethernet(data).map_err(|e| e.to_string()),
        Link::Ip => LaxSlicedPacket::from_ip(data).map_err(|e| e.to_string()),
        Link::LinuxSll => match LinuxSllSlice::from_slice(data) {
            Ok(sll) => match sll.protocol_type() {
                LinuxSllProtocolType::EtherType(t) => Ok(LaxSlicedPacket::from_ether_type(t, sll.payload_slice())),
                _ => return Frame::Other,
            },
            Err(e) => Err(e.to_string()),
        },
    };
    match sliced {
        Ok(LaxSlicedPacket { transport: Some(TransportSlice::Udp(udp)), .. }) => {
            let payload = udp.payload();
            let payload_offset = data_offset + (payload.as_ptr() as usize - data.as_ptr() as usize) as u64;
            Frame::Udp { dst_port: udp.destination_port(), payload, payload_offset }
        }
        Ok(LaxSlicedPacket { stop_err: Some((e, _)), .. }) => Frame::Bad(e.to_string()),
        Ok(_) => Frame::Other,
        Err(e) => Frame::Bad(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A little-endian pcap with one Ethernet/IPv4/UDP record (4-byte payload `DE AD BE EF` from
    /// port 1234 to 2368), built byte by byte; `records` copies of the record.
    fn capture(records: usize) -> Vec<u8> {
        let mut f = vec![0xD4, 0xC3, 0xB2, 0xA1, 2, 0, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF, 0, 0, 1, 0, 0, 0];
        let frame: Vec<u8> = [
            &[0u8; 12][..],                                                                       // MACs
            &[0x08, 0x00],                                                                        // IPv4
            &[0x45, 0, 0, 32, 0, 0, 0x40, 0, 64, 17, 0, 0, 192, 168, 1, 201, 255, 255, 255, 255], // IPv4 header, 32 bytes total
            &[0x04, 0xD2, 0x09, 0x40, 0, 12, 0, 0],                                               // UDP 1234 → 2368, length 12
            &[0xDE, 0xAD, 0xBE, 0xEF],
        ]
        .concat();
        let n = frame.len() as u32;
        for _ in 0..records {
            f.extend_from_slice(&[1, 0, 0, 0, 2, 0, 0, 0]);
            f.extend_from_slice(&n.to_le_bytes());
            f.extend_from_slice(&n.to_le_bytes());
            f.extend_from_slice(&frame);
        }
        f
    }

    /// A record with its frame copied out of the stream's window.
    #[derive(Debug, PartialEq)]
    enum Owned {
        Udp(u16, Vec<u8>, u64),
        Other,
        Bad(String),
    }

    type Recs = Vec<Result<(u64, Owned), CaptureError>>;

    fn records(path: &str, bytes: &[u8]) -> Result<Recs, CaptureError> {
        let mut s = PcapStream::new(Path::new(path), bytes)?;
        let mut v = Vec::new();
        while let Some(r) = s.next_record() {
            v.push(r.map(|r| {
                let f = match r.frame {
                    Frame::Udp { dst_port, payload, payload_offset } => Owned::Udp(dst_port, payload.to_vec(), payload_offset),
                    Frame::Other => Owned::Other,
                    Frame::Bad(m) => Owned::Bad(m),
                };
                (r.offset, f)
            }));
        }
        Ok(v)
    }

    #[test]
    fn yields_the_udp_payload_and_its_offset() {
        let recs = records("a.pcap", &capture(1)).unwrap();
        // 24 (file header) + 16 (record header) + 14 + 20 + 8 = 82.
        assert_eq!(recs.len(), 1);
        assert_eq!(recs[0].as_ref().unwrap(), &(24, Owned::Udp(2368, vec![0xDE, 0xAD, 0xBE, 0xEF], 82)));
    }

    #[test]
    fn records_across_read_chunks_keep_their_offsets() {
        // 20 000 records of 62 bytes (1.24 MB): several 256 KiB chunks, records straddling them.
        let f = capture(20_000);
        let recs = records("many.pcap", &f).unwrap();
        assert_eq!(recs.len(), 20_000);
        for (i, r) in recs.iter().enumerate() {
            let off = 24 + 62 * i as u64;
            assert_eq!(r.as_ref().unwrap(), &(off, Owned::Udp(2368, vec![0xDE, 0xAD, 0xBE, 0xEF], off + 58)));
        }
    }

    #[test]
    fn truncation_and_garbage_lengths_are_errors_with_offsets() {
        let f = capture(1);
        let recs = records("a.pcap", &f[..f.len() - 1]).unwrap();
        assert_eq!(recs.len(), 1);
        match &recs[0] {
            Err(CaptureError::TruncatedRecord { offset: 24, needed: 62, available: 61, .. }) => {}
            other => panic!("{other:?}"),
        }
        let mut g = capture(2);
        g[24 + 62 + 8..24 + 62 + 12].copy_from_slice(&0xFFFF_FF00u32.to_le_bytes());
        let recs = records("g.pcap", &g).unwrap();
        assert_eq!(recs.len(), 2);
        assert!(recs[0].is_ok());
        let e = recs[1].as_ref().unwrap_err();
        assert!(matches!(e, CaptureError::CorruptRecord { offset: 86, .. }), "{e:?}");
        assert!(e.to_string().starts_with("g.pcap: byte 86: corrupt pcap record header"), "{e}");
        // Fewer than 16 bytes of record header.
        let recs = records("h.pcap", &f[..24 + 10]).unwrap();
        assert!(matches!(recs[0], Err(CaptureError::TruncatedRecord { offset: 24, needed: 16, available: 10, .. })), "{recs:?}");
        assert!(matches!(records("h.pcap", &f[..20]), Err(CaptureError::PcapHeaderTruncated { len: 20, .. })));
        // Captured length above the original: framing holds, the record is skipped as bad.
        let mut k = capture(1);
        k[24 + 12..24 + 16].copy_from_slice(&40u32.to_le_bytes());
        assert!(matches!(records("k.pcap", &k).unwrap()[0], Ok((24, Owned::Bad(_)))));
    }

    #[test]
    fn file_kinds() {
        assert!(matches!(records("x", &[0xFF, 0xEE, 0, 0, 0]), Err(CaptureError::NotPcap { magic: 0xFFEE0000, .. })));
        assert!(matches!(records("x", &[0x0A, 0x0D, 0x0D, 0x0A, 0]), Err(CaptureError::PcapNg { .. })));
        let mut f = capture(1);
        f[20] = 147; // a user link type
        assert!(matches!(records("x", &f), Err(CaptureError::LinkType { link_type: 147, .. })));
        assert!(looks_like_pcap(&capture(0)));
        assert!(!looks_like_pcap(&[0xFF, 0xEE, 0x00, 0x01]));
        // IPv4 carrying an unassigned protocol (0x99) instead of UDP is other traffic.
        let mut a = capture(1);
        a[24 + 16 + 14 + 9] = 0x99;
        assert_eq!(records("ip.pcap", &a).unwrap()[0].as_ref().unwrap(), &(24, Owned::Other));
        // An Ethernet frame too short for its header is bad.
        let mut b = capture(0);
        b.extend_from_slice(&[1, 0, 0, 0, 2, 0, 0, 0, 6, 0, 0, 0, 6, 0, 0, 0, 1, 2, 3, 4, 5, 6]);
        assert!(matches!(records("short.pcap", &b).unwrap()[0], Ok((24, Owned::Bad(_)))));
    }
}
