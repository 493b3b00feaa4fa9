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

mod assemble;
mod capture;
mod packet;
mod udp;
pub use assemble::*;
pub use capture::*;
pub use packet::*;
pub use udp::*;

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

#[cfg(test)]
mod tests;
