//! [`Sim`]: a [`World`] in motion — the robot's LiDAR, camera detector and base, and the people.
//!
//! Time is virtual and only advances in [`Sim::step`]. The seed given to [`Sim::new`] decides,
//! each from its own ChaCha stream: the start jitter, which position each target is at, where
//! along their loops the people start, and the LiDAR noise and dropouts. The same seed and the
//! same calls give bit-identical results.
//!
//! The base follows a list of waypoints with a simple turn-then-drive law; it checks every
//! motion sub-step (≤ 2 cm) against the true world. A sub-step that would touch something is
//! turned by up to 60° to slide along it (Spot's own obstacle avoidance); if no such turn is
//! free, the base refuses to move rather than touch anything, reporting [`BaseStatus::Blocked`]. People walk their loops at constant speed, wait
//! while the robot stands in their way and turn round after [`PERSON_PATIENCE_S`] of waiting, so
//! a robot and a person meeting head-on in a corridor do not block each other for ever.

use std::collections::VecDeque;
use std::f64::consts::PI;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::geometry::{dist, wrap_angle, Scene, SceneBuilder, TARGET_OWNER_BASE};
use super::{HitKind, Shape, World, P2};

mod config;
mod motion;
mod sensing;
pub use config::*;

/// One LiDAR sweep in the laser frame (REP-103: x forward, y left, angles counter-clockwise);
/// the laser sits at [`SimConfig::mount`] on the base ([`Sim::laser_pose`]). Beam `i` points at
/// `angle_min + i · angle_increment`.
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    /// The first beam's direction (−π for the 360° scanners: backwards).
    pub angle_min: f64,
    /// Angle between beams.
    pub angle_increment: f64,
    /// The scanner's minimum range (ROS `range_min`): readings below it are NaN.
    pub range_min_m: f64,
    /// The scanner's maximum range (ROS `range_max`): nothing within it is `+inf`.
    pub range_max_m: f64,
    /// Measured range per beam (ROS conventions): `f32::INFINITY` when nothing is within the
    /// maximum range, `f32::NAN` for a dropout or a return below the minimum range.
    pub ranges_m: Vec<f32>,
    /// Ground truth per beam: what it hit; [`HitKind::None`] exactly where the range is infinite.
    pub hits: Vec<HitKind>,
}

/// What the base is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaseStatus {
    /// No path (never given one, or stopped).
    Idle,
    /// Following the path.
    Moving,
    /// Reached the last waypoint (and turned to the final yaw, if one was given).
    Arrived,
    /// The next motion would touch something; the base did not move. It keeps the path and
    /// tries again on the next step (a person may walk away).
    Blocked,
}

/// Intermediate waypoints are passed when the robot is this close.
pub const WAYPOINT_TOLERANCE_M: f64 = 0.15;
/// The last waypoint is reached when the robot is this close (the same as the others).
pub const GOAL_TOLERANCE_M: f64 = WAYPOINT_TOLERANCE_M;
/// The final yaw is reached within this angle.
pub const YAW_TOLERANCE_RAD: f64 = 1e-3;
/// The base drives while turning only when the heading error is below this.
pub const DRIVE_WHILE_TURNING_RAD: f64 = PI / 6.0;
/// Longest motion sub-step.
pub const MAX_SUBSTEP_S: f64 = 0.02;
/// Largest turn of a sub-step that would touch something: the base slides along what it grazes
/// by turning the step up to this far, left before right.
pub const AVOID_MAX_RAD: f64 = PI / 3.0;
/// Turn increment of that search.
pub const AVOID_STEP_RAD: f64 = PI / 12.0;
/// A person who has waited this long for the robot to get out of the way turns round.
pub const PERSON_PATIENCE_S: f64 = 2.0;
/// Outline sample points per target for the detector.
pub const DETECT_SAMPLES: usize = 32;

/// RNG streams derived from the user's seed, numbered from 1 in this order (`Stream::Start as
/// u64` is 1): the numbers choose the draws, so a new stream goes last.
#[derive(Clone, Copy)]
enum Stream {
    Start = 1,
    Targets,
    People,
    Sensor,
    Odom,
    Beams,
}

fn rng_for(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// A person on their loop.
#[derive(Clone, Debug)]
struct Walker {
    path: Vec<P2>,
    /// Cumulative length at each corner; `cum[n]` is the loop length.
    cum: Vec<f64>,
    speed: f64,
    radius: f64,
    /// Arc length along the loop.
    s: f64,
    /// +1 along the loop as written, −1 back.
    dir: f64,
    /// How long they have been waiting for the robot.
    waited_s: f64,
}

impl Walker {
    fn new(path: &[P2], speed: f64, radius: f64) -> Walker {
        let n = path.len();
        let mut cum = vec![0.0];
        for i in 0..n {
            let l = if n > 1 { dist(path[i], path[(i + 1) % n]) } else { 0.0 };
            cum.push(cum[i] + l);
        }
        Walker { path: path.to_vec(), cum, speed, radius, s: 0.0, dir: 1.0, waited_s: 0.0 }
    }

    fn length(&self) -> f64 {
        *self.cum.last().unwrap_or(&0.0)
    }

    fn position_at(&self, s: f64) -> P2 {
        let n = self.path.len();
        let len = self.length();
        if n <= 1 || len.is_nan() || len <= 0.0 {
            return self.path.first().copied().unwrap_or([0.0, 0.0]);
        }
        let s = s.rem_euclid(len);
        let i = match self.cum.binary_search_by(|c| c.total_cmp(&s)) {
            Ok(i) => i.min(n - 1),
            Err(i) => i.saturating_sub(1).min(n - 1),
        };
        let (a, b) = (self.path[i], self.path[(i + 1) % n]);
        let seg = self.cum[i + 1] - self.cum[i];
        let t = if seg > 0.0 { ((s - self.cum[i]) / seg).clamp(0.0, 1.0) } else { 0.0 };
        [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]
    }

    fn position(&self) -> P2 {
        self.position_at(self.s)
    }
}

/// The simulation. See the module docs.
pub struct Sim {
    world: World,
    config: SimConfig,
    /// Walls, obstacles and the placed targets.
    scene: Scene,
    target_shapes: Vec<Shape>,
    target_positions: Vec<P2>,
    walkers: Vec<Walker>,
    pose: [f64; 3],
    time_s: f64,
    path: VecDeque<P2>,
    final_yaw: Option<f64>,
    gaze: Option<f64>,
    status: BaseStatus,
    driven_m: f64,
    sensor_rng: ChaCha8Rng,
    /// The realistic profiles' draws (jitter, no-returns, glass, mixed pixels, noise).
    beam_rng: ChaCha8Rng,
    /// Drifting odometry, `None` when it is exact.
    odom: Option<Odom>,
    /// The controller's goal, kept in its frame (the laser in the odometry frame) and
    /// re-expressed for the base every sub-step, as a real base following goals in `odom` does.
    goal: Option<OdomGoal>,
}

/// Odometry that drifts: its pose, and this run's scale errors.
#[derive(Clone, Debug)]
struct Odom {
    /// The base's pose in the odometry frame (starts equal to the true pose).
    pose: [f64; 3],
    /// Odometry counts `1 + slip` metres per metre driven.
    slip: f64,
    /// And `1 + drift` radians per radian turned.
    drift: f64,
}

/// A path and headings for the laser frame, in the odometry frame.
#[derive(Clone, Debug)]
struct OdomGoal {
    path: VecDeque<P2>,
    final_yaw: Option<f64>,
    gaze: Option<f64>,
}

/// One firing's physical outcome before noise.
#[derive(Clone, Copy, Debug)]
enum Firing {
    /// No usable reading (a dropout).
    Dropout,
    /// Nothing came back.
    Nothing,
    /// A return from `t` metres, off a surface of this kind.
    Return(f64, HitKind),
}

/// `a ∘ b` for poses `[x, y, yaw]`.
fn compose(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let (s, c) = a[2].sin_cos();
    [a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap_angle(a[2] + b[2])]
}

impl Sim {
    /// A simulation of `world`. `seed` picks the start jitter, each target's position, the
    /// people's phases and the sensor noise stream.
    pub fn new(world: World, config: SimConfig, seed: u64) -> Sim {
        // Targets.
        let mut trng = rng_for(seed, Stream::Targets as u64);
        let mut target_shapes = Vec::new();
        let mut target_positions = Vec::new();
        for t in &world.targets {
            let options = t.positions();
            let p = options[trng.gen_range(0..options.len())];
            target_shapes.push(t.shape_at(p));
            target_positions.push(p);
        }
        let mut b = SceneBuilder::new();
        for (i, w) in world.walls.iter().enumerate() {
            b.wall_of(w[0], w[1], world.wall_material(i));
        }
        for (i, o) in world.obstacles.iter().enumerate() {
            b.shape_of(&o.shape, o.kind, i as u32, o.material);
        }
        for (i, s) in target_shapes.iter().enumerate() {
            b.shape(s, HitKind::Target, TARGET_OWNER_BASE + i as u32);
        }
        let scene = b.build(0.5);
        let r = if config.robot_radius_m.is_finite() { config.robot_radius_m.max(0.0) } else { 0.0 };

        // Start: jitter, rejecting poses that touch anything.
        let mut srng = rng_for(seed, Stream::Start as u64);
        let s = world.start.pose;
        let mut pose = s;
        for _ in 0..100 {
            let dx = srng.gen_range(-1.0..=1.0) * world.start.jitter_m;
            let dy = srng.gen_range(-1.0..=1.0) * world.start.jitter_m;
            let dyaw = srng.gen_range(-1.0..=1.0) * world.start.jitter_yaw_rad;
            let p = [s[0] + dx, s[1] + dy];
            if !scene.disc_collides(p, r) {
                pose = [p[0], p[1], wrap_angle(s[2] + dyaw)];
                break;
            }
        }

        // People: a random phase each, away from the robot.
        let mut prng = rng_for(seed, Stream::People as u64);
        let mut walkers = Vec::new();
        for p in &world.people {
            let mut w = Walker::new(&p.path, p.speed_mps, p.radius_m);
            let len = w.length();
            for _ in 0..50 {
                w.s = if len > 0.0 { prng.gen_range(0.0..len) } else { 0.0 };
                if dist(w.position(), [pose[0], pose[1]]) >= w.radius + r + 0.5 {
                    break;
                }
            }
            walkers.push(w);
        }

        let odom = config.drifts().then(|| {
            // This run's errors: the configured sizes, each scaled by a factor in
            // [0.5, 1.5] and given a sign, from the seed.
            let mut r = rng_for(seed, Stream::Odom as u64);
            let mut draw = |size: f64| {
                let sign = if r.gen::<bool>() { 1.0 } else { -1.0 };
                sign * size * r.gen_range(0.5..=1.5)
            };
            let slip = draw(config.odom_slip_per_m);
            let drift = draw(config.odom_heading_drift_per_rad);
            Odom { pose, slip, drift }
        });
        Sim {
            world,
            config,
            scene,
            target_shapes,
            target_positions,
            walkers,
            pose,
            time_s: 0.0,
            path: VecDeque::new(),
            final_yaw: None,
            gaze: None,
            status: BaseStatus::Idle,
            driven_m: 0.0,
            sensor_rng: rng_for(seed, Stream::Sensor as u64),
            beam_rng: rng_for(seed, Stream::Beams as u64),
            odom,
            goal: None,
        }
    }

    /// The base's pose as its odometry reports it, in the odometry frame (equal to
    /// [`Sim::pose`] at the start and whenever odometry does not drift).
    pub fn odom_pose(&self) -> [f64; 3] {
        self.odom.as_ref().map_or(self.pose, |o| o.pose)
    }

    /// The laser's true pose in the world: [`Sim::pose`] ∘ [`SimConfig::mount`].
    pub fn laser_pose(&self) -> [f64; 3] {
        self.mounted(self.pose)
    }

    /// What a controller is given: the laser's pose in the odometry frame,
    /// [`Sim::odom_pose`] ∘ mount (as a replayed bag composes odometry with the laser's `tf`).
    pub fn controller_pose(&self) -> [f64; 3] {
        self.mounted(self.odom_pose())
    }

    fn mounted(&self, base: [f64; 3]) -> [f64; 3] {
        if self.config.mount == [0.0; 3] {
            base
        } else {
            compose(base, self.config.mount)
        }
    }

    /// The odometry frame's drift, the transform from odometry to world coordinates
    /// `(rotation, translation)`: `p_world = R(rotation) · p_odom + translation`.
    fn odom_to_world(&self) -> (f64, P2) {
        let o = self.odom_pose();
        let rot = wrap_angle(self.pose[2] - o[2]);
        let (s, c) = rot.sin_cos();
        (rot, [self.pose[0] - (c * o[0] - s * o[1]), self.pose[1] - (s * o[0] + c * o[1])])
    }

    /// Follow a path the controller sent: waypoints for the laser (the pose the controller is
    /// given, [`Sim::controller_pose`]) in the odometry frame, and the laser's final heading.
    /// The base keeps the goal in that frame, so odometry drift moves where it really goes, as
    /// on a real robot. Without drift and mount it is [`Sim::set_path`].
    pub fn set_goal_path(&mut self, waypoints: &[P2], final_yaw: Option<f64>) {
        if self.odom.is_none() && self.config.mount == [0.0; 3] {
            return self.set_path(waypoints, final_yaw);
        }
        let gaze = self.goal.as_ref().and_then(|g| g.gaze);
        self.set_path(waypoints, final_yaw);
        let path = self.path.clone();
        let final_yaw = self.final_yaw;
        self.goal = Some(OdomGoal { path, final_yaw, gaze });
        self.goal_to_base();
    }

    /// [`Sim::set_gaze`] for a heading of the laser in the odometry frame.
    pub fn set_goal_gaze(&mut self, yaw: Option<f64>) {
        if self.odom.is_none() && self.config.mount == [0.0; 3] {
            return self.set_gaze(yaw);
        }
        let yaw = yaw.filter(|y| y.is_finite()).map(wrap_angle);
        match &mut self.goal {
            Some(g) => g.gaze = yaw,
            None => self.goal = Some(OdomGoal { path: VecDeque::new(), final_yaw: None, gaze: yaw }),
        }
        self.goal_to_base();
    }

    /// Re-expresses the controller's goal for the base, in the world, with the odometry's drift
    /// now: a laser waypoint `p` puts the base at `p − R(yaw) · mount` (yaw: the final one at the
    /// last waypoint, else the base's current one).
    fn goal_to_base(&mut self) {
        let Some(g) = &self.goal else { return };
        let (rot, t) = self.odom_to_world();
        let (s, c) = rot.sin_cos();
        let m = self.config.mount;
        let base_yaw = |laser_yaw: f64| wrap_angle(laser_yaw + rot - m[2]);
        let final_yaw = g.final_yaw.map(base_yaw);
        let n = g.path.len();
        let here = self.pose[2];
        let path: VecDeque<P2> = g
            .path
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let w = [c * p[0] - s * p[1] + t[0], s * p[0] + c * p[1] + t[1]];
                let yaw = if i + 1 == n { final_yaw.unwrap_or(here) } else { here };
                let (sy, cy) = yaw.sin_cos();
                [w[0] - (cy * m[0] - sy * m[1]), w[1] - (sy * m[0] + cy * m[1])]
            })
            .collect();
        self.gaze = g.gaze.map(base_yaw);
        self.path = path;
        if self.final_yaw.is_some() {
            self.final_yaw = final_yaw;
        }
    }

    /// After a sub-step: drop the goal's waypoints the base passed and its final yaw once
    /// reached.
    fn goal_progress(&mut self) {
        let (n, done_yaw) = (self.path.len(), self.final_yaw.is_none());
        if let Some(g) = &mut self.goal {
            while g.path.len() > n {
                g.path.pop_front();
            }
            if done_yaw {
                g.final_yaw = None;
            }
        }
    }

    /// Moves the odometry by the base's true motion from `before` to the current pose, with
    /// this run's scale errors.
    fn integrate_odom(&mut self, before: [f64; 3]) {
        let after = self.pose;
        let Some(o) = &mut self.odom else { return };
        let (s0, c0) = before[2].sin_cos();
        let (dx, dy) = (after[0] - before[0], after[1] - before[1]);
        // The motion in the body frame at the start of the sub-step.
        let (bx, by) = (c0 * dx + s0 * dy, -s0 * dx + c0 * dy);
        let dyaw = wrap_angle(after[2] - before[2]);
        let k = 1.0 + o.slip;
        let (so, co) = o.pose[2].sin_cos();
        o.pose[0] += k * (co * bx - so * by);
        o.pose[1] += k * (so * bx + co * by);
        o.pose[2] = wrap_angle(o.pose[2] + dyaw * (1.0 + o.drift));
    }

    pub fn world(&self) -> &World {
        &self.world
    }

    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// Simulated seconds since the start.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// True pose `[x, y, yaw]` in the world frame (metres, radians in (−π, π]).
    pub fn pose(&self) -> [f64; 3] {
        self.pose
    }

    /// Where the targets actually are (centre of each, in world order).
    pub fn target_positions(&self) -> Vec<P2> {
        self.target_positions.clone()
    }

    /// The placed targets' outlines.
    pub fn target_shapes(&self) -> &[Shape] {
        &self.target_shapes
    }

    /// Current centres and radii of the people.
    pub fn people(&self) -> Vec<(P2, f64)> {
        self.walkers.iter().map(|w| (w.position(), w.radius)).collect()
    }

    /// The base's current status.
    pub fn base_status(&self) -> BaseStatus {
        self.status
    }
}

#[cfg(test)]
mod tests;
