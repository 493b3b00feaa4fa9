//! The messages of both directions and their conversions to and from the core's types.
//!
//! Every message is a plain value type (integers, fixed-point bits, `heapless` vectors) with a
//! serde derive; postcard turns it into bytes (see `docs/protocol.md` for the byte layout of every
//! field). Distances travel as the bits of [`Meters`] (Q16.16, so `1.0 m` is `65536`), angles as
//! the bits of a [`BinaryAngle`] (2³² per turn), times as microseconds, ranges as millimetres.
//!
//! **Versioning.** A change to any message here (a field added, removed, re-typed or re-ordered,
//! a variant added or moved) bumps [`PROTOCOL_VERSION`]; the golden-byte tests in
//! `protocol/golden.rs` fail until it is bumped and the goldens are renewed. [`Hello`] and
//! [`HelloAck`] are *frozen*: variant 0 of their enum, the same fields, in every version, so a peer
//! of any version can read the other's version and say why it refuses.
//!
//! **Conversions** borrow or copy, never allocate: [`ScanMsg::scan_input`] lends the message's own
//! vectors to the core as a [`ScanInput`]; [`ScanMsg::from_scan_input`] refuses a scan of more than
//! [`MAX_WIRE_BEAMS`] beams with [`WireError::TooManyBeams`]. [`ScanMsg::segments`] cuts a scan
//! into [`ScanSegmentMsg`]s of at most [`MAX_SEGMENT_BEAMS`] beams for a noisy line (protocol v2);
//! the core's [`crate::protocol::Inbox`] puts them back together.

pub use super::config_msg::{BudgetsMsg, ConfigMsg};
use crate::capacity::{BEAMS, MAX_PATH_WAYPOINTS};
use crate::controller::Mode;
use crate::scan::BeamLabel;
use serde::{Deserialize, Serialize};

mod core_to_host;
mod host_to_core;
pub use core_to_host::*;
pub use host_to_core::*;

/// The protocol version both peers must speak. Bumped by any change to any message.
///
/// * v1: the first release.
/// * v2: `HostToCore::ScanSegment` (tag 8): a scan may cross in segments; the configuration
///   carries `gaze` and `gaze_min_gain`, the status the gaze heading and its stage cost.
/// * v3: the configuration carries `nonmap_view_cap`.
/// * v4: the configuration carries `nonmap_drop_vacated`.
/// * v5: `ErrorCode::ConfigInvalid`: a configuration outside the core's ranges is refused, naming
///   the field; `Command(Reset)` is applied on arrival (a new search, lockstep time from 0).
/// * v6: scans and scan segments carry their sensor's `range_min_mm` and `range_max_mm` (REP 117:
///   a reading at or beyond `range_max` is "no return" and clears no farther than it);
///   `WireScanError::BadRangeLimits`. The configuration carries
///   `scan_matching` (after `budgets`).
/// * v7: LIVE's `MapRow` and `Route`, `live_priority_interval_us` in the configuration,
///   `search_entropy_bits` in the status.
/// * v8: the configuration carries `scan_match_field` (after `live_priority_interval_us`).
/// * v9: the configuration carries `lethal_radius_m` (after `scan_match_field`).
pub const PROTOCOL_VERSION: u16 = 9;

/// Most beams one scan carries, whole ([`ScanMsg`]) or in segments ([`ScanSegmentMsg`]): a 360°
/// scan at 0.33° (1091 beams) fits. Larger scans are refused ([`WireError::TooManyBeams`]).
/// Below the core's own limit ([`crate::capacity::MAX_INPUT_BEAMS`]), so every scan that crosses
/// the wire is one the core takes.
pub const MAX_WIRE_BEAMS: usize = 1100;

/// Most beams one [`ScanSegmentMsg`] carries. A segment of `n` labelled beams is a frame of about
/// `28 + 3n` bytes (`28 + 2n` unlabelled): 16 beams make 76 bytes, which survive a line that
/// corrupts 1 % of its bytes about half the time (0.99⁷⁶ ≈ 0.47), where a whole 897-beam scan
/// (2.7 kB) never does.
pub const MAX_SEGMENT_BEAMS: usize = 128;

/// Most waypoints in a [`GoalMsg`] path (the planner's [`MAX_PATH_WAYPOINTS`]).
pub const MAX_WIRE_WAYPOINTS: usize = MAX_PATH_WAYPOINTS;

/// Labels in a [`LabelsMsg`]: one per beam of the core's beam grid ([`BEAMS`]).
pub const MAX_WIRE_LABELS: usize = BEAMS;

// ---------------------------------------------------------------------------------------------
// Worst-case serialised sizes (postcard bytes, before CRC and COBS).

/// Bytes of a postcard varint holding `v`.
pub const fn varint_len(mut v: u64) -> usize {
    let mut n = 1;
    while v >= 0x80 {
        v >>= 7;
        n += 1;
    }
    n
}

const U32_MAX_LEN: usize = varint_len(u32::MAX as u64); // 5 (also any zigzag i32)
const U64_MAX_LEN: usize = varint_len(u64::MAX); // 10 (also any zigzag i64)

/// Largest [`HostToCore`] message: a [`ScanMsg`] of [`MAX_WIRE_BEAMS`] beams with labels
/// (tag, `t_us`, two angles, the two range limits, length + 2 bytes per range, `Some` + length +
/// 1 byte per label).
pub const MAX_HOST_TO_CORE_LEN: usize = 1
    + U64_MAX_LEN
    + 2 * U32_MAX_LEN
    + 2 * varint_len(u16::MAX as u64)
    + varint_len(MAX_WIRE_BEAMS as u64)
    + 2 * MAX_WIRE_BEAMS
    + 1
    + varint_len(MAX_WIRE_BEAMS as u64)
    + MAX_WIRE_BEAMS;

/// Largest [`GoalMsg`] message (64 waypoints, every field at its widest).
pub const MAX_GOAL_LEN: usize = 1
    + U32_MAX_LEN
    + 3 * U32_MAX_LEN
    + U64_MAX_LEN
    + varint_len(MAX_WIRE_WAYPOINTS as u64)
    + MAX_WIRE_WAYPOINTS * 2 * U32_MAX_LEN
    + U32_MAX_LEN;

/// Largest [`LabelsMsg`] message.
pub const MAX_LABELS_LEN: usize = 1 + U64_MAX_LEN + varint_len(MAX_WIRE_LABELS as u64) + MAX_WIRE_LABELS;

/// Largest [`CoreToHost`] message: the larger of [`MAX_GOAL_LEN`] and [`MAX_LABELS_LEN`] (every
/// other core-to-host message is smaller: a status is at most ~180 bytes).
pub const MAX_CORE_TO_HOST_LEN: usize = if MAX_GOAL_LEN > MAX_LABELS_LEN { MAX_GOAL_LEN } else { MAX_LABELS_LEN };

// ---------------------------------------------------------------------------------------------
// Handshake (frozen).

/// What kind of host is on the other end (logged; every role is accepted).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Role {
    /// A bridge to a real robot (ROS or a serial driver).
    Robot,
    /// The host simulator.
    Simulator,
    /// A replay of a recorded run.
    Replay,
}

/// The host's opening message. Frozen in every protocol version.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Hello {
    /// The host's [`PROTOCOL_VERSION`].
    pub version: u16,
    /// What the host is.
    pub role: Role,
    /// Ask the core to send a [`LabelsMsg`] after every scan it integrates (for logging).
    pub want_labels: bool,
}

impl Hello {
    /// A hello in this build's protocol version.
    pub const fn new(role: Role, want_labels: bool) -> Self {
        Self { version: PROTOCOL_VERSION, role, want_labels }
    }
}

/// Why a [`Hello`] was accepted or refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum AckReason {
    /// Same protocol version: the session is open.
    Compatible,
    /// Different protocol version: the core ignores everything but a new `Hello`.
    VersionMismatch,
}

/// The core's answer to a [`Hello`]. Frozen in every protocol version.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct HelloAck {
    /// The core's [`PROTOCOL_VERSION`].
    pub version: u16,
    /// Whether the session is open.
    pub accepted: bool,
    /// Why.
    pub reason: AckReason,
}

impl HelloAck {
    /// The core's answer to `hello`: accepted if and only if the versions are equal.
    pub const fn answer(hello: &Hello) -> Self {
        if hello.version == PROTOCOL_VERSION {
            Self { version: PROTOCOL_VERSION, accepted: true, reason: AckReason::Compatible }
        } else {
            Self { version: PROTOCOL_VERSION, accepted: false, reason: AckReason::VersionMismatch }
        }
    }

    /// The host's check of the answer: `Ok` only if the core accepted and speaks this build's
    /// version.
    pub const fn check(&self) -> Result<(), IncompatiblePeer> {
        if self.accepted && self.version == PROTOCOL_VERSION {
            Ok(())
        } else {
            Err(IncompatiblePeer { ours: PROTOCOL_VERSION, theirs: self.version })
        }
    }
}

/// The peer speaks another protocol version (or refused ours). Its `Display` says what to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct IncompatiblePeer {
    /// This build's version.
    pub ours: u16,
    /// The peer's version.
    pub theirs: u16,
}

impl core::fmt::Display for IncompatiblePeer {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.ours == self.theirs {
            write!(f, "the peer refused protocol v{} although it speaks it", self.ours)
        } else {
            write!(f, "incompatible protocol: this side speaks v{}, the peer v{}; build both from the same release", self.ours, self.theirs)
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Shared.

/// A liveness beacon, sent by both sides about once a second.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Heartbeat {
    /// Sender's clock, microseconds.
    pub t_us: u64,
    /// Sender's heartbeat counter (wraps).
    pub seq: u32,
}

/// A controller mode on the wire (mirrors [`Mode`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum WireMode {
    /// [`Mode::Idle`].
    Idle,
    /// [`Mode::Exploring`].
    Exploring,
    /// [`Mode::TargetFound`].
    TargetFound,
    /// [`Mode::Exhausted`].
    Exhausted,
    /// [`Mode::Stopped`].
    Stopped,
}

impl From<Mode> for WireMode {
    fn from(m: Mode) -> Self {
        match m {
            Mode::Idle => Self::Idle,
            Mode::Exploring => Self::Exploring,
            Mode::TargetFound => Self::TargetFound,
            Mode::Exhausted => Self::Exhausted,
            Mode::Stopped => Self::Stopped,
        }
    }
}

impl From<WireMode> for Mode {
    fn from(m: WireMode) -> Self {
        match m {
            WireMode::Idle => Self::Idle,
            WireMode::Exploring => Self::Exploring,
            WireMode::TargetFound => Self::TargetFound,
            WireMode::Exhausted => Self::Exhausted,
            WireMode::Stopped => Self::Stopped,
        }
    }
}

/// Why a wire value could not be built from a core value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WireError {
    /// The scan has more than [`MAX_WIRE_BEAMS`] beams (the count is given), in one message or
    /// in segments: decimate it on the host.
    TooManyBeams(usize),
    /// The label slice's length differs from the range slice's.
    LabelCountMismatch,
}

/// Why a [`ScanSegmentMsg`] cannot be part of a scan (the core counts and drops it; see
/// [`crate::protocol::Inbox::segments_refused`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SegmentError {
    /// No beams in the segment.
    Empty,
    /// `total_beams` is 0 or above [`MAX_WIRE_BEAMS`].
    BadTotal,
    /// The segment's beams do not lie within `0..total_beams`.
    OutOfRange,
    /// The labels' count differs from the ranges'.
    LabelCountMismatch,
}

// ---------------------------------------------------------------------------------------------
// Serde helpers: heapless vectors without the `heapless/serde` feature, fixed-width ranges, and
// beam labels as one byte.

impl Serialize for BeamLabel {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(*self as u8)
    }
}

impl<'de> Deserialize<'de> for BeamLabel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match u8::deserialize(d)? {
            0 => Ok(BeamLabel::Unlabelled),
            1 => Ok(BeamLabel::Map),
            2 => Ok(BeamLabel::NonMap),
            v => Err(serde::de::Error::invalid_value(serde::de::Unexpected::Unsigned(v as u64), &"a beam label 0, 1 or 2")),
        }
    }
}

mod ser {
    //! `#[serde(with = …)]` modules. Each reads a sequence into a `heapless::Vec`, refusing one
    //! longer than the capacity before reading past it (bounded work, no allocation).
    use core::marker::PhantomData;
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    struct SeqVisitor<T, E, const N: usize>(PhantomData<fn() -> (T, E)>);

    impl<'de, T, E, const N: usize> Visitor<'de> for SeqVisitor<T, E, N>
    where
        E: Deserialize<'de> + Into<T>,
    {
        type Value = heapless::Vec<T, N>;

        fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
            write!(f, "a sequence of at most {N} elements")
        }

        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            if let Some(n) = seq.size_hint() {
                if n > N {
                    return Err(A::Error::invalid_length(n, &self));
                }
            }
            let mut out = heapless::Vec::new();
            while let Some(e) = seq.next_element::<E>()? {
                if out.push(e.into()).is_err() {
                    return Err(A::Error::invalid_length(N + 1, &self));
                }
            }
            Ok(out)
        }
    }

    /// A range as two little-endian bytes (postcard would spend 3 bytes on values ≥ 16384).
    struct LeU16(u16);

    impl<'de> Deserialize<'de> for LeU16 {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            <[u8; 2]>::deserialize(d).map(|b| LeU16(u16::from_le_bytes(b)))
        }
    }

    impl From<LeU16> for u16 {
        fn from(v: LeU16) -> u16 {
            v.0
        }
    }

    pub mod vec {
        //! Any `heapless::Vec<T, N>` as a postcard sequence (length, then the elements).
        use super::*;

        pub fn serialize<S: Serializer, T: Serialize, const N: usize>(v: &heapless::Vec<T, N>, s: S) -> Result<S::Ok, S::Error> {
            s.collect_seq(v.iter())
        }

        pub fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(d: D) -> Result<heapless::Vec<T, N>, D::Error> {
            d.deserialize_seq(SeqVisitor::<T, T, N>(PhantomData))
        }
    }

    pub mod ranges {
        //! `heapless::Vec<u16, N>` as a length, then 2 bytes little-endian per element.
        use super::*;

        pub fn serialize<S: Serializer, const N: usize>(v: &heapless::Vec<u16, N>, s: S) -> Result<S::Ok, S::Error> {
            s.collect_seq(v.iter().map(|r| r.to_le_bytes()))
        }

        pub fn deserialize<'de, D: Deserializer<'de>, const N: usize>(d: D) -> Result<heapless::Vec<u16, N>, D::Error> {
            d.deserialize_seq(SeqVisitor::<u16, LeU16, N>(PhantomData))
        }
    }

    pub mod opt_labels {
        //! `Option<heapless::Vec<T, N>>`: postcard's option tag, then the sequence.
        use super::*;

        struct Seq<'a, T, const N: usize>(&'a heapless::Vec<T, N>);

        impl<T: Serialize, const N: usize> Serialize for Seq<'_, T, N> {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.collect_seq(self.0.iter())
            }
        }

        pub fn serialize<S: Serializer, T: Serialize, const N: usize>(v: &Option<heapless::Vec<T, N>>, s: S) -> Result<S::Ok, S::Error> {
            match v {
                None => s.serialize_none(),
                Some(v) => s.serialize_some(&Seq(v)),
            }
        }

        struct OptVisitor<T, const N: usize>(PhantomData<fn() -> T>);

        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for OptVisitor<T, N> {
            type Value = Option<heapless::Vec<T, N>>;

            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                write!(f, "an optional sequence of at most {N} elements")
            }

            fn visit_none<E: Error>(self) -> Result<Self::Value, E> {
                Ok(None)
            }

            fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
                super::vec::deserialize(d).map(Some)
            }
        }

        pub fn deserialize<'de, D: Deserializer<'de>, T: Deserialize<'de>, const N: usize>(
            d: D,
        ) -> Result<Option<heapless::Vec<T, N>>, D::Error> {
            d.deserialize_option(OptVisitor::<T, N>(PhantomData))
        }
    }
}

#[cfg(test)]
mod tests;
