//! # The wire: messages between the host bridge and the controller core
//!
//! One byte stream each way (a UART, a USB CDC port, a pipe, a pseudo-terminal). The layers, from
//! the value to the bytes on the line:
//!
//! | layer | what | module |
//! |---|---|---|
//! | message | [`HostToCore`] / [`CoreToHost`]: integers, Q16.16 bits, binary angles, µs, mm | [`message`] |
//! | encoding | postcard 1.x (varints, zigzag for signed; fields in declaration order) | `postcard` |
//! | check | CRC-32/ISO-HDLC of the postcard bytes, appended little-endian | [`frame`] |
//! | framing | COBS over message and CRC, then one `0x00` delimiter | [`frame`] |
//!
//! The full byte-level description, with a worked frame, is `docs/protocol.md`; the golden-byte
//! tests (`protocol/golden.rs`) pin every message type to exact bytes.
//!
//! **Sessions.** The host opens with [`Hello`] carrying its [`PROTOCOL_VERSION`]; the core
//! answers [`HelloAck`] and acts on nothing else until the versions agree ([`Session`]). Any
//! change to any message bumps the version.
//!
//! **Robustness.** Decoding never allocates and never panics: a frame with bad COBS, a bad CRC,
//! an undecodable body or too many bytes is dropped and counted ([`LinkCounters`]), and decoding
//! resumes after the next `0x00`. The largest frame is [`MAX_FRAME_LEN`] bytes: a scan of
//! [`MAX_WIRE_BEAMS`] beams with labels; larger scans are refused at the sender. On a noisy line
//! the host sends scans in [`ScanSegmentMsg`]s of a few dozen beams instead (protocol v2), small
//! frames that mostly survive, and the [`Inbox`] assembles them; lost segments cost beams, not
//! the scan.
//!
//! **In the core** a node owns a [`CoreDecoder`], a [`Session`], an [`Inbox`] and the controller:
//! bytes in → messages → admitted → the next tick's [`crate::Inputs`]; the tick's
//! [`crate::Outputs`] → [`output_messages`] → [`encode`] → bytes out.
//!
//! This module owns the wire format and nothing else: it does not tick the controller, read a
//! clock or touch a port.

pub mod config_msg;
pub mod frame;
#[cfg(test)]
mod fuzz;
#[cfg(test)]
mod golden;
pub mod inbox;
pub mod message;
pub mod session;

pub use frame::{
    encode, CoreDecoder, Decoder, FrameError, HostDecoder, CRC_LEN, MAX_CORE_TO_HOST_FRAME, MAX_FRAME_LEN, MAX_HOST_TO_CORE_FRAME,
};
pub use inbox::{Accepted, Inbox};
pub use message::{
    output_messages, AckReason, BaseStatus, ConfigMsg, CoreToHost, DetectionMsg, ErrorCode, ErrorMsg, GoalMsg, Heartbeat, Hello, HelloAck,
    HostToCore, IncompatiblePeer, LabelsMsg, LinkCounters, MapRowMsg, PoseMsg, Role, RouteMsg, ScanMsg, ScanSegmentMsg, SegmentError,
    StatusMsg, StopMsg, WireCommand, WireError, WireMode, WireWaypoint, MAP_ROW_BYTES, MAX_ROUTE_CHUNK, MAX_SEGMENT_BEAMS, MAX_WIRE_BEAMS,
    PROTOCOL_VERSION,
};
pub use session::{Admission, Session, SessionState};
