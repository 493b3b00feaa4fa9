//! The simulator as a source: it senses a scan, the pose and a detection each tick, and moves
//! its base for one period in [`SUBSTEPS`] steps. It keeps what scoring a simulated run needs
//! (the true trajectory, blocked periods, collisions, a [`RunTally`]).

use super::cycle::{Act, Answer, Frame, Source, TICK_US};
use super::score::RunTally;
use super::walk::Walker;
use crate::run::range::{encode_range, EncodedScan, RangeLimits};
use crate::sim::{BaseStatus, HitKind, Scan, Sim, SimConfig};
use firmware::scan::BeamLabel;
use firmware::{BinaryAngle, Pose2};

/// Base sub-steps per tick.
const SUBSTEPS: u32 = 4;

/// How a simulator source keeps time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clock {
    /// Tick `k` is at `k` × [`TICK_US`] (lockstep: the same run bit for bit).
    Ticks,
    /// A tick is at the simulator's own time, rounded to the microsecond (the bridge in real
    /// time, whose period may differ from [`TICK_US`]).
    SimTime,
}

/// The simulator, driven one period per tick.
pub struct SimSource {
    /// The simulator.
    pub sim: Sim,
    /// Where it started.
    pub start: [f64; 3],
    /// The true position after every period, the start first.
    pub trajectory: Vec<[f64; 2]>,
    /// The true pose at the last sense.
    pub pose: [f64; 3],
    /// The last scan.
    pub scan: Option<Scan>,
    /// Periods in which the base reported blocked.
    pub blocked: u32,
    /// Periods at whose end the robot overlapped an obstacle, wall or person (must stay 0).
    pub collisions: u32,
    /// Motion and sightings.
    pub tally: RunTally,
    base_blocked: bool,
    /// The tick last sensed.
    tick: u32,
    /// Give the brain the ground-truth labels.
    labels: bool,
    /// The brain works in the drifting odometry frame (the laser's pose, `Sim::controller_pose`,
    /// as a robot's odometry and `tf` give it); otherwise in the simulator's true frame.
    odometry_frame: bool,
    /// Sense detections.
    detect: bool,
    clock: Clock,
    period_s: f64,
    /// The run ends when the simulated time reaches it.
    limit_s: Option<f64>,
    /// The run ends after this many ticks.
    max_ticks: Option<u32>,
    /// Drives the base when no brain does ([`Act::Wander`]).
    walker: Option<(Walker, Vec<[f64; 2]>)>,
}

impl SimSource {
    /// A search's simulator: the brain in the odometry frame, ticks of [`TICK_US`], detections
    /// sensed, ground-truth labels if `labels`, until `limit_s`.
    pub fn new(sim: Sim, labels: bool, limit_s: f64) -> Self {
        let start = sim.pose();
        let camera_range_m = sim.config().camera_range_m;
        SimSource {
            sim,
            start,
            trajectory: vec![[start[0], start[1]]],
            pose: start,
            scan: None,
            blocked: 0,
            collisions: 0,
            tally: RunTally::new(camera_range_m),
            base_blocked: false,
            tick: 0,
            labels,
            odometry_frame: true,
            detect: true,
            clock: Clock::Ticks,
            period_s: TICK_US as f64 / 1e6,
            limit_s: Some(limit_s),
            max_ticks: None,
            walker: None,
        }
    }

    /// An episode's simulator (datasets, unseen-world walks): `ticks` ticks, the brain in the true
    /// frame, detections sensed if `detect`, `walker` driving on [`Act::Wander`] among `free`.
    pub fn episode(sim: Sim, ticks: u32, labels: bool, detect: bool, walker: Walker, free: Vec<[f64; 2]>) -> Self {
        SimSource {
            odometry_frame: false,
            detect,
            limit_s: None,
            max_ticks: Some(ticks),
            walker: Some((walker, free)),
            ..SimSource::new(sim, labels, 0.0)
        }
    }

    /// Keeps time by `clock`, a period of `period_s`.
    pub fn with_clock(self, clock: Clock, period_s: f64) -> Self {
        SimSource { clock, period_s, ..self }
    }

    fn goal_path(&mut self, path: &[[f64; 2]], yaw: Option<f64>) {
        if self.odometry_frame {
            // In the controller's frame: the base follows it in the odometry frame.
            self.sim.set_goal_path(path, yaw);
        } else {
            self.sim.set_path(path, yaw);
        }
    }
}

impl Source for SimSource {
    fn sense(&mut self, tick: u32) -> Option<Frame> {
        if self.max_ticks.is_some_and(|n| tick >= n) {
            return None;
        }
        self.tick = tick;
        let t_us = match self.clock {
            Clock::Ticks => tick as u64 * TICK_US,
            Clock::SimTime => (self.sim.time_s() * 1e6).round() as u64,
        };
        let p = self.sim.pose();
        let q = if self.odometry_frame { self.sim.controller_pose() } else { p };
        let scan = self.sim.scan();
        self.tally.scan(t_us, &scan);
        let encoded = encode_sim_scan(&scan);
        let detection = self.detect && self.sim.detect().is_some();
        self.pose = p;
        self.scan = Some(scan);
        Some(Frame {
            t_us,
            pose: Pose2::from_f64(q[0], q[1], q[2]),
            base_pose: p,
            time_s: self.sim.time_s(),
            scan: encoded,
            labels: self.labels,
            detection,
            base_blocked: self.base_blocked,
        })
    }

    fn act(&mut self, answer: &Answer) -> bool {
        for a in &answer.acts {
            match a {
                Act::Stop => self.sim.stop_base(),
                Act::Path(path, yaw) => self.goal_path(path, *yaw),
                Act::Gaze(g) => self.sim.set_goal_gaze(*g),
                Act::Wander => {
                    if let Some((w, free)) = &mut self.walker {
                        w.update(&mut self.sim, free, self.tick, self.base_blocked);
                    }
                }
            }
        }
        let before = self.sim.pose();
        let moved = step_base(&mut self.sim, self.period_s);
        self.tally.step(before, self.sim.pose(), self.period_s);
        self.base_blocked = moved.blocked;
        self.blocked += moved.blocked as u32;
        self.trajectory.push(moved.position);
        self.collisions += moved.collided as u32;
        self.limit_s.is_none_or(|l| self.sim.time_s() < l)
    }
}

/// The sensor limits of the simulator's LiDAR (what its scans say in `range_min`/`range_max`).
pub fn sim_limits(cfg: &SimConfig) -> RangeLimits {
    RangeLimits::new(cfg.lidar_min_range_m, cfg.lidar_max_range_m)
}

/// One simulated scan in the core's encoding (the host/core boundary, [`crate::run::range`]) with its
/// scanner's own limits, and the ground-truth label of every beam.
pub fn encode_sim_scan(scan: &Scan) -> EncodedScan {
    let fallback = BinaryAngle::from_fraction(1, scan.ranges_m.len().max(1) as i64);
    let limits = RangeLimits::new(scan.range_min_m, scan.range_max_m);
    let (range_min_mm, range_max_mm) = limits.mm();
    EncodedScan {
        angle_min: BinaryAngle::from_radians(scan.angle_min).unwrap_or(BinaryAngle::HALF),
        angle_increment: BinaryAngle::from_radians(scan.angle_increment).unwrap_or(fallback),
        ranges_mm: scan.ranges_m.iter().map(|&r| encode_range(r as f64, &limits)).collect(),
        range_min_mm,
        range_max_mm,
        labels: scan.hits.iter().map(|&h| gt_label(h)).collect(),
        combined: 1,
    }
    .fitted()
}

/// What the base did during one controller period.
pub struct BaseStep {
    /// It reported blocked in at least one sub-step.
    pub blocked: bool,
    /// Where it ended.
    pub position: [f64; 2],
    /// It ended overlapping a wall, an obstacle or a person (must never happen).
    pub collided: bool,
}

/// Moves the simulated base for `period_s` in [`SUBSTEPS`] steps.
pub fn step_base(sim: &mut Sim, period_s: f64) -> BaseStep {
    let mut blocked = false;
    for _ in 0..SUBSTEPS {
        blocked |= sim.step(period_s / SUBSTEPS as f64) == BaseStatus::Blocked;
    }
    let q = sim.pose();
    BaseStep { blocked, position: [q[0], q[1]], collided: sim.collides([q[0], q[1]]) }
}

/// The ground-truth label of what a beam hit.
pub fn gt_label(h: HitKind) -> BeamLabel {
    match h {
        HitKind::None => BeamLabel::Unlabelled,
        HitKind::Wall => BeamLabel::Map,
        HitKind::Furniture | HitKind::Clutter | HitKind::Person | HitKind::Target => BeamLabel::NonMap,
    }
}
