//! Framing: message → postcard bytes → CRC-32 appended → COBS → `0x00`.
//!
//! ```text
//! frame = COBS( postcard(message) ‖ CRC-32/ISO-HDLC(postcard(message)) as 4 bytes little-endian ) ‖ 0x00
//! ```
//!
//! [`encode`] writes one frame into a caller's buffer (postcard's COBS and CRC flavors, in one
//! pass, no scratch buffer). [`Decoder`] takes bytes as they arrive, keeps at most `N` bytes of
//! the current frame, and at each `0x00` delimiter undoes COBS in place, checks the CRC, and
//! decodes the message. Every frame that fails is dropped and counted in [`LinkCounters`] under
//! its cause; the next byte after a delimiter starts a new frame, so any damage costs at most the
//! frames it touches. An empty frame (two delimiters in a row) is idle fill: skipped, not counted.
//!
//! Nothing here allocates or panics, whatever the input.

use crate::protocol::message::{CoreToHost, HostToCore, LinkCounters, MAX_CORE_TO_HOST_LEN, MAX_HOST_TO_CORE_LEN};
use core::marker::PhantomData;
use postcard::ser_flavors::crc::CrcModifier;
use postcard::ser_flavors::{Cobs, Slice};
use serde::de::DeserializeOwned;
use serde::Serialize;

/// The frame check: CRC-32/ISO-HDLC (the CRC of Ethernet, zlib and PNG: polynomial 0x04C11DB7,
/// reflected, init and xor-out 0xFFFFFFFF; check value of `"123456789"` is 0xCBF43926).
pub const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
/// Bytes of the CRC in a frame.
pub const CRC_LEN: usize = 4;
/// The frame delimiter.
pub const DELIMITER: u8 = 0x00;

/// Largest COBS encoding of `n` bytes: one code byte per started run of 254 bytes, plus one.
pub const fn cobs_max_len(n: usize) -> usize {
    n + n / 254 + 1
}

/// Largest frame (delimiter included) carrying a message of at most `message_len` postcard bytes.
pub const fn frame_len_for(message_len: usize) -> usize {
    cobs_max_len(message_len + CRC_LEN) + 1
}

/// Largest host-to-core frame, delimiter included (a full [`MAX_WIRE_BEAMS`] scan with labels):
/// 3351 bytes.
///
/// [`MAX_WIRE_BEAMS`]: crate::protocol::message::MAX_WIRE_BEAMS
pub const MAX_HOST_TO_CORE_FRAME: usize = frame_len_for(MAX_HOST_TO_CORE_LEN);
/// Largest core-to-host frame, delimiter included (the labels of a whole beam grid): 919 bytes.
pub const MAX_CORE_TO_HOST_FRAME: usize = frame_len_for(MAX_CORE_TO_HOST_LEN);
/// Largest frame in either direction, delimiter included: size an encode buffer with this.
pub const MAX_FRAME_LEN: usize =
    if MAX_HOST_TO_CORE_FRAME > MAX_CORE_TO_HOST_FRAME { MAX_HOST_TO_CORE_FRAME } else { MAX_CORE_TO_HOST_FRAME };

/// The core's decoder: host-to-core messages, a buffer of one largest frame (delimiter excluded).
pub type CoreDecoder = Decoder<HostToCore, { MAX_HOST_TO_CORE_FRAME - 1 }>;
/// The host's decoder: core-to-host messages, a buffer of one largest frame (delimiter excluded).
pub type HostDecoder = Decoder<CoreToHost, { MAX_CORE_TO_HOST_FRAME - 1 }>;

/// Why a frame was not sent or not received.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum FrameError {
    /// Encoding: the output buffer is too small for the frame (use [`MAX_FRAME_LEN`]).
    BufferTooSmall,
    /// Encoding: the message could not be serialised (a sequence without a known length).
    Serialize,
    /// Decoding: the bytes between two delimiters are not valid COBS.
    Cobs,
    /// Decoding: the CRC does not match (or the frame is too short to hold one).
    Crc,
    /// Decoding: the CRC matched but the bytes are not a message of this direction (an unknown
    /// tag, a value out of range, a sequence over capacity, bytes left over).
    Decode,
    /// Decoding: the frame was longer than the decoder's buffer; dropped up to the next
    /// delimiter.
    Overflow,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::BufferTooSmall => "frame buffer too small",
            Self::Serialize => "message could not be serialised",
            Self::Cobs => "invalid COBS encoding",
            Self::Crc => "CRC mismatch",
            Self::Decode => "not a valid message",
            Self::Overflow => "frame longer than the receive buffer",
        })
    }
}

/// Writes `msg` as one frame (delimiter included) at the start of `buf`; returns the frame.
pub fn encode<'b, M: Serialize + ?Sized>(msg: &M, buf: &'b mut [u8]) -> Result<&'b [u8], FrameError> {
    let cobs = Cobs::try_new(Slice::new(buf)).map_err(|_| FrameError::BufferTooSmall)?;
    let flavor = CrcModifier::new(cobs, CRC.digest());
    match postcard::serialize_with_flavor(msg, flavor) {
        Ok(frame) => Ok(frame),
        Err(postcard::Error::SerializeBufferFull) => Err(FrameError::BufferTooSmall),
        Err(_) => Err(FrameError::Serialize),
    }
}

/// Decodes the bytes of one frame (without its delimiter) in place. Used by [`Decoder`].
pub fn decode_in_place<M: DeserializeOwned>(frame: &mut [u8]) -> Result<M, FrameError> {
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let data = frame.get(..n).ok_or(FrameError::Cobs)?;
    let (payload, crc) = data.split_last_chunk::<CRC_LEN>().ok_or(FrameError::Crc)?;
    if payload.is_empty() || CRC.checksum(payload) != u32::from_le_bytes(*crc) {
        return Err(FrameError::Crc);
    }
    match postcard::take_from_bytes::<M>(payload) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(FrameError::Decode),
    }
}

/// A streaming frame decoder for messages `M`, holding at most `N` bytes of a frame.
///
/// Feed it bytes as they arrive ([`Decoder::push`] or [`Decoder::feed`]); each delimiter ends a
/// frame and yields its message or the reason it was dropped. Size: `N` plus a few words — keep it
/// in a `static` or inside the node that owns it.
pub struct Decoder<M, const N: usize> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
    counters: LinkCounters,
    _msg: PhantomData<fn() -> M>,
}

impl<M: DeserializeOwned, const N: usize> Decoder<M, N> {
    /// An empty decoder (`const`, so it can live in a `static`).
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflowed: false,
            counters: LinkCounters { frames_ok: 0, crc_errors: 0, cobs_errors: 0, decode_errors: 0, overflows: 0, ignored: 0 },
            _msg: PhantomData,
        }
    }

    /// Takes one byte. Returns `Some` when the byte is a delimiter that ends a non-empty frame:
    /// the message, or why the frame was dropped (already counted).
    pub fn push(&mut self, byte: u8) -> Option<Result<M, FrameError>> {
        if byte != DELIMITER {
            if self.overflowed {
                // Dropping the rest of an over-long frame.
            } else if self.len < N {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return None;
        }
        let result = if self.overflowed {
            Err(FrameError::Overflow)
        } else if self.len == 0 {
            return None;
        } else {
            decode_in_place::<M>(&mut self.buf[..self.len])
        };
        self.len = 0;
        self.overflowed = false;
        self.counters.count(result.as_ref().err().copied());
        Some(result)
    }

    /// Takes a run of bytes; the iterator yields one item per frame they complete. Drain it:
    /// bytes not yet consumed when it is dropped are not taken.
    pub fn feed<'d, 'b>(&'d mut self, bytes: &'b [u8]) -> Feed<'d, 'b, M, N> {
        Feed { decoder: self, bytes: bytes.iter() }
    }

    /// The receive counters.
    pub const fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// Drops a partial frame (after a link reset); the counters stay.
    pub fn clear(&mut self) {
        self.len = 0;
        self.overflowed = false;
    }

    /// Bytes of the current, unfinished frame.
    pub const fn pending(&self) -> usize {
        self.len
    }

    /// The buffer capacity `N`: the longest frame (delimiter excluded) this decoder takes.
    pub const fn capacity(&self) -> usize {
        N
    }
}

impl<M: DeserializeOwned, const N: usize> Default for Decoder<M, N> {
    fn default() -> Self {
        Self::new()
    }
}

/// The frames completed by a run of bytes (see [`Decoder::feed`]).
pub struct Feed<'d, 'b, M, const N: usize> {
    decoder: &'d mut Decoder<M, N>,
    bytes: core::slice::Iter<'b, u8>,
}

impl<M: DeserializeOwned, const N: usize> Iterator for Feed<'_, '_, M, N> {
    type Item = Result<M, FrameError>;

    fn next(&mut self) -> Option<Self::Item> {
        for &b in self.bytes.by_ref() {
            if let Some(r) = self.decoder.push(b) {
                return Some(r);
            }
        }
        None
    }
}

// The sizes stated in the docs (and docs/protocol.md), checked at compile time.
const _: () = assert!(MAX_HOST_TO_CORE_FRAME == 3351);
const _: () = assert!(MAX_CORE_TO_HOST_FRAME == 919);
const _: () = assert!(MAX_FRAME_LEN <= u16::MAX as usize);

/// The receive side's counting (the counters themselves are a message's: [`StatusMsg::link`]).
///
/// [`StatusMsg::link`]: crate::protocol::StatusMsg::link
impl LinkCounters {
    /// Counts one frame: decoded (`None`) or dropped for `error`.
    fn count(&mut self, error: Option<FrameError>) {
        let c = match error {
            None => &mut self.frames_ok,
            Some(FrameError::Crc) => &mut self.crc_errors,
            Some(FrameError::Cobs) => &mut self.cobs_errors,
            Some(FrameError::Overflow) => &mut self.overflows,
            Some(_) => &mut self.decode_errors,
        };
        *c = c.wrapping_add(1);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::protocol::message::*;
    use crate::scan::BeamLabel;
    use fixed_point::BinaryAngle;

    use crate::protocol::fuzz::Rng;

    fn pose_msg() -> HostToCore {
        HostToCore::Pose(PoseMsg { t_us: 1_500_000, x: 98_304, y: -147_456, theta: 1 << 30 })
    }

    fn heartbeat_msg(seq: u32) -> HostToCore {
        HostToCore::Heartbeat(Heartbeat { t_us: 1_000_000 + seq as u64, seq })
    }

    fn frame_of<M: Serialize>(m: &M) -> heapless::Vec<u8, MAX_FRAME_LEN> {
        let mut buf = [0u8; MAX_FRAME_LEN];
        heapless::Vec::from_slice(encode(m, &mut buf).unwrap()).unwrap()
    }

    /// A frame around arbitrary payload bytes (a valid CRC and COBS, whatever the payload).
    fn raw_frame(payload: &[u8]) -> heapless::Vec<u8, { MAX_FRAME_LEN + 64 }> {
        let mut data: heapless::Vec<u8, { MAX_FRAME_LEN + 64 }> = heapless::Vec::from_slice(payload).unwrap();
        data.extend_from_slice(&CRC.checksum(payload).to_le_bytes()).unwrap();
        let mut out = [0u8; MAX_FRAME_LEN + 64];
        let n = cobs::encode(&data, &mut out);
        out[n] = 0;
        heapless::Vec::from_slice(&out[..n + 1]).unwrap()
    }

    fn full_scan(labels: bool) -> ScanMsg {
        let mut s = ScanMsg {
            t_us: u64::MAX,
            angle_min: i32::MIN,
            angle_increment: i32::MIN,
            range_min_mm: u16::MAX,
            range_max_mm: u16::MAX,
            ..Default::default()
        };
        s.ranges_mm.extend_from_slice(&[u16::MAX; MAX_WIRE_BEAMS]).unwrap();
        if labels {
            s.labels = Some(heapless::Vec::from_slice(&[BeamLabel::NonMap; MAX_WIRE_BEAMS]).unwrap());
        }
        s
    }

    #[test]
    fn the_crc_is_crc32_iso_hdlc() {
        assert_eq!(CRC.checksum(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn a_full_1100_beam_scan_with_labels_fits_one_frame() {
        let msg = HostToCore::Scan(full_scan(true));
        let mut buf = [0u8; MAX_FRAME_LEN];
        assert_eq!(postcard::to_slice(&msg, &mut buf).unwrap().len(), MAX_HOST_TO_CORE_LEN, "the worst case is exact");
        let frame = encode(&msg, &mut buf).unwrap();
        assert!(frame.len() <= MAX_HOST_TO_CORE_FRAME && MAX_HOST_TO_CORE_FRAME == 3351, "{}", frame.len());
        let mut dec = CoreDecoder::new();
        let got: std::vec::Vec<_> = dec.feed(frame).collect();
        assert_eq!(got, std::vec![Ok(msg)]);
    }

    #[test]
    fn the_largest_core_messages_fit_their_frames() {
        let mut goal = GoalMsg { seq: u32::MAX, x: i32::MIN, y: i32::MIN, theta: i32::MIN, utility: i64::MIN, ..Default::default() };
        goal.path.extend_from_slice(&[(i32::MIN, i32::MIN); MAX_WIRE_WAYPOINTS]).unwrap();
        goal.path_length_m = i32::MIN;
        let labels = LabelsMsg { t_us: u64::MAX, labels: heapless::Vec::from_slice(&[BeamLabel::NonMap; MAX_WIRE_LABELS]).unwrap() };
        let link = LinkCounters {
            frames_ok: u32::MAX,
            crc_errors: u32::MAX,
            cobs_errors: u32::MAX,
            decode_errors: u32::MAX,
            overflows: u32::MAX,
            ignored: u32::MAX,
        };
        let status = StatusMsg {
            t_us: u64::MAX,
            mode: WireMode::Stopped,
            ticks: u32::MAX,
            scans: u32::MAX,
            scans_rejected: u32::MAX,
            poses_rejected: u32::MAX,
            last_scan_error: Some(WireScanError::LabelCountMismatch { ranges: u32::MAX, labels: u32::MAX }),
            plans: u32::MAX,
            goals: u32::MAX,
            blacklisted: u32::MAX,
            retired: u32::MAX,
            watchdog_trips: u32::MAX,
            cost: StageCostMsg { classify: u32::MAX, lidar: u32::MAX, visual: u32::MAX, nonmap: u32::MAX, plan: u32::MAX, gaze: u32::MAX },
            overruns: [u32::MAX; 5],
            heap_overflows: u32::MAX,
            link,
            gaze: Some(i32::MIN),
            search_entropy_bits: u32::MAX,
        };
        let mut buf = [0u8; MAX_FRAME_LEN];
        let goal = CoreToHost::Goal(goal);
        let labels = CoreToHost::Labels(labels);
        let status = CoreToHost::Status(status);
        assert_eq!(postcard::to_slice(&goal, &mut buf).unwrap().len(), MAX_GOAL_LEN);
        assert_eq!(postcard::to_slice(&labels, &mut buf).unwrap().len(), MAX_LABELS_LEN);
        assert!(postcard::to_slice(&status, &mut buf).unwrap().len() <= 200);
        let config = HostToCore::Config(ConfigMsg {
            replan_interval_us: u64::MAX,
            goal_timeout_us: u64::MAX,
            blocked_timeout_us: u64::MAX,
            watchdog_us: u64::MAX,
            ..ConfigMsg::from_config(&crate::Config::DEFAULT)
        });
        assert!(postcard::to_slice(&config, &mut buf).unwrap().len() < 200);
        for m in [goal, labels, status] {
            let frame = encode(&m, &mut buf).unwrap();
            assert!(frame.len() <= MAX_CORE_TO_HOST_FRAME);
            let mut dec = HostDecoder::new();
            assert_eq!(dec.feed(frame).collect::<std::vec::Vec<_>>(), std::vec![Ok(m)]);
        }
    }

    #[test]
    fn a_scan_over_the_wire_limit_is_refused_by_sender_and_receiver() {
        let ranges = [1000u16; MAX_WIRE_BEAMS + 1];
        let input = crate::ScanInput {
            angle_min: BinaryAngle::ZERO,
            angle_increment: BinaryAngle(1 << 20),
            ranges_mm: &ranges,
            labels: None,
            range_min_mm: 0,
            range_max_mm: crate::scan::RANGE_LIMIT_MM,
        };
        assert_eq!(ScanMsg::from_scan_input(0, &input).unwrap_err(), WireError::TooManyBeams(MAX_WIRE_BEAMS + 1));
        // A hand-made frame claiming 1101 ranges (valid CRC): dropped as undecodable, counted.
        let mut payload: heapless::Vec<u8, 4096> = heapless::Vec::new();
        payload.extend_from_slice(&[3, 0, 0, 0, 0xcd, 0x08]).unwrap(); // tag, t_us, angles, varint 1101
        payload.extend_from_slice(&[0x10; 2 * (MAX_WIRE_BEAMS + 1)]).unwrap();
        payload.push(0).unwrap(); // labels: None
        let mut dec = CoreDecoder::new();
        assert_eq!(dec.feed(&raw_frame(&payload)).collect::<std::vec::Vec<_>>(), std::vec![Err(FrameError::Decode)]);
        assert_eq!(dec.counters().decode_errors, 1);
    }

    #[test]
    fn every_single_bit_flip_is_rejected_counted_and_followed_by_resync() {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let mut scan = ScanMsg { t_us: 7, angle_min: -5, angle_increment: 1 << 22, ..Default::default() };
        scan.ranges_mm.extend_from_slice(&[0, 1, 255, 256, 65_535, 12_000, 0, 0]).unwrap();
        let good = heartbeat_msg(9);
        let good_frame = frame_of(&good);
        let (mut flips, mut bits) = (0, 0);
        for msg in [pose_msg(), HostToCore::Scan(scan), HostToCore::Hello(Hello::new(Role::Robot, false))] {
            let frame = encode(&msg, &mut buf).unwrap();
            bits += frame.len() * 8;
            for i in 0..frame.len() * 8 {
                let mut bad: heapless::Vec<u8, 256> = heapless::Vec::from_slice(frame).unwrap();
                bad[i / 8] ^= 1 << (i % 8);
                // The damaged frame, a delimiter (in case the flip ate the frame's own), a good frame.
                let mut dec = CoreDecoder::new();
                let mut results: std::vec::Vec<_> = dec.feed(&bad).collect();
                results.extend(dec.feed(&[0]));
                assert!(!results.is_empty() && results.iter().all(|r| r.is_err()), "flip {i}: {results:?}");
                let c = dec.counters();
                assert_eq!(c.frames_ok, 0);
                assert_eq!(c.dropped() as usize, results.len());
                let after: std::vec::Vec<_> = dec.feed(&good_frame).collect();
                assert_eq!(after, std::vec![Ok(good.clone())], "flip {i}: no resync");
                flips += 1;
            }
        }
        assert_eq!(flips, bits);
        assert!(bits > 400);
    }

    #[test]
    fn dropped_bytes_cost_only_the_frames_they_touch() {
        let a = pose_msg();
        let b = heartbeat_msg(1);
        let c = heartbeat_msg(2);
        let (fa, fb, fc) = (frame_of(&a), frame_of(&b), frame_of(&c));
        for i in 0..fa.len() {
            let mut stream: std::vec::Vec<u8> = std::vec::Vec::new();
            stream.extend(fa.iter().enumerate().filter(|&(j, _)| j != i).map(|(_, &x)| x));
            stream.extend_from_slice(&fb);
            stream.extend_from_slice(&fc);
            let mut dec = CoreDecoder::new();
            let out: std::vec::Vec<_> = dec.feed(&stream).collect();
            let oks: std::vec::Vec<_> = out.iter().filter_map(|r| r.as_ref().ok()).cloned().collect();
            if i == fa.len() - 1 {
                // The delimiter was dropped: A and B merge into one bad frame.
                assert_eq!(oks, std::vec![c.clone()], "byte {i}");
            } else {
                assert_eq!(oks, std::vec![b.clone(), c.clone()], "byte {i}");
            }
            assert_eq!(dec.counters().dropped(), 1, "byte {i}");
        }
    }

    #[test]
    fn truncated_frames_and_garbage_between_frames_resynchronise() {
        let a = pose_msg();
        let b = heartbeat_msg(1);
        let (fa, fb) = (frame_of(&a), frame_of(&b));
        let mut stream: std::vec::Vec<u8> = std::vec::Vec::new();
        stream.extend_from_slice(&[0x42, 0x17, 0x99]); // line noise before the first delimiter
        stream.push(0);
        stream.extend_from_slice(&fa[..fa.len() / 2]); // a frame cut short by a reset …
        stream.push(0); // … then the sender's delimiter
        stream.extend_from_slice(&fb);
        stream.extend_from_slice(&[0, 0, 0]); // idle fill: empty frames, not errors
        stream.extend_from_slice(&[0xde, 0xad, 0xbe, 0xef, 0x00]); // garbage between frames
        stream.extend_from_slice(&fa);
        let mut dec = CoreDecoder::new();
        let out: std::vec::Vec<_> = dec.feed(&stream).collect();
        assert_eq!(out.len(), 5, "{out:?}");
        assert!(out[0].is_err() && out[1].is_err() && out[3].is_err());
        assert_eq!(out[2], Ok(b));
        assert_eq!(out[4], Ok(a));
        let c = dec.counters();
        assert_eq!((c.frames_ok, c.dropped()), (2, 3));
    }

    #[test]
    fn an_over_long_frame_is_counted_as_overflow_and_dropped() {
        let hello = frame_of(&HostToCore::Hello(Hello::new(Role::Replay, false)));
        assert_eq!(hello.len(), 10);
        // A decoder exactly as long as the frame (without its delimiter) takes it …
        let mut fits = Decoder::<HostToCore, 9>::new();
        assert!(matches!(fits.feed(&hello).next(), Some(Ok(HostToCore::Hello(_)))));
        // … one byte shorter drops it, counts it, and still takes a frame that fits.
        let mut short = Decoder::<HostToCore, 8>::new();
        assert_eq!(short.feed(&hello).collect::<std::vec::Vec<_>>(), std::vec![Err(FrameError::Overflow)]);
        let start = HostToCore::Command(WireCommand::Start);
        let start_frame = frame_of(&start);
        assert_eq!(start_frame.len(), 8);
        assert_eq!(short.feed(&start_frame).collect::<std::vec::Vec<_>>(), std::vec![Ok(start)]);
        assert_eq!(short.counters(), LinkCounters { frames_ok: 1, overflows: 1, ..Default::default() });

        // A 5000-byte run without a delimiter into the core's decoder: held to its capacity,
        // reported once at the delimiter, then the next frame decodes.
        let mut core = CoreDecoder::new();
        assert_eq!(core.feed(&[0x55u8; 5000]).count(), 0);
        assert_eq!(core.pending(), core.capacity());
        assert_eq!(core.feed(&[0]).collect::<std::vec::Vec<_>>(), std::vec![Err(FrameError::Overflow)]);
        assert!(matches!(core.feed(&hello).next(), Some(Ok(HostToCore::Hello(_)))));
        assert_eq!(core.counters(), LinkCounters { frames_ok: 1, overflows: 1, ..Default::default() });
    }

    #[test]
    fn encoding_into_a_short_buffer_fails_cleanly() {
        let msg = pose_msg();
        let need = frame_of(&msg).len();
        let mut buf = [0u8; 64];
        for n in 0..need {
            assert_eq!(encode(&msg, &mut buf[..n]), Err(FrameError::BufferTooSmall), "{n}");
        }
        assert_eq!(encode(&msg, &mut buf[..need]).map(|f| f.len()), Ok(need));
    }

    #[test]
    fn random_byte_soup_never_panics_and_every_frame_is_accounted_for() {
        let mut rng = Rng(0x5EED_1234_ABCD_0001);
        let mut core = CoreDecoder::new();
        let mut host = HostDecoder::new();
        let mut reported = 0u32;
        for _ in 0..100_000 {
            let b = rng.byte();
            reported += core.push(b).is_some() as u32;
            let _ = host.push(b);
        }
        let c = core.counters();
        assert_eq!(c.frames_ok + c.dropped(), reported);
        assert!(reported > 100, "a 1-in-256 delimiter should end many frames: {reported}");
    }

    #[test]
    fn valid_frames_hidden_in_byte_soup_all_come_through() {
        let mut rng = Rng(42);
        let mut stream: std::vec::Vec<u8> = std::vec::Vec::new();
        let mut sent = std::vec::Vec::new();
        while stream.len() < 100_000 {
            for _ in 0..rng.below(600) {
                stream.push(rng.byte());
            }
            let m = heartbeat_msg(sent.len() as u32);
            stream.push(0); // a sender starts each frame after a delimiter (or idle fill)
            stream.extend_from_slice(&frame_of(&m));
            sent.push(m);
        }
        let mut dec = CoreDecoder::new();
        let got: std::vec::Vec<_> = dec.feed(&stream).filter_map(Result::ok).collect();
        assert_eq!(got, sent, "every hidden frame decodes, no soup decodes");
    }

    #[test]
    fn random_payloads_with_valid_crc_never_panic_the_message_decoder() {
        // Past COBS and CRC: postcard meets arbitrary bytes (lengths, tags, varints) directly.
        let mut rng = Rng(7);
        let (mut ok, mut bad) = (0, 0);
        for round in 0..20_000 {
            let len = 1 + rng.below(if round % 10 == 0 { 3000 } else { 40 });
            let mut payload: heapless::Vec<u8, 4096> = heapless::Vec::new();
            payload.push(rng.below(10) as u8).unwrap();
            for _ in 1..len {
                let b = match rng.below(4) {
                    0 => 0,
                    1 => 1 + rng.below(3) as u8,
                    _ => rng.byte(),
                };
                payload.push(b).unwrap();
            }
            let f = raw_frame(&payload);
            let mut core = CoreDecoder::new();
            let mut host = HostDecoder::new();
            for r in core.feed(&f).map(|r| r.map(|_| ())).chain(host.feed(&f).map(|r| r.map(|_| ()))) {
                match r {
                    Ok(()) => ok += 1,
                    Err(FrameError::Decode | FrameError::Overflow) => bad += 1,
                    Err(e) => panic!("a valid frame failed below the message layer: {e:?}"),
                }
            }
        }
        assert!(ok > 0 && bad > 0, "{ok} {bad}");
    }

    #[test]
    fn decoder_sizes() {
        // The decoders are their buffer plus a few words.
        assert!(core::mem::size_of::<CoreDecoder>() <= MAX_HOST_TO_CORE_FRAME + 48);
        assert!(core::mem::size_of::<HostDecoder>() <= MAX_CORE_TO_HOST_FRAME + 48);
        std::println!(
            "CoreDecoder {} B, HostDecoder {} B, HostToCore {} B, CoreToHost {} B, Inbox {} B",
            core::mem::size_of::<CoreDecoder>(),
            core::mem::size_of::<HostDecoder>(),
            core::mem::size_of::<HostToCore>(),
            core::mem::size_of::<CoreToHost>(),
            core::mem::size_of::<crate::protocol::Inbox>(),
        );
    }
}
