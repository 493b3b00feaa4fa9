//! The core's side of the handshake: which messages reach the controller.
//!
//! The host opens with [`Hello`]; the core answers every `Hello` with a [`HelloAck`] and opens the
//! session only if the versions are equal. Until then every other message is refused with an
//! [`ErrorCode`] that says why — [`ErrorCode::HandshakeRequired`] before any `Hello`,
//! [`ErrorCode::VersionMismatch`] after a refused one — and counted in
//! [`LinkCounters::ignored`]. A new `Hello` at any time starts over (a host that restarted, or
//! was updated).

use crate::protocol::message::LinkCounters;
use crate::protocol::message::{ErrorCode, Hello, HelloAck, HostToCore, Role};

/// Where the handshake stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SessionState {
    /// No `Hello` yet.
    AwaitingHello,
    /// A compatible host said `Hello`.
    Open {
        /// What the host is.
        role: Role,
        /// It asked for per-scan labels.
        want_labels: bool,
    },
    /// The last `Hello` came from a host speaking protocol `peer`.
    Refused {
        /// The host's version.
        peer: u16,
    },
}

/// What to do with a decoded message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Admission {
    /// Hand it to the controller.
    Deliver,
    /// It was a `Hello`: send this answer.
    Answer(HelloAck),
    /// Not admitted (and counted): send `Error { code }` (rate-limit as you like).
    Refuse(ErrorCode),
}

/// The handshake state and its counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Session {
    state: SessionState,
    ignored: u32,
}

impl Session {
    /// No session yet.
    pub const fn new() -> Self {
        Self { state: SessionState::AwaitingHello, ignored: 0 }
    }

    /// Where the handshake stands.
    pub const fn state(&self) -> SessionState {
        self.state
    }

    /// True once a compatible `Hello` was accepted.
    pub const fn is_open(&self) -> bool {
        matches!(self.state, SessionState::Open { .. })
    }

    /// The host asked for [`crate::protocol::LabelsMsg`] after every integrated scan.
    pub const fn wants_labels(&self) -> bool {
        matches!(self.state, SessionState::Open { want_labels: true, .. })
    }

    /// Decides what happens to `msg`.
    pub fn admit(&mut self, msg: &HostToCore) -> Admission {
        if let HostToCore::Hello(h) = msg {
            return Admission::Answer(self.hello(h));
        }
        let refuse = match self.state {
            SessionState::Open { .. } => return Admission::Deliver,
            SessionState::AwaitingHello => ErrorCode::HandshakeRequired,
            SessionState::Refused { peer } => ErrorCode::VersionMismatch { peer },
        };
        self.ignored = self.ignored.wrapping_add(1);
        Admission::Refuse(refuse)
    }

    /// Answers a `Hello` and moves to the state it implies.
    pub fn hello(&mut self, h: &Hello) -> HelloAck {
        let ack = HelloAck::answer(h);
        self.state = if ack.accepted {
            SessionState::Open { role: h.role, want_labels: h.want_labels }
        } else {
            SessionState::Refused { peer: h.version }
        };
        ack
    }

    /// `rx` (a decoder's counters) with this session's `ignored` count filled in.
    pub const fn counters(&self, rx: LinkCounters) -> LinkCounters {
        LinkCounters { ignored: self.ignored, ..rx }
    }
}

impl Default for Session {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::message::{AckReason, PoseMsg, PROTOCOL_VERSION};

    #[test]
    fn a_wrong_version_is_refused_with_a_clear_status() {
        let mut s = Session::new();
        let pose = HostToCore::Pose(PoseMsg::default());
        assert_eq!(s.admit(&pose), Admission::Refuse(ErrorCode::HandshakeRequired));

        let old = Hello { version: PROTOCOL_VERSION + 1, role: Role::Robot, want_labels: false };
        let ack = match s.admit(&HostToCore::Hello(old)) {
            Admission::Answer(a) => a,
            other => panic!("expected an answer, got {other:?}"),
        };
        assert_eq!(ack, HelloAck { version: PROTOCOL_VERSION, accepted: false, reason: AckReason::VersionMismatch });
        assert_eq!(s.state(), SessionState::Refused { peer: PROTOCOL_VERSION + 1 });
        // Everything else is refused, saying which version the host spoke.
        assert_eq!(s.admit(&pose), Admission::Refuse(ErrorCode::VersionMismatch { peer: PROTOCOL_VERSION + 1 }));
        assert_eq!(s.counters(LinkCounters::default()).ignored, 3 - 1);
        // The host side reads the same answer as an error that says what to do.
        let err = ack.check().unwrap_err();
        assert_eq!((err.ours, err.theirs), (PROTOCOL_VERSION, PROTOCOL_VERSION));

        // A compatible Hello opens the session; messages flow.
        let ack = s.hello(&Hello::new(Role::Simulator, true));
        assert_eq!(ack, HelloAck { version: PROTOCOL_VERSION, accepted: true, reason: AckReason::Compatible });
        assert_eq!(ack.check(), Ok(()));
        assert!(s.is_open() && s.wants_labels());
        assert_eq!(s.admit(&pose), Admission::Deliver);
    }

    #[test]
    fn the_host_names_both_versions_when_the_core_is_older() {
        // A core of version 6 answers our Hello.
        let ack = HelloAck { version: 6, accepted: false, reason: AckReason::VersionMismatch };
        let err = ack.check().unwrap_err();
        assert_eq!((err.ours, err.theirs), (PROTOCOL_VERSION, 6));
        let mut text = heapless::String::<160>::new();
        core::fmt::write(&mut text, format_args!("{err}")).unwrap();
        assert!(text.contains("v6") && text.contains("incompatible"), "{text}");
    }
}
