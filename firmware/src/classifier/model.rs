//! The model blob: a checked, borrowed view ([`ModelView`]) and a writer ([`ModelWriter`]).
//!
//! The blob is what the offline quantiser (`host::model::quantise`) produces and what the robot
//! flashes next to its firmware. The classifier never copies it: the two 897 × 897 weight matrices
//! alone are 1.6 MB, so every weight is read in place from the borrowed bytes.
//!
//! The layout is written down in `docs/model-format.md`; in short (all integers little-endian,
//! every offset a named constant in [`field`] and [`layout`]):
//!
//! | offset | size | contents |
//! |---|---|---|
//! | 0 | 64 | header: magic `LIVM`, version, shapes, input normalisation, payload length, CRC-32 |
//! | 64 | 32 | pre-activation scales of the 7 tanh inputs, IEEE-754 binary32 bits (informational) |
//! | 96 | 1 792 | 7 tanh tables × 256 int8, indexed by `q + 128` |
//! | 1 888 | 16 | head: the two multipliers of the output stage |
//! | 1 904 | 32 424 | per-channel records of the 6 weighted layers: bias `i32`, multiplier `i32`, shift `i32` |
//! | 34 328 | 1 682 080 | int8 weights of the 6 weighted layers, each padded to 4 bytes |
//!
//! [`ModelView::parse`] validates every length, the shapes against the firmware's compile-time
//! ones, the checksum, the normalisation constants and every multiplier before it hands out a view;
//! after that, reads cannot fail. It never panics, whatever the bytes.

use super::{ENC_KERNEL, HISTORY, POSE_CHANNELS, POSE_FEATURES, POSE_FLAT};
use crate::capacity::BEAMS;
use fixed_point::QuantizedMultiplier;

/// The blob's first four bytes.
pub const MAGIC: [u8; 4] = *b"LIVM";
/// The format version this firmware reads.
pub const VERSION: u16 = 1;
/// Header length in bytes.
pub const HEADER_LEN: usize = 64;
/// Number of tanh tables (one per [`Layer`]).
pub const TANH_TABLES: usize = 7;
/// Bytes per tanh table.
pub const TANH_TABLE_LEN: usize = 256;
/// Bytes per channel record (bias, multiplier, shift).
pub const CHANNEL_RECORD_LEN: usize = 12;

/// Header field offsets (bytes from the start of the blob).
pub mod field {
    /// `[u8; 4]`, [`super::MAGIC`].
    pub const MAGIC: usize = 0;
    /// `u16`, [`super::VERSION`].
    pub const VERSION: usize = 4;
    /// `u16`, [`super::HEADER_LEN`].
    pub const HEADER_LEN: usize = 6;
    /// `u16`, history length k (9).
    pub const HISTORY: usize = 8;
    /// `u16`, beams per scan (897).
    pub const BEAMS: usize = 10;
    /// `u8`, encoder kernel height, along time (9).
    pub const ENC_KERNEL_TIME: usize = 12;
    /// `u8`, encoder kernel width, along the beams (9).
    pub const ENC_KERNEL_BEAMS: usize = 13;
    /// `u8`, pose encoder output channels (9).
    pub const POSE_CHANNELS: usize = 14;
    /// `u8`, pose features per step and pose kernel width (3: x, y, θ).
    pub const POSE_FEATURES: usize = 15;
    /// `u8`, tanh tables (7).
    pub const TANH_TABLES: usize = 16;
    /// `u8`, the range encoding ([`super::RangeEncoding`]: 0 linear, 1 inverse). Zero in blobs
    /// written before it existed (then a reserved byte).
    pub const RANGE_ENCODING: usize = 17;
    /// Bytes 18 ..= 19: reserved, zero.
    pub const RESERVED_A: usize = 18;
    /// `u32`, range that normalises to 1.0, millimetres.
    pub const RANGE_MAX_MM: usize = 20;
    /// `u32`, relative pose distance that normalises to 1.0, millimetres.
    pub const POSE_SCALE_MM: usize = 24;
    /// Bytes 28 ..= 55: reserved, zero.
    pub const RESERVED_B: usize = 28;
    /// `u32`, payload bytes after the header.
    pub const PAYLOAD_LEN: usize = 56;
    /// `u32`, CRC-32/ISO-HDLC over bytes 0 ..= 59 followed by the payload.
    pub const CRC: usize = 60;
}

/// The network's stages, in blob order. Each has a tanh table; all but [`Layer::Head`] have
/// weights and per-channel records.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Layer {
    /// Scan encoder convolution, 9 × 9, one channel.
    ScanConv = 0,
    /// Scan encoder linear layer, 897 → 897.
    ScanFc = 1,
    /// Label encoder convolution, 9 × 9, one channel.
    LabelConv = 2,
    /// Label encoder linear layer, 897 → 897.
    LabelFc = 3,
    /// Pose encoder convolution, 1 × 3, nine channels.
    PoseConv = 4,
    /// Pose encoder linear layer, 81 → 897.
    PoseFc = 5,
    /// The output stage `tanh(scan_enc + pose_enc) · label_enc` (no weights).
    Head = 6,
}

impl Layer {
    /// Every stage, in blob order.
    pub const ALL: [Layer; 7] =
        [Layer::ScanConv, Layer::ScanFc, Layer::LabelConv, Layer::LabelFc, Layer::PoseConv, Layer::PoseFc, Layer::Head];
    /// The stages with weights, in blob order.
    pub const WEIGHTED: [Layer; 6] = [Layer::ScanConv, Layer::ScanFc, Layer::LabelConv, Layer::LabelFc, Layer::PoseConv, Layer::PoseFc];

    /// Output channels (rows of the weight matrix); 0 for [`Layer::Head`].
    pub const fn channels(self) -> usize {
        match self {
            Layer::ScanConv | Layer::LabelConv => 1,
            Layer::ScanFc | Layer::LabelFc | Layer::PoseFc => BEAMS,
            Layer::PoseConv => POSE_CHANNELS,
            Layer::Head => 0,
        }
    }

    /// Weights per output channel (the row length); 0 for [`Layer::Head`].
    pub const fn fan_in(self) -> usize {
        match self {
            Layer::ScanConv | Layer::LabelConv => HISTORY * ENC_KERNEL,
            Layer::ScanFc | Layer::LabelFc => BEAMS,
            Layer::PoseConv => POSE_FEATURES,
            Layer::PoseFc => POSE_FLAT,
            Layer::Head => 0,
        }
    }

    /// Weight bytes, unpadded.
    pub const fn weights_len(self) -> usize {
        self.channels() * self.fan_in()
    }
}

/// Payload offsets (bytes from the start of the blob), derived from the shapes.
pub mod layout {
    use super::{Layer, CHANNEL_RECORD_LEN, HEADER_LEN, TANH_TABLES, TANH_TABLE_LEN};

    /// Pre-activation scales, one binary32 bit pattern per [`Layer`], plus one reserved word.
    pub const SCALES: usize = HEADER_LEN;
    /// Bytes of the scales section.
    pub const SCALES_LEN: usize = 8 * 4;
    /// The tanh tables, one per [`Layer`].
    pub const TANH: usize = SCALES + SCALES_LEN;
    /// The head's multipliers: sum multiplier, sum shift, product multiplier, product shift (`i32` each).
    pub const HEAD: usize = TANH + TANH_TABLES * TANH_TABLE_LEN;
    /// Bytes of the head section.
    pub const HEAD_LEN: usize = 16;
    /// Channel records of the weighted layers.
    pub const CHANNELS: usize = HEAD + HEAD_LEN;

    const fn pad4(n: usize) -> usize {
        (n + 3) & !3
    }

    /// Offset of the first channel record of `layer` (the blob's end of channel records for `Head`).
    pub const fn channels_of(layer: Layer) -> usize {
        let mut off = CHANNELS;
        let mut i = 0;
        while i < Layer::WEIGHTED.len() && (i as u8) < layer as u8 {
            off += Layer::WEIGHTED[i].channels() * CHANNEL_RECORD_LEN;
            i += 1;
        }
        off
    }

    /// Start of the weights.
    pub const WEIGHTS: usize = channels_of(Layer::Head);

    /// Offset of the weights of `layer` (the blob's end for `Head`).
    pub const fn weights_of(layer: Layer) -> usize {
        let mut off = WEIGHTS;
        let mut i = 0;
        while i < Layer::WEIGHTED.len() && (i as u8) < layer as u8 {
            off += pad4(Layer::WEIGHTED[i].weights_len());
            i += 1;
        }
        off
    }

    /// Total blob length.
    pub const BLOB_LEN: usize = weights_of(Layer::Head);
    /// Payload length (what the header's `payload_len` must say).
    pub const PAYLOAD_LEN: usize = BLOB_LEN - HEADER_LEN;
}

/// Which header shape field disagreed with the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShapeField {
    /// The history length k.
    History,
    /// Beams per scan.
    Beams,
    /// Encoder kernel height.
    EncKernelTime,
    /// Encoder kernel width.
    EncKernelBeams,
    /// Pose encoder channels.
    PoseChannels,
    /// Pose features.
    PoseFeatures,
    /// Number of tanh tables.
    TanhTables,
    /// Features per beam of the geometric model ([`super::geo`]).
    GeoFeatures,
    /// Hidden units of the geometric model.
    GeoHidden,
}

/// Why a blob was refused. Checked in this order, so a blob has exactly one error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ModelError {
    /// The first four bytes are not [`MAGIC`].
    BadMagic,
    /// Fewer bytes than the header (or the header's payload length) needs.
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes given.
        got: usize,
    },
    /// A format version this firmware does not read.
    UnsupportedVersion(u16),
    /// The header length field is not [`HEADER_LEN`].
    BadHeaderLength(u16),
    /// A shape differs from the firmware's compile-time shape.
    ShapeMismatch {
        /// Which field.
        field: ShapeField,
        /// What the firmware is built for.
        expected: u32,
        /// What the blob says.
        found: u32,
    },
    /// Reserved header bytes are not zero.
    ReservedNotZero,
    /// The header's payload length differs from what the shapes imply.
    PayloadLength {
        /// Implied by the shapes.
        expected: u32,
        /// Stated in the header.
        found: u32,
    },
    /// Bytes after the payload.
    TrailingBytes {
        /// How many.
        extra: usize,
    },
    /// The CRC-32 does not match the bytes.
    ChecksumMismatch {
        /// Stored in the header.
        stored: u32,
        /// Computed over the blob.
        computed: u32,
    },
    /// A normalisation constant is zero or out of range.
    BadNormalisation,
    /// A requantisation multiplier is not normalised (mantissa outside [2³⁰, 2³¹) or shift
    /// outside [−31, 30]).
    BadMultiplier {
        /// The stage.
        layer: Layer,
        /// The channel (0 and 1 for the head's sum and product multipliers).
        channel: u16,
    },
    /// A requantisation multiplier of the geometric model ([`super::geo`]) is not normalised:
    /// hidden unit `channel`, or the output when `channel` is the hidden width.
    BadGeoMultiplier {
        /// The unit.
        channel: u16,
    },
}

impl core::fmt::Display for ModelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            ModelError::BadMagic => f.write_str("not a classifier blob (its first four bytes are not the model magic)"),
            ModelError::Truncated { needed, got } => write!(f, "truncated: {got} bytes where the header needs {needed}"),
            ModelError::UnsupportedVersion(v) => write!(f, "format version {v}, which this firmware does not read"),
            ModelError::BadHeaderLength(n) => write!(f, "header length {n}, expected {HEADER_LEN}"),
            ModelError::ShapeMismatch { field, expected, found } => {
                write!(f, "{} is {found}, the firmware is built for {expected}", field.name())
            }
            ModelError::ReservedNotZero => f.write_str("reserved header bytes are not zero"),
            ModelError::PayloadLength { expected, found } => {
                write!(f, "the header states a payload of {found} bytes, the shapes imply {expected}")
            }
            ModelError::TrailingBytes { extra } => write!(f, "{extra} bytes after the payload"),
            ModelError::ChecksumMismatch { stored, computed } => {
                write!(f, "CRC-32 mismatch (stored {stored:#010x}, computed {computed:#010x}): the file is corrupt")
            }
            ModelError::BadNormalisation => f.write_str("a normalisation constant is zero or out of range"),
            ModelError::BadMultiplier { layer, channel } => {
                write!(f, "requantisation multiplier of layer {layer:?}, channel {channel} is not normalised")
            }
            ModelError::BadGeoMultiplier { channel } => {
                write!(f, "requantisation multiplier of geometric hidden unit {channel} is not normalised")
            }
        }
    }
}

impl ShapeField {
    /// The field's name in messages.
    pub fn name(self) -> &'static str {
        match self {
            ShapeField::History => "the history length",
            ShapeField::Beams => "the beam count",
            ShapeField::EncKernelTime => "the encoder kernel's height",
            ShapeField::EncKernelBeams => "the encoder kernel's width",
            ShapeField::PoseChannels => "the pose encoder's channel count",
            ShapeField::PoseFeatures => "the pose feature count",
            ShapeField::TanhTables => "the tanh table count",
            ShapeField::GeoFeatures => "the geometric model's feature count",
            ShapeField::GeoHidden => "the geometric model's hidden width",
        }
    }
}

/// How a range in millimetres becomes the network's scan input (header byte 17).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RangeEncoding {
    /// `min(r, R) / R`: invalid → 0, no return → 1 (code 0).
    Linear,
    /// `min(1, R / r)` (inverse range, `R` = `range_max_mm` the reference range): no return → 0;
    /// an invalid beam takes the value of the nearest valid beam before it (wrapping around the
    /// scan; 0 if none is valid) (code 1).
    Inverse,
}

impl RangeEncoding {
    /// The header code.
    pub const fn code(self) -> u8 {
        match self {
            RangeEncoding::Linear => 0,
            RangeEncoding::Inverse => 1,
        }
    }

    /// From the header code.
    pub const fn from_code(c: u8) -> Option<Self> {
        match c {
            0 => Some(RangeEncoding::Linear),
            1 => Some(RangeEncoding::Inverse),
            _ => None,
        }
    }
}

/// How raw sensor integers become the network's inputs (see `docs/model-format.md`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Normalisation {
    /// Linear: the range that maps to 1.0 (int8 127), longer ranges clamp. Inverse: the reference
    /// range `R` of `min(1, R / r)`. Millimetres, 1 ..= 65 534 (a `u32` in the header).
    pub range_max_mm: u16,
    /// The relative-pose distance that maps to 1.0 (int8 127), millimetres; larger clamp.
    /// 1 ..= 1 000 000.
    pub pose_scale_mm: u32,
    /// How ranges are encoded.
    pub range_encoding: RangeEncoding,
}

impl Normalisation {
    /// The defaults the quantiser writes: 30 m ranges (linear), 5 m relative poses.
    pub const DEFAULT: Self = Self { range_max_mm: 30_000, pose_scale_mm: 5_000, range_encoding: RangeEncoding::Linear };

    /// True when both constants are in range.
    pub const fn is_valid(&self) -> bool {
        self.range_max_mm >= 1 && self.range_max_mm <= 65_534 && self.pose_scale_mm >= 1 && self.pose_scale_mm <= 1_000_000
    }
}

/// Bias and requantisation multiplier of one output channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ChannelParams {
    /// Bias at the accumulator's scale (input scale × weight scale).
    pub bias: i32,
    /// Accumulator → pre-activation int8 (the tanh table's input scale).
    pub multiplier: QuantizedMultiplier,
}

/// The output stage's two multipliers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct HeadParams {
    /// `scan_enc + pose_enc` (scale 1/127) → the head tanh table's input scale.
    pub sum: QuantizedMultiplier,
    /// `tanh · label_enc` (scale 1/127²) → the output's scale 1/127.
    pub product: QuantizedMultiplier,
}

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The blob's CRC-32/ISO-HDLC (the zlib/PNG CRC) over bytes `0 .. 60` followed by everything from
/// byte 64 on, i.e. the whole blob but the CRC field. `None` if `blob` is shorter than the header.
pub fn checksum(blob: &[u8]) -> Option<u32> {
    let head = blob.get(..field::CRC)?;
    let payload = blob.get(HEADER_LEN..)?;
    let mut d = CRC32.digest();
    d.update(head);
    d.update(payload);
    Some(d.finalize())
}

#[inline]
fn get_u16(b: &[u8], off: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(off..off + 2)?.try_into().ok()?))
}

#[inline]
fn get_u32(b: &[u8], off: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(off..off + 4)?.try_into().ok()?))
}

#[inline]
fn get_i32(b: &[u8], off: usize) -> Option<i32> {
    get_u32(b, off).map(|v| v as i32)
}

/// Reads a multiplier record (`i32` mantissa, `i32` shift) and checks it is normalised.
fn read_multiplier(b: &[u8], off: usize) -> Option<QuantizedMultiplier> {
    let m = get_i32(b, off)?;
    let s = get_i32(b, off + 4)?;
    if s < QuantizedMultiplier::MIN_SHIFT as i32 || s > QuantizedMultiplier::MAX_SHIFT as i32 {
        return None;
    }
    let q = QuantizedMultiplier::from_raw(m, s as i8);
    q.is_normalised().then_some(q)
}

/// A validated model blob, borrowed. `Copy`: pass it by value.
#[derive(Clone, Copy)]
pub struct ModelView<'a> {
    bytes: &'a [u8],
    norm: Normalisation,
    head: HeadParams,
}

impl core::fmt::Debug for ModelView<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ModelView").field("len", &self.bytes.len()).field("norm", &self.norm).field("head", &self.head).finish()
    }
}

impl<'a> ModelView<'a> {
    /// Validates `bytes` and returns a view over them. Checks, in order: magic, header length,
    /// version, header-length field, shapes, reserved bytes, payload length, total length,
    /// checksum, normalisation constants, every multiplier. Never panics.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, ModelError> {
        let got = bytes.len();
        if got < MAGIC.len() {
            return Err(ModelError::Truncated { needed: HEADER_LEN, got });
        }
        if bytes[..MAGIC.len()] != MAGIC {
            return Err(ModelError::BadMagic);
        }
        if got < HEADER_LEN {
            return Err(ModelError::Truncated { needed: HEADER_LEN, got });
        }
        let h = &bytes[..HEADER_LEN];
        let truncated = ModelError::Truncated { needed: HEADER_LEN, got };
        let version = get_u16(h, field::VERSION).ok_or(truncated)?;
        if version != VERSION {
            return Err(ModelError::UnsupportedVersion(version));
        }
        let header_len = get_u16(h, field::HEADER_LEN).ok_or(truncated)?;
        if header_len as usize != HEADER_LEN {
            return Err(ModelError::BadHeaderLength(header_len));
        }
        let shapes: [(ShapeField, u32, u32); 7] = [
            (ShapeField::History, HISTORY as u32, get_u16(h, field::HISTORY).ok_or(truncated)? as u32),
            (ShapeField::Beams, BEAMS as u32, get_u16(h, field::BEAMS).ok_or(truncated)? as u32),
            (ShapeField::EncKernelTime, ENC_KERNEL as u32, h[field::ENC_KERNEL_TIME] as u32),
            (ShapeField::EncKernelBeams, ENC_KERNEL as u32, h[field::ENC_KERNEL_BEAMS] as u32),
            (ShapeField::PoseChannels, POSE_CHANNELS as u32, h[field::POSE_CHANNELS] as u32),
            (ShapeField::PoseFeatures, POSE_FEATURES as u32, h[field::POSE_FEATURES] as u32),
            (ShapeField::TanhTables, TANH_TABLES as u32, h[field::TANH_TABLES] as u32),
        ];
        for (field, expected, found) in shapes {
            if expected != found {
                return Err(ModelError::ShapeMismatch { field, expected, found });
            }
        }
        let reserved_zero = h[field::RESERVED_A..field::RANGE_MAX_MM].iter().all(|&b| b == 0)
            && h[field::RESERVED_B..field::PAYLOAD_LEN].iter().all(|&b| b == 0);
        if !reserved_zero {
            return Err(ModelError::ReservedNotZero);
        }
        let payload_len = get_u32(h, field::PAYLOAD_LEN).ok_or(truncated)?;
        if payload_len as usize != layout::PAYLOAD_LEN {
            return Err(ModelError::PayloadLength { expected: layout::PAYLOAD_LEN as u32, found: payload_len });
        }
        if got < layout::BLOB_LEN {
            return Err(ModelError::Truncated { needed: layout::BLOB_LEN, got });
        }
        if got > layout::BLOB_LEN {
            return Err(ModelError::TrailingBytes { extra: got - layout::BLOB_LEN });
        }
        let stored = get_u32(h, field::CRC).ok_or(truncated)?;
        let computed = checksum(bytes).ok_or(truncated)?;
        if stored != computed {
            return Err(ModelError::ChecksumMismatch { stored, computed });
        }
        let norm = Normalisation {
            range_max_mm: u16::try_from(get_u32(h, field::RANGE_MAX_MM).ok_or(truncated)?).map_err(|_| ModelError::BadNormalisation)?,
            pose_scale_mm: get_u32(h, field::POSE_SCALE_MM).ok_or(truncated)?,
            range_encoding: RangeEncoding::from_code(h[field::RANGE_ENCODING]).ok_or(ModelError::BadNormalisation)?,
        };
        if !norm.is_valid() {
            return Err(ModelError::BadNormalisation);
        }
        let bad_head = |channel| ModelError::BadMultiplier { layer: Layer::Head, channel };
        let head = HeadParams {
            sum: read_multiplier(bytes, layout::HEAD).ok_or(bad_head(0))?,
            product: read_multiplier(bytes, layout::HEAD + 8).ok_or(bad_head(1))?,
        };
        for layer in Layer::WEIGHTED {
            let base = layout::channels_of(layer);
            for c in 0..layer.channels() {
                if read_multiplier(bytes, base + c * CHANNEL_RECORD_LEN + 4).is_none() {
                    return Err(ModelError::BadMultiplier { layer, channel: c as u16 });
                }
            }
        }
        Ok(Self { bytes, norm, head })
    }

    /// The whole blob.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// The input normalisation constants.
    pub fn normalisation(&self) -> Normalisation {
        self.norm
    }

    /// The output stage's multipliers.
    pub fn head(&self) -> HeadParams {
        self.head
    }

    /// The blob's CRC-32 (as stored and verified).
    pub fn crc(&self) -> u32 {
        get_u32(self.bytes, field::CRC).unwrap_or(0)
    }

    /// The pre-activation scale of `layer`'s tanh input as IEEE-754 binary32 bits (informational:
    /// inference does not use it).
    pub fn scale_bits(&self, layer: Layer) -> u32 {
        get_u32(self.bytes, layout::SCALES + 4 * layer as usize).unwrap_or(0)
    }

    /// The tanh table of `layer`: entry `q + 128` is the int8 output (scale 1/127) for input `q`.
    pub fn tanh_table(&self, layer: Layer) -> &'a [u8; TANH_TABLE_LEN] {
        const ZERO: [u8; TANH_TABLE_LEN] = [0; TANH_TABLE_LEN];
        let off = layout::TANH + TANH_TABLE_LEN * layer as usize;
        self.bytes.get(off..off + TANH_TABLE_LEN).and_then(|s| s.try_into().ok()).unwrap_or(&ZERO)
    }

    /// Bias and multiplier of channel `c` of a weighted layer (zeros for the head or `c` out of range).
    #[inline]
    pub fn channel(&self, layer: Layer, c: usize) -> ChannelParams {
        if c >= layer.channels() {
            return ChannelParams { bias: 0, multiplier: QuantizedMultiplier::ZERO };
        }
        let off = layout::channels_of(layer) + c * CHANNEL_RECORD_LEN;
        let bias = get_i32(self.bytes, off).unwrap_or(0);
        let m = get_i32(self.bytes, off + 4).unwrap_or(0);
        let s = get_i32(self.bytes, off + 8).unwrap_or(0);
        ChannelParams { bias, multiplier: QuantizedMultiplier::from_raw(m, s as i8) }
    }

    /// All weights of `layer`, row-major `[channel][fan_in]`, as raw bytes (each an `i8`).
    #[inline]
    pub fn weights(&self, layer: Layer) -> &'a [u8] {
        let off = layout::weights_of(layer);
        self.bytes.get(off..off + layer.weights_len()).unwrap_or(&[])
    }

    /// Row `c` of `layer`'s weights (`fan_in` bytes, each an `i8`); empty if `c` is out of range.
    #[inline]
    pub fn weight_row(&self, layer: Layer, c: usize) -> &'a [u8] {
        let n = layer.fan_in();
        self.weights(layer).get(c * n..c * n + n).unwrap_or(&[])
    }
}

/// Writes a blob into a caller-provided buffer of exactly [`layout::BLOB_LEN`] bytes: the one
/// implementation of the layout that the host's quantiser and the tests use. Fields can be set in
/// any order; [`ModelWriter::finish`] writes the header and the checksum last.
pub struct ModelWriter<'a> {
    buf: &'a mut [u8],
    norm: Normalisation,
}

impl<'a> ModelWriter<'a> {
    /// A writer over `buf`, which must be [`layout::BLOB_LEN`] bytes long; it is zeroed.
    pub fn new(buf: &'a mut [u8]) -> Result<Self, ModelError> {
        if buf.len() < layout::BLOB_LEN {
            return Err(ModelError::Truncated { needed: layout::BLOB_LEN, got: buf.len() });
        }
        if buf.len() > layout::BLOB_LEN {
            return Err(ModelError::TrailingBytes { extra: buf.len() - layout::BLOB_LEN });
        }
        buf.fill(0);
        Ok(Self { buf, norm: Normalisation::DEFAULT })
    }

    fn put(&mut self, off: usize, bytes: &[u8]) {
        if let Some(dst) = self.buf.get_mut(off..off + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
    }

    /// Sets the input normalisation constants.
    pub fn set_normalisation(&mut self, norm: Normalisation) {
        self.norm = norm;
    }

    /// Records `layer`'s pre-activation scale (binary32 bits; informational).
    pub fn set_scale_bits(&mut self, layer: Layer, bits: u32) {
        self.put(layout::SCALES + 4 * layer as usize, &bits.to_le_bytes());
    }

    /// Sets `layer`'s tanh table: `table[q + 128]` is the output for input `q`.
    pub fn set_tanh_table(&mut self, layer: Layer, table: &[i8; TANH_TABLE_LEN]) {
        let off = layout::TANH + TANH_TABLE_LEN * layer as usize;
        for (i, &v) in table.iter().enumerate() {
            self.put(off + i, &[v as u8]);
        }
    }

    /// Sets the head's multipliers.
    pub fn set_head(&mut self, head: HeadParams) {
        let mut rec = [0u8; 16];
        rec[0..4].copy_from_slice(&head.sum.multiplier.to_le_bytes());
        rec[4..8].copy_from_slice(&(head.sum.shift as i32).to_le_bytes());
        rec[8..12].copy_from_slice(&head.product.multiplier.to_le_bytes());
        rec[12..16].copy_from_slice(&(head.product.shift as i32).to_le_bytes());
        self.put(layout::HEAD, &rec);
    }

    /// Sets channel `c` of a weighted layer (ignored for the head or `c` out of range).
    pub fn set_channel(&mut self, layer: Layer, c: usize, p: ChannelParams) {
        if c >= layer.channels() {
            return;
        }
        let mut rec = [0u8; CHANNEL_RECORD_LEN];
        rec[0..4].copy_from_slice(&p.bias.to_le_bytes());
        rec[4..8].copy_from_slice(&p.multiplier.multiplier.to_le_bytes());
        rec[8..12].copy_from_slice(&(p.multiplier.shift as i32).to_le_bytes());
        self.put(layout::channels_of(layer) + c * CHANNEL_RECORD_LEN, &rec);
    }

    /// `layer`'s weights, row-major `[channel][fan_in]`, to fill (each byte an `i8`).
    pub fn weights_mut(&mut self, layer: Layer) -> &mut [u8] {
        let off = layout::weights_of(layer);
        self.buf.get_mut(off..off + layer.weights_len()).unwrap_or(&mut [])
    }

    /// Writes the header and the checksum; returns the blob length.
    pub fn finish(self) -> usize {
        let mut h = [0u8; HEADER_LEN];
        h[field::MAGIC..field::MAGIC + 4].copy_from_slice(&MAGIC);
        h[field::VERSION..field::VERSION + 2].copy_from_slice(&VERSION.to_le_bytes());
        h[field::HEADER_LEN..field::HEADER_LEN + 2].copy_from_slice(&(HEADER_LEN as u16).to_le_bytes());
        h[field::HISTORY..field::HISTORY + 2].copy_from_slice(&(HISTORY as u16).to_le_bytes());
        h[field::BEAMS..field::BEAMS + 2].copy_from_slice(&(BEAMS as u16).to_le_bytes());
        h[field::ENC_KERNEL_TIME] = ENC_KERNEL as u8;
        h[field::ENC_KERNEL_BEAMS] = ENC_KERNEL as u8;
        h[field::POSE_CHANNELS] = POSE_CHANNELS as u8;
        h[field::POSE_FEATURES] = POSE_FEATURES as u8;
        h[field::TANH_TABLES] = TANH_TABLES as u8;
        h[field::RANGE_ENCODING] = self.norm.range_encoding.code();
        h[field::RANGE_MAX_MM..field::RANGE_MAX_MM + 4].copy_from_slice(&(self.norm.range_max_mm as u32).to_le_bytes());
        h[field::POSE_SCALE_MM..field::POSE_SCALE_MM + 4].copy_from_slice(&self.norm.pose_scale_mm.to_le_bytes());
        h[field::PAYLOAD_LEN..field::PAYLOAD_LEN + 4].copy_from_slice(&(layout::PAYLOAD_LEN as u32).to_le_bytes());
        let buf = self.buf;
        if let Some(dst) = buf.get_mut(..HEADER_LEN) {
            dst.copy_from_slice(&h);
        }
        let crc = checksum(buf).unwrap_or(0);
        if let Some(dst) = buf.get_mut(field::CRC..field::CRC + 4) {
            dst.copy_from_slice(&crc.to_le_bytes());
        }
        buf.len()
    }
}

#[cfg(test)]
mod tests;
