//! Host messages between two ticks, gathered into one tick's [`Inputs`].
//!
//! Messages arrive at the link's pace, the controller ticks at its own. The inbox keeps what the
//! next tick needs: the latest pose, the latest scan (an older one not yet ticked is superseded
//! and counted), the latest detection, the base's blocked flag (a state: it stays until the base
//! reports otherwise) and up to [`MAX_PENDING_COMMANDS`] commands, one per tick, in order (a
//! `Reset` then a `Start` must both happen). A configuration is handed back to the caller, which
//! decides when to apply it.

use crate::controller::{Command, Detection, Inputs};
use crate::protocol::message::{ConfigMsg, Heartbeat, HostToCore, ScanMsg};
use fixed_point::Pose2;

/// Commands queued between ticks; more are dropped and counted.
pub const MAX_PENDING_COMMANDS: usize = 4;

/// What [`Inbox::accept`] did with a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Accepted {
    /// Stored for the next tick (or a heartbeat noted).
    Stored,
    /// A configuration: the caller applies it (the inbox keeps nothing).
    Config(ConfigMsg),
    /// A `Hello`, which belongs to the [`crate::protocol::Session`]; ignored here.
    NotForInbox,
}

/// The next tick's inputs, as they accumulate.
#[derive(Clone, Debug, Default)]
pub struct Inbox {
    pose: Option<Pose2>,
    scan: Option<ScanMsg>,
    detection: Option<Detection>,
    commands: heapless::Deque<Command, MAX_PENDING_COMMANDS>,
    base_blocked: bool,
    last_heartbeat: Option<Heartbeat>,
    /// Scans replaced by a newer one before a tick took them.
    pub scans_superseded: u32,
    /// Commands dropped because [`MAX_PENDING_COMMANDS`] were already waiting.
    pub commands_dropped: u32,
}

impl Inbox {
    /// An empty inbox.
    pub const fn new() -> Self {
        Self {
            pose: None,
            scan: None,
            detection: None,
            commands: heapless::Deque::new(),
            base_blocked: false,
            last_heartbeat: None,
            scans_superseded: 0,
            commands_dropped: 0,
        }
    }

    /// Takes one admitted message.
    pub fn accept(&mut self, msg: HostToCore) -> Accepted {
        match msg {
            HostToCore::Hello(_) => return Accepted::NotForInbox,
            HostToCore::Heartbeat(h) => self.last_heartbeat = Some(h),
            HostToCore::Pose(p) => self.pose = Some(p.pose()),
            HostToCore::Scan(s) => {
                if self.scan.replace(s).is_some() {
                    self.scans_superseded = self.scans_superseded.wrapping_add(1);
                }
            }
            HostToCore::Detection(d) => self.detection = Some(d.detection()),
            HostToCore::Command(c) => {
                if self.commands.push_back(c.into()).is_err() {
                    self.commands_dropped = self.commands_dropped.wrapping_add(1);
                }
            }
            HostToCore::Config(c) => return Accepted::Config(c),
            HostToCore::BaseStatus(b) => self.base_blocked = b.blocked,
        }
        Accepted::Stored
    }

    /// The inputs for the next tick, borrowing the stored scan.
    pub fn inputs(&self) -> Inputs<'_> {
        Inputs {
            pose: self.pose,
            scan: self.scan.as_ref().map(ScanMsg::scan_input),
            detection: self.detection,
            command: self.commands.front().copied(),
            base_blocked: self.base_blocked,
        }
    }

    /// After a tick: forgets the pose, scan and detection it took and the command it ran; keeps
    /// the blocked flag and the other queued commands.
    pub fn ticked(&mut self) {
        self.pose = None;
        self.scan = None;
        self.detection = None;
        self.commands.pop_front();
    }

    /// The host's last heartbeat.
    pub const fn last_heartbeat(&self) -> Option<Heartbeat> {
        self.last_heartbeat
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::message::{BaseStatus, DetectionMsg, PoseMsg, WireCommand};

    fn scan(t_us: u64) -> HostToCore {
        let mut m = ScanMsg { t_us, angle_min: 0, angle_increment: 1 << 20, ..Default::default() };
        m.ranges_mm.extend_from_slice(&[1000, 2000, 3000]).unwrap();
        HostToCore::Scan(m)
    }

    #[test]
    fn messages_between_ticks_become_one_tick_of_inputs() {
        let mut inbox = Inbox::new();
        assert_eq!(inbox.accept(HostToCore::Pose(PoseMsg { t_us: 1, x: 65_536, y: -65_536, theta: 1 << 30 })), Accepted::Stored);
        inbox.accept(scan(1));
        inbox.accept(scan(2));
        inbox.accept(HostToCore::Detection(DetectionMsg { t_us: 2, position: None }));
        inbox.accept(HostToCore::Command(WireCommand::Reset));
        inbox.accept(HostToCore::Command(WireCommand::Start));
        inbox.accept(HostToCore::BaseStatus(BaseStatus { blocked: true }));
        assert_eq!(inbox.scans_superseded, 1);

        let i = inbox.inputs();
        assert_eq!(i.pose.unwrap().x.to_bits(), 65_536);
        assert_eq!(i.scan.unwrap().ranges_mm, &[1000, 2000, 3000]);
        assert!(i.detection.is_some() && i.base_blocked);
        assert_eq!(i.command, Some(Command::Reset));

        inbox.ticked();
        let i = inbox.inputs();
        assert!(i.pose.is_none() && i.scan.is_none() && i.detection.is_none());
        assert_eq!(i.command, Some(Command::Start), "the second command runs on the next tick");
        assert!(i.base_blocked, "blocked is a state, it stays");
        inbox.ticked();
        assert_eq!(inbox.inputs().command, None);
    }

    #[test]
    fn commands_beyond_the_queue_are_dropped_and_counted() {
        let mut inbox = Inbox::new();
        for _ in 0..MAX_PENDING_COMMANDS + 2 {
            inbox.accept(HostToCore::Command(WireCommand::Stop));
        }
        assert_eq!(inbox.commands_dropped, 2);
    }
}
