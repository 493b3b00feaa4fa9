//! A fault-injecting link for tests.
//!
//! [`FaultyLink`] wraps a [`Link`] and damages the bytes *it reads* (wrap both ends to damage
//! both directions). It cuts the incoming stream into frames at the `0x00` delimiters and, per
//! frame, with a seeded RNG (so a run is reproducible for the same stream):
//!
//! * drops the whole frame (delimiter included) — `drop_frame_prob`;
//! * drops single bytes — `drop_byte_prob` per byte (never the delimiter, never all bytes);
//! * replaces single bytes by another non-zero value — `corrupt_byte_prob` per byte, and one
//!   byte of the frame with `corrupt_frame_prob` (the delimiter is never touched and no `0x00` is
//!   made, so every damaged frame stays exactly one frame and the receiver's counters can be
//!   checked against [`FaultStats::frames_damaged`] exactly);
//! * with `line_noise`, `corrupt_byte_prob` hits every byte on the line instead, delimiters
//!   included, and a byte may become any other value, `0x00` included — as on a real line: a
//!   corrupted delimiter merges two frames into one, a byte turned into `0x00` splits one in two;
//! * holds every frame for `delay` before the reader sees it.
//!
//! **Accounting.** Merges and splits make "damaged frames" the wrong unit, so the link also counts
//! what the *reader* sees: it cuts the bytes it hands out at `0x00`, as a decoder does, and sorts
//! each non-empty run ([`FaultStats::rx_frames`]) into *intact* — exactly one frame as it came in,
//! every byte and its delimiter unchanged, starting right after a delimiter (or at the start) — and
//! *damaged* (everything else: a damaged frame, a piece of a split frame, a merge of frames).
//! A receiver that decodes every intact run and rejects every damaged one has
//! `frames_ok == rx_frames_intact` and `dropped() == rx_frames_damaged`, exactly — up to a
//! damaged run that passes the CRC-32 by chance (2⁻³² each), which would show as a mismatch. A
//! run still open when the reader stops (its delimiter not yet read) is counted by neither.
//!
//! A [`FaultHandle`] shared by both wrapped ends pulls the cable: [`FaultHandle::disconnect`]
//! makes reads and writes fail (the port vanished) and loses whatever was on the line;
//! [`FaultHandle::blackhole`] silently loses every frame while the ports stay (the far end
//! went quiet). Frames are delivered whole, so the reader never sees half a frame.

use super::Link;
use firmware::protocol::frame::DELIMITER;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::VecDeque;
use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What to damage (probabilities in `[0, 1]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FaultConfig {
    /// Per byte of a frame (delimiter excluded): replaced by another non-zero byte.
    pub corrupt_byte_prob: f64,
    /// Per frame: one of its bytes replaced by another non-zero byte.
    pub corrupt_frame_prob: f64,
    /// Per byte of a frame (delimiter excluded): lost.
    pub drop_byte_prob: f64,
    /// Per frame: lost whole.
    pub drop_frame_prob: f64,
    /// `corrupt_byte_prob` applies to every byte, delimiters included, and a corrupted byte may
    /// become `0x00`: frames merge and split (see the module docs).
    pub line_noise: bool,
    /// Every frame arrives this much later.
    pub delay: Duration,
}

/// What a [`FaultyLink`] did to the frames it delivered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct FaultStats {
    /// Complete frames that came in from the wrapped link.
    pub frames_in: u64,
    /// Frames delivered to the reader (damaged or not).
    pub frames_delivered: u64,
    /// Frames lost whole (dropped, or lost on a pulled cable).
    pub frames_dropped: u64,
    /// Delivered frames with at least one byte replaced.
    pub frames_corrupted: u64,
    /// Delivered frames with at least one byte lost.
    pub frames_truncated: u64,
    /// Delivered frames that were damaged in any way (each counted once): every one of them must
    /// show up in the reader's rejected-frame counters.
    pub frames_damaged: u64,
    /// Bytes replaced.
    pub bytes_corrupted: u64,
    /// Bytes lost from delivered frames.
    pub bytes_dropped: u64,
    /// Bytes lost on a pulled cable (partial frames, reads while disconnected).
    pub bytes_lost_disconnected: u64,
    /// Delivered delimiters replaced by another value (`line_noise`): merged frames.
    pub delimiters_corrupted: u64,
    /// Delivered bytes turned into `0x00` (`line_noise`): split frames.
    pub zeros_made: u64,
    /// Non-empty `0x00`-delimited runs the reader was handed: the frames its decoder sees.
    pub rx_frames: u64,
    /// Of those, runs that are exactly one original frame, unchanged: a decoder takes each.
    pub rx_frames_intact: u64,
    /// Of those, every other run: a decoder must reject each (`dropped()` equals this).
    pub rx_frames_damaged: u64,
}

#[derive(Default)]
struct Shared {
    disconnected: AtomicBool,
    blackhole: AtomicBool,
}

/// Pulls the cable of the [`FaultyLink`]s that share it.
#[derive(Clone, Default)]
pub struct FaultHandle(Arc<Shared>);

impl FaultHandle {
    /// A connected cable.
    pub fn new() -> Self {
        Self::default()
    }
    /// Pulls the cable: reads and writes fail until [`FaultHandle::reconnect`].
    pub fn disconnect(&self) {
        self.0.disconnected.store(true, Ordering::SeqCst);
    }
    /// Plugs it back.
    pub fn reconnect(&self) {
        self.0.disconnected.store(false, Ordering::SeqCst);
    }
    /// Every frame is silently lost while `on` (the ports stay open, the peer goes quiet).
    pub fn blackhole(&self, on: bool) {
        self.0.blackhole.store(on, Ordering::SeqCst);
    }
    /// True while disconnected.
    pub fn is_disconnected(&self) -> bool {
        self.0.disconnected.load(Ordering::SeqCst)
    }
}

/// A [`Link`] that damages what it reads (see the module documentation).
pub struct FaultyLink<L: Link> {
    inner: L,
    cfg: FaultConfig,
    rng: ChaCha8Rng,
    handle: FaultHandle,
    stats: Arc<Mutex<FaultStats>>,
    partial: Vec<u8>,
    /// Frames on their way: due time, bytes (delimiter or what it became included), intact.
    held: VecDeque<(Instant, Vec<u8>, bool)>,
    /// Bytes ready for the reader, and whether each is the first byte of an intact frame.
    out: VecDeque<(u8, bool)>,
    /// The reader's current run: its length, and whether it started with an intact frame.
    run_len: usize,
    run_intact: bool,
}

impl<L: Link> FaultyLink<L> {
    /// Wraps `inner`, damaging reads as `cfg` says, with RNG `seed`.
    pub fn new(inner: L, cfg: FaultConfig, seed: u64) -> Self {
        FaultyLink {
            inner,
            cfg,
            rng: ChaCha8Rng::seed_from_u64(seed),
            handle: FaultHandle::new(),
            stats: Arc::default(),
            partial: Vec::new(),
            held: VecDeque::new(),
            out: VecDeque::new(),
            run_len: 0,
            run_intact: false,
        }
    }

    /// Shares `handle` (one cable for both ends).
    pub fn with_handle(mut self, handle: FaultHandle) -> Self {
        self.handle = handle;
        self
    }

    /// The cable.
    pub fn handle(&self) -> FaultHandle {
        self.handle.clone()
    }

    /// Live counters (readable while another thread owns the link).
    pub fn stats_handle(&self) -> Arc<Mutex<FaultStats>> {
        self.stats.clone()
    }

    /// A copy of the counters.
    pub fn stats(&self) -> FaultStats {
        *self.stats.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn other_byte(&mut self, b: u8) -> u8 {
        // 1..=255 without b: never a delimiter, never the same value.
        let v = self.rng.gen_range(1..=254u8);
        if v >= b && b != 0 {
            v + 1
        } else {
            v
        }
    }

    /// Any value but `b`, `0x00` included (line noise).
    fn any_other_byte(&mut self, b: u8) -> u8 {
        let v = self.rng.gen_range(0..=254u8);
        if v >= b {
            v + 1
        } else {
            v
        }
    }

    /// Applies the faults to one complete frame (without its delimiter).
    fn damage(&mut self, mut frame: Vec<u8>) {
        let mut st = *self.stats.lock().unwrap_or_else(|e| e.into_inner());
        st.frames_in += 1;
        if self.handle.0.blackhole.load(Ordering::SeqCst) || self.rng.gen_bool(self.cfg.drop_frame_prob.clamp(0.0, 1.0)) {
            st.frames_dropped += 1;
            *self.stats.lock().unwrap_or_else(|e| e.into_inner()) = st;
            return;
        }
        let mut truncated = false;
        if self.cfg.drop_byte_prob > 0.0 && frame.len() > 1 {
            let p = self.cfg.drop_byte_prob.clamp(0.0, 1.0);
            let before = frame.len();
            let keep: Vec<bool> = (0..before).map(|_| !self.rng.gen_bool(p)).collect();
            let mut kept: Vec<u8> = frame.iter().zip(&keep).filter(|(_, k)| **k).map(|(b, _)| *b).collect();
            if kept.is_empty() {
                kept.push(frame[0]);
            }
            if kept.len() < before {
                truncated = true;
                st.bytes_dropped += (before - kept.len()) as u64;
                frame = kept;
            }
        }
        let mut corrupted = 0u64;
        let noise = self.cfg.line_noise;
        frame.push(DELIMITER);
        let body = frame.len() - 1;
        if self.cfg.corrupt_byte_prob > 0.0 {
            let p = self.cfg.corrupt_byte_prob.clamp(0.0, 1.0);
            // Line noise reaches the delimiter too.
            let reach = if noise { frame.len() } else { body };
            for (i, byte) in frame.iter_mut().enumerate().take(reach) {
                if self.rng.gen_bool(p) {
                    *byte = if noise { self.any_other_byte(*byte) } else { self.other_byte(*byte) };
                    corrupted += 1;
                    if i == body {
                        st.delimiters_corrupted += 1;
                    } else if *byte == 0 {
                        st.zeros_made += 1;
                    }
                }
            }
        }
        if body > 0 && self.rng.gen_bool(self.cfg.corrupt_frame_prob.clamp(0.0, 1.0)) {
            let i = self.rng.gen_range(0..body);
            let b = frame[i];
            // A byte already turned into 0x00 by line noise is any byte's equal here.
            frame[i] = if b == 0 { self.any_other_byte(b) } else { self.other_byte(b) };
            corrupted += 1;
        }
        st.bytes_corrupted += corrupted;
        st.frames_corrupted += (corrupted > 0) as u64;
        st.frames_truncated += truncated as u64;
        st.frames_damaged += (corrupted > 0 || truncated) as u64;
        st.frames_delivered += 1;
        *self.stats.lock().unwrap_or_else(|e| e.into_inner()) = st;
        let intact = corrupted == 0 && !truncated;
        self.held.push_back((Instant::now() + self.cfg.delay, frame, intact));
    }

    /// Hands up to `buf.len()` ready bytes to the reader, sorting the runs it completes.
    fn deliver(&mut self, buf: &mut [u8]) -> usize {
        let n = buf.len().min(self.out.len());
        let (mut runs, mut intact) = (0u64, 0u64);
        for (d, (b, starts_intact)) in buf.iter_mut().zip(self.out.drain(..n)) {
            *d = b;
            if self.run_len == 0 {
                self.run_intact = starts_intact;
            }
            if b == DELIMITER {
                if self.run_len > 0 {
                    // An intact frame has no 0x00 inside and its own delimiter: if the run began
                    // with one, this 0x00 is that frame's delimiter and the run is the frame.
                    runs += 1;
                    intact += self.run_intact as u64;
                }
                self.run_len = 0;
            } else {
                self.run_len += 1;
            }
        }
        let mut st = self.stats.lock().unwrap_or_else(|e| e.into_inner());
        st.rx_frames += runs;
        st.rx_frames_intact += intact;
        st.rx_frames_damaged += runs - intact;
        n
    }

    fn take_bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if b == DELIMITER {
                let frame = std::mem::take(&mut self.partial);
                if frame.is_empty() {
                    continue; // idle fill
                }
                self.damage(frame);
            } else {
                self.partial.push(b);
            }
        }
    }

    /// Moves due frames to the output queue; returns how long until the next one is due.
    fn release(&mut self) -> Option<Duration> {
        let now = Instant::now();
        while let Some((due, _, _)) = self.held.front() {
            if *due > now {
                return Some(*due - now);
            }
            if let Some((_, f, intact)) = self.held.pop_front() {
                self.out.extend(f.iter().enumerate().map(|(i, &b)| (b, intact && i == 0)));
            }
        }
        None
    }

    fn lose_line(&mut self) {
        let mut st = self.stats.lock().unwrap_or_else(|e| e.into_inner());
        st.bytes_lost_disconnected += self.partial.len() as u64 + self.out.len() as u64;
        st.frames_dropped += self.held.len() as u64;
        self.partial.clear();
        self.held.clear();
        self.out.clear();
        // The reader drops its partial frame when its port fails: so does the run count.
        self.run_len = 0;
    }
}

fn pulled() -> io::Error {
    io::Error::new(io::ErrorKind::NotConnected, "cable pulled (fault injection)")
}

impl<L: Link> Link for FaultyLink<L> {
    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.handle.is_disconnected() {
                // Whatever was on the line is gone.
                self.lose_line();
                let mut scratch = [0u8; 4096];
                let n = self.inner.read(&mut scratch, timeout.min(Duration::from_millis(10))).unwrap_or(0);
                self.stats.lock().unwrap_or_else(|e| e.into_inner()).bytes_lost_disconnected += n as u64;
                return Err(pulled());
            }
            let next_due = self.release();
            if !self.out.is_empty() {
                return Ok(self.deliver(buf));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(0);
            }
            let wait = next_due.map_or(deadline - now, |d| d.min(deadline - now)).min(Duration::from_millis(20));
            let mut scratch = [0u8; 4096];
            let n = self.inner.read(&mut scratch, wait)?;
            self.take_bytes(&scratch[..n]);
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        if self.handle.is_disconnected() {
            return Err(pulled());
        }
        self.inner.write_all(bytes)
    }

    fn reconnect(&mut self) -> io::Result<()> {
        if self.handle.is_disconnected() {
            return Err(pulled());
        }
        self.inner.reconnect()
    }

    fn describe(&self) -> String {
        format!("faulty({})", self.inner.describe())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::mem_pair;
    use firmware::protocol::{encode, CoreDecoder, Heartbeat, HostToCore, MAX_FRAME_LEN};

    fn frames(n: u32) -> Vec<u8> {
        let mut out = Vec::new();
        let mut buf = [0u8; MAX_FRAME_LEN];
        for seq in 0..n {
            out.extend_from_slice(encode(&HostToCore::Heartbeat(Heartbeat { t_us: seq as u64 * 1_000_003, seq }), &mut buf).unwrap());
        }
        out
    }

    fn pump(cfg: FaultConfig, seed: u64, n: u32) -> (FaultStats, firmware::protocol::LinkCounters, Vec<u32>) {
        let (mut a, b) = mem_pair();
        let mut f = FaultyLink::new(b, cfg, seed);
        a.write_all(&frames(n)).unwrap();
        let mut dec = CoreDecoder::new();
        let mut seqs = Vec::new();
        let mut buf = [0u8; 1000];
        loop {
            let k = f.read(&mut buf, Duration::from_millis(5)).unwrap();
            if k == 0 {
                break;
            }
            for m in dec.feed(&buf[..k]).flatten() {
                if let HostToCore::Heartbeat(h) = m {
                    seqs.push(h.seq);
                }
            }
        }
        (f.stats(), dec.counters(), seqs)
    }

    #[test]
    fn every_damaged_frame_is_rejected_and_every_clean_one_arrives() {
        let cfg = FaultConfig {
            corrupt_byte_prob: 0.01,
            corrupt_frame_prob: 0.05,
            drop_byte_prob: 0.01,
            drop_frame_prob: 0.05,
            ..Default::default()
        };
        let (st, rx, seqs) = pump(cfg.clone(), 7, 20_000);
        assert_eq!(st.frames_in, 20_000);
        assert_eq!(st.frames_delivered + st.frames_dropped, 20_000);
        assert!(st.frames_damaged > 1000 && st.frames_dropped > 500, "{st:?}");
        assert_eq!(rx.dropped() as u64, st.frames_damaged, "{rx:?} vs {st:?}");
        assert_eq!(rx.frames_ok as u64, st.frames_delivered - st.frames_damaged);
        // Without line noise a damaged frame stays one frame: the two accountings agree.
        assert_eq!((st.rx_frames_damaged, st.rx_frames_intact), (st.frames_damaged, st.frames_delivered - st.frames_damaged));
        // What got through is the original, in order.
        assert!(seqs.windows(2).all(|w| w[0] < w[1]));
        // Same seed, same damage.
        assert_eq!(pump(cfg, 7, 20_000).0, st);
    }

    #[test]
    fn with_line_noise_frames_merge_and_split_and_the_reader_side_count_is_exact() {
        // 1 % of all bytes, delimiters included, to any value: merged and split frames.
        let cfg = FaultConfig { corrupt_byte_prob: 0.01, line_noise: true, drop_frame_prob: 0.05, ..Default::default() };
        let (st, rx, seqs) = pump(cfg.clone(), 3, 50_000);
        // (A corrupted byte becomes 0x00 one time in 255.)
        assert!(st.delimiters_corrupted > 100 && st.zeros_made > 10, "{st:?}");
        // The reader's decoder rejected exactly the damaged runs and took exactly the intact ones.
        assert_eq!(rx.dropped() as u64, st.rx_frames_damaged, "{rx:?} vs {st:?}");
        assert_eq!(rx.frames_ok as u64, st.rx_frames_intact);
        assert_eq!(seqs.len() as u64, st.rx_frames_intact);
        // A frame's worth of damage: merges make fewer runs than damaged frames, splits more.
        assert_ne!(st.rx_frames_damaged, st.frames_damaged);
        // An undamaged frame is not intact only when merged into the run of the frame before,
        // whose delimiter was corrupted (a frame with a corrupted delimiter counts as damaged).
        let undamaged = st.frames_delivered - st.frames_damaged;
        assert!(st.rx_frames_intact <= undamaged && st.rx_frames_intact + st.delimiters_corrupted >= undamaged, "{st:?}");
        assert!(seqs.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(pump(cfg, 3, 50_000).0, st);
    }

    #[test]
    fn delay_holds_frames_and_the_cable_can_be_pulled() {
        let (mut a, b) = mem_pair();
        let mut f = FaultyLink::new(b, FaultConfig { delay: Duration::from_millis(60), ..Default::default() }, 1);
        let h = f.handle();
        a.write_all(&frames(1)).unwrap();
        let t0 = Instant::now();
        let mut buf = [0u8; 64];
        let mut n = 0;
        while n == 0 && t0.elapsed() < Duration::from_secs(1) {
            n = f.read(&mut buf, Duration::from_millis(10)).unwrap();
        }
        assert!(n > 0 && t0.elapsed() >= Duration::from_millis(60));
        h.disconnect();
        assert!(f.read(&mut buf, Duration::from_millis(1)).is_err());
        assert!(f.write_all(&[1, 0]).is_err());
        assert!(f.reconnect().is_err());
        a.write_all(&frames(3)).unwrap(); // lost on the pulled cable
        let _ = f.read(&mut buf, Duration::from_millis(1));
        h.reconnect();
        f.reconnect().unwrap();
        assert_eq!(f.read(&mut buf, Duration::from_millis(100)).unwrap(), 0);
        h.blackhole(true);
        a.write_all(&frames(2)).unwrap();
        assert_eq!(f.read(&mut buf, Duration::from_millis(30)).unwrap(), 0);
        assert!(f.stats().bytes_lost_disconnected > 0 && f.stats().frames_dropped == 2);
    }
}
