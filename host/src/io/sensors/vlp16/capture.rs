//! Captures: pcap files and raw payload streams, decoded into scans with every rejected packet counted.

use super::*;
use std::fmt;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// Every way reading VLP-16 data can fail. File errors name the file and the byte offset.
#[derive(Debug)]
#[non_exhaustive]
pub enum Vlp16Error {
    /// The configuration cannot work.
    Config(ConfigError),
    /// Opening or reading a file, or the socket.
    Io { path: Option<PathBuf>, source: io::Error },
    /// The pcap file could not be read ([`crate::io::sensors::pcap::CaptureError`]).
    Capture(crate::io::sensors::pcap::CaptureError),
    /// A raw payload file ends inside a packet.
    TruncatedPayload { path: PathBuf, offset: u64, len: u64 },
    /// The file has no bytes.
    Empty { path: PathBuf },
    /// Not a pcap file, and no offset of it frames a VLP-16 data packet ([`frames_packet`]).
    NoPacket { path: PathBuf },
}

impl fmt::Display for Vlp16Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Config(e) => write!(f, "VLP-16 configuration: {e}"),
            Self::Io { path: Some(p), source } => write!(f, "{}: {source}", p.display()),
            Self::Io { path: None, source } => write!(f, "VLP-16 socket: {source}"),
            Self::Capture(e) => e.fmt(f),
            Self::TruncatedPayload { path, offset, len } => {
                write!(f, "{}: byte {offset}: the file ends {len} bytes into a {PACKET_LEN}-byte packet", path.display())
            }
            Self::Empty { path } => write!(f, "{} is not a VLP-16 capture: the file is empty", path.display()),
            Self::NoPacket { path } => {
                write!(f, "{} is not a VLP-16 capture: no packet found (neither pcap nor raw {PACKET_LEN}-byte payloads)", path.display())
            }
        }
    }
}

impl std::error::Error for Vlp16Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Config(e) => Some(e),
            Self::Io { source, .. } => Some(source),
            Self::Capture(e) => e.source(),
            _ => None,
        }
    }
}

impl From<crate::io::sensors::pcap::CaptureError> for Vlp16Error {
    fn from(e: crate::io::sensors::pcap::CaptureError) -> Self {
        Self::Capture(e)
    }
}

impl From<ConfigError> for Vlp16Error {
    fn from(e: ConfigError) -> Self {
        Self::Config(e)
    }
}

/// Why a captured datagram was not used as a data packet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RejectReason {
    /// Ethernet/IP/UDP headers that do not parse (the message of `etherparse`).
    Headers(String),
    /// A datagram on the data port that is not a valid data packet.
    Packet(PacketError),
}

impl fmt::Display for RejectReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Headers(e) => write!(f, "headers: {e}"),
            Self::Packet(e) => write!(f, "{e}"),
        }
    }
}

/// A rejected datagram and where it is: the byte offset of its payload in the file (of the pcap
/// record for `Headers`), or the index of the datagram on a socket.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rejected {
    pub offset: u64,
    pub reason: RejectReason,
}

/// How many datagrams were seen, by fate.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PacketCounts {
    /// Valid data packets, all decoded into scans.
    pub data: u64,
    /// Datagrams on the data port (or records) that failed a check: counted and skipped.
    pub rejected: u64,
    /// Other traffic: position packets (port 8308), other ports, non-UDP frames.
    pub other: u64,
}

/// At most this many rejected datagrams (and skipped runs of bytes) are kept with their offsets
/// (all are counted).
pub const MAX_REJECTS_KEPT: usize = 100;

/// A run of bytes of a raw payload file that frames no packet, skipped to the next offset that
/// does ([`frames_packet`]): bytes inserted or lost, or a stretch of garbage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Skipped {
    /// Byte offset in the file of the first byte skipped.
    pub offset: u64,
    /// Bytes skipped.
    pub len: u64,
}

/// Scans decoded from a capture (pcap or raw payloads), with what was skipped and, if the file is
/// damaged, the error that ended the read: everything before the damage is still here.
#[derive(Debug)]
pub struct PcapScans {
    /// The file read.
    pub path: PathBuf,
    /// Rotations ended by an azimuth wrap, in order (the first is partial when the capture
    /// started mid-rotation: its unseen beams are `NaN`). Empty from the `stream_*` readers,
    /// which hand each scan to their callback instead.
    pub scans: Vec<PlanarScan>,
    /// The rotation still open when the file (or the good part of it) ended.
    pub partial: Option<PlanarScan>,
    /// Datagrams by fate.
    pub counts: PacketCounts,
    /// The first [`MAX_REJECTS_KEPT`] rejected datagrams.
    pub rejects: Vec<Rejected>,
    /// Bytes of a raw payload file skipped to resynchronise on the next packet (0 for pcap).
    pub skipped_bytes: u64,
    /// The first [`MAX_REJECTS_KEPT`] runs of skipped bytes (all are in `skipped_bytes`).
    pub skips: Vec<Skipped>,
    /// The damage that ended the read early (truncated or corrupt record), if any.
    pub error: Option<Vlp16Error>,
    /// Channels (0–15) of the lasers used.
    pub lasers: Vec<usize>,
}

/// Feeds payloads to an assembler and keeps the counts (shared by the file readers and UDP).
#[derive(Debug)]
pub(crate) struct Decoder {
    pub asm: ScanAssembler,
    pub counts: PacketCounts,
    pub rejects: Vec<Rejected>,
    pub skipped_bytes: u64,
    pub skips: Vec<Skipped>,
}

impl Decoder {
    pub fn new(cfg: Vlp16Config) -> Result<Self, ConfigError> {
        Ok(Self {
            asm: ScanAssembler::new(cfg)?,
            counts: PacketCounts::default(),
            rejects: Vec::new(),
            skipped_bytes: 0,
            skips: Vec::new(),
        })
    }

    /// `len` bytes at `offset` that frame no packet.
    pub fn skip(&mut self, offset: u64, len: u64) {
        self.skipped_bytes += len;
        if self.skips.len() < MAX_REJECTS_KEPT {
            self.skips.push(Skipped { offset, len });
        }
    }

    pub fn reject(&mut self, offset: u64, reason: RejectReason) {
        self.counts.rejected += 1;
        if self.rejects.len() < MAX_REJECTS_KEPT {
            self.rejects.push(Rejected { offset, reason });
        }
    }

    /// One data-port payload at `offset`.
    pub fn payload(&mut self, offset: u64, bytes: &[u8]) -> Option<PlanarScan> {
        match Vlp16Packet::new_checked(bytes) {
            Ok(p) => {
                self.counts.data += 1;
                self.asm.push(&p)
            }
            Err(e) => {
                self.reject(offset, RejectReason::Packet(e));
                None
            }
        }
    }

    /// The counts and the open rotation; `scans` is left empty for the caller to fill.
    pub fn into_scans(mut self, path: &Path, error: Option<Vlp16Error>) -> PcapScans {
        let partial = self.asm.finish();
        PcapScans {
            path: path.to_path_buf(),
            scans: Vec::new(),
            partial,
            counts: self.counts,
            rejects: self.rejects,
            skipped_bytes: self.skipped_bytes,
            skips: self.skips,
            error,
            lasers: self.asm.lasers(),
        }
    }
}

/// Classic pcap: UDP datagrams to [`DATA_PORT`] are decoded, other traffic (position packets on
/// 8308, anything else) is counted and ignored, invalid data packets are counted and skipped. A
/// truncated or corrupt record ends the read: the error is returned in `Ok` and the scans before it
/// are kept. `Err` only when nothing could be read (not a pcap, unusable header).
fn decode_pcap<R: Read>(path: &Path, reader: R, dec: &mut Decoder, on_scan: OnScan) -> Result<Option<Vlp16Error>, Vlp16Error> {
    use crate::io::sensors::pcap::{Frame, PcapStream, Record};
    let mut stream = PcapStream::new(path, reader)?;
    while let Some(rec) = stream.next_record() {
        match rec {
            Ok(Record { offset, frame }) => match frame {
                Frame::Udp { dst_port: DATA_PORT, payload, payload_offset } => {
                    if let Some(scan) = dec.payload(payload_offset, payload) {
                        on_scan(scan);
                    }
                }
                Frame::Udp { .. } | Frame::Other => dec.counts.other += 1,
                Frame::Bad(msg) => dec.reject(offset, RejectReason::Headers(msg)),
            },
            Err(e) => return Ok(Some(Vlp16Error::from(e))),
        }
    }
    Ok(None)
}

/// Raw 1206-byte payloads back to back (no framing, e.g. `einride_vlp16_recording.bin`). A packet
/// whose framing is right ([`frames_packet`]) is decoded, or counted and skipped when a later check
/// fails (an azimuth). After a packet whose framing is wrong the reader resynchronises: it goes on
/// at the next offset where a packet's framing is right. If that is exactly one packet on (or the
/// end of the file, after an earlier packet), the stream is still in step and the packet is counted
/// as rejected; otherwise the bytes up to it (inserted, lost or garbage) are counted in
/// `skipped_bytes` and `skips`, and reading goes on. A file that ends inside a packet ends the read
/// with the error returned in `Ok` (the scans before it are kept). `Err` when the file cannot be
/// read, is empty, or frames no packet at any offset ([`Vlp16Error::NoPacket`]).
fn decode_raw<R: Read>(path: &Path, reader: R, dec: &mut Decoder, on_scan: OnScan) -> Result<Option<Vlp16Error>, Vlp16Error> {
    let mut w = RawWindow::new(reader);
    // Whether any offset framed a packet (a whole one or one cut by the end of the file).
    let mut framed = false;
    let mut packet = [0u8; PACKET_LEN];
    let error = loop {
        let offset = w.offset();
        if let Err(source) = w.ensure(PACKET_LEN) {
            break Some(Vlp16Error::Io { path: Some(path.to_path_buf()), source });
        }
        let avail = w.rest();
        if avail.is_empty() {
            break None;
        }
        if frames_packet(avail) {
            framed = true;
            if avail.len() < PACKET_LEN {
                break Some(Vlp16Error::TruncatedPayload { path: path.to_path_buf(), offset, len: avail.len() as u64 });
            }
            if let Some(scan) = dec.payload(offset, &avail[..PACKET_LEN]) {
                on_scan(scan);
            }
            w.consume(PACKET_LEN);
            continue;
        }
        // Framing lost: find the next offset that frames a packet (or the end of the file).
        let whole = avail.len() >= PACKET_LEN;
        if whole {
            packet.copy_from_slice(&avail[..PACKET_LEN]);
        }
        w.consume(1);
        let mut skipped = 1u64;
        let found = loop {
            if let Err(source) = w.ensure(PACKET_LEN) {
                break Err(source);
            }
            let avail = w.rest();
            if let Some(i) = next_packet_start(avail, w.eof) {
                w.consume(i);
                skipped += i as u64;
                break Ok(true);
            }
            // Nothing here frames a packet: keep only the bytes a later start could still need.
            let n = if w.eof { avail.len() } else { avail.len() + 1 - PACKET_LEN };
            w.consume(n);
            skipped += n as u64;
            if w.eof && w.rest().is_empty() {
                break Ok(false);
            }
        };
        let found = match found {
            Ok(f) => f,
            Err(source) => {
                dec.skip(offset, skipped);
                break Some(Vlp16Error::Io { path: Some(path.to_path_buf()), source });
            }
        };
        if whole && skipped == PACKET_LEN as u64 && (found || framed) {
            // Still in step: one damaged packet (its check names what is wrong).
            if let Some(scan) = dec.payload(offset, &packet) {
                on_scan(scan);
            }
        } else {
            dec.skip(offset, skipped);
        }
    };
    if error.is_none() && !framed {
        return Err(if w.offset() == 0 {
            Vlp16Error::Empty { path: path.to_path_buf() }
        } else {
            Vlp16Error::NoPacket { path: path.to_path_buf() }
        });
    }
    Ok(error)
}

/// The first `i` from which `window` frames a packet ([`frames_packet`]). Before the end of the
/// file only offsets with a whole packet after them are tried; at the end (`eof`), also the start
/// of a packet cut by it.
pub(super) fn next_packet_start(window: &[u8], eof: bool) -> Option<usize> {
    let last = if eof { window.len().checked_sub(BLOCK_FLAG.len())? } else { window.len().checked_sub(PACKET_LEN)? };
    (0..=last).find(|&i| window[i..i + 2] == BLOCK_FLAG && frames_packet(&window[i..]))
}

/// A window on a raw payload file: `buf[0]` is file byte `base`; `buf[pos..end]` is read and not
/// yet consumed. The buffer is allocated once (zeroing a fresh chunk per read, at the host's
/// opt-level, cost more than decoding).
pub(super) struct RawWindow<R: Read> {
    reader: R,
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    base: u64,
    /// The reader is exhausted: `buf[pos..end]` is the rest of the file.
    eof: bool,
}

impl<R: Read> RawWindow<R> {
    fn new(reader: R) -> Self {
        Self { reader, buf: vec![0; RAW_CHUNK], pos: 0, end: 0, base: 0, eof: false }
    }

    /// Offset in the file of the next unconsumed byte.
    fn offset(&self) -> u64 {
        self.base + self.pos as u64
    }

    /// Reads on until at least `n` (at most a packet) bytes are unconsumed, or to the end of the file.
    fn ensure(&mut self, n: usize) -> io::Result<()> {
        while self.end - self.pos < n && !self.eof {
            self.buf.copy_within(self.pos..self.end, 0);
            self.base += self.pos as u64;
            self.end -= self.pos;
            self.pos = 0;
            let want = self.buf.len() - self.end;
            let got = crate::io::sensors::pcap::read_full(&mut self.reader, &mut self.buf[self.end..]);
            let got_n = *got.as_ref().unwrap_or(&0);
            self.end += got_n;
            self.eof = got_n < want;
            got?;
        }
        Ok(())
    }

    /// The unconsumed bytes.
    fn rest(&self) -> &[u8] {
        &self.buf[self.pos..self.end]
    }

    fn consume(&mut self, n: usize) {
        self.pos += n;
    }
}

/// Bytes read from a raw payload file at a time.
pub(super) const RAW_CHUNK: usize = 256 * 1024;

/// Reads a pcap capture, or a raw payload file when the file does not start with a pcap (or
/// pcap-ng) magic number.
pub fn read_capture(path: &Path, cfg: &Vlp16Config) -> Result<(CaptureFormat, PcapScans), Vlp16Error> {
    let mut format = CaptureFormat::Raw;
    let r = collect(|on_scan| {
        let (f, r) = stream_capture(path, cfg, on_scan)?;
        format = f;
        Ok(r)
    })?;
    Ok((format, r))
}

/// [`read_capture`] without keeping the scans (see [`CaptureFormat::stream`]).
pub fn stream_capture(
    path: &Path,
    cfg: &Vlp16Config,
    on_scan: &mut dyn FnMut(PlanarScan),
) -> Result<(CaptureFormat, PcapScans), Vlp16Error> {
    let mut file = open(path)?;
    let mut magic = [0u8; 4];
    let n = crate::io::sensors::pcap::read_full(&mut file, &mut magic)
        .map_err(|source| Vlp16Error::Io { path: Some(path.to_path_buf()), source })?;
    let reader = io::Read::chain(&magic[..n], file);
    let format = if crate::io::sensors::pcap::looks_like_pcap(&magic[..n]) { CaptureFormat::Pcap } else { CaptureFormat::Raw };
    Ok((format, format.stream(path, reader, cfg, on_scan)?))
}

pub(super) fn open(path: &Path) -> Result<std::fs::File, Vlp16Error> {
    std::fs::File::open(path).map_err(|source| Vlp16Error::Io { path: Some(path.to_path_buf()), source })
}

/// Runs a streaming reader and keeps its scans.
pub(super) fn collect(run: impl FnOnce(&mut dyn FnMut(PlanarScan)) -> Result<PcapScans, Vlp16Error>) -> Result<PcapScans, Vlp16Error> {
    let mut scans = Vec::new();
    let mut r = run(&mut |s| scans.push(s))?;
    r.scans = scans;
    Ok(r)
}

/// The two capture formats, and the readers of each. [`read_capture`] picks one by the file's magic
/// number and says which it used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaptureFormat {
    /// Classic pcap (either byte order, µs or ns timestamps; Ethernet, raw IP or Linux cooked).
    Pcap,
    /// Raw 1206-byte payloads back to back.
    Raw,
}

/// Where a streaming reader hands each scan as soon as it is complete.
type OnScan<'a> = &'a mut dyn FnMut(PlanarScan);

impl CaptureFormat {
    /// Reads the file `path` in this format, a chunk at a time, and keeps the scans, with every
    /// rejected packet and skipped byte counted (see [`Self::stream`] for what ends a read).
    pub fn read(self, path: &Path, cfg: &Vlp16Config) -> Result<PcapScans, Vlp16Error> {
        collect(|on_scan| self.stream(path, open(path)?, cfg, on_scan))
    }

    /// [`Self::read`] on bytes already in memory (`path` names them in errors).
    pub fn decode_bytes(self, path: &Path, bytes: &[u8], cfg: &Vlp16Config) -> Result<PcapScans, Vlp16Error> {
        collect(|on_scan| self.stream(path, bytes, cfg, on_scan))
    }

    /// [`Self::read`] without keeping the scans: each completed scan goes to `on_scan` as soon as
    /// it is complete, and the returned `scans` is empty. Reads `reader` a chunk at a time.
    /// Damage (a truncated or corrupt pcap record, a raw file ending inside a packet) ends the read
    /// with `error` set and the scans before it kept. `Err` only when nothing could be read: not a
    /// pcap or an unusable pcap header; a raw file that is empty or frames no packet at any offset
    /// ([`Vlp16Error::NoPacket`]).
    pub fn stream<R: Read>(self, path: &Path, reader: R, cfg: &Vlp16Config, on_scan: OnScan) -> Result<PcapScans, Vlp16Error> {
        let mut dec = Decoder::new(*cfg)?;
        let error = match self {
            Self::Pcap => decode_pcap(path, reader, &mut dec, on_scan)?,
            Self::Raw => decode_raw(path, reader, &mut dec, on_scan)?,
        };
        Ok(dec.into_scans(path, error))
    }
}
