//! Fuzz targets: every parser and decoder that takes bytes from outside, as one function each
//! taking `&[u8]` (issue 29; `docs/reliability.md`).
//!
//! The same functions run in two ways:
//!
//! * **coverage-guided** (libFuzzer through `cargo fuzz`): `fuzz/fuzz_targets/<name>.rs` calls
//!   [`run`] with the target's name; `fuzz/corpus/<name>/` holds the seeds (taken from the real
//!   fixtures in `tests/data/` and the test builders) and every regression input;
//! * **deterministically** in `cargo test` (`tests/tests/fuzz.rs`): each committed corpus file,
//!   then a fixed number of seeded mutations of them ([`Mutator`]), through the same function —
//!   no nightly toolchain, the same bytes on every run.
//!
//! A target fails by panicking: on a panic of the code under test, and on a property broken
//! (below). What each one checks besides "no panic, no abort, no hang":
//!
//! | target | entry | properties |
//! |---|---|---|
//! | `frames_to_core` | `CoreDecoder` and a lockstep `Node` fed the bytes | what decodes re-encodes to the same message; the decoder's counters add up to the frames it ended |
//! | `frames_to_host` | `HostDecoder` | the same |
//! | `world` | `World::from_toml_str` | an error has a line within the file and no internal type name (`RawRect`, `i128`, `f64`, `struct`) |
//! | `carmen` | `carmen::parse_line` per line | — |
//! | `vlp16` | `ScanAssembler::push_bytes` per 1206-byte packet, `CaptureFormat::Raw.decode_bytes` | every scan has the configured beam count |
//! | `pcap` | `CaptureFormat::Pcap.decode_bytes` | the same |
//! | `mcap` | `rosbag::read_mcap` | every offset it reports is within the file |
//! | `sqlite` | `rosbag::read_db3` on the bytes as a file | — |
//! | `ros1bag` | `rosbag::read_bag1` | every offset it reports is within the file |
//! | `cdr` | `decode_laser_scan`, `decode_odometry`, `decode_tf_message`, `rosbag::cut` (a `PointCloud2` to its planar scan), CDR and ROS 1 | a cut has the core's beam count |
//! | `model` | `model::validate_blob` (geometric and `LabelPoseNet` blobs) | a blob that validates installs in a `Controller` |
//! | `adapter` | `link::adapter::parse_line` per line | — |
//! | `map` | `map_file::MapMeta::parse` and `PriorMap::from_meta` (YAML, then `%%IMAGE%%` and the image) | an error names the file at fault; a YAML error's line is within the file; a map that loads resamples onto a grid |
//!
//! Allocation is bounded by the code under test, not by the fuzzer: the campaign builds without a
//! sanitizer, where libFuzzer cannot check single allocations, so it runs with `-rss_limit_mb=2048`
//! and an allocation beyond the address space aborts as a crash (`docs/reliability.md`).

use crate::io::replay::{carmen, cdr, rosbag, ReplayError};
use crate::io::sensors::vlp16;
use firmware::protocol::frame::{decode_in_place, encode, CoreDecoder, HostDecoder, MAX_FRAME_LEN};
use std::path::Path;

/// The targets, by name (the directory names under `fuzz/corpus/` and the binaries under
/// `fuzz/fuzz_targets/`).
pub const TARGETS: &[&str] = &[
    "frames_to_core",
    "frames_to_host",
    "world",
    "carmen",
    "vlp16",
    "pcap",
    "mcap",
    "sqlite",
    "ros1bag",
    "cdr",
    "model",
    "adapter",
    "map",
];

/// Runs target `name` on `data`. Panics on an unknown name.
pub fn run(name: &str, data: &[u8]) {
    match name {
        "frames_to_core" => frames_to_core(data),
        "frames_to_host" => frames_to_host(data),
        "world" => world(data),
        "carmen" => carmen_lines(data),
        "vlp16" => vlp16_packets(data),
        "pcap" => pcap(data),
        "mcap" => mcap(data),
        "sqlite" => sqlite(data),
        "ros1bag" => ros1bag(data),
        "cdr" => cdr_messages(data),
        "model" => model(data),
        "adapter" => adapter(data),
        "map" => map(data),
        other => panic!("no fuzz target {other:?} (targets: {})", TARGETS.join(", ")),
    }
}

/// Counts the non-empty runs between `0x00` delimiters that `data` ends: the frames a decoder
/// must account for (fed from empty).
fn frames_ended(data: &[u8]) -> u32 {
    let mut n = 0;
    let mut len = 0usize;
    for &b in data {
        if b == 0 {
            n += (len > 0) as u32;
            len = 0;
        } else {
            len += 1;
        }
    }
    n
}

macro_rules! decoder_target {
    ($name:ident, $dec:ty, $msg:ty) => {
        /// Frames in one direction: the decoder fed `data`; every decoded message re-encodes
        /// and decodes to itself; the counters account for every frame ended.
        pub fn $name(data: &[u8]) {
            let mut dec = Box::new(<$dec>::new());
            let mut scratch = vec![0u8; MAX_FRAME_LEN];
            let mut ended = 0u32;
            for r in dec.feed(data) {
                ended += 1;
                if let Ok(m) = r {
                    let f = encode(&m, &mut scratch).expect("a decoded message always encodes");
                    let mut copy = f[..f.len() - 1].to_vec();
                    let again: $msg = decode_in_place(&mut copy).expect("and decodes again");
                    assert_eq!(again, m);
                }
            }
            assert_eq!(ended, frames_ended(data));
            let c = dec.counters();
            let total = c.frames_ok + c.crc_errors + c.cobs_errors + c.decode_errors + c.overflows;
            assert_eq!(total, ended, "{c:?}");
        }
    };
}

decoder_target!(host_decoder, HostDecoder, firmware::protocol::CoreToHost);
decoder_target!(core_decoder, CoreDecoder, firmware::protocol::HostToCore);

/// Host → core frames: the core's decoder, and a lockstep node with a controller taking the
/// same bytes (sessions, commands, scans in segments, configuration).
pub fn frames_to_core(data: &[u8]) {
    core_decoder(data);
    use firmware::node::{Node, NodeConfig, TimeMode};
    // One controller per thread, brought back to a new one's state before each input (the
    // default configuration, then `reset`: maps, goal, counters, classifier state): building a
    // 1.4 MiB controller per input cost 93 % of the target's time (200 µs of 215 µs per input
    // unfuzzed, ten times that under coverage instrumentation).
    thread_local! {
        static CTL: std::cell::RefCell<Box<firmware::Controller>> =
            std::cell::RefCell::new(Box::new(firmware::Controller::new(firmware::Config::DEFAULT)));
    }
    CTL.with(|c| {
        let ctl = &mut **c.borrow_mut();
        ctl.set_config(firmware::Config::DEFAULT).expect("the default configuration is valid");
        ctl.reset();
        let mut node = Box::new(Node::new(NodeConfig::new(TimeMode::Lockstep)));
        let mut sent = 0usize;
        // In two halves, with a tick between, so a session opened by the first half sees one.
        let (a, b) = data.split_at(data.len() / 2);
        node.receive(a, ctl, |f| sent += f.len());
        node.tick(1_000, ctl, |f| sent += f.len());
        node.receive(b, ctl, |f| sent += f.len());
        node.tick(2_000, ctl, |f| sent += f.len());
    })
}

/// Core → host frames: the host's decoder.
pub fn frames_to_host(data: &[u8]) {
    host_decoder(data);
}

/// A world file: loads or is an error in the format's words, with a line in the file.
pub fn world(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Err(e) = crate::sim::World::from_toml_str(text, "fuzz.toml") {
        let s = e.to_string();
        let lines = text.split('\n').count();
        if let Some(line) = e.line() {
            assert!(line >= 1 && line <= lines, "line {line} of {lines}: {s}");
        }
        // (A name the file itself holds may be quoted back, as in the key `walt RawRectls`.)
        for internal in [
            "RawRect",
            "RawCircle",
            "RawStart",
            "RawWall",
            "RawObstacle",
            "RawTarget",
            "RawPerson",
            "RawWorld",
            "RawKind",
            "i128",
            "struct ",
        ] {
            assert!(text.contains(internal) || !s.contains(internal), "internal name {internal:?} in: {s}");
        }
    }
}

/// CARMEN text: each line through the line parser.
pub fn carmen_lines(data: &[u8]) {
    for line in data.split(|&b| b == b'\n') {
        if let Ok(text) = std::str::from_utf8(line) {
            let _ = carmen::parse_line(text);
        }
    }
}

fn check_scans(scans: &vlp16::PcapScans, beams: usize) {
    for s in scans.scans.iter().chain(&scans.partial) {
        assert_eq!(s.ranges_m.len(), beams);
    }
}

/// VLP-16 UDP payloads: 1206-byte packets into the scan assembler, and the bytes as a raw
/// capture.
pub fn vlp16_packets(data: &[u8]) {
    let cfg = vlp16::Vlp16Config::default();
    let beams = cfg.beams;
    let mut asm = vlp16::ScanAssembler::new(cfg).expect("the default configuration is valid");
    for packet in data.chunks(vlp16::PACKET_LEN) {
        if let Ok(Some(scan)) = asm.push_bytes(packet) {
            assert_eq!(scan.ranges_m.len(), beams);
        }
    }
    if let Some(scan) = asm.finish() {
        assert_eq!(scan.ranges_m.len(), beams);
    }
    if let Ok(scans) = vlp16::CaptureFormat::Raw.decode_bytes(Path::new("fuzz.bin"), data, &cfg) {
        check_scans(&scans, beams);
    }
}

/// A pcap file of VLP-16 datagrams.
pub fn pcap(data: &[u8]) {
    let cfg = vlp16::Vlp16Config::default();
    if let Ok(scans) = vlp16::CaptureFormat::Pcap.decode_bytes(Path::new("fuzz.pcap"), data, &cfg) {
        check_scans(&scans, cfg.beams);
    }
}

/// An MCAP bag: every offset reported lies within the file.
pub fn mcap(data: &[u8]) {
    bag(data, rosbag::read_mcap(Path::new("fuzz.mcap"), data));
}

/// A ROS 1 bag: as `mcap`.
pub fn ros1bag(data: &[u8]) {
    bag(data, rosbag::read_bag1(Path::new("fuzz.bag"), data));
}

/// What a bag read from `data` gave: every offset within the file, then the scan builder.
fn bag(data: &[u8], c: rosbag::BagContents) {
    let within = |e: &ReplayError| match e {
        ReplayError::Bag { offset, .. } | ReplayError::BagChunk { offset, .. } => assert!(*offset <= data.len() as u64, "{e}"),
        other => panic!("not a bag error: {other}"),
    };
    c.error.iter().for_each(within);
    c.bad.first.iter().for_each(within);
    for m in &c.messages {
        if let crate::io::replay::Location::Offset(o) = m.at {
            assert!(o < data.len() as u64);
        }
    }
    // What the bag gave goes on to the scan builder, as in `lives replay`.
    let _ = rosbag::scans_from_messages(Path::new("fuzz.bag"), c.messages);
}

/// A sqlite3 bag: the bytes written to a file of this process's own, then read as `lives
/// replay` reads a `.db3`.
pub fn sqlite(data: &[u8]) {
    thread_local! {
        static PATH: std::path::PathBuf = {
            let dir = if Path::new("/dev/shm").is_dir() { std::path::PathBuf::from("/dev/shm") } else { std::env::temp_dir() };
            dir.join(format!("lives-fuzz-{}-{:?}.db3", std::process::id(), std::thread::current().id()))
        };
    }
    PATH.with(|path| {
        std::fs::write(path, data).expect("writing the scratch file");
        let c = rosbag::read_db3(path);
        let _ = rosbag::scans_from_messages(path, c.messages);
        let _ = std::fs::remove_file(path);
    });
}

/// CDR messages: every decoder on the same bytes (the bags' three with both layouts, and what
/// `lives ros2` reads besides).
pub fn cdr_messages(data: &[u8]) {
    for wire in [cdr::Wire::Cdr, cdr::Wire::Ros1] {
        let _ = cdr::decode_laser_scan(data, wire);
        let _ = cdr::decode_odometry(data, wire);
        let _ = cdr::decode_tf_message(data, wire);
        if let Ok(s) = rosbag::cut(data, wire) {
            assert_eq!(s.ranges.len(), rosbag::CLOUD_BEAMS, "a cloud's cut has the core's beams");
        }
    }
    // What `lives ros2` reads besides (CDR only: ROS 2's wire).
    let _ = cdr::decode_detection2d_array(data);
    let _ = cdr::decode_point_stamped(data);
    let _ = cdr::decode_bool(data);
}

/// A classifier blob of either format: validates or is an error; one that validates installs in
/// a controller as `--model` does.
pub fn model(data: &[u8]) {
    if crate::io::model_file::validate_blob(data).is_ok() {
        // Only blobs that validate are kept for the rest of the process (the controller takes a
        // `'static` blob, as the firmware's embedded ones are); mutations rarely validate.
        let blob: &'static [u8] = Box::leak(data.to_vec().into_boxed_slice());
        let mut ctl = Box::new(firmware::Controller::new(firmware::Config::DEFAULT));
        ctl.set_model(blob).expect("a blob that validates installs");
    }
}

/// The robot adapter's JSON lines, one by one.
pub fn adapter(data: &[u8]) {
    for line in data.split(|&b| b == b'\n') {
        let _ = crate::link::adapter::parse_line(line);
    }
}

/// Separates a `map` input's YAML from its image.
pub const MAP_IMAGE_MARK: &[u8] = b"\n%%IMAGE%%\n";

/// A map_server map: the YAML text, then [`MAP_IMAGE_MARK`] and the image (PGM or PNG). Without
/// the mark the bytes are tried as the YAML (with a 2 x 2 PGM) and as the image (with a good
/// YAML). Errors name the file at fault (and a YAML error's line is within it); a map that
/// loads is resampled onto a small grid.
pub fn map(data: &[u8]) {
    use crate::io::map_file::{MapMeta, PriorMap};
    const YAML: &str = "image: m.pgm\nresolution: 0.05\norigin: [-0.1, 0.2, 0]\n";
    const PGM: &[u8] = b"P5\n2 2\n255\n\x00\xfe\xcd\xfe";
    let one = |yaml: &[u8], image: &[u8]| {
        let text = String::from_utf8_lossy(yaml);
        match MapMeta::parse(&text, "m.yaml") {
            Err(e) => {
                assert_eq!(e.file, "m.yaml", "{e}");
                if let Some(l) = e.line {
                    let lines = crate::io::map_file::yaml_lines(&text);
                    assert!(l >= 1 && l <= lines, "line {l} of {lines}: {e}");
                }
            }
            Ok(meta) => match PriorMap::from_meta(meta, image, "m.yaml", "m.pgm") {
                Err(e) => assert_eq!(e.file, "m.pgm", "{e}"),
                Ok(m) => {
                    assert_eq!(m.cells.len(), m.width * m.height);
                    if let Err(e) = m.to_grid(10.0, 32, [-1.0, -1.0]) {
                        assert_eq!(e.file, "m.yaml", "{e}");
                    }
                }
            },
        }
    };
    match data.windows(MAP_IMAGE_MARK.len()).position(|w| w == MAP_IMAGE_MARK) {
        Some(i) => one(&data[..i], &data[i + MAP_IMAGE_MARK.len()..]),
        None => {
            one(data, PGM);
            one(YAML.as_bytes(), data);
        }
    }
}

/// Deterministic mutations for the campaign in `cargo test`: a seeded xorshift64* and the usual
/// byte-level operators (bit flips, random and boundary bytes, inserted, deleted and repeated
/// runs, truncation, splices with another input, 8-byte little-endian lengths overwritten with
/// large values).
pub struct Mutator(u64);

impl Mutator {
    /// A generator seeded with `seed` (0 is replaced).
    pub fn new(seed: u64) -> Self {
        Mutator(seed.max(1))
    }

    /// The next number of the xorshift64* sequence (a test may draw from it directly, so that a
    /// failure reproduces from the seed).
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A number in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next_u64() % n as u64) as usize
        }
    }

    /// A mutation of `input`, with `other` for splicing; 1 to 4 operators.
    pub fn mutate(&mut self, input: &[u8], other: &[u8]) -> Vec<u8> {
        let mut b = input.to_vec();
        for _ in 0..1 + self.below(4) {
            let len = b.len();
            match self.below(10) {
                0 | 1 if len > 0 => {
                    let i = self.below(len);
                    b[i] ^= 1 << self.below(8);
                }
                2 if len > 0 => {
                    let i = self.below(len);
                    b[i] = self.next_u64() as u8;
                }
                3 if len > 0 => {
                    let i = self.below(len);
                    b[i] = [0x00, 0xff, 0x7f, 0x80, 0x01, b'\n', b'"', b'['][self.below(8)];
                }
                4 => {
                    let i = self.below(len + 1);
                    let n = 1 + self.below(16);
                    let bytes: Vec<u8> = (0..n).map(|_| self.next_u64() as u8).collect();
                    b.splice(i..i, bytes);
                }
                5 if len > 0 => {
                    let i = self.below(len);
                    let n = 1 + self.below((len - i).min(64));
                    b.drain(i..i + n);
                }
                6 if len > 0 => {
                    let i = self.below(len);
                    let n = 1 + self.below((len - i).min(64));
                    let run = b[i..i + n].to_vec();
                    b.splice(i..i, run);
                }
                7 if len > 0 => b.truncate(self.below(len)),
                8 if !other.is_empty() => {
                    let cut = self.below(len + 1);
                    let from = self.below(other.len());
                    b.truncate(cut);
                    b.extend_from_slice(&other[from..]);
                }
                9 if len >= 8 => {
                    let i = self.below(len - 7);
                    let v: u64 = [u64::MAX, 1 << 62, 0x7fff_ffff_ffff_ffff, 1 << 32, 0xffff_ffff, self.next_u64()][self.below(6)];
                    b[i..i + 8].copy_from_slice(&v.to_le_bytes());
                }
                _ => {
                    if len > 0 {
                        let i = self.below(len);
                        b[i] = b[i].wrapping_add(1 + self.below(3) as u8);
                    }
                }
            }
        }
        b
    }
}
