//! A seeded property test of the whole receive path: well over 10⁶ random and mutated frames
//! through [`CoreDecoder`], [`HostDecoder`] and the [`Node`] (lockstep and real time, session
//! open and closed), in bounded time as part of `cargo test` (release: overflow checks are on, so
//! an arithmetic overflow anywhere is a panic and fails the test).
//!
//! The frames, from one seeded xorshift generator (no clock, no OS randomness — the same bytes
//! on every run):
//!
//! * **valid** frames of every message type of both directions (small and worst-case sizes);
//! * **frame mutations**, CRC left as it is (caught by COBS or the CRC): bit flips, random bytes,
//!   bytes inserted or deleted, truncation, two frames spliced, a `0x00` inserted (a split
//!   frame), the delimiter removed (merged frames);
//! * **payload mutations re-framed with a recomputed CRC**, so that the mutated bytes reach the
//!   postcard decoder: all of the above on the message bytes, plus varint and length edits
//!   (continuation bits set, a length byte replaced by a large value, a tag out of range), and
//!   payloads of one message type spliced onto another's;
//! * **random** frames: random bytes (zeros included), and random payloads with a valid CRC.
//!
//! Properties checked:
//!
//! * nothing panics, whatever the bytes (every consumer gets every byte);
//! * accounting: each decoder's `frames_ok + dropped()` equals the number of non-empty
//!   `0x00`-delimited runs it was fed, counted independently; the node's receive counters equal
//!   a stand-alone core decoder's on the same stream;
//! * a frame with a valid CRC fails only as *decode* (or *overflow* when longer than the
//!   receiver's buffer) — never as COBS or CRC;
//! * whatever decodes can be sent back: encoding the decoded message succeeds and decodes to the
//!   same message;
//! * no state leaks: a known good frame after a resynchronising `0x00`, every 97 frames, decodes
//!   to exactly its message on every decoder.

extern crate std;

use super::frame::{decode_in_place, CRC};
use super::message::*;
use super::*;
use crate::config::Config;
use crate::controller::Controller;
use crate::node::{Node, NodeConfig, TimeMode};
use crate::scan::BeamLabel;
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::boxed::Box;
use std::vec::Vec;

/// Frames generated (each goes to every consumer).
const FRAMES: usize = 1_100_000;

/// Seeded xorshift64*: the protocol tests' only source of randomness.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub(crate) fn byte(&mut self) -> u8 {
        (self.next() >> 56) as u8
    }
    pub(crate) fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
    pub(crate) fn chance(&mut self, per_mille: u64) -> bool {
        self.next() % 1000 < per_mille
    }
}

fn payload_of<M: Serialize>(m: &M) -> Vec<u8> {
    let mut buf = std::vec![0u8; MAX_FRAME_LEN];
    let n = postcard::to_slice(m, &mut buf).expect("serialises").len();
    buf.truncate(n);
    buf
}

/// A frame (delimiter included) around any payload: valid COBS and CRC.
fn frame_around(payload: &[u8]) -> Vec<u8> {
    let mut data = payload.to_vec();
    data.extend_from_slice(&CRC.checksum(payload).to_le_bytes());
    let mut out = std::vec![0u8; data.len() + data.len() / 254 + 2];
    let n = cobs::encode(&data, &mut out);
    out.truncate(n);
    out.push(0);
    out
}

fn scan(n: usize, labels: bool, t_us: u64) -> ScanMsg {
    let mut s = ScanMsg { t_us, angle_min: i32::MIN, angle_increment: (u32::MAX / n as u32) as i32, ..Default::default() };
    for i in 0..n {
        let _ = s.ranges_mm.push(match i % 5 {
            0 => 0,
            1 => u16::MAX,
            _ => 300 + 37 * i as u16,
        });
    }
    if labels {
        s.labels = Some((0..n).map(|i| [BeamLabel::Unlabelled, BeamLabel::Map, BeamLabel::NonMap][i % 3]).collect());
    }
    s
}

/// One or more values of every host-to-core variant (the tags are checked below).
fn host_corpus() -> Vec<HostToCore> {
    let mut v = std::vec![
        HostToCore::Hello(Hello::new(Role::Simulator, true)),
        HostToCore::Hello(Hello { version: PROTOCOL_VERSION.wrapping_add(1), role: Role::Robot, want_labels: false }),
        HostToCore::Heartbeat(Heartbeat { t_us: 1_000_000, seq: 0x8000_0001 }),
        HostToCore::Pose(PoseMsg { t_us: 1_500_000, x: 1_677_722, y: 1_677_722, theta: 1 << 30 }),
        HostToCore::Scan(scan(5, true, 2_000_000)),
        HostToCore::Scan(scan(40, false, 1_500_000)),
        // A heartbeat closing a batch (with the pose and the scan above): the lockstep node ticks.
        HostToCore::Heartbeat(Heartbeat { t_us: 1_500_000, seq: 0x8000_0002 }),
        HostToCore::Scan(scan(897, true, 2_200_000)),
        HostToCore::Scan(scan(MAX_WIRE_BEAMS, true, u64::MAX)),
        HostToCore::Detection(DetectionMsg { t_us: 2_300_000, position: Some((196_608, -65_536)) }),
        HostToCore::Detection(DetectionMsg { t_us: 2_300_000, position: None }),
        HostToCore::Command(WireCommand::Start),
        HostToCore::Command(WireCommand::Stop),
        HostToCore::Command(WireCommand::Reset),
        HostToCore::Config(ConfigMsg::from_config(&Config::DEFAULT)),
        // Out of range: refused (it once overflowed the planner's arithmetic on the next plan).
        HostToCore::Config(ConfigMsg::from_config(&Config { viewpoint_snap_radius_m: Config::mm(3_000_000), ..Config::DEFAULT })),
        HostToCore::BaseStatus(BaseStatus { blocked: true }),
    ];
    let big = scan(897, true, 2_400_000);
    v.extend(big.segments(16).take(3).map(HostToCore::ScanSegment));
    v.extend(big.segments(MAX_SEGMENT_BEAMS).skip(6).map(HostToCore::ScanSegment));
    v.extend(scan(30, false, 2_500_000).segments(8).map(HostToCore::ScanSegment));
    v
}

/// One or more values of every core-to-host variant.
fn core_corpus() -> Vec<CoreToHost> {
    let mut goal = GoalMsg { seq: 3, x: 98_304, y: -147_456, theta: i32::MIN, utility: -425_984, ..Default::default() };
    for i in 0..MAX_WIRE_WAYPOINTS as i32 {
        let _ = goal.path.push((i * 6_554, -i * 13_107));
    }
    let short = GoalMsg { path: goal.path.iter().take(3).copied().collect(), ..goal.clone() };
    let status =
        StatusMsg::from_status(5_000_000, &crate::controller::Status::default(), LinkCounters { frames_ok: 300, ..Default::default() });
    std::vec![
        CoreToHost::HelloAck(HelloAck::answer(&Hello::new(Role::Simulator, false))),
        CoreToHost::HelloAck(HelloAck { version: 9, accepted: false, reason: AckReason::VersionMismatch }),
        CoreToHost::Heartbeat(Heartbeat { t_us: 3_000_000, seq: 42 }),
        CoreToHost::Goal(goal),
        CoreToHost::Goal(short),
        CoreToHost::Stop(StopMsg { mode: WireMode::Stopped }),
        CoreToHost::Status(status),
        CoreToHost::Labels(LabelsMsg {
            t_us: 1,
            labels: (0..MAX_WIRE_LABELS).map(|i| [BeamLabel::Map, BeamLabel::NonMap][i % 2]).collect()
        }),
        CoreToHost::Labels(LabelsMsg { t_us: 1, labels: (0..4).map(|_| BeamLabel::NonMap).collect() }),
        CoreToHost::Error(ErrorMsg { code: ErrorCode::HandshakeRequired }),
        CoreToHost::Error(ErrorMsg { code: ErrorCode::VersionMismatch { peer: 1 } }),
        CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigRefused }),
        CoreToHost::Error(ErrorMsg { code: ErrorCode::ConfigInvalid { field: 34 } }),
    ]
}

/// Mutates message or frame bytes in place, one of several ways.
fn mutate(rng: &mut Rng, b: &mut Vec<u8>, other: &[u8], payload: bool) {
    let most = if rng.chance(100) { 8 } else { 2 };
    let rounds = 1 + rng.below(most);
    for _ in 0..rounds {
        let len = b.len();
        match rng.below(if payload { 12 } else { 9 }) {
            // One bit flipped.
            0 if len > 0 => {
                let i = rng.below(len);
                b[i] ^= 1 << rng.below(8);
            }
            // A byte replaced.
            1 if len > 0 => {
                let i = rng.below(len);
                b[i] = rng.byte();
            }
            // Bytes inserted.
            2 => {
                for _ in 0..1 + rng.below(4) {
                    let i = rng.below(b.len() + 1);
                    b.insert(i, rng.byte());
                }
            }
            // Bytes deleted.
            3 if len > 0 => {
                let i = rng.below(len);
                let n = (1 + rng.below(4)).min(len - i);
                b.drain(i..i + n);
            }
            // Truncated.
            4 => b.truncate(rng.below(len + 1)),
            // Spliced with another message or frame: a prefix of one, a suffix of the other.
            5 => {
                let cut = rng.below(len + 1);
                let from = rng.below(other.len() + 1);
                b.truncate(cut);
                b.extend_from_slice(&other[from..]);
            }
            // A run duplicated (a repeated field or range).
            6 if len > 1 => {
                let i = rng.below(len);
                let n = (1 + rng.below(16)).min(len - i);
                let run: Vec<u8> = b[i..i + n].to_vec();
                let at = rng.below(b.len() + 1);
                for (k, x) in run.into_iter().enumerate() {
                    b.insert(at + k, x);
                }
            }
            // Frame: a 0x00 inside (a split frame) or the delimiter gone (merged with the next).
            7 if !payload && len > 0 => {
                let i = rng.below(len);
                b[i] = 0;
            }
            8 if !payload && len > 0 && b[len - 1] == 0 => {
                b.pop();
            }
            // Payload: a varint made longer (continuation bit on a byte).
            7 if payload && len > 0 => {
                let i = rng.below(len);
                b[i] |= 0x80;
            }
            // Payload: a length or count made huge (a 5-byte varint at a random position).
            8 if payload && len > 0 => {
                let i = rng.below(len);
                let v = [0xff, 0xff, 0xff, 0xff, 0x0f];
                let n = 1 + rng.below(5);
                b.splice(i..(i + 1).min(b.len()), v[5 - n..].iter().copied());
            }
            // Payload: a length nudged by ±1 (where a sequence length is, often).
            9 if payload && len > 0 => {
                let i = rng.below(len);
                b[i] = if rng.chance(500) { b[i].wrapping_add(1) } else { b[i].wrapping_sub(1) };
            }
            // Payload: an unknown or foreign tag.
            10 if payload && len > 0 => b[0] = rng.below(16) as u8,
            // Payload: a non-minimal varint (0x80 0x00 for 0) at a random position.
            11 if payload => {
                let i = rng.below(len + 1);
                b.insert(i, 0x80);
                b.insert(i + 1, 0x00);
            }
            _ => {}
        }
    }
}

/// Non-empty `0x00`-delimited runs in a stream: the frames a receiver must account for.
#[derive(Default)]
struct Runs {
    runs: u64,
    run_len: usize,
}

impl Runs {
    fn feed(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if b == 0 {
                self.runs += (self.run_len > 0) as u64;
                self.run_len = 0;
            } else {
                self.run_len += 1;
            }
        }
    }
}

/// One consumer of the stream: a decoder of one direction, with the expected count of frames.
struct Checked<M, const N: usize> {
    dec: Decoder<M, N>,
    runs: Runs,
    ok: u64,
}

impl<M: DeserializeOwned + Serialize + PartialEq + core::fmt::Debug, const N: usize> Checked<M, N> {
    fn new() -> Self {
        Self { dec: Decoder::new(), runs: Runs::default(), ok: 0 }
    }

    /// Feeds `bytes`. `crc_valid`: the bytes are exactly one frame with a valid CRC around a
    /// payload that is empty (`Some(true)`) or not (`Some(false)`).
    fn feed(&mut self, bytes: &[u8], crc_valid: Option<bool>, scratch: &mut [u8]) {
        self.runs.feed(bytes);
        for &b in bytes {
            match self.dec.push(b) {
                None => {}
                Some(Ok(m)) => {
                    self.ok += 1;
                    // Whatever decodes can be sent back, as the same message.
                    let f = encode(&m, scratch).expect("a decoded message always encodes");
                    let mut copy = f[..f.len() - 1].to_vec();
                    let again: M = decode_in_place(&mut copy).expect("and decodes again");
                    assert_eq!(again, m);
                }
                Some(Err(e)) => match crc_valid {
                    // A valid CRC: the bytes reached postcard (or did not fit the buffer).
                    Some(false) => assert!(matches!(e, FrameError::Decode | FrameError::Overflow), "{e:?}"),
                    // No payload byte: refused before postcard.
                    Some(true) => assert_eq!(e, FrameError::Crc),
                    None => {}
                },
            }
        }
    }

    fn check(&self) {
        let c = self.dec.counters();
        assert_eq!(c.frames_ok as u64 + c.dropped() as u64, self.runs.runs, "{c:?}");
        assert_eq!(c.frames_ok as u64, self.ok);
    }
}

#[test]
fn a_million_random_and_mutated_frames_never_panic_and_are_all_accounted_for() {
    let mut rng = Rng(0x00F0_22ED_5EED_0005);
    let hosts: Vec<(Vec<u8>, HostToCore)> = host_corpus().into_iter().map(|m| (payload_of(&m), m)).collect();
    let cores: Vec<(Vec<u8>, CoreToHost)> = core_corpus().into_iter().map(|m| (payload_of(&m), m)).collect();
    // Every variant of both enums is in the corpus.
    fn tags<M>(p: &[(Vec<u8>, M)]) -> usize {
        p.iter().map(|(b, _)| b[0]).collect::<std::collections::BTreeSet<u8>>().len()
    }
    assert_eq!((tags(&hosts), tags(&cores)), (9, 7));
    let payloads: Vec<Vec<u8>> = hosts.iter().map(|h| h.0.clone()).chain(cores.iter().map(|c| c.0.clone())).collect();
    // The control frame: a pose, after a resynchronising delimiter.
    let control_msg = HostToCore::Pose(PoseMsg { t_us: 77, x: 1, y: -1, theta: 5 });
    let mut control = std::vec![0u8];
    control.extend(frame_around(&payload_of(&control_msg)));
    let hello = frame_around(&payload_of(&HostToCore::Hello(Hello::new(Role::Simulator, true))));

    let mut core = Checked::<HostToCore, { MAX_HOST_TO_CORE_FRAME - 1 }>::new();
    let mut host = Checked::<CoreToHost, { MAX_CORE_TO_HOST_FRAME - 1 }>::new();
    let mut lockstep = Node::new(NodeConfig::new(TimeMode::Lockstep));
    let mut realtime = Node::new(NodeConfig::new(TimeMode::RealTime));
    let mut closed = Node::new(NodeConfig::new(TimeMode::Lockstep));
    let mut ctl = Box::new(Controller::new(Config::DEFAULT));
    let mut ctl_rt = Box::new(Controller::new(Config::DEFAULT));
    let mut ctl_closed = Box::new(Controller::new(Config::DEFAULT));
    let mut scratch = std::vec![0u8; MAX_FRAME_LEN];
    let (mut sent, mut ticks, mut bytes) = (0u64, 0u64, 0u64);
    let (mut valid, mut recrc, mut framed_mut, mut random) = (0u64, 0u64, 0u64, 0u64);
    let mut control_ok = 0u64;
    let (mut lock_runs, mut rt_runs) = (Runs::default(), Runs::default());

    for i in 0..FRAMES {
        // Worst-case-sized messages are picked 1 time in 50 (they cost most of the bytes).
        let pick = |rng: &mut Rng| loop {
            let k = rng.below(payloads.len());
            if payloads[k].len() < 700 || rng.chance(20) {
                break k;
            }
        };
        let k = pick(&mut rng);
        let other = &payloads[pick(&mut rng)];
        let (frame, crc_valid) = match rng.below(100) {
            0..=9 => {
                valid += 1;
                (frame_around(&payloads[k]), Some(false))
            }
            10..=54 => {
                recrc += 1;
                let mut p = payloads[k].clone();
                mutate(&mut rng, &mut p, other, true);
                (frame_around(&p), Some(p.is_empty()))
            }
            55..=89 => {
                framed_mut += 1;
                let mut f = frame_around(&payloads[k]);
                mutate(&mut rng, &mut f, &frame_around(other), false);
                (f, None)
            }
            _ => {
                random += 1;
                let most = if rng.chance(50) { 4000 } else { 64 };
                let n = rng.below(most);
                if rng.chance(500) {
                    let p: Vec<u8> = (0..n).map(|_| rng.byte()).collect();
                    (frame_around(&p), Some(p.is_empty()))
                } else {
                    let mut f: Vec<u8> = (0..n).map(|_| if rng.chance(10) { 0 } else { rng.byte() }).collect();
                    f.push(0);
                    (f, None)
                }
            }
        };
        bytes += frame.len() as u64;
        // A frame with a valid CRC is exactly one frame only if it starts a run: a delimiter
        // first ends whatever a mutation left open.
        let lead: &[u8] = if crc_valid.is_some() { &[0] } else { &[] };
        for (part, crc) in [(lead, None), (&frame[..], crc_valid)] {
            core.feed(part, crc, &mut scratch);
            host.feed(part, crc, &mut scratch);
            ticks += lockstep.receive(part, &mut ctl, |f| sent += f.len() as u64) as u64;
            realtime.receive(part, &mut ctl_rt, |f| sent += f.len() as u64);
            closed.receive(part, &mut ctl_closed, |f| sent += f.len() as u64);
            lock_runs.feed(part);
            rt_runs.feed(part);
        }
        // Keep the sessions open (a mutated Hello may have closed them).
        for (node, c, runs) in [(&mut lockstep, &mut ctl, &mut lock_runs), (&mut realtime, &mut ctl_rt, &mut rt_runs)] {
            if !node.session().is_open() {
                node.receive(&hello, c, |f| sent += f.len() as u64);
                runs.feed(&hello);
            }
        }
        if i % 10_000 == 9_999 {
            realtime.tick(i as u64 * 20, &mut ctl_rt, |f| sent += f.len() as u64);
            ticks += 1;
        }
        if i % 97 == 0 {
            // No state leaks from the garbage before: a good frame decodes as itself.
            // (The leading delimiter ends whatever run was open, which may decode: count after it.)
            core.feed(&control[..1], None, &mut scratch);
            host.feed(&control[..1], None, &mut scratch);
            let d = core.dec.counters().frames_ok;
            core.feed(&control[1..], None, &mut scratch);
            assert_eq!(core.dec.counters().frames_ok, d + 1, "frame {i}: the control frame was lost");
            let d = host.dec.counters().frames_ok;
            host.feed(&control[1..], None, &mut scratch);
            assert_eq!(host.dec.counters().frames_ok, d, "a host-to-core pose is not a core-to-host message");
            lockstep.receive(&control[..1], &mut ctl, |f| sent += f.len() as u64);
            let before = lockstep.link_counters().frames_ok;
            lockstep.receive(&control[1..], &mut ctl, |f| sent += f.len() as u64);
            realtime.receive(&control, &mut ctl_rt, |f| sent += f.len() as u64);
            closed.receive(&control, &mut ctl_closed, |f| sent += f.len() as u64);
            lock_runs.feed(&control);
            rt_runs.feed(&control);
            assert_eq!(lockstep.link_counters().frames_ok, before + 1);
            control_ok += 1;
        }
    }
    core.check();
    host.check();
    // A node's receive counters are a core decoder's on the same bytes; every node accounts for
    // every frame it was fed (the open ones also got a Hello whenever a mutated one closed them).
    let (a, c) = (core.dec.counters(), closed.link_counters());
    assert_eq!(LinkCounters { ignored: 0, ..c }, a);
    let (l, r) = (lockstep.link_counters(), realtime.link_counters());
    assert_eq!(l.frames_ok as u64 + l.dropped() as u64, lock_runs.runs, "{l:?}");
    assert_eq!(r.frames_ok as u64 + r.dropped() as u64, rt_runs.runs, "{r:?}");
    assert!(a.frames_ok > 100_000 && a.decode_errors > 50_000 && a.crc_errors > 50_000 && a.cobs_errors > 1_000, "{a:?}");
    let h = host.dec.counters();
    assert!(h.frames_ok > 50_000 && h.decode_errors > 50_000 && h.overflows > 100, "{h:?}");
    std::println!(
        "fuzz: {FRAMES} frames ({valid} valid, {recrc} payload-mutated with a recomputed CRC, {framed_mut} frame-mutated, {random} random) + {control_ok} control frames, {} kB",
        bytes / 1000
    );
    std::println!("fuzz: core decoder {a:?}");
    std::println!("fuzz: host decoder {h:?}");
    std::println!(
        "fuzz: lockstep node {:?} {:?}, segments accepted {} refused {}; real-time node {:?}; {ticks} ticks, {sent} bytes answered",
        l,
        lockstep.counters(),
        lockstep.inbox().segments_accepted,
        lockstep.inbox().segments_refused,
        r
    );
}

/// Writes the seeds of the coverage-guided frame targets (`fuzz/corpus/frames_to_core/` and
/// `fuzz/corpus/frames_to_host/`, `host::fuzz`): each message of [`host_corpus`] and
/// [`core_corpus`] as one frame, and each direction's whole corpus as one stream. Run by hand
/// when the protocol changes: `cargo test -p firmware --lib write_fuzz_seeds -- --ignored`.
#[test]
#[ignore]
fn write_fuzz_seeds() {
    fn write<M: Serialize>(dir: &str, msgs: &[M]) {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus").join(dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut buf = std::vec![0u8; MAX_FRAME_LEN];
        let mut all = Vec::new();
        for (i, m) in msgs.iter().enumerate() {
            let f = encode(m, &mut buf).unwrap();
            std::fs::write(dir.join(std::format!("seed-{i:02}.bin")), f).unwrap();
            all.extend_from_slice(f);
        }
        std::fs::write(dir.join("seed-stream.bin"), &all).unwrap();
    }
    write("frames_to_core", &host_corpus());
    write("frames_to_host", &core_corpus());
}
