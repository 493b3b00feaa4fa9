//! The simulator through the node ([`run_sim`], `lives bridge` with the simulator): the run loop
//! ([`crate::run::drive`]) with the simulator as the source and the node, over the link, as the
//! brain ([`NodeBrain`]). With a clean link in lockstep the run is the in-process
//! [`crate::search::run`] tick for tick: the same source, another brain.
//!
//! The session ([`Bridge`]) stops the base the moment the link is lost, from inside its I/O. Here
//! its base is a [`QueuedBase`]: what the session does to the base is queued, in order, and the
//! simulator applies the queue before it moves. The simulator stands still while the brain
//! thinks (in lockstep while the node answers, in real time until the next deadline), so the base
//! ends each tick exactly as if the session had driven it directly.

use super::bridge::{
    Base, Bridge, BridgeError, BridgeOptions, BridgeResult, ClassifierCheck, NOT_TICKING_ECHOES, NOT_TICKING_FOR, SEQ_BASE,
};
use super::{Link, TimeMode};
use crate::run::{controller_config, drive, Act, Answer, Brain, Clock, End, Ended, Frame};
use crate::search::{SearchResult, SearchSpec};
use firmware::protocol::{
    BaseStatus, ConfigMsg, CoreToHost, DetectionMsg, GoalMsg, HostToCore, PoseMsg, ScanMsg, StatusMsg, WireCommand, WireMode,
};
use firmware::{BinaryAngle, GridGeometry, Meters};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The simulator's base as the session sees it: its pose and time are those of the frame being
/// answered; what the session does to it is queued for the simulator.
pub(super) struct QueuedBase {
    time_s: f64,
    pose: [f64; 3],
    acts: Vec<Act>,
}

impl Base for QueuedBase {
    fn time_s(&self) -> f64 {
        self.time_s
    }
    fn pose(&self) -> [f64; 3] {
        self.pose
    }
    fn set_path(&mut self, path: &[[f64; 2]], final_yaw: Option<f64>) {
        // The node's goals are in its frame: the laser's, in the (drifting) odometry frame.
        self.acts.push(Act::Path(path.to_vec(), final_yaw));
    }
    fn stop_base(&mut self) {
        self.acts.push(Act::Stop);
    }
}

/// The node at the other end of the link as the run's brain.
pub(super) struct NodeBrain<'l> {
    b: Bridge<'l, QueuedBase>,
    config_msg: ConfigMsg,
    geom: GridGeometry,
    classifier_check: ClassifierCheck,
    /// Every new goal applied to the base, in order (cell and heading).
    goals: Vec<((i32, i32), BinaryAngle)>,
    recorded_seq: Option<u32>,
    /// Ticks the node answered (lockstep) or that were sent (real time).
    ticks: u32,
    need_start: bool,
    next_tick: Instant,
}

impl NodeBrain<'_> {
    /// Records a goal applied to the base in the run's decision list (once per `seq`: a goal
    /// resumed after a lost link is the same decision).
    fn note_goal(&mut self, g: &GoalMsg) {
        if self.recorded_seq != Some(g.seq) {
            self.recorded_seq = Some(g.seq);
            self.goals.push((self.geom.cell_of(Meters::from_bits(g.x), Meters::from_bits(g.y)), BinaryAngle(g.theta)));
        }
    }

    fn answer(&mut self, end: Option<End>) -> Answer {
        Answer { command: None, end, acts: std::mem::take(&mut self.b.sim.acts) }
    }

    fn progress(&self) {
        if let Some(pr) = &self.b.opts.progress {
            pr.store(self.ticks, Ordering::Relaxed);
        }
    }

    /// The frames of a tick: `Start` (after the configuration if the node is idle again), the
    /// base's state, the pose, a detection, the scan (whole or in segments).
    fn batch(&mut self, frame: &Frame) -> Vec<u8> {
        let now_us = frame.t_us;
        let scan_msg = match ScanMsg::from_scan_input(now_us, &frame.scan.input(frame.labels)) {
            Ok(m) => m,
            Err(e) => panic!("the simulator's {} beams must fit a scan frame: {e:?}", frame.scan.ranges_mm.len()),
        };
        let b = &mut self.b;
        let mut batch = Vec::new();
        if self.need_start {
            if self.ticks > 0 {
                // The node is idle (it restarted, or missed Start): configure it again.
                batch.extend(b.frame(&HostToCore::Config(self.config_msg)));
            }
            batch.extend(b.frame(&HostToCore::Command(WireCommand::Start)));
        }
        batch.extend(b.frame(&HostToCore::BaseStatus(BaseStatus { blocked: frame.base_blocked })));
        let pose = frame.pose.unwrap_or_default();
        batch.extend(b.frame(&HostToCore::Pose(PoseMsg::from_pose(now_us, &pose))));
        if frame.detection {
            batch.extend(b.frame(&HostToCore::Detection(DetectionMsg { t_us: now_us, position: None })));
        }
        if let Some(Ok(mut o)) = b.opts.observer.as_ref().map(|o| o.0.lock()) {
            let detection = frame.detection.then_some(DetectionMsg { t_us: now_us, position: None });
            o.tick(&PoseMsg::from_pose(now_us, &pose), &scan_msg, detection.as_ref());
        }
        let before = batch.len();
        if b.opts.scan_segment_beams > 0 {
            let segments = scan_msg.segments(b.opts.scan_segment_beams);
            b.st.scan_frames = segments.len();
            for seg in segments {
                batch.extend(b.frame(&HostToCore::ScanSegment(seg)));
            }
        } else {
            b.st.scan_frames = 1;
            batch.extend(b.frame(&HostToCore::Scan(scan_msg)));
        }
        b.st.scan_frame_bytes = batch.len() - before;
        batch
    }

    /// Real time: sends the batch (closed by a heartbeat: a node in real time echoes it at once,
    /// the link's round trip, and a node started in lockstep ticks on it, at this batch's time,
    /// instead of once per probe), then applies what the node says until the next deadline.
    fn real_time(&mut self, t_us: u64, mut batch: Vec<u8>) -> Result<Answer, BridgeError> {
        if self.b.open {
            let (_, hb) = self.b.probe(t_us, true);
            batch.extend(hb);
            self.b.send(&batch);
        }
        self.ticks += 1;
        super::advance_deadline(&mut self.next_tick, self.b.opts.period, Instant::now());
        self.progress();
        loop {
            if let Some(end) = self.ready()? {
                return Ok(self.answer(Some(end)));
            }
            if Instant::now() >= self.next_tick {
                return Ok(self.answer(None));
            }
            // Between ticks: apply what the node says.
            let wait = self.next_tick.saturating_duration_since(Instant::now()).min(Duration::from_millis(20));
            for m in self.b.poll(wait) {
                match m {
                    CoreToHost::Goal(g) if self.b.open && self.b.apply_goal(&g) => self.note_goal(&g),
                    CoreToHost::Stop(_) => self.b.sim.stop_base(),
                    CoreToHost::Status(s) => {
                        self.classifier_check.observe(&s)?;
                        self.need_start = s.mode == WireMode::Idle;
                        self.b.sim.acts.push(Act::Gaze(s.gaze.map(|h| BinaryAngle(h).to_radians())));
                        match s.mode {
                            WireMode::TargetFound => return Ok(self.answer(Some(End::Found))),
                            WireMode::Exhausted => return Ok(self.answer(Some(End::Exhausted))),
                            _ => {}
                        }
                    }
                    _ => {}
                }
            }
        }
    }

    /// Lockstep: sends until the node has answered this batch. Its status may come with any
    /// attempt (a retry of a ticked batch brings the same outputs again); the goal it counts
    /// too, possibly with another attempt.
    fn lockstep(&mut self, now_us: u64, batch: Vec<u8>) -> Result<Answer, BridgeError> {
        let b = &mut self.b;
        let mut attempts = 0u32;
        let mut status_t: Option<StatusMsg> = None;
        let mut answers = 0u32;
        // Attempts in a row the node echoed without ticking (a damaged batch is echoed without
        // a tick too, but never this many times running: the node ticks a partial scan after
        // a few beats).
        let mut echoed_idle = 0u32;
        let mut idle_since = Instant::now();
        // Statuses of other times meanwhile (a late answer to the last batch is one or two).
        let mut other_statuses = 0u32;
        let status = loop {
            if !b.await_session().unwrap_or(false) || b.should_stop() {
                if let Some(e) = b.incompatible {
                    return Err(BridgeError::Incompatible(e));
                }
                return Ok(self.answer(Some(End::Stopped)));
            }
            if attempts > 0 {
                b.st.retries += 1;
            }
            attempts += 1;
            let (seq, hb) = b.probe(now_us, false);
            let mut bytes = batch.clone();
            bytes.extend(hb);
            b.send(&bytes);
            let sent = Instant::now();
            let mut echoed = false;
            let mut done = false;
            while b.open && !echoed && !done && sent.elapsed() < b.opts.retry_timeout && !b.should_stop() {
                for m in b.poll(Duration::from_millis(20)) {
                    match m {
                        CoreToHost::Status(s) if s.t_us == now_us => status_t = Some(s),
                        CoreToHost::Status(_) => other_statuses += 1,
                        // The echo of any attempt at this batch closes its answer.
                        CoreToHost::Heartbeat(h) if h.t_us == now_us && h.seq & SEQ_BASE != 0 => echoed = h.seq <= seq,
                        _ => {}
                    }
                }
                // The tick's status and the goal it counts are here: done, echo or not.
                done = status_t.is_some_and(|s| b.goal_consistent(&s));
            }
            echoed_idle = if echoed && status_t.is_none() { echoed_idle + 1 } else { 0 };
            if echoed_idle <= 1 {
                idle_since = sent;
            }
            // (Echoes without ticks and no other statuses: a line too damaged for a whole batch to
            // arrive, which retries heal, or a node that ran before, which says so itself.)
            if other_statuses >= 5 && echoed_idle >= NOT_TICKING_ECHOES && idle_since.elapsed() >= NOT_TICKING_FOR {
                return Err(BridgeError::NotLockstep { t_us: now_us, echoed: echoed_idle });
            }
            if let Some(s) = status_t {
                answers += 1;
                // (After many answers without the goal — a long path on a very noisy line — go
                // on with the last good one rather than retry for ever: the next tick asks
                // again.)
                if b.goal_consistent(&s) || answers >= 16 {
                    break s;
                }
            }
        };
        self.ticks += 1;
        self.progress();
        self.classifier_check.observe(&status)?;
        self.need_start = status.mode == WireMode::Idle;
        match status.mode {
            WireMode::TargetFound => return Ok(self.answer(Some(End::Found))),
            WireMode::Exhausted => return Ok(self.answer(Some(End::Exhausted))),
            _ => {}
        }
        if status.mode != WireMode::Exploring {
            self.b.sim.stop_base();
        } else if let Some(g) = self.b.goal.clone() {
            if self.b.apply_goal(&g) {
                self.note_goal(&g);
            }
        }
        // Where the camera looks while walking (as the in-process loop does).
        self.b.sim.acts.push(Act::Gaze(status.gaze.map(|h| BinaryAngle(h).to_radians())));
        Ok(self.answer(None))
    }
}

impl Brain for NodeBrain<'_> {
    type Error = BridgeError;

    fn ready(&mut self) -> Result<Option<End>, BridgeError> {
        if self.b.should_stop() {
            return Ok(Some(End::Stopped));
        }
        if let Some(e) = self.b.incompatible {
            return Err(BridgeError::Incompatible(e));
        }
        if let Some(field) = self.b.config_invalid {
            return Err(BridgeError::config_invalid(&self.config_msg, field));
        }
        Ok(None)
    }

    fn think(&mut self, frame: &Frame) -> Result<Answer, BridgeError> {
        self.b.sim.time_s = frame.time_s;
        self.b.sim.pose = frame.base_pose;
        let batch = self.batch(frame);
        match self.b.opts.mode {
            TimeMode::RealTime => self.real_time(frame.t_us, batch),
            TimeMode::Lockstep => self.lockstep(frame.t_us, batch),
        }
    }
}

/// Runs the simulated search `spec` through the node at the other end of `link` until the
/// target is found, the search is exhausted, the time limit passes, or `stop` is set
/// ([`super::run_bridge`] with [`super::Source::Sim`]).
pub fn run_sim(link: &mut dyn Link, spec: SearchSpec, opts: &BridgeOptions, stop: &AtomicBool) -> Result<BridgeResult, BridgeError> {
    let cfg = controller_config(&spec.controller, &spec.world, spec.planner.kind());
    // As in the in-process loop: ground-truth labels unless `lives` runs the node's classifier
    // (then the node must have been started with the same model, see `NodeOptions::model`).
    let classifier = spec.classifier();
    let mut source = spec.sim_source();
    let base = QueuedBase { time_s: source.sim.time_s(), pose: source.sim.pose(), acts: Vec::new() };
    let mut b = Bridge::new(link, opts, stop, base);
    let config_msg = ConfigMsg::from_config(&cfg);
    // A known building: its map and the route, sent with the configuration (`crate::live`).
    let known = spec.prior_map.as_ref().map_or_else(Vec::new, |cells| {
        let start = source.sim.pose();
        let (_, route) = crate::live::plan_route(&cfg, cells, [start[0], start[1]]);
        let mut m = crate::live::map_messages(cells, &cfg);
        m.extend(route.as_ref().map(crate::live::route_messages).unwrap_or_default());
        m
    });
    b.setup(&config_msg, &known)?;
    if opts.mode == TimeMode::RealTime {
        source = source.with_clock(Clock::SimTime, opts.period.as_secs_f64());
    }
    let mut brain = NodeBrain {
        b,
        config_msg,
        geom: GridGeometry { origin_x: cfg.origin_x_m, origin_y: cfg.origin_y_m },
        classifier_check: ClassifierCheck { expected: classifier, seen: false },
        goals: Vec::new(),
        recorded_seq: None,
        ticks: 0,
        need_start: true,
        next_tick: Instant::now(),
    };
    let ended = drive(&mut source, &mut brain, &mut [])?;
    let NodeBrain { mut b, goals, ticks, .. } = brain;
    let status = b.st.node_status;
    b.finish_stats();
    let ended = Ended { end: ended.end, ticks };
    // The core's labels stay in the node: the link carries no per-beam labels back.
    let result = SearchResult::simulated(
        &spec,
        &source,
        ended,
        status.map_or(0, |s| s.goals),
        status.map_or(0, |s| s.blacklisted),
        classifier,
        None,
    );
    Ok(BridgeResult {
        result,
        goals,
        goals_received: b.goals_received,
        stats: b.st,
        events: b.events,
        trajectory: source.trajectory,
        wall_s: b.started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::mem_pair;
    use crate::sim::{Scenario, World};
    use firmware::protocol::{encode, AckReason, CoreDecoder, HelloAck, IncompatiblePeer, PROTOCOL_VERSION};

    #[test]
    fn hello_is_repeated_until_answered_and_an_incompatible_node_is_refused_clearly() {
        let (mut node_end, mut bridge_end) = mem_pair();
        // A node of version 99 that answers only the third Hello.
        let fake = std::thread::spawn(move || {
            let mut dec = CoreDecoder::new();
            let mut buf = [0u8; 4096];
            let mut hellos = 0;
            let t0 = Instant::now();
            while hellos < 3 && t0.elapsed() < Duration::from_secs(5) {
                let n = node_end.read(&mut buf, Duration::from_millis(10)).unwrap_or(0);
                for m in dec.feed(&buf[..n]).flatten() {
                    if let HostToCore::Hello(h) = m {
                        assert_eq!(h.version, PROTOCOL_VERSION);
                        hellos += 1;
                    }
                }
            }
            let ack = HelloAck { version: 99, accepted: false, reason: AckReason::VersionMismatch };
            let mut out = [0u8; 64];
            node_end.write_all(encode(&CoreToHost::HelloAck(ack), &mut out).unwrap()).unwrap();
            std::thread::sleep(Duration::from_millis(200));
            hellos
        });
        let spec = SearchSpec::new(
            "apartment",
            World::builtin("apartment", Scenario::Easy).unwrap(),
            Scenario::Easy,
            crate::search::PlannerChoice::LivesGt,
            1,
        );
        let opts = BridgeOptions {
            hello_interval: Duration::from_millis(50),
            max_wall: Some(Duration::from_secs(5)),
            ..BridgeOptions::new(TimeMode::Lockstep)
        };
        let err = run_sim(&mut bridge_end, spec, &opts, &AtomicBool::new(false)).err().expect("refused");
        assert_eq!(err, BridgeError::Incompatible(IncompatiblePeer { ours: PROTOCOL_VERSION, theirs: 99 }));
        let text = err.to_string();
        assert!(text.contains("v99") && text.contains("incompatible"), "{text}");
        assert_eq!(fake.join().unwrap(), 3);
    }
}
