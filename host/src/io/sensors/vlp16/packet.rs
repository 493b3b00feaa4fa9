//! One data packet: its return mode, checked view ([`Vlp16Packet`]) and framing test.

use super::*;
use std::fmt;

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
pub(super) fn azimuth_diff(a: u16, b: u16) -> u32 {
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
