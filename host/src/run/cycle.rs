//! The loop and what passes through it (see the module above).

use crate::run::range::EncodedScan;
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
