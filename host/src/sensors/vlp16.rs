//! Velodyne VLP-16 ("Puck") data packets → planar scans on the classifier's beam grid.
//!
//! This module owns the VLP-16 wire format and its conversion into a [`PlanarScan`]; it must not
//! know about grids, the controller or the serial link (the bridge feeds the scans onwards).
//!
//! # The data packet (1206 bytes, the UDP payload on port 2368)
//!
//! ```text
//! offset  size  field
//!      0  100   block 0: flag FF EE, azimuth u16 LE (0.01°), 32 × (distance u16 LE, 2 mm; reflectivity u8)
//!    100  100   block 1
//!    ...
//!   1100  100   block 11
//!   1200    4   timestamp u32 LE, µs past the top of the hour (time of block 0's first firing)
//!   1204    1   return mode: 0x37 strongest, 0x38 last, 0x39 dual
//!   1205    1   product id (0x22 for a VLP-16; NOT trusted: captures in the wild say 0x21)
//! ```
//!
//! Channels 0–15 of a block are one firing of the 16 lasers, channels 16–31 the next firing of the
//! same lasers 55.296 µs later. Laser elevations by channel are [`ELEVATION_DEG`]. The second
//! firing's azimuth is interpolated halfway to the next block's azimuth (in dual-return mode the
//! next *pair* of blocks: blocks 2k and 2k+1 are the strongest and last returns of the same two
//! firings and carry the same azimuth). The last block (pair) of a packet reuses the step of the
//! previous one. A distance of 0 means "no return".
//!
//! # Frames and the beam grid
//!
//! The VLP-16 measures azimuth clockwise seen from above, 0 along its own +Y axis (the side
//! opposite the cable). The scan is published in the frame the ROS `velodyne` driver uses
//! (REP-103): x = the sensor's +Y (azimuth 0), y = the sensor's −X, z up, so a return at azimuth
//! `a` lies at yaw `θ = −a` (counter-clockwise positive). Beam `b` of a scan is at
//! `θ_b = −π + b·2π/beams` (the core's `BeamScan` grid), and a firing goes to the beam nearest its
//! yaw. Each beam keeps the nearest valid horizontal range `distance · cos(elevation)` over the
//! selected lasers ([`Vlp16Config`]'s elevation band) and every firing in the rotation.
//!
//! A scan ends each time the azimuth wraps past 360° (one rotation), so the first scan after a
//! start is usually partial; beams nothing fired into are `NaN`, beams where lasers fired but got
//! no return (or only returns beyond `max_range_m`) are `+∞` — the ROS `LaserScan` conventions.
//! Returns closer than `min_range_m` (the robot's own body) are dropped as if the laser had not
//! fired: they say nothing about the space beyond.
//!
//! Conversions are exact integer arithmetic up to the final `f32` range: azimuths are kept in
//! 0.005° units so the halfway interpolation is exact, and the bin is a rounded integer division.

use std::fmt;
use std::io::{self, Read};
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Length of a VLP-16 data packet (the UDP payload).
pub const PACKET_LEN: usize = 1206;
/// Data blocks per packet.
pub const BLOCKS: usize = 12;
/// Bytes per data block.
pub const BLOCK_LEN: usize = 100;
/// Channels (distance + reflectivity) per block: two firings of 16 lasers.
pub const CHANNELS_PER_BLOCK: usize = 32;
/// Lasers of the VLP-16.
pub const LASERS: usize = 16;
/// The block flag, bytes `FF EE` on the wire.
pub const BLOCK_FLAG: [u8; 2] = [0xFF, 0xEE];
/// Velodyne's default UDP port for data packets.
pub const DATA_PORT: u16 = 2368;
/// Velodyne's default UDP port for position (GPS/IMU) packets, which are not decoded here.
pub const POSITION_PORT: u16 = 8308;
/// One distance unit in metres.
pub const DISTANCE_UNIT_M: f64 = 0.002;
/// Azimuth units (0.01°) in a full turn.
pub const AZIMUTH_TURN: u32 = 36_000;
/// Time between two firings of the 16 lasers, nanoseconds (VLP-16 manual: 55.296 µs).
pub const FIRING_PERIOD_NS: u64 = 55_296;
/// Largest azimuth step between consecutive blocks (pairs) a packet may contain, in 0.01°.
/// At the fastest rotation (20 Hz) a block is ~0.8° apart; anything above 5° is a corrupt azimuth
/// (interpolating across it would smear the firings over the jump).
pub const MAX_BLOCK_STEP: u32 = 500;
/// Elevation of the laser on each channel, degrees (channels 16–31 repeat channels 0–15).
pub const ELEVATION_DEG: [i8; LASERS] = [-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15];

/// Field offsets inside the packet and a block.
pub mod field {
    use core::ops::Range;
    /// Block flag, relative to the block start.
    pub const FLAG: Range<usize> = 0..2;
    /// Block azimuth, relative to the block start.
    pub const AZIMUTH: Range<usize> = 2..4;
    /// First channel, relative to the block start; each channel is 3 bytes.
    pub const CHANNELS: usize = 4;
    /// Bytes per channel (distance u16, reflectivity u8).
    pub const CHANNEL_LEN: usize = 3;
    /// Timestamp (µs past the hour), relative to the packet start.
    pub const TIMESTAMP: Range<usize> = 1200..1204;
    /// Return mode byte.
    pub const RETURN_MODE: usize = 1204;
    /// Product id byte.
    pub const PRODUCT: usize = 1205;
}

/// The return mode byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReturnMode {
    /// 0x37: the strongest return of each firing.
    Strongest,
    /// 0x38: the last return of each firing.
    Last,
    /// 0x39: both; blocks come in pairs with the same azimuth.
    Dual,
}

impl ReturnMode {
    /// The mode for a return-mode byte, if it is one of the three the VLP-16 sends.
    pub fn from_byte(b: u8) -> Option<Self> {
        match b {
            0x37 => Some(Self::Strongest),
            0x38 => Some(Self::Last),
            0x39 => Some(Self::Dual),
            _ => None,
        }
    }

    /// Blocks per firing pair: 2 in dual mode, 1 otherwise.
    pub fn block_stride(self) -> usize {
        if self == Self::Dual {
            2
        } else {
            1
        }
    }
}

/// Why a datagram is not a VLP-16 data packet.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum PacketError {
    /// The payload is not 1206 bytes long.
    Length { len: usize },
    /// A block does not start with `FF EE`.
    BlockFlag { block: usize, found: [u8; 2] },
    /// A block azimuth is 360° or more.
    Azimuth { block: usize, azimuth: u16 },
    /// The return-mode byte is none of 0x37, 0x38, 0x39.
    ReturnMode(u8),
    /// Dual-return mode, but the two blocks of a pair have different azimuths.
    DualPair { block: usize },
    /// Consecutive blocks (pairs) are more than [`MAX_BLOCK_STEP`] apart.
    AzimuthStep { block: usize, step: u32 },
}

impl fmt::Display for PacketError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Length { len } => write!(f, "payload is {len} bytes, a VLP-16 data packet has {PACKET_LEN}"),
            Self::BlockFlag { block, found } => {
                write!(f, "block {block} starts with {:02X} {:02X}, expected FF EE", found[0], found[1])
            }
            Self::Azimuth { block, azimuth } => write!(f, "block {block} azimuth {azimuth} is not below 36000 (0.01°)"),
            Self::ReturnMode(b) => write!(f, "return mode byte 0x{b:02X} is none of 0x37, 0x38, 0x39"),
            Self::DualPair { block } => write!(f, "dual-return blocks {block} and {} have different azimuths", block + 1),
            Self::AzimuthStep { block, step } => {
                write!(f, "azimuth jumps {:.2}° at block {block} (more than {:.0}°)", *step as f64 / 100.0, MAX_BLOCK_STEP as f64 / 100.0)
            }
        }
    }
}

impl std::error::Error for PacketError {}

/// A checked view over the bytes of one data packet (smoltcp style): construct it with
/// [`Vlp16Packet::new_checked`], then read fields without further bounds checks failing.
#[derive(Debug, Clone, Copy)]
pub struct Vlp16Packet<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Vlp16Packet<T> {
    /// Wraps bytes without checking them; field accessors panic on a short buffer.
    pub fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps bytes after [`check`](Self::check).
    pub fn new_checked(buffer: T) -> Result<Self, PacketError> {
        let p = Self::new_unchecked(buffer);
        p.check()?;
        Ok(p)
    }

    /// Validates the length, the 12 block flags, the azimuths (below 360°, steps of at most
    /// [`MAX_BLOCK_STEP`], equal within dual-mode pairs) and the return-mode byte. The product
    /// byte is not checked.
    pub fn check(&self) -> Result<(), PacketError> {
        let b = self.buffer.as_ref();
        if b.len() != PACKET_LEN {
            return Err(PacketError::Length { len: b.len() });
        }
        for block in 0..BLOCKS {
            let at = block * BLOCK_LEN;
            let found = [b[at + field::FLAG.start], b[at + field::FLAG.start + 1]];
            if found != BLOCK_FLAG {
                return Err(PacketError::BlockFlag { block, found });
            }
            let azimuth = self.azimuth(block);
            if azimuth as u32 >= AZIMUTH_TURN {
                return Err(PacketError::Azimuth { block, azimuth });
            }
        }
        let mode = self.return_mode().ok_or(PacketError::ReturnMode(self.return_mode_byte()))?;
        let stride = mode.block_stride();
        if stride == 2 {
            for block in (0..BLOCKS).step_by(2) {
                if self.azimuth(block) != self.azimuth(block + 1) {
                    return Err(PacketError::DualPair { block });
                }
            }
        }
        for block in (stride..BLOCKS).step_by(stride) {
            let step = azimuth_diff(self.azimuth(block - stride), self.azimuth(block));
            if step > MAX_BLOCK_STEP {
                return Err(PacketError::AzimuthStep { block, step });
            }
        }
        Ok(())
    }

    /// The underlying bytes.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// Block azimuth in 0.01° (clockwise from the sensor's +Y).
    pub fn azimuth(&self, block: usize) -> u16 {
        let at = block * BLOCK_LEN + field::AZIMUTH.start;
        let b = self.buffer.as_ref();
        u16::from_le_bytes([b[at], b[at + 1]])
    }

    /// Distance of `channel` (0–31) in `block`, in 2 mm units; 0 = no return.
    pub fn distance(&self, block: usize, channel: usize) -> u16 {
        let at = block * BLOCK_LEN + field::CHANNELS + channel * field::CHANNEL_LEN;
        let b = self.buffer.as_ref();
        u16::from_le_bytes([b[at], b[at + 1]])
    }

    /// Calibrated reflectivity of `channel` in `block` (0–255).
    pub fn reflectivity(&self, block: usize, channel: usize) -> u8 {
        self.buffer.as_ref()[block * BLOCK_LEN + field::CHANNELS + channel * field::CHANNEL_LEN + 2]
    }

    /// Timestamp of block 0's first firing, µs past the top of the hour.
    pub fn timestamp_us(&self) -> u32 {
        let b = self.buffer.as_ref();
        u32::from_le_bytes([b[1200], b[1201], b[1202], b[1203]])
    }

    /// The raw return-mode byte.
    pub fn return_mode_byte(&self) -> u8 {
        self.buffer.as_ref()[field::RETURN_MODE]
    }

    /// The return mode, if the byte is a known one.
    pub fn return_mode(&self) -> Option<ReturnMode> {
        ReturnMode::from_byte(self.return_mode_byte())
    }

    /// The product byte (not trusted; see the module docs).
    pub fn product_id(&self) -> u8 {
        self.buffer.as_ref()[field::PRODUCT]
    }

    /// Azimuth of firing `firing` (0 or 1) of `block` in 0.005° units, `[0, 72000)`: the block's
    /// azimuth for the first firing, halfway to the next block (pair) for the second.
    /// Requires a checked packet.
    pub fn firing_azimuth_half(&self, block: usize, firing: usize) -> u32 {
        let a = 2 * self.azimuth(block) as u32;
        if firing == 0 {
            return a;
        }
        let stride = self.return_mode().map_or(1, ReturnMode::block_stride);
        let group = block - block % stride;
        let step = if group + stride < BLOCKS {
            azimuth_diff(self.azimuth(group), self.azimuth(group + stride))
        } else {
            azimuth_diff(self.azimuth(group - stride), self.azimuth(group))
        };
        // Halfway in 0.01° is `step` in 0.005° units: exact.
        (a + step) % (2 * AZIMUTH_TURN)
    }

    /// Time of firing `firing` of `block` after the packet's timestamp, in nanoseconds.
    pub fn firing_offset_ns(&self, block: usize, firing: usize) -> u64 {
        let stride = self.return_mode().map_or(1, ReturnMode::block_stride);
        ((block / stride) * 2 + firing) as u64 * FIRING_PERIOD_NS
    }
}

/// Clockwise azimuth step from `a` to `b` in 0.01°, across the 36000 wrap.
fn azimuth_diff(a: u16, b: u16) -> u32 {
    (b as u32 + AZIMUTH_TURN - a as u32) % AZIMUTH_TURN
}

/// Whether a data packet starts at `bytes[0]`: of the first 1206 bytes, every block flag (`FF EE`
/// every 100 bytes) and the return-mode byte that lie within `bytes` are right, and there is at
/// least block 0's flag. For a whole packet that is all twelve flags and a known return mode, the
/// framing [`Vlp16Packet::check`] looks at first (azimuths and the product byte are not looked at);
/// for fewer bytes, whether they could be the start of one cut by the end of a file. A raw payload
/// file resynchronises on this after damage.
pub fn frames_packet(bytes: &[u8]) -> bool {
    let b = &bytes[..bytes.len().min(PACKET_LEN)];
    b.len() >= BLOCK_FLAG.len()
        && (0..BLOCKS).map(|k| k * BLOCK_LEN + field::FLAG.start).filter(|&at| at + 2 <= b.len()).all(|at| b[at..at + 2] == BLOCK_FLAG)
        && b.get(field::RETURN_MODE).is_none_or(|&m| ReturnMode::from_byte(m).is_some())
}

/// What the scan assembler keeps: which lasers, how many beams, which ranges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vlp16Config {
    /// Lowest laser elevation used, degrees (inclusive).
    pub elevation_min_deg: f64,
    /// Highest laser elevation used, degrees (inclusive).
    pub elevation_max_deg: f64,
    /// Beams over 360° (the classifier's grid: 897).
    pub beams: usize,
    /// Returns with a horizontal range below this are dropped (the robot's own body), metres.
    pub min_range_m: f64,
    /// Returns with a horizontal range above this count as no return, metres (VLP-16: 100 m).
    pub max_range_m: f64,
}

impl Default for Vlp16Config {
    /// The two near-horizontal lasers (−1° and +1°) onto 897 beams, 0.3–100 m.
    fn default() -> Self {
        Self { elevation_min_deg: -1.0, elevation_max_deg: 1.0, beams: firmware::capacity::BEAMS, min_range_m: 0.3, max_range_m: 100.0 }
    }
}

impl Vlp16Config {
    /// Channels 0–15 whose laser lies in the elevation band.
    pub fn lasers(&self) -> Vec<usize> {
        (0..LASERS)
            .filter(|&c| {
                let e = ELEVATION_DEG[c] as f64;
                e >= self.elevation_min_deg && e <= self.elevation_max_deg
            })
            .collect()
    }

    /// Checks the band selects a laser, the beam count and the range limits.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let (lo, hi) = (self.elevation_min_deg, self.elevation_max_deg);
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return Err(ConfigError::EmptyBand { min_deg: self.elevation_min_deg, max_deg: self.elevation_max_deg });
        }
        if self.lasers().is_empty() {
            return Err(ConfigError::NoLaser { min_deg: self.elevation_min_deg, max_deg: self.elevation_max_deg });
        }
        if self.beams == 0 || self.beams > 36_000 {
            return Err(ConfigError::Beams(self.beams));
        }
        if !(self.min_range_m >= 0.0 && self.min_range_m < self.max_range_m && self.max_range_m.is_finite()) {
            return Err(ConfigError::Range { min_m: self.min_range_m, max_m: self.max_range_m });
        }
        Ok(())
    }
}

/// A [`Vlp16Config`] that cannot work.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum ConfigError {
    /// The band's minimum is above its maximum (or not a number).
    EmptyBand { min_deg: f64, max_deg: f64 },
    /// No laser's elevation lies in the band.
    NoLaser { min_deg: f64, max_deg: f64 },
    /// The beam count is 0 or above 36000 (one per 0.01°).
    Beams(usize),
    /// The range limits are negative, unordered or infinite.
    Range { min_m: f64, max_m: f64 },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::EmptyBand { min_deg, max_deg } => write!(f, "elevation band {min_deg}..{max_deg}° is empty"),
            Self::NoLaser { min_deg, max_deg } => {
                write!(f, "no VLP-16 laser lies in the elevation band {min_deg}..{max_deg}° (lasers are at ±1, ±3, …, ±15°)")
            }
            Self::Beams(n) => write!(f, "{n} beams: expected 1 to 36000"),
            Self::Range { min_m, max_m } => write!(f, "range limits {min_m}..{max_m} m: need 0 ≤ min < max < ∞"),
        }
    }
}

impl std::error::Error for ConfigError {}

/// One rotation on a beam grid, in the sensor frame (REP-103, see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarScan {
    /// Sensor time of the scan's first firing: µs past the top of the hour of the stream's first
    /// packet, counting on across hours.
    pub stamp_us: u64,
    /// Angle of beam 0 (−π), radians.
    pub angle_min_rad: f64,
    /// Angle between beams (2π / beams), radians.
    pub angle_increment_rad: f64,
    /// One per beam: nearest horizontal range in metres; `+∞` fired but no return; `NaN` nothing fired.
    pub ranges_m: Vec<f32>,
    /// The configured minimum and maximum range ([`Vlp16Config`]), metres: the scan's `range_min`
    /// and `range_max`.
    pub range_limits_m: [f64; 2],
}

impl PlanarScan {
    /// Beams with a finite range.
    pub fn valid_beams(&self) -> usize {
        self.ranges_m.iter().filter(|r| r.is_finite()).count()
    }

    /// Beams where lasers fired without a return within range (`+∞`).
    pub fn no_return_beams(&self) -> usize {
        self.ranges_m.iter().filter(|r| r.is_infinite()).count()
    }

    /// Beams nothing fired into (`NaN`).
    pub fn unseen_beams(&self) -> usize {
        self.ranges_m.iter().filter(|r| r.is_nan()).count()
    }

    /// Yaw of beam `b` in the sensor frame, radians.
    pub fn beam_angle_rad(&self, b: usize) -> f64 {
        self.angle_min_rad + b as f64 * self.angle_increment_rad
    }
}

/// Beam of a firing at `azimuth_half` (0.005° units, clockwise from the sensor's +Y) on a grid of
/// `beams` beams starting at −π in the REP-103 frame (yaw = −azimuth). Rounds to the nearest beam.
pub fn beam_of_azimuth(azimuth_half: u32, beams: usize) -> usize {
    let turn = 2 * AZIMUTH_TURN as u64; // 72000 units
                                        // Yaw + π in units: (−a + 180°) mod 360°.
    let u = (turn / 2 + turn - azimuth_half as u64 % turn) % turn;
    ((u * beams as u64 + turn / 2) / turn) as usize % beams
}

/// Turns "µs past the hour" timestamps into a count that goes on across hours.
#[derive(Debug, Clone, Copy, Default)]
struct HourClock {
    hours: u64,
    last_us: Option<u32>,
}

const HOUR_US: u64 = 3_600_000_000;

impl HourClock {
    fn unwrap(&mut self, us: u32) -> u64 {
        if let Some(last) = self.last_us {
            // A drop of more than half an hour is the top of the hour, not jitter or reordering.
            if (last as u64) > us as u64 + HOUR_US / 2 {
                self.hours += 1;
            }
        }
        self.last_us = Some(us);
        self.hours * HOUR_US + us as u64
    }
}

/// Gathers the firings of successive packets into one [`PlanarScan`] per rotation.
#[derive(Debug, Clone)]
pub struct ScanAssembler {
    cfg: Vlp16Config,
    /// Selected channels (0–15) and cos(elevation).
    lasers: Vec<(usize, f64)>,
    /// The rotation in progress: nearest range per beam (NaN until something fires into it).
    ranges: Vec<f32>,
    /// Whether any firing has gone into the current scan.
    open: bool,
    stamp_us: u64,
    last_azimuth_half: Option<u32>,
    clock: HourClock,
}

impl ScanAssembler {
    /// A new assembler; the configuration is validated.
    pub fn new(cfg: Vlp16Config) -> Result<Self, ConfigError> {
        cfg.validate()?;
        let lasers = cfg.lasers().into_iter().map(|c| (c, (ELEVATION_DEG[c] as f64).to_radians().cos())).collect();
        Ok(Self {
            cfg,
            lasers,
            ranges: vec![f32::NAN; cfg.beams],
            open: false,
            stamp_us: 0,
            last_azimuth_half: None,
            clock: HourClock::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &Vlp16Config {
        &self.cfg
    }

    /// Channels (0–15) of the lasers in use.
    pub fn lasers(&self) -> Vec<usize> {
        self.lasers.iter().map(|&(c, _)| c).collect()
    }

    /// Checks and adds one packet's bytes; returns the scan completed by an azimuth wrap in it.
    pub fn push_bytes(&mut self, bytes: &[u8]) -> Result<Option<PlanarScan>, PacketError> {
        let p = Vlp16Packet::new_checked(bytes)?;
        Ok(self.push(&p))
    }

    /// Adds the firings of a checked packet in order; when the azimuth wraps (one rotation ends),
    /// the finished scan is returned and the packet's remaining firings start the next one.
    /// Checked packets move less than 60° and so wrap at most once.
    pub fn push<T: AsRef<[u8]>>(&mut self, p: &Vlp16Packet<T>) -> Option<PlanarScan> {
        let t0_us = self.clock.unwrap(p.timestamp_us());
        let mut done = None;
        let half_turn = AZIMUTH_TURN; // 180° in 0.005° units
        let stride = p.return_mode().map_or(1, ReturnMode::block_stride);
        // In time order: in dual mode both blocks of a pair hold the same firing.
        for group in (0..BLOCKS).step_by(stride) {
            for firing in 0..2 {
                for block in group..group + stride {
                    let az = p.firing_azimuth_half(block, firing);
                    // A drop of more than half a turn is the wrap past 360°.
                    if self.open && self.last_azimuth_half.is_some_and(|last| last > az + half_turn) {
                        done = done.or(Some(self.take()));
                    }
                    self.last_azimuth_half = Some(az);
                    if !self.open {
                        self.open = true;
                        self.stamp_us = t0_us + p.firing_offset_ns(block, firing) / 1000;
                    }
                    self.bin(p, block, firing, az);
                }
            }
        }
        done
    }

    /// Puts one firing's selected lasers into the beam of `az`, keeping the nearest range.
    fn bin<T: AsRef<[u8]>>(&mut self, p: &Vlp16Packet<T>, block: usize, firing: usize, az: u32) {
        let slot = &mut self.ranges[beam_of_azimuth(az, self.cfg.beams)];
        for &(laser, cos_el) in &self.lasers {
            let d = p.distance(block, firing * LASERS + laser);
            let r = d as f64 * DISTANCE_UNIT_M * cos_el;
            if d != 0 && r < self.cfg.min_range_m {
                continue; // The robot's own body: as if the laser had not fired.
            }
            let r = if d == 0 || r > self.cfg.max_range_m { f32::INFINITY } else { r as f32 };
            // Keep the nearest: NaN (unseen) and +∞ (no return) yield to anything smaller.
            if slot.is_nan() || r < *slot {
                *slot = r;
            }
        }
    }

    /// The rotation in progress, if any firing went into it (e.g. at the end of a capture); the
    /// assembler starts afresh.
    pub fn finish(&mut self) -> Option<PlanarScan> {
        if self.open {
            Some(self.take())
        } else {
            None
        }
    }

    fn take(&mut self) -> PlanarScan {
        let n = self.cfg.beams;
        let ranges_m = std::mem::replace(&mut self.ranges, vec![f32::NAN; n]);
        self.open = false;
        PlanarScan {
            stamp_us: self.stamp_us,
            angle_min_rad: -std::f64::consts::PI,
            angle_increment_rad: std::f64::consts::TAU / n as f64,
            ranges_m,
            range_limits_m: [self.cfg.min_range_m, self.cfg.max_range_m],
        }
    }
}

/// Every way reading VLP-16 data can fail. File errors name the file and the byte offset.
#[derive(Debug)]
#[non_exhaustive]
pub enum Vlp16Error {
    /// The configuration cannot work.
    Config(ConfigError),
    /// Opening or reading a file, or the socket.
    Io { path: Option<PathBuf>, source: io::Error },
    /// The pcap file could not be read ([`super::pcap::CaptureError`]).
    Capture(super::pcap::CaptureError),
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

impl From<super::pcap::CaptureError> for Vlp16Error {
    fn from(e: super::pcap::CaptureError) -> Self {
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

/// Reads a classic pcap capture: UDP datagrams to [`DATA_PORT`] are decoded, other traffic
/// (position packets on 8308, anything else) is counted and ignored, invalid data packets are
/// counted and skipped. A truncated or corrupt record ends the read with `error` set and the scans
/// before it kept. `Err` only when nothing could be read (no file, not a pcap, unusable header).
pub fn read_pcap(path: &Path, cfg: &Vlp16Config) -> Result<PcapScans, Vlp16Error> {
    collect(|on_scan| stream_pcap(path, open(path)?, cfg, on_scan))
}

/// [`read_pcap`] on bytes already in memory (`path` names them in errors).
pub fn decode_pcap_bytes(path: &Path, bytes: &[u8], cfg: &Vlp16Config) -> Result<PcapScans, Vlp16Error> {
    collect(|on_scan| stream_pcap(path, bytes, cfg, on_scan))
}

/// [`read_pcap`] without keeping the scans: each completed scan goes to `on_scan` as soon as it is
/// complete, and the returned `scans` is empty. Reads `reader` a chunk at a time.
pub fn stream_pcap<R: Read>(
    path: &Path,
    reader: R,
    cfg: &Vlp16Config,
    on_scan: &mut dyn FnMut(PlanarScan),
) -> Result<PcapScans, Vlp16Error> {
    use super::pcap::{Frame, PcapStream, Record};
    let mut dec = Decoder::new(*cfg)?;
    let mut stream = PcapStream::new(path, reader)?;
    let mut error = None;
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
            Err(e) => {
                error = Some(Vlp16Error::from(e));
                break;
            }
        }
    }
    Ok(dec.into_scans(path, error))
}

/// Reads a file of raw 1206-byte payloads back to back (no framing, e.g.
/// `einride_vlp16_recording.bin`). A packet whose framing is right ([`frames_packet`]) is decoded,
/// or counted and skipped when a later check fails (an azimuth). After a packet whose framing is
/// wrong the reader resynchronises: it goes on at the next offset where a packet's framing is
/// right. If that is exactly one packet on (or the end of the file, after an earlier packet), the
/// stream is still in step and the packet is counted as rejected; otherwise the bytes up to it
/// (inserted, lost or garbage) are counted in `skipped_bytes` and `skips`, and reading goes on.
/// A file that ends inside a packet sets `error` (the scans before it are kept). `Err` when the
/// file cannot be read, is empty, or frames no packet at any offset ([`Vlp16Error::NoPacket`]).
pub fn read_raw(path: &Path, cfg: &Vlp16Config) -> Result<PcapScans, Vlp16Error> {
    collect(|on_scan| stream_raw(path, open(path)?, cfg, on_scan))
}

/// [`read_raw`] on bytes already in memory.
pub fn decode_raw_bytes(path: &Path, bytes: &[u8], cfg: &Vlp16Config) -> Result<PcapScans, Vlp16Error> {
    collect(|on_scan| stream_raw(path, bytes, cfg, on_scan))
}

/// [`read_raw`] without keeping the scans (see [`stream_pcap`]).
pub fn stream_raw<R: Read>(
    path: &Path,
    reader: R,
    cfg: &Vlp16Config,
    on_scan: &mut dyn FnMut(PlanarScan),
) -> Result<PcapScans, Vlp16Error> {
    let mut dec = Decoder::new(*cfg)?;
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
    Ok(dec.into_scans(path, error))
}

/// The first `i` from which `window` frames a packet ([`frames_packet`]). Before the end of the
/// file only offsets with a whole packet after them are tried; at the end (`eof`), also the start
/// of a packet cut by it.
fn next_packet_start(window: &[u8], eof: bool) -> Option<usize> {
    let last = if eof { window.len().checked_sub(BLOCK_FLAG.len())? } else { window.len().checked_sub(PACKET_LEN)? };
    (0..=last).find(|&i| window[i..i + 2] == BLOCK_FLAG && frames_packet(&window[i..]))
}

/// A window on a raw payload file: `buf[0]` is file byte `base`; `buf[pos..end]` is read and not
/// yet consumed. The buffer is allocated once (zeroing a fresh chunk per read, at the host's
/// opt-level, cost more than decoding).
struct RawWindow<R: Read> {
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
            let got = super::pcap::read_full(&mut self.reader, &mut self.buf[self.end..]);
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
const RAW_CHUNK: usize = 256 * 1024;

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

/// [`read_capture`] without keeping the scans (see [`stream_pcap`]).
pub fn stream_capture(
    path: &Path,
    cfg: &Vlp16Config,
    on_scan: &mut dyn FnMut(PlanarScan),
) -> Result<(CaptureFormat, PcapScans), Vlp16Error> {
    let mut file = open(path)?;
    let mut magic = [0u8; 4];
    let n = super::pcap::read_full(&mut file, &mut magic).map_err(|source| Vlp16Error::Io { path: Some(path.to_path_buf()), source })?;
    let reader = io::Read::chain(&magic[..n], file);
    if super::pcap::looks_like_pcap(&magic[..n]) {
        Ok((CaptureFormat::Pcap, stream_pcap(path, reader, cfg, on_scan)?))
    } else {
        Ok((CaptureFormat::Raw, stream_raw(path, reader, cfg, on_scan)?))
    }
}

fn open(path: &Path) -> Result<std::fs::File, Vlp16Error> {
    std::fs::File::open(path).map_err(|source| Vlp16Error::Io { path: Some(path.to_path_buf()), source })
}

/// Runs a streaming reader and keeps its scans.
fn collect(run: impl FnOnce(&mut dyn FnMut(PlanarScan)) -> Result<PcapScans, Vlp16Error>) -> Result<PcapScans, Vlp16Error> {
    let mut scans = Vec::new();
    let mut r = run(&mut |s| scans.push(s))?;
    r.scans = scans;
    Ok(r)
}

/// Which reader [`read_capture`] used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaptureFormat {
    /// Classic pcap.
    Pcap,
    /// Raw 1206-byte payloads back to back.
    Raw,
}

/// A live VLP-16 on UDP: bind to the data port and receive one scan per rotation.
///
/// A sensor broadcasts its data packets to port 2368; bind `0.0.0.0:2368` (or the address of the
/// interface the sensor is on) to hear one. Datagrams that are not data packets are counted as
/// rejected and skipped.
#[derive(Debug)]
pub struct Vlp16Udp {
    socket: UdpSocket,
    dec: Decoder,
    datagrams: u64,
    buf: Vec<u8>,
}

impl Vlp16Udp {
    /// Binds a socket (port 0 picks a free one: see [`local_addr`](Self::local_addr)).
    /// An unusable configuration is an `InvalidInput` error.
    pub fn bind(addr: SocketAddr, cfg: Vlp16Config) -> io::Result<Self> {
        let dec = Decoder::new(cfg).map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        let socket = UdpSocket::bind(addr)?;
        Ok(Self { socket, dec, datagrams: 0, buf: vec![0; 2048] })
    }

    /// The address bound.
    pub fn local_addr(&self) -> io::Result<SocketAddr> {
        self.socket.local_addr()
    }

    /// Datagrams by fate so far (`offset` of a [`Rejected`] is the datagram's index).
    pub fn counts(&self) -> PacketCounts {
        self.dec.counts
    }

    /// The first rejected datagrams.
    pub fn rejects(&self) -> &[Rejected] {
        &self.dec.rejects
    }

    /// Waits up to `timeout` for a rotation to end and returns it; `None` on timeout (the
    /// rotation in progress is kept for the next call).
    pub fn recv_scan(&mut self, timeout: Duration) -> Result<Option<PlanarScan>, Vlp16Error> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.socket.set_read_timeout(Some(left)).map_err(|source| Vlp16Error::Io { path: None, source })?;
            match self.socket.recv_from(&mut self.buf) {
                Ok((n, _from)) => {
                    let index = self.datagrams;
                    self.datagrams += 1;
                    let Self { dec, buf, .. } = self;
                    if let Some(scan) = dec.payload(index, &buf[..n]) {
                        return Ok(Some(scan));
                    }
                }
                Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut | io::ErrorKind::Interrupted) => {}
                Err(source) => return Err(Vlp16Error::Io { path: None, source }),
            }
        }
    }
}

/// Throughput of decode + binning measured by [`bench_decode`].
#[derive(Debug, Clone, Copy)]
pub struct DecodeBench {
    /// Packets per repetition.
    pub packets: usize,
    /// Median wall time of one repetition, milliseconds.
    pub median_ms: f64,
    /// Packets per second at the median.
    pub packets_per_s: f64,
}

/// The recorded VLP-16 payloads the benchmark and tests use (`tests/data/velodyne/`).
pub fn default_recording() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/velodyne/einride_vlp16_recording.bin")
}

/// Times checking, decoding and binning the payloads of `path` (raw format) into scans with the
/// default configuration, `reps` times; `None` if the file cannot be read.
pub fn bench_decode(path: &Path, reps: usize) -> Option<DecodeBench> {
    let bytes = std::fs::read(path).ok()?;
    let packets = bytes.len() / PACKET_LEN;
    let mut times = Vec::with_capacity(reps.max(1));
    let mut scans = 0;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let r = decode_raw_bytes(path, &bytes, &Vlp16Config::default()).ok()?;
        scans = std::hint::black_box(r.scans.len());
        times.push(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(scans);
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    Some(DecodeBench { packets, median_ms: median * 1e3, packets_per_s: packets as f64 / median })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strongest-return packet built by hand: block `k` at azimuth 100·k + 35950 (mod 36000), i.e.
    /// 359.50°, 0.50°, 1.50°, … so block 1 wraps; channel `c` of block `k` has distance
    /// `1000 + 10·k + c` (2 mm units), except channel 14 (−1°) of block 0 = 0 (no return) and
    /// channel 1 (+1°) of block 2's second firing (channel 17) = 100 (0.2 m, below min range).
    fn golden_packet() -> [u8; PACKET_LEN] {
        let mut p = [0u8; PACKET_LEN];
        for k in 0..BLOCKS {
            let at = k * BLOCK_LEN;
            p[at..at + 2].copy_from_slice(&BLOCK_FLAG);
            let az = ((35_950 + 100 * k) % 36_000) as u16;
            p[at + 2..at + 4].copy_from_slice(&az.to_le_bytes());
            for c in 0..CHANNELS_PER_BLOCK {
                let d: u16 = match (k, c) {
                    (0, 14) => 0,
                    (2, 17) => 100,
                    _ => 1000 + 10 * k as u16 + c as u16,
                };
                let o = at + 4 + 3 * c;
                p[o..o + 2].copy_from_slice(&d.to_le_bytes());
                p[o + 2] = c as u8;
            }
        }
        p[1200..1204].copy_from_slice(&1_000_000u32.to_le_bytes());
        p[1204] = 0x37;
        p[1205] = 0x22;
        p
    }

    #[test]
    fn golden_packet_fields() {
        let bytes = golden_packet();
        // The first bytes as they are on the wire: FF EE, 35950 = 0x8C6E LE, channel 0 = 1000 = 0x03E8 LE,
        // reflectivity 0, then channel 1 = 1001 = 0x03E9 LE.
        assert_eq!(&bytes[..8], &[0xFF, 0xEE, 0x6E, 0x8C, 0xE8, 0x03, 0x00, 0xE9]);
        let p = Vlp16Packet::new_checked(&bytes[..]).unwrap();
        assert_eq!(p.azimuth(0), 35_950);
        assert_eq!(p.azimuth(1), 50);
        assert_eq!(p.azimuth(11), 1_050);
        assert_eq!(p.distance(3, 5), 1035);
        assert_eq!(p.reflectivity(3, 5), 5);
        assert_eq!(p.timestamp_us(), 1_000_000);
        assert_eq!(p.return_mode(), Some(ReturnMode::Strongest));
        assert_eq!(p.product_id(), 0x22);
        // Firing azimuths in 0.005°: block 0 second firing halfway across the wrap: 359.50° + 0.50° = 0.00°.
        assert_eq!(p.firing_azimuth_half(0, 0), 71_900);
        assert_eq!(p.firing_azimuth_half(0, 1), 0);
        assert_eq!(p.firing_azimuth_half(1, 1), 200); // 0.50° + 0.50°
                                                      // The last block reuses the previous step (1°): 10.50° + 0.50°.
        assert_eq!(p.firing_azimuth_half(11, 1), 2_200);
        assert_eq!(p.firing_offset_ns(11, 1), 23 * 55_296);
    }

    #[test]
    fn beam_grid_convention() {
        // 897 beams over 360°: beam b at −π + b·2π/897. Azimuth 0 (sensor +Y) is straight ahead
        // (yaw 0), i.e. beam 448.5 → rounds up to 449 (−π + 449·0.40134° = +0.2007°, nearer than 448 at −0.2007°? equal:
        // 0 sits exactly between; round half up gives 449).
        assert_eq!(beam_of_azimuth(0, 897), 449);
        // Azimuth 90° (clockwise: the sensor's right, +X) is yaw −90° = −π/2: beam (π/2)/(2π/897) = 224.25 → 224.
        assert_eq!(beam_of_azimuth(18_000, 897), 224);
        // Azimuth 270° (left) is yaw +90°: beam 672.75 → 673.
        assert_eq!(beam_of_azimuth(54_000, 897), 673);
        // Azimuth 180° (behind) is yaw ±π: beam 0.
        assert_eq!(beam_of_azimuth(36_000, 897), 0);
        // With 360 beams (1° each) azimuth 1° is yaw −1°: beam 179.
        assert_eq!(beam_of_azimuth(200, 360), 179);
    }

    #[test]
    fn assembler_bins_the_golden_packet() {
        let bytes = golden_packet();
        let mut a = ScanAssembler::new(Vlp16Config { beams: 360, ..Vlp16Config::default() }).unwrap();
        assert_eq!(a.lasers(), vec![1, 14]);
        // Block 0 firing 0 at 359.50° opens the scan; its second firing at 0.00° is not a wrap
        // (359.5° → 0° drops more than half a turn: it is). The packet wraps once, inside block 0.
        let s = a.push_bytes(&bytes).unwrap().expect("the wrap inside block 0 ends a scan");
        // The scan before the wrap holds only block 0's first firing at azimuth 359.50° = yaw +0.5°:
        // with 360 beams, beam (180.5) → rounds half up to 181.
        assert_eq!(s.valid_beams(), 1);
        // Channel 14 (−1°) had no return, channel 1 (+1°) 1001 units = 2.002 m · cos 1° = 2.0016951 m.
        let r = s.ranges_m[181];
        assert!((r - 2.002 * 1f32.to_radians().cos()).abs() < 1e-6, "{r}");
        assert_eq!(s.stamp_us, 1_000_000);
        let rest = a.finish().unwrap();
        // Beam 180 (yaw −0.5°..+0.5°): block 0's second firing at 0.00° (ch 17 = 1017, ch 30 = 1030)
        // and block 1's first at 0.50° (180.5 rounds up; ch 1 = 1011, ch 14 = 1024): 1011 · 2 mm · cos 1°.
        assert!((rest.ranges_m[180] - (2.022 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
        // Its stamp is the second firing's time: 1 000 000 µs + 55.296 µs, truncated.
        assert_eq!(rest.stamp_us, 1_000_055);
        // Beam 179: block 1's second firing at 1.00° (ch 17 = 1027, ch 30 = 1040) and block 2's first
        // at 1.50° (178.5 rounds up; ch 1 = 1021, ch 14 = 1034): 1021.
        assert!((rest.ranges_m[179] - (2.042 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
        // Beam 178: block 2's second firing at 2.00° has ch 17 = 100 (0.2 m, below the 0.3 m minimum:
        // dropped, else it would win) and ch 30 = 1050; block 3's first at 2.50° has ch 1 = 1031: 1031.
        assert!((rest.ranges_m[178] - (2.062 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
        // Behind the sensor nothing fired.
        assert!(rest.ranges_m[0].is_nan());
    }

    #[test]
    fn no_return_is_infinity_and_beyond_max_too() {
        let mut bytes = golden_packet();
        // All distances of block 5 to 0.
        for c in 0..CHANNELS_PER_BLOCK {
            let o = 5 * BLOCK_LEN + 4 + 3 * c;
            bytes[o..o + 2].copy_from_slice(&0u16.to_le_bytes());
        }
        let mut a = ScanAssembler::new(Vlp16Config { beams: 360, max_range_m: 2.05, ..Vlp16Config::default() }).unwrap();
        let _ = a.push_bytes(&bytes).unwrap();
        let s = a.finish().unwrap();
        // Block 5 at 4.50° (yaw −4.5°, beam 175.5 → 176) and 5.00° (beam 175): no returns.
        assert_eq!(s.ranges_m[176], f32::INFINITY);
        assert_eq!(s.ranges_m[175], f32::INFINITY);
        // Block 11 second firing (11.00°, beam 169): ch 17 1127 units = 2.254 m > 2.05 m → +∞.
        assert_eq!(s.ranges_m[169], f32::INFINITY);
    }

    #[test]
    fn dual_mode_keeps_the_nearest_of_both_returns() {
        let mut bytes = golden_packet();
        // Dual: pairs (2k, 2k+1) share azimuth 2k·100 + 35950.
        for k in 0..BLOCKS {
            let az = ((35_950 + 100 * (k - k % 2)) % 36_000) as u16;
            bytes[k * BLOCK_LEN + 2..k * BLOCK_LEN + 4].copy_from_slice(&az.to_le_bytes());
        }
        bytes[1204] = 0x39;
        let p = Vlp16Packet::new_checked(&bytes[..]).unwrap();
        // The second firing is halfway to the next pair (2° on): 359.50° + 1° = 0.50°, for both blocks of the pair.
        assert_eq!(p.firing_azimuth_half(0, 1), 100);
        assert_eq!(p.firing_azimuth_half(1, 1), 100);
        assert_eq!(p.firing_offset_ns(3, 1), 3 * 55_296);
        let mut a = ScanAssembler::new(Vlp16Config { beams: 360, ..Vlp16Config::default() }).unwrap();
        let first = a.push(&p).unwrap();
        // Pair (0,1) first firing, 359.50° (beam 181): block 0 ch 1 = 1001, block 1 ch 1 = 1011 → 1001.
        assert!((first.ranges_m[181] - (2.002 * 1f64.to_radians().cos()) as f32).abs() < 1e-6);
        // In dual mode the pair azimuths must agree.
        bytes[3 * BLOCK_LEN + 2] ^= 1;
        assert_eq!(Vlp16Packet::new_checked(&bytes[..]).unwrap_err(), PacketError::DualPair { block: 2 });
    }

    #[test]
    fn checks_reject_each_cause() {
        let good = golden_packet();
        assert_eq!(Vlp16Packet::new_checked(&good[..1205]).unwrap_err(), PacketError::Length { len: 1205 });
        let mut b = good;
        b[7 * BLOCK_LEN + 1] = 0xEF;
        assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::BlockFlag { block: 7, found: [0xFF, 0xEF] });
        let mut b = good;
        b[4 * BLOCK_LEN + 2..4 * BLOCK_LEN + 4].copy_from_slice(&36_000u16.to_le_bytes());
        assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::Azimuth { block: 4, azimuth: 36_000 });
        let mut b = good;
        b[1204] = 0x40;
        assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::ReturnMode(0x40));
        let mut b = good;
        b[6 * BLOCK_LEN + 2..6 * BLOCK_LEN + 4].copy_from_slice(&2_000u16.to_le_bytes()); // 4.50° → 20.00°
        assert_eq!(Vlp16Packet::new_checked(&b[..]).unwrap_err(), PacketError::AzimuthStep { block: 6, step: 1_550 });
        // The product byte is not checked.
        let mut b = good;
        b[1205] = 0x21;
        assert!(Vlp16Packet::new_checked(&b[..]).is_ok());
    }

    #[test]
    fn config_errors() {
        let d = Vlp16Config::default();
        assert_eq!(d.lasers(), vec![1, 14]);
        assert_eq!(
            ScanAssembler::new(Vlp16Config { elevation_min_deg: 1.5, elevation_max_deg: 2.5, ..d }).unwrap_err(),
            ConfigError::NoLaser { min_deg: 1.5, max_deg: 2.5 }
        );
        assert!(matches!(
            Vlp16Config { elevation_min_deg: 2.0, elevation_max_deg: -2.0, ..d }.validate(),
            Err(ConfigError::EmptyBand { .. })
        ));
        assert_eq!(Vlp16Config { beams: 0, ..d }.validate(), Err(ConfigError::Beams(0)));
        assert!(matches!(Vlp16Config { min_range_m: 5.0, max_range_m: 1.0, ..d }.validate(), Err(ConfigError::Range { .. })));
        assert_eq!(Vlp16Config { elevation_min_deg: -15.0, elevation_max_deg: 15.0, ..d }.lasers().len(), 16);
    }

    #[test]
    fn hour_clock_counts_on() {
        let mut c = HourClock::default();
        assert_eq!(c.unwrap(3_599_999_000), 3_599_999_000);
        assert_eq!(c.unwrap(500), HOUR_US + 500);
        assert_eq!(c.unwrap(400), HOUR_US + 400); // small reordering is not a new hour
    }

    #[test]
    fn raw_file_cut_mid_packet_keeps_earlier_packets() {
        let mut bytes = golden_packet().to_vec();
        bytes.extend_from_slice(&golden_packet()[..300]);
        let r = decode_raw_bytes(Path::new("x.bin"), &bytes, &Vlp16Config::default()).unwrap();
        assert_eq!(r.counts.data, 1);
        assert_eq!(r.scans.len(), 1);
        match r.error {
            Some(Vlp16Error::TruncatedPayload { offset: 1206, len: 300, .. }) => {}
            e => panic!("{e:?}"),
        }
        assert_eq!(r.error.unwrap().to_string(), "x.bin: byte 1206: the file ends 300 bytes into a 1206-byte packet");
    }

    #[test]
    fn framing_is_the_twelve_flags_and_the_return_mode() {
        let good = golden_packet();
        assert!(frames_packet(&good));
        // Whatever follows the packet is not looked at; a packet's first bytes frame one (cut by the end of a file).
        assert!(frames_packet(&[&good[..], &[0u8; 7][..]].concat()));
        assert!(frames_packet(&good[..2]));
        assert!(frames_packet(&good[..1_205]));
        assert!(!frames_packet(&good[..1]));
        assert!(!frames_packet(&good[1..]));
        let mut b = good;
        b[11 * BLOCK_LEN] = 0xFE;
        assert!(!frames_packet(&b));
        assert!(frames_packet(&b[..11 * BLOCK_LEN + 1])); // the broken flag is not within these bytes
        let mut b = good;
        b[field::RETURN_MODE] = 0x22;
        assert!(!frames_packet(&b));
        // Azimuths and the product byte are the check's business, not the framing's.
        let mut b = good;
        b[4 * BLOCK_LEN + 2..4 * BLOCK_LEN + 4].copy_from_slice(&36_000u16.to_le_bytes());
        b[field::PRODUCT] = 0x99;
        assert!(frames_packet(&b) && Vlp16Packet::new_checked(&b[..]).is_err());
    }

    /// Golden packets back to back with `edit` applied; each one ends a scan (its block 0 wraps).
    fn raw(packets: usize, edit: impl FnOnce(&mut Vec<u8>)) -> PcapScans {
        let mut bytes: Vec<u8> = (0..packets).flat_map(|_| golden_packet()).collect();
        edit(&mut bytes);
        decode_raw_bytes(Path::new("r.bin"), &bytes, &Vlp16Config::default()).unwrap()
    }

    fn fates(r: &PcapScans) -> (u64, u64, u64, Vec<Skipped>) {
        (r.counts.data, r.counts.rejected, r.skipped_bytes, r.skips.clone())
    }

    #[test]
    fn raw_stream_resynchronises_after_bytes_inserted_or_lost() {
        let skip = |offset, len| Skipped { offset, len };
        // One byte inserted into packet 2 (of 6): packet 2 and the byte are skipped, 3..6 decode.
        let r = raw(6, |b| b.insert(2 * PACKET_LEN + 321, 0));
        assert_eq!(fates(&r), (5, 0, 1_207, vec![skip(2_412, 1_207)]));
        assert!(r.error.is_none());
        // One byte lost from packet 2: the rest of it (1205 bytes) is skipped.
        let r = raw(6, |b| {
            b.remove(2 * PACKET_LEN + 321);
        });
        assert_eq!(fates(&r), (5, 0, 1_205, vec![skip(2_412, 1_205)]));
        // Garbage between packets 3 and 4 (with a lone FF EE in it): nothing good is lost.
        let r = raw(6, |b| {
            let mut junk = vec![0x20u8; 700];
            junk[100..102].copy_from_slice(&BLOCK_FLAG);
            b.splice(3 * PACKET_LEN..3 * PACKET_LEN, junk);
        });
        assert_eq!(fates(&r), (6, 0, 700, vec![skip(3_618, 700)]));
        assert_eq!(r.scans.len(), 6);
        // Garbage at the start and the end of the file.
        let r = raw(2, |b| {
            b.splice(0..0, *b"hello");
            b.extend_from_slice(&[0x20; 1_300]);
        });
        assert_eq!(fates(&r), (2, 0, 1_305, vec![skip(0, 5), skip(2_417, 1_300)]));
        assert!(r.error.is_none());
    }

    #[test]
    fn raw_stream_in_step_rejects_a_damaged_packet_and_skips_a_damaged_run() {
        let skip = |offset, len| Skipped { offset, len };
        // A broken flag in packet 1, the next packet where it should be: rejected, by its check's reason.
        let r = raw(4, |b| b[PACKET_LEN + 7 * BLOCK_LEN + 1] = 0xEF);
        assert_eq!(fates(&r), (3, 1, 0, vec![]));
        assert_eq!(
            r.rejects[0],
            Rejected { offset: 1_206, reason: RejectReason::Packet(PacketError::BlockFlag { block: 7, found: [0xFF, 0xEF] }) }
        );
        // The same in the last packet: the end of the file is where the next one should be.
        let r = raw(4, |b| b[3 * PACKET_LEN + field::RETURN_MODE] = 0);
        assert_eq!(fates(&r), (3, 1, 0, vec![]));
        assert_eq!(r.rejects[0].reason, RejectReason::Packet(PacketError::ReturnMode(0)));
        // Two damaged packets in a row: one run of 2412 bytes skipped; every byte is accounted for.
        let r = raw(5, |b| {
            b[PACKET_LEN] = 0;
            b[2 * PACKET_LEN] = 0;
        });
        assert_eq!(fates(&r), (3, 0, 2_412, vec![skip(1_206, 2_412)]));
        // A file cut inside a packet after garbage: the cut packet is still named.
        let r = raw(2, |b| {
            b.extend_from_slice(&[1, 2, 3]);
            b.extend_from_slice(&golden_packet()[..300]);
        });
        assert_eq!(fates(&r), (2, 0, 3, vec![skip(2_412, 3)]));
        assert!(matches!(r.error, Some(Vlp16Error::TruncatedPayload { offset: 2_415, len: 300, .. })), "{:?}", r.error);
    }

    #[test]
    fn raw_file_without_a_packet_is_an_error() {
        let cfg = Vlp16Config::default();
        let e = decode_raw_bytes(Path::new("empty.bin"), &[], &cfg).unwrap_err();
        assert!(matches!(e, Vlp16Error::Empty { .. }), "{e:?}");
        assert_eq!(e.to_string(), "empty.bin is not a VLP-16 capture: the file is empty");
        // Text, and text as long as a few packets: no offset frames a packet.
        let text = "# LIVES\\nA robot looks for things.\\n".repeat(200);
        for bytes in [&b"hi"[..], &text.as_bytes()[..3 * PACKET_LEN], text.as_bytes()] {
            let e = decode_raw_bytes(Path::new("README.md"), bytes, &cfg).unwrap_err();
            assert_eq!(
                e.to_string(),
                "README.md is not a VLP-16 capture: no packet found (neither pcap nor raw 1206-byte payloads)",
                "{} bytes",
                bytes.len()
            );
        }
        // The first bytes of a packet are one, cut short.
        let r = decode_raw_bytes(Path::new("cut.bin"), &golden_packet()[..500], &cfg).unwrap();
        assert!(matches!(r.error, Some(Vlp16Error::TruncatedPayload { offset: 0, len: 500, .. })));
    }

    #[test]
    fn resync_search_crosses_read_chunks() {
        // A run of 300 050 garbage bytes (longer than a read chunk) with FF EE every 100 bytes, all
        // but the twelfth flag of a packet: framing is lost for the whole run, then found again.
        let r = raw(3, |b| {
            let mut junk = vec![0u8; 300_050];
            for at in (0..junk.len()).step_by(BLOCK_LEN) {
                if at % (12 * BLOCK_LEN) != 11 * BLOCK_LEN {
                    junk[at..at + 2].copy_from_slice(&BLOCK_FLAG);
                }
            }
            b.splice(PACKET_LEN..PACKET_LEN, junk);
        });
        assert_eq!(fates(&r), (3, 0, 300_050, vec![Skipped { offset: 1_206, len: 300_050 }]));
        assert_eq!(r.scans.len(), 3);
    }
}
