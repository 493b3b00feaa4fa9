//! One run loop: a *source* senses, a *brain* answers, *observers* watch ([`drive`]).
//!
//! Every way the host runs the controller is this loop with other parts:
//!
//! | run                       | source                              | brain                                  |
//! |---------------------------|-------------------------------------|----------------------------------------|
//! | `lives search`, `eval`    | [`SimSource`] (lockstep)            | [`InProcess`]                          |
//! | `lives bridge` (simulator)| [`SimSource`] (lockstep or paced)   | the node over a link (`link::sim_bridge`) |
//! | `lives replay`            | a recorded log (`replay::run`)      | [`InProcess`], restarting when exhausted |
//! | dataset episodes          | [`SimSource`] with a [`Walker`]     | [`InProcess`] until it hands over, then none |
//! | unseen-world walks        | [`SimSource`] with a [`Walker`]     | none ([`Idle`])                        |
//!
//! A tick is: [`Brain::ready`] (may end the run before anything is sensed), [`Source::sense`]
//! (a [`Frame`]: time, pose, scan, detection, the base's state; `None` ends the run), the
//! [`Brain::think`] ([`Answer`]: how the run ends, if it does, and what the base is to do, in
//! order), every observer's [`Observer::answered`], then [`Source::act`] (the base does what it
//! was told and moves for one period; it may end the run: a time limit) and
//! [`Observer::acted`]. Nothing in the loop reads a clock.
//!
//! What cannot be shared stays in the part that needs it, not in the loop:
//! * **Pacing.** The simulator in lockstep moves one period per tick whatever the wall clock says;
//!   the serial bridge in real time sends a tick each `period` of wall time and handles what the
//!   node says in between. That wait is inside the node brain's `think` (it returns at the next
//!   deadline); the simulator does not move while a brain thinks, so a goal applied when it
//!   arrives and one applied when `think` returns are the same goal.
//! * **Safety stops.** The bridge's session stops the base the moment the link is lost, from
//!   inside its I/O. For the simulator its base is a proxy that queues what the session does to
//!   the base ([`Act`]s, in order), which the simulator applies before it moves: exact, since
//!   the simulator stands still while the brain thinks. A real robot (`link::robot`) must be
//!   stopped at once, not at the end of a tick, and its sensors arrive on their own clocks
//!   (odometry, scans and detections from the adapter's client and a VLP-16 thread, polled
//!   between the node's frames), so its loop stays its own: a session that owns the robot's base.
//! * **Tick counts.** The loop counts thoughts; the bridge counts ticks the node answered
//!   (lockstep) or that were sent (real time), its own definition, kept in the node brain.

mod controller;
mod score;
mod sim;
mod walk;

pub use controller::{centred_origin, controller_config, Idle, InProcess};
pub use score::{
    count_labels, LabelScore, Motion, RunTally, LIDAR_SIGHTING_BEAMS, MOVING_M_PER_TICK, TURNING_RAD_PER_TICK,
};
pub use sim::{encode_sim_scan, gt_label, sim_limits, step_base, BaseStep, Clock, SimSource};
pub use walk::{line_clear, Walker};

use crate::range::EncodedScan;
use firmware::{Command, Detection, Inputs, Pose2};

/// Controller period and simulator step, microseconds (the LiDAR's 5 Hz).
pub const TICK_US: u64 = 200_000;

/// What a source sensed at one tick.
pub struct Frame {
    /// The tick's time, microseconds.
    pub t_us: u64,
    /// The pose the brain is given (the laser's, in the controller's frame); `None` if not valid.
    pub pose: Option<Pose2>,
    /// Where the base is in the source's own frame `[x, y, yaw]` (the simulator's truth, a log's
    /// pose): what a goal interrupted by a lost link resumes from.
    pub base_pose: [f64; 3],
    /// The source's time then, seconds (simulated, or a log's).
    pub time_s: f64,
    /// The scan.
    pub scan: EncodedScan,
    /// Give the brain the scan's per-beam labels (ground truth for `lives-gt`).
    pub labels: bool,
    /// The camera detects the target.
    pub detection: bool,
    /// The base reported it was blocked during the last period.
    pub base_blocked: bool,
}

impl Frame {
    /// The controller's inputs for this frame, with `command`.
    pub fn inputs(&self, command: Option<Command>) -> Inputs<'_> {
        Inputs {
            pose: self.pose,
            scan: Some(self.scan.input(self.labels)),
            detection: self.detection.then_some(Detection { position: None }),
            command,
            base_blocked: self.base_blocked,
        }
    }
}

/// What the base is to do, in the brain's frame (the one of [`Frame::pose`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Act {
    /// Stop.
    Stop,
    /// Drive along `path` and turn to `final_yaw` at its end.
    Path(Vec<[f64; 2]>, Option<f64>),
    /// Where the camera looks while walking (radians), `None`: ahead.
    Gaze(Option<f64>),
    /// No brain drives: the source's own walker does.
    Wander,
}

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// The brain found the target.
    Found,
    /// The brain has nothing left to explore.
    Exhausted,
    /// The brain was told to stop (or lost its node for good).
    Stopped,
    /// The source ended: a time limit, a log's last scan, an episode's length.
    Source,
}

/// A brain's answer to a frame.
#[derive(Clone, Debug, Default)]
pub struct Answer {
    /// The command the brain gave its controller with the frame (`Start`), for observers.
    pub command: Option<Command>,
    /// The run ends here (the base does not act on this answer).
    pub end: Option<End>,
    /// What the base is to do, in order.
    pub acts: Vec<Act>,
}

/// Yields sensor frames and moves the base.
pub trait Source {
    /// The frame of tick `tick` (0, 1, …); `None`: the source has no more.
    fn sense(&mut self, tick: u32) -> Option<Frame>;
    /// Does what the brain said and moves for one period; `false` ends the run ([`End::Source`]).
    fn act(&mut self, answer: &Answer) -> bool;
}

/// Answers frames with goals.
pub trait Brain {
    /// Why a run cannot go on (a node refusing the session).
    type Error;
    /// Before a tick is sensed: `Some` ends the run there (told to stop).
    fn ready(&mut self) -> Result<Option<End>, Self::Error> {
        Ok(None)
    }
    /// The answer to `frame`.
    fn think(&mut self, frame: &Frame) -> Result<Answer, Self::Error>;
}

/// Watches a run; it reads, it cannot change it.
pub trait Observer<S, B> {
    /// After the brain answered a frame.
    fn answered(&mut self, _source: &S, _frame: &Frame, _brain: &B, _answer: &Answer) {}
    /// After the base acted on the answer and moved.
    fn acted(&mut self, _source: &S) {}
}

impl<S, B, F: FnMut(&S, &Frame, &B, &Answer)> Observer<S, B> for F {
    fn answered(&mut self, source: &S, frame: &Frame, brain: &B, answer: &Answer) {
        self(source, frame, brain, answer)
    }
}

/// Calls `f` with the source after every period the base moved (progress bars).
pub struct AfterAct<F>(pub F);

impl<S, B, F: FnMut(&S)> Observer<S, B> for AfterAct<F> {
    fn acted(&mut self, source: &S) {
        (self.0)(source)
    }
}

/// How a run went.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Ended {
    /// Why it ended.
    pub end: End,
    /// Frames the brain answered.
    pub ticks: u32,
}

/// Runs `brain` on `source` until one of them ends the run, showing every tick to `observers`.
pub fn drive<S: Source, B: Brain>(source: &mut S, brain: &mut B, observers: &mut [&mut dyn Observer<S, B>]) -> Result<Ended, B::Error> {
    let mut ticks = 0u32;
    loop {
        if let Some(end) = brain.ready()? {
            return Ok(Ended { end, ticks });
        }
        let Some(frame) = source.sense(ticks) else {
            return Ok(Ended { end: End::Source, ticks });
        };
        let answer = brain.think(&frame)?;
        ticks += 1;
        for o in observers.iter_mut() {
            o.answered(source, &frame, brain, &answer);
        }
        if let Some(end) = answer.end {
            return Ok(Ended { end, ticks });
        }
        let go_on = source.act(&answer);
        for o in observers.iter_mut() {
            o.acted(source);
        }
        if !go_on {
            return Ok(Ended { end: End::Source, ticks });
        }
    }
}
