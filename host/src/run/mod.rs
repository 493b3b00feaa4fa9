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
//!
//! Every source gives its scans to the loop in the core's encoding, by one rule ([`range`]: a
//! metric range to the wire's millimetres, ROS's REP 117).

mod controller;
mod cycle;
pub mod range;
mod score;
mod sim;
mod walk;

pub use controller::{centred_origin, controller_config, Idle, InProcess};
pub use cycle::{drive, Act, AfterAct, Answer, Brain, End, Ended, Frame, Observer, Source, TICK_US};
pub use score::{
    count_labels, round3, LabelScore, Motion, RunTally, Summary, LIDAR_SIGHTING_BEAMS, MOVING_M_PER_TICK, TURNING_RAD_PER_TICK,
};
pub use sim::{encode_sim_scan, gt_label, sim_limits, step_base, BaseStep, Clock, SimSource};
pub use walk::{line_clear, Walker};
