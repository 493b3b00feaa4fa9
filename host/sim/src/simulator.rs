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

use super::geometry::{dist, norm, ray_circle, sub, wrap_angle, Scene, SceneBuilder, NO_OWNER, TARGET_OWNER_BASE};
use super::{HitKind, Material, Shape, World, P2};

/// The LiDAR a [`SimConfig`] was set up from ([`SimConfig::with_lidar`]). The numbers of each
/// profile, with their sources, are in `docs/sim-sensors.md`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum LidarModel {
    /// The simulator's clean sensor as it was before the profiles: 897 beams over 360°, 30 m,
    /// 1 cm Gaussian noise, 1 % dropouts, every surface returns, no jitter, no mixed pixels.
    #[default]
    Ideal,
    /// Slamtec RPLIDAR A2M8: 360°, 0.15–12 m, 0.45° at 10 Hz (800 samples a turn).
    RplidarA2,
    /// Slamtec RPLIDAR A3M1 (enhanced mode): 360°, 0.2–25 m, 0.225° at 10 Hz (1600 a turn).
    RplidarA3,
    /// Hokuyo UTM-30LX: 270°, 0.1–30 m, 0.25° steps (1081 readings, steps 0–1080).
    HokuyoUtm30lx,
    /// Velodyne VLP-16 cut to the scan plane as `lives lidar` does: the ±1° lasers, the nearest
    /// of the firings in each of 897 bins over 360°, 0.3–100 m.
    Vlp16,
}

impl LidarModel {
    /// Every profile, `ideal` first.
    pub const ALL: [LidarModel; 5] =
        [LidarModel::Ideal, LidarModel::RplidarA2, LidarModel::RplidarA3, LidarModel::HokuyoUtm30lx, LidarModel::Vlp16];

    /// The name `--sim lidar=NAME` takes.
    pub fn as_str(self) -> &'static str {
        match self {
            LidarModel::Ideal => "ideal",
            LidarModel::RplidarA2 => "rplidar-a2",
            LidarModel::RplidarA3 => "rplidar-a3",
            LidarModel::HokuyoUtm30lx => "hokuyo-utm30lx",
            LidarModel::Vlp16 => "vlp16",
        }
    }

    /// The profile of a name (exact).
    pub fn from_name(name: &str) -> Option<LidarModel> {
        LidarModel::ALL.into_iter().find(|m| m.as_str() == name)
    }
}

/// Reflectance of the "white" target the datasheets' ranges are given for (white paper, Kodak
/// white card: about 0.9).
pub const WHITE_REFLECTANCE: f64 = 0.9;
/// Width of the no-return ramp, as a share of the effective range: the no-return probability
/// is a logistic in `(r − R_eff) / (NO_RETURN_RAMP · R_eff)`, ½ at `R_eff`.
pub const NO_RETURN_RAMP: f64 = 0.1;
/// A pane of glass returns the beam itself only within this angle of normal incidence
/// (specular reflection back into the receiver).
pub const GLASS_SPECULAR_RAD: f64 = 5.0 * PI / 180.0;
/// Share of the beams past [`GLASS_SPECULAR_RAD`] that go through a pane (float glass transmits
/// about 90 % of near-infrared light); the rest return nothing.
pub const GLASS_TRANSMITTANCE: f64 = 0.9;
/// Panes of glass one beam may pass before it is counted lost.
pub const MAX_GLASS_PANES: usize = 4;
/// Two firings whose surfaces are farther apart than this form a depth edge where a footprint
/// may straddle both (a mixed pixel).
pub const MIXED_PIXEL_MIN_GAP_M: f64 = 0.1;

/// Sensor and base parameters. Units are in the names. [`SimConfig::default`] is the `ideal`
/// LiDAR on the paper's Spot (the simulator as it was before the LiDAR profiles); `lives search`
/// uses a real profile (`host::search::default_sim`).
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// The profile the LiDAR fields were set from (for reports; the fields rule).
    pub lidar: LidarModel,
    /// LiDAR beams (readings per scan).
    pub beams: usize,
    /// Direction of the first beam in the laser frame, radians.
    pub angle_min_rad: f64,
    /// Angle between beams, radians.
    pub angle_increment_rad: f64,
    /// Returns beyond this are reported as no return (`f32::INFINITY`); the scan's `range_max`.
    pub lidar_max_range_m: f64,
    /// Returns closer than this are reported as no return; the scan's `range_min`.
    pub lidar_min_range_m: f64,
    /// Standard deviation of the Gaussian range noise (at zero range).
    pub range_noise_std_m: f64,
    /// Noise standard deviation added per metre of range.
    pub range_noise_per_m: f64,
    /// Probability that a beam returns nothing, whatever it points at (NaN).
    pub dropout_prob: f64,
    /// The physical no-return model: the range at which a white target
    /// ([`WHITE_REFLECTANCE`]) at normal incidence returns half the time. A surface of
    /// reflectance ρ hit at incidence α returns half the time at `white_range_m · √(ρ cos α / 0.9)`
    /// (received power ∝ ρ cos α / r²). 0 turns the model (and glass) off: every surface returns.
    pub white_range_m: f64,
    /// Firings per beam; a beam reports the nearest valid one (the VLP-16's projection).
    pub samples_per_beam: usize,
    /// Full beam divergence; a firing whose footprint may straddle a depth edge returns a mixed
    /// pixel (0: none).
    pub beam_divergence_rad: f64,
    /// Standard deviation of each firing's true direction around its nominal one.
    pub angular_jitter_rad: f64,
    /// The laser's pose on the base, `[x forward, y left, yaw]` (metres, radians): the scan is in
    /// this frame.
    pub mount: [f64; 3],
    /// Odometry's scale error: metres of error per metre driven (the seed picks its sign).
    pub odom_slip_per_m: f64,
    /// Odometry's heading error per radian turned (the seed picks its sign).
    pub odom_heading_drift_per_rad: f64,
    /// Scan rate the controller is expected to use (the simulator does not enforce it).
    pub scan_hz: f64,
    /// Full horizontal field of view of the camera.
    pub camera_fov_rad: f64,
    /// The detector sees targets up to this far.
    pub camera_range_m: f64,
    /// Fraction of a target's outline sample points that must be visible for a detection.
    pub detect_min_visible_fraction: f64,
    /// Maximum forward speed of the base.
    pub speed_mps: f64,
    /// Maximum turn rate of the base.
    pub turn_rate_rps: f64,
    /// The robot is a disc of this radius for collisions.
    pub robot_radius_m: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            lidar: LidarModel::Ideal,
            beams: 897,
            angle_min_rad: -PI,
            angle_increment_rad: 2.0 * PI / 897.0,
            lidar_max_range_m: 30.0,
            lidar_min_range_m: 0.1,
            range_noise_std_m: 0.01,
            range_noise_per_m: 0.0,
            dropout_prob: 0.01,
            white_range_m: 0.0,
            samples_per_beam: 1,
            beam_divergence_rad: 0.0,
            angular_jitter_rad: 0.0,
            mount: [0.0; 3],
            odom_slip_per_m: 0.0,
            odom_heading_drift_per_rad: 0.0,
            scan_hz: 5.0,
            camera_fov_rad: 90f64.to_radians(),
            camera_range_m: 4.0,
            detect_min_visible_fraction: 0.3,
            speed_mps: 0.5,
            turn_rate_rps: 1.0,
            robot_radius_m: 0.3,
        }
    }
}

impl SimConfig {
    /// This configuration with the LiDAR of `model`: its beams, field of view, range limits,
    /// noise, no-return model, firings per beam, divergence and jitter (the numbers and their
    /// sources are in `docs/sim-sensors.md`). The base, the camera, the mount and the odometry
    /// are kept.
    pub fn with_lidar(self, model: LidarModel) -> SimConfig {
        let deg = PI / 180.0;
        let full = |beams: usize| (-PI, 2.0 * PI / beams as f64);
        // Not in the datasheets: a 3 mrad divergence (the VLP-16's horizontal one) and the
        // jitter of the scanners' angle encoders; see docs/sim-sensors.md.
        let div = 0.003;
        let lidar = |beams: usize, (angle_min_rad, angle_increment_rad): (f64, f64), min: f64, max: f64| SimConfig {
            lidar: model,
            beams,
            angle_min_rad,
            angle_increment_rad,
            lidar_min_range_m: min,
            lidar_max_range_m: max,
            ..self.clone()
        };
        match model {
            LidarModel::Ideal => {
                let d = SimConfig::default();
                SimConfig {
                    white_range_m: d.white_range_m,
                    samples_per_beam: d.samples_per_beam,
                    beam_divergence_rad: d.beam_divergence_rad,
                    angular_jitter_rad: d.angular_jitter_rad,
                    range_noise_std_m: d.range_noise_std_m,
                    range_noise_per_m: d.range_noise_per_m,
                    dropout_prob: d.dropout_prob,
                    ..lidar(d.beams, (d.angle_min_rad, d.angle_increment_rad), d.lidar_min_range_m, d.lidar_max_range_m)
                }
            }
            LidarModel::RplidarA2 | LidarModel::RplidarA3 => {
                let (beams, min, max) = if model == LidarModel::RplidarA2 { (800, 0.15, 12.0) } else { (1600, 0.2, 25.0) };
                SimConfig {
                    // Datasheets: "< 1 % of the distance"; read as 2σ, with a 5 mm floor.
                    range_noise_std_m: 0.005,
                    range_noise_per_m: 0.005,
                    dropout_prob: 0.01,
                    white_range_m: max,
                    samples_per_beam: 1,
                    beam_divergence_rad: div,
                    angular_jitter_rad: 0.1 * deg,
                    ..lidar(beams, full(beams), min, max)
                }
            }
            LidarModel::HokuyoUtm30lx => SimConfig {
                // ±30 mm to 10 m, ±50 mm to 30 m, read as 2σ.
                range_noise_std_m: 0.015,
                range_noise_per_m: 0.0005,
                dropout_prob: 0.01,
                white_range_m: 30.0,
                samples_per_beam: 1,
                beam_divergence_rad: div,
                angular_jitter_rad: 0.01 * deg,
                ..lidar(1081, (-135.0 * deg, 0.25 * deg), 0.1, 30.0)
            },
            LidarModel::Vlp16 => SimConfig {
                // ±3 cm typical, read as 2σ; 0.1° firings at 5 Hz: 4 per 0.4° bin.
                range_noise_std_m: 0.015,
                range_noise_per_m: 0.0,
                dropout_prob: 0.01,
                white_range_m: 100.0,
                samples_per_beam: 4,
                beam_divergence_rad: div,
                angular_jitter_rad: 0.01 * deg,
                ..lidar(897, full(897), 0.3, 100.0)
            },
        }
    }

    /// True when the LiDAR is the clean one of before the profiles (no no-return model, one
    /// firing per beam, no mixed pixels, no jitter, range-independent noise): [`Sim::scan`] then
    /// draws exactly as it always did.
    pub fn clean_lidar(&self) -> bool {
        self.white_range_m == 0.0
            && self.samples_per_beam <= 1
            && self.beam_divergence_rad == 0.0
            && self.angular_jitter_rad == 0.0
            && self.range_noise_per_m == 0.0
    }

    /// True when odometry drifts.
    pub fn drifts(&self) -> bool {
        self.odom_slip_per_m != 0.0 || self.odom_heading_drift_per_rad != 0.0
    }
}

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

/// RNG streams derived from the user's seed.
const STREAM_START: u64 = 1;
const STREAM_TARGETS: u64 = 2;
const STREAM_PEOPLE: u64 = 3;
const STREAM_SENSOR: u64 = 4;
const STREAM_ODOM: u64 = 5;
const STREAM_BEAMS: u64 = 6;

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
        let mut trng = rng_for(seed, STREAM_TARGETS);
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
        let mut srng = rng_for(seed, STREAM_START);
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
        let mut prng = rng_for(seed, STREAM_PEOPLE);
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
            let mut r = rng_for(seed, STREAM_ODOM);
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
            sensor_rng: rng_for(seed, STREAM_SENSOR),
            beam_rng: rng_for(seed, STREAM_BEAMS),
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

    /// First hit of a ray against the scene and the people, within `max_t`.
    fn cast(&self, o: P2, d: P2, max_t: f64, ignore_owner: u32) -> Option<(f64, HitKind)> {
        let mut best = self.scene.raycast(o, d, max_t, ignore_owner).map(|h| (h.t, h.kind));
        for w in &self.walkers {
            if let Some(t) = ray_circle(o, d, w.position(), w.radius) {
                if t <= max_t && best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, HitKind::Person));
                }
            }
        }
        best
    }

    /// One LiDAR sweep from the laser's current pose ([`Sim::laser_pose`]) with people where they
    /// are now, in the laser frame. With a clean LiDAR ([`SimConfig::clean_lidar`]) each beam
    /// draws one dropout uniform and one Gaussian from the sensor stream, hit or not, so the
    /// stream does not depend on the scene (the simulator's sensor before the profiles, bit for
    /// bit). Otherwise [`Sim::physical_scan`].
    pub fn scan(&mut self) -> Scan {
        let lp = self.laser_pose();
        let c = &self.config;
        let n = c.beams;
        let (angle_min, inc) = (c.angle_min_rad, c.angle_increment_rad);
        let (range_min_m, range_max_m) = (c.lidar_min_range_m, c.lidar_max_range_m);
        if !c.clean_lidar() {
            let (ranges_m, hits) = self.physical_scan(lp);
            return Scan { angle_min, angle_increment: inc, range_min_m, range_max_m, ranges_m, hits };
        }
        let mut ranges_m = Vec::with_capacity(n);
        let mut hits = Vec::with_capacity(n);
        let o = [lp[0], lp[1]];
        let max_r = c.lidar_max_range_m;
        let (noise_std, dropout, min_r) = (c.range_noise_std_m, c.dropout_prob, c.lidar_min_range_m);
        // Generous cast limit so that noise cannot pull a return from beyond the max range.
        let cast_max = max_r + 6.0 * noise_std.abs().min(1.0);
        let people: Vec<(P2, f64)> = self.people();
        for i in 0..n {
            let a = lp[2] + angle_min + i as f64 * inc;
            let d = [a.cos(), a.sin()];
            let u: f64 = self.sensor_rng.gen();
            let g = gaussian(&mut self.sensor_rng);
            let mut best = self.scene.raycast(o, d, cast_max, NO_OWNER).map(|h| (h.t, h.kind));
            for &(pc, pr) in &people {
                if let Some(t) = ray_circle(o, d, pc, pr) {
                    if t <= cast_max && best.is_none_or(|(bt, _)| t < bt) {
                        best = Some((t, HitKind::Person));
                    }
                }
            }
            let measured = best.map(|(t, k)| (t + noise_std * g, k));
            // ROS LaserScan conventions: a dropout or a reading below the minimum range is NaN
            // (no usable reading: it must not clear anything), nothing within range is +inf.
            match measured {
                _ if u < dropout => {
                    ranges_m.push(f32::NAN);
                    hits.push(HitKind::None);
                }
                Some((r, k)) if r >= min_r && r <= max_r => {
                    ranges_m.push(r as f32);
                    hits.push(k);
                }
                Some((r, _)) if r < min_r => {
                    ranges_m.push(f32::NAN);
                    hits.push(HitKind::None);
                }
                _ => {
                    ranges_m.push(f32::INFINITY);
                    hits.push(HitKind::None);
                }
            }
        }
        Scan { angle_min, angle_increment: inc, range_min_m, range_max_m, ranges_m, hits }
    }

    /// The first surface a ray meets beyond `min_t` (scene or people): range, kind, material and
    /// the cosine of the angle of incidence.
    fn surface(&self, o: P2, d: P2, min_t: f64, max_t: f64, people: &[(P2, f64)]) -> Option<(f64, HitKind, Material, f64)> {
        let mut best = self.scene.raycast_beyond(o, d, min_t, max_t, NO_OWNER).map(|h| (h.t, h.kind, h.material, h.normal));
        for &(pc, pr) in people {
            if let Some(t) = ray_circle(o, d, pc, pr) {
                if t > min_t && t <= max_t && best.is_none_or(|(bt, ..)| t < bt) {
                    let p = [o[0] + d[0] * t - pc[0], o[1] + d[1] * t - pc[1]];
                    let n = norm(p).max(1e-12);
                    best = Some((t, HitKind::Person, Material::Default, [p[0] / n, p[1] / n]));
                }
            }
        }
        best.map(|(t, k, m, n)| (t, k, m, (d[0] * n[0] + d[1] * n[1]).abs()))
    }

    /// One firing from `o` along angle `a`: through glass, then the no-return model.
    fn fire(&mut self, o: P2, a: f64, cast_max: f64, people: &[(P2, f64)]) -> Firing {
        let c = &self.config;
        if self.beam_rng.gen::<f64>() < c.dropout_prob {
            return Firing::Dropout;
        }
        let physical = c.white_range_m > 0.0;
        let white = c.white_range_m;
        let d = [a.cos(), a.sin()];
        let mut from = f64::NEG_INFINITY;
        for _ in 0..=MAX_GLASS_PANES {
            let Some((t, kind, material, cos_i)) = self.surface(o, d, from, cast_max, people) else {
                return Firing::Nothing;
            };
            if !physical {
                return Firing::Return(t, kind);
            }
            if material == Material::Glass {
                if cos_i >= GLASS_SPECULAR_RAD.cos() {
                    return Firing::Return(t, kind);
                }
                if self.beam_rng.gen::<f64>() < GLASS_TRANSMITTANCE {
                    from = t + 1e-6;
                    continue;
                }
                return Firing::Nothing;
            }
            let r_eff = white * (material.reflectance() * cos_i / WHITE_REFLECTANCE).sqrt();
            let p_miss = if r_eff > 0.0 { 1.0 / (1.0 + (-(t - r_eff) / (NO_RETURN_RAMP * r_eff)).exp()) } else { 1.0 };
            return if self.beam_rng.gen::<f64>() < p_miss { Firing::Nothing } else { Firing::Return(t, kind) };
        }
        Firing::Nothing
    }

    /// A realistic sweep: every beam fires [`SimConfig::samples_per_beam`] times across its
    /// angular bin, each firing off its nominal direction by the angular jitter, through glass
    /// and the no-return model ([`Sim::fire`]); a firing next to a depth edge (a neighbouring
    /// firing's surface [`MIXED_PIXEL_MIN_GAP_M`] or more away) whose footprint reaches the edge
    /// returns a mixed pixel between the two surfaces; then range noise; then each beam reports
    /// its nearest valid firing (`+inf` if none returned within range, NaN if none was usable).
    /// Labels: the surface the beam's reported firing came off (for a mixed pixel, its own
    /// surface: it lies nearer to it).
    fn physical_scan(&mut self, lp: [f64; 3]) -> (Vec<f32>, Vec<HitKind>) {
        let c = self.config.clone();
        let n = c.beams;
        let k = c.samples_per_beam.max(1);
        let o = [lp[0], lp[1]];
        let people = self.people();
        let max_noise = c.range_noise_std_m.abs() + c.range_noise_per_m.abs() * c.lidar_max_range_m;
        let cast_max = c.lidar_max_range_m + 6.0 * max_noise.min(1.0);
        let spacing = c.angle_increment_rad / k as f64;
        let mut firings = Vec::with_capacity(n * k);
        for i in 0..n {
            for j in 0..k {
                let nominal = lp[2] + c.angle_min_rad + i as f64 * c.angle_increment_rad + (j as f64 + 0.5 - k as f64 / 2.0) * spacing;
                let jitter = if c.angular_jitter_rad > 0.0 { c.angular_jitter_rad * gaussian(&mut self.beam_rng) } else { 0.0 };
                firings.push(self.fire(o, nominal + jitter, cast_max, &people));
            }
        }
        // Mixed pixels: the edge lies somewhere between two neighbouring firings; this firing's
        // footprint (half-width divergence / 2) reaches it with probability (divergence / 2) /
        // spacing, and then covers the far surface by a share f in (0, ½).
        let reach = if spacing > 0.0 { (c.beam_divergence_rad / 2.0 / spacing).min(1.0) } else { 0.0 };
        let mut ranges: Vec<Option<(f64, HitKind)>> = Vec::with_capacity(firings.len());
        let mut states = Vec::with_capacity(firings.len());
        for (idx, f) in firings.iter().enumerate() {
            let mut out = match *f {
                Firing::Return(t, kind) => Some((t, kind)),
                _ => None,
            };
            if let (Some((t, kind)), true) = (out, reach > 0.0) {
                for nb in [idx.wrapping_sub(1), idx + 1] {
                    let Some(Firing::Return(tn, _)) = firings.get(nb) else { continue };
                    if (tn - t).abs() >= MIXED_PIXEL_MIN_GAP_M && self.beam_rng.gen::<f64>() < reach {
                        let share: f64 = self.beam_rng.gen_range(0.0..0.5);
                        out = Some((t + share * (tn - t), kind));
                        break;
                    }
                }
            }
            ranges.push(out);
            states.push(*f);
        }
        let mut ranges_m = Vec::with_capacity(n);
        let mut hits = Vec::with_capacity(n);
        for i in 0..n {
            let mut best: Option<(f64, HitKind)> = None;
            let mut nothing = false;
            for j in 0..k {
                let idx = i * k + j;
                match ranges[idx] {
                    Some((t, kind)) => {
                        let sigma = c.range_noise_std_m + c.range_noise_per_m * t;
                        let r = t + sigma * gaussian(&mut self.beam_rng);
                        if r > c.lidar_max_range_m {
                            nothing = true;
                        } else if r >= c.lidar_min_range_m && best.is_none_or(|(b, _)| r < b) {
                            best = Some((r, kind));
                        }
                    }
                    None => nothing |= matches!(states[idx], Firing::Nothing),
                }
            }
            match best {
                Some((r, kind)) => {
                    ranges_m.push(r as f32);
                    hits.push(kind);
                }
                None => {
                    ranges_m.push(if nothing { f32::INFINITY } else { f32::NAN });
                    hits.push(HitKind::None);
                }
            }
        }
        (ranges_m, hits)
    }

    /// Fraction of target `i`'s outline samples the camera sees now (0 when out of the cone).
    pub fn visible_fraction(&self, i: usize) -> f64 {
        let Some(shape) = self.target_shapes.get(i) else {
            return 0.0;
        };
        let c = &self.config;
        let o = [self.pose[0], self.pose[1]];
        let samples = shape.outline_samples(DETECT_SAMPLES);
        let owner = TARGET_OWNER_BASE + i as u32;
        let mut visible = 0usize;
        for p in &samples {
            let v = sub(*p, o);
            let r = norm(v);
            if r.is_nan() || r > c.camera_range_m {
                continue;
            }
            if r > 1e-9 {
                let bearing = wrap_angle(v[1].atan2(v[0]) - self.pose[2]);
                if bearing.abs() > c.camera_fov_rad / 2.0 {
                    continue;
                }
                let d = [v[0] / r, v[1] / r];
                if self.cast(o, d, r - 1e-6, owner).is_some() {
                    continue;
                }
            }
            visible += 1;
        }
        visible as f64 / samples.len().max(1) as f64
    }

    /// The world bearings (radians) of target `i`'s outline samples ([`DETECT_SAMPLES`] of them)
    /// that a camera at `from` would see if it faced them: within the camera's range and in line
    /// of sight through the walls, obstacles and other targets, as [`Sim::visible_fraction`]
    /// checks them, but without the people (who move). The detector fires at a heading that has
    /// at least `detect_min_visible_fraction` of the samples within half the field of view
    /// ([`crate::oracle`]). A sample at `from` itself has bearing NaN (seen at every heading).
    pub fn static_sightlines(&self, i: usize, from: P2) -> Vec<f64> {
        let Some(shape) = self.target_shapes.get(i) else {
            return Vec::new();
        };
        let owner = TARGET_OWNER_BASE + i as u32;
        let mut out = Vec::new();
        for p in &shape.outline_samples(DETECT_SAMPLES) {
            let v = sub(*p, from);
            let r = norm(v);
            if r.is_nan() || r > self.config.camera_range_m {
                continue;
            }
            if r > 1e-9 {
                let d = [v[0] / r, v[1] / r];
                if self.scene.raycast(from, d, r - 1e-6, owner).is_some() {
                    continue;
                }
                out.push(v[1].atan2(v[0]));
            } else {
                out.push(f64::NAN);
            }
        }
        out
    }

    /// Walls, obstacles and the placed targets (no people).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Puts the robot at `pose` (world frame) without driving there: for tests that check what
    /// the sensors report from a given pose. Odometry, the path and the clock are left as they
    /// are.
    pub fn place_robot(&mut self, pose: [f64; 3]) {
        self.pose = [pose[0], pose[1], wrap_angle(pose[2])];
    }

    /// The target the camera sees now: inside the cone (field of view, range) along the robot's
    /// heading, with at least `detect_min_visible_fraction` of its outline sample points in
    /// line of sight (walls, obstacles, other targets and people block; the target itself does
    /// not). The best-visible target wins; `None` if none qualifies.
    pub fn detect(&self) -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for i in 0..self.target_shapes.len() {
            let f = self.visible_fraction(i);
            if f > 0.0 && f >= self.config.detect_min_visible_fraction && best.is_none_or(|(_, bf)| f > bf) {
                best = Some((i, f));
            }
        }
        best.map(|(i, _)| i)
    }

    /// Replace the path. Non-finite waypoints are dropped; a non-finite final yaw is ignored.
    pub fn set_path(&mut self, waypoints: &[P2], final_yaw: Option<f64>) {
        self.goal = None;
        self.path = waypoints.iter().copied().filter(|p| p[0].is_finite() && p[1].is_finite()).collect();
        self.final_yaw = final_yaw.filter(|y| y.is_finite()).map(wrap_angle);
        self.status = if self.path.is_empty() && self.final_yaw.is_none() { BaseStatus::Arrived } else { BaseStatus::Moving };
    }

    /// Which way the body (and camera) should face while walking the path: `Some(yaw)` walks
    /// holonomically (Spot can walk one way and face another) turning towards `yaw`; `None`
    /// faces the direction of travel. A non-finite yaw counts as `None`. At the end of the path
    /// the final yaw of [`Sim::set_path`] applies either way.
    pub fn set_gaze(&mut self, yaw: Option<f64>) {
        if let Some(g) = &mut self.goal {
            g.gaze = None;
        }
        self.gaze = yaw.filter(|y| y.is_finite()).map(wrap_angle);
    }

    /// Drop the path and stand still.
    pub fn stop_base(&mut self) {
        self.goal = None;
        self.path.clear();
        self.final_yaw = None;
        self.status = BaseStatus::Idle;
    }

    /// Distance the base has driven.
    pub fn path_length_m(&self) -> f64 {
        self.driven_m
    }

    /// Does the robot disc at `p` touch a wall, obstacle, target or person (as they are now)?
    pub fn collides(&self, p: P2) -> bool {
        let r = self.config.robot_radius_m;
        self.scene.disc_collides(p, r) || self.walkers.iter().any(|w| dist(w.position(), p) < w.radius + r)
    }

    /// Advance virtual time by `dt_s` in sub-steps of at most [`MAX_SUBSTEP_S`]: people walk, the
    /// base follows its path. Returns the base status after the last sub-step. A non-positive or
    /// non-finite `dt_s` changes nothing.
    pub fn step(&mut self, dt_s: f64) -> BaseStatus {
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return self.status;
        }
        let n = ((dt_s / MAX_SUBSTEP_S).ceil() as usize).clamp(1, 10_000_000);
        let h = dt_s / n as f64;
        for _ in 0..n {
            self.walk_people(h);
            if matches!(self.status, BaseStatus::Moving | BaseStatus::Blocked) {
                let before = self.pose;
                self.goal_to_base();
                self.drive(h);
                self.goal_progress();
                self.integrate_odom(before);
            }
        }
        self.time_s += dt_s;
        self.status
    }

    fn walk_people(&mut self, h: f64) {
        let robot = [self.pose[0], self.pose[1]];
        let r = self.config.robot_radius_m;
        for w in &mut self.walkers {
            let len = w.length();
            if len.is_nan() || len <= 0.0 || w.speed == 0.0 {
                continue;
            }
            let next = (w.s + w.dir * w.speed * h).rem_euclid(len);
            let (now_d, next_d) = (dist(w.position(), robot), dist(w.position_at(next), robot));
            // Wait rather than walk into the robot (always allowed to move away); after
            // PERSON_PATIENCE_S of waiting, turn round.
            if next_d < w.radius + r && next_d < now_d {
                w.waited_s += h;
                if w.waited_s >= PERSON_PATIENCE_S {
                    w.dir = -w.dir;
                    w.waited_s = 0.0;
                }
                continue;
            }
            w.waited_s = 0.0;
            w.s = next;
        }
    }

    /// Would the robot disc at `to` (coming from `from`) touch anything? People only block
    /// motion that brings the robot closer to them.
    fn motion_blocked(&self, from: P2, to: P2) -> bool {
        let r = self.config.robot_radius_m;
        self.scene.disc_collides(to, r)
            || self.walkers.iter().any(|w| {
                let c = w.position();
                dist(c, to) < w.radius + r && dist(c, to) < dist(c, from)
            })
    }

    /// Take a sub-step the base found clear: stand at `to` facing `yaw`, count the distance.
    fn move_to(&mut self, to: P2, yaw: f64) {
        self.driven_m += dist([self.pose[0], self.pose[1]], to);
        self.pose = [to[0], to[1], yaw];
        self.status = BaseStatus::Moving;
    }

    /// The sub-step the base takes when it means to go from `p` to `to`: `to` itself if that
    /// touches nothing, else the same step turned by up to [`AVOID_MAX_RAD`] (in
    /// [`AVOID_STEP_RAD`] steps, left before right), as Spot's own obstacle avoidance slides
    /// along what it grazes; `None` (blocked) when every one of them touches something.
    fn avoid(&self, p: P2, to: P2) -> Option<P2> {
        let v = sub(to, p);
        if norm(v) == 0.0 || !self.motion_blocked(p, to) {
            return Some(to);
        }
        let turns = (AVOID_MAX_RAD / AVOID_STEP_RAD).round() as i32;
        (1..=turns)
            .flat_map(|k| [k, -k])
            .map(|k| {
                let (s, c) = (k as f64 * AVOID_STEP_RAD).sin_cos();
                [p[0] + c * v[0] - s * v[1], p[1] + s * v[0] + c * v[1]]
            })
            .find(|&q| !self.motion_blocked(p, q))
    }

    fn drive(&mut self, h: f64) {
        let c = &self.config;
        let (speed, turn) = (c.speed_mps.max(0.0), c.turn_rate_rps.max(0.0));
        let p = [self.pose[0], self.pose[1]];
        while let Some(w) = self.path.front() {
            let tol = if self.path.len() > 1 { WAYPOINT_TOLERANCE_M } else { GOAL_TOLERANCE_M };
            if dist(*w, p) < tol {
                self.path.pop_front();
            } else {
                break;
            }
        }
        if let (Some(&w), Some(g)) = (self.path.front(), self.gaze) {
            // Holonomic: walk towards the waypoint whichever way the body faces, turning
            // towards the gaze heading at the turn rate.
            let v = sub(w, p);
            let d = norm(v);
            let e = wrap_angle(g - self.pose[2]);
            let yaw = wrap_angle(self.pose[2] + e.clamp(-turn * h, turn * h));
            let step = (speed * h).min(d);
            let to = if d > 0.0 { [p[0] + step * v[0] / d, p[1] + step * v[1] / d] } else { p };
            let Some(to) = self.avoid(p, to) else {
                self.pose[2] = yaw;
                self.status = BaseStatus::Blocked;
                return;
            };
            self.move_to(to, yaw);
        } else if let Some(&w) = self.path.front() {
            let v = sub(w, p);
            let d = norm(v);
            let e = wrap_angle(v[1].atan2(v[0]) - self.pose[2]);
            let dyaw = e.clamp(-turn * h, turn * h);
            let yaw = wrap_angle(self.pose[2] + dyaw);
            let e_after = e - dyaw;
            let step = if e_after.abs() < DRIVE_WHILE_TURNING_RAD { (speed * e_after.cos() * h).min(d) } else { 0.0 };
            let to = [p[0] + step * yaw.cos(), p[1] + step * yaw.sin()];
            let Some(to) = self.avoid(p, to) else {
                self.status = BaseStatus::Blocked;
                return;
            };
            self.move_to(to, yaw);
        } else if let Some(fy) = self.final_yaw {
            let e = wrap_angle(fy - self.pose[2]);
            if e.abs() <= YAW_TOLERANCE_RAD {
                self.pose[2] = fy;
                self.final_yaw = None;
                self.status = BaseStatus::Arrived;
            } else {
                self.pose[2] = wrap_angle(self.pose[2] + e.clamp(-turn * h, turn * h));
                self.status = BaseStatus::Moving;
            }
        } else {
            self.status = BaseStatus::Arrived;
        }
    }
}

/// A standard normal draw (Box–Muller, one of the pair).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.gen::<f64>(); // (0, 1]
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scenario;

    /// A closed 10 × 4 m room, the robot starting at (2, 2), plus `extra` (TOML tables).
    fn room_world(name: &str, extra: &str) -> World {
        let text = format!(
            r#"name = "{name}"
time_limit_s = 60
[start]
position = [2.0, 2.0]
[[walls]]
points = [[0, 0], [10, 0], [10, 4], [0, 4]]
closed = true
{extra}"#
        );
        World::from_toml_str(&text, &format!("{name}.toml")).unwrap()
    }

    /// The room split by a wall at x = 5 (no door), a suitcase behind the wall.
    fn walled_world(target_x: f64) -> World {
        let extra = format!(
            r#"[[walls]]
points = [[5, 0], [5, 4]]
[[targets]]
rect = {{ center = [{target_x}, 2.0], size = [0.5, 0.35] }}
"#
        );
        room_world("wall test", &extra)
    }

    #[test]
    fn detector_does_not_see_through_walls() {
        // Target 2 m ahead behind a wall: unseen.
        let sim = Sim::new(walled_world(6.0), SimConfig::default(), 1);
        assert_eq!(sim.visible_fraction(0), 0.0);
        assert_eq!(sim.detect(), None);
        // Same distance, same side: seen.
        let sim = Sim::new(walled_world(4.0), SimConfig::default(), 1);
        assert_eq!(sim.detect(), Some(0));
        assert!(sim.visible_fraction(0) >= 0.3);
    }

    #[test]
    fn detector_needs_cone_and_range() {
        let mut w = walled_world(4.0);
        w.start.pose[2] = PI; // facing away
        let sim = Sim::new(w, SimConfig::default(), 1);
        assert_eq!(sim.detect(), None);
        let cfg = SimConfig { camera_range_m: 1.5, ..SimConfig::default() };
        let sim = Sim::new(walled_world(4.0), cfg, 1);
        assert_eq!(sim.detect(), None);
    }

    #[test]
    fn detector_is_blocked_by_obstacles_and_people() {
        let mut w = walled_world(4.5);
        w.obstacles.push(crate::Obstacle {
            shape: Shape::Rect { center: [3.0, 2.0], size: [0.3, 1.5], yaw: 0.0 },
            kind: HitKind::Furniture,
            label: "shelf".into(),
            material: Material::Default,
        });
        let sim = Sim::new(w, SimConfig::default(), 1);
        assert_eq!(sim.detect(), None);
        let mut w = walled_world(4.5);
        w.people.push(crate::Person { path: vec![[3.0, 2.0]], speed_mps: 0.0, radius_m: 0.5 });
        let sim = Sim::new(w, SimConfig::default(), 1);
        assert_eq!(sim.detect(), None);
    }

    #[test]
    fn base_never_enters_a_wall() {
        let mut sim = Sim::new(walled_world(8.0), SimConfig::default(), 3);
        sim.set_path(&[[4.0, 2.0], [8.0, 2.0]], None);
        let mut blocked = false;
        for _ in 0..200 {
            let s = sim.step(0.1);
            let p = sim.pose();
            assert!(!sim.collides([p[0], p[1]]), "collides at {p:?}");
            assert!(p[0] < 5.0 - 0.3, "crossed the wall: {p:?}");
            if s == BaseStatus::Blocked {
                blocked = true;
            }
        }
        assert!(blocked);
        assert_eq!(sim.step(0.1), BaseStatus::Blocked);
        assert!(sim.pose()[0] > 4.6, "drove up to the wall: {:?}", sim.pose());
        sim.stop_base();
        assert_eq!(sim.step(0.1), BaseStatus::Idle);
    }

    #[test]
    fn base_follows_path_and_turns_to_final_yaw() {
        let mut sim = Sim::new(walled_world(8.0), SimConfig::default(), 3);
        let p0 = sim.pose();
        sim.set_path(&[[3.0, 1.0], [4.0, 3.0]], Some(PI));
        let mut status = BaseStatus::Moving;
        for _ in 0..300 {
            status = sim.step(0.1);
            if status == BaseStatus::Arrived {
                break;
            }
        }
        assert_eq!(status, BaseStatus::Arrived);
        let p = sim.pose();
        assert!(dist([p[0], p[1]], [4.0, 3.0]) < GOAL_TOLERANCE_M);
        assert!((wrap_angle(p[2] - PI)).abs() < 1e-9);
        let straight = dist([p0[0], p0[1]], [3.0, 1.0]) + dist([3.0, 1.0], [4.0, 3.0]);
        assert!((sim.path_length_m() - straight).abs() < 2.0 * WAYPOINT_TOLERANCE_M + 0.1, "{} vs {straight}", sim.path_length_m());
        // Speed limit respected: driving ~3.5 m at 0.5 m/s takes ≥ 7 s.
        assert!(sim.time_s() >= sim.path_length_m() / 0.5);
    }

    #[test]
    fn same_seed_same_scans() {
        let w = World::builtin("office", Scenario::Hard).unwrap();
        let mut a = Sim::new(w.clone(), SimConfig::default(), 42);
        let mut b = Sim::new(w.clone(), SimConfig::default(), 42);
        let mut c = Sim::new(w, SimConfig::default(), 43);
        for _ in 0..5 {
            let (sa, sb, sc) = (a.scan(), b.scan(), c.scan());
            assert_eq!(sa.hits, sb.hits);
            let bits = |s: &Scan| s.ranges_m.iter().map(|r| r.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&sa), bits(&sb));
            assert_ne!(bits(&sa), bits(&sc));
            a.step(0.2);
            b.step(0.2);
            c.step(0.2);
        }
        assert_eq!(a.pose(), b.pose());
        assert_eq!(a.people(), b.people());
        assert_eq!(a.target_positions(), b.target_positions());
    }

    #[test]
    fn scan_shape_and_ground_truth() {
        let mut sim = Sim::new(walled_world(8.0), SimConfig::default(), 5);
        let s = sim.scan();
        assert_eq!(s.ranges_m.len(), 897);
        assert_eq!(s.hits.len(), 897);
        assert_eq!(s.angle_min, -PI);
        assert!((s.angle_increment * 897.0 - 2.0 * PI).abs() < 1e-12);
        // A beam without a return is +inf (nothing in range) or NaN (dropout, too close), and only
        // such beams have no ground-truth hit.
        for (r, h) in s.ranges_m.iter().zip(&s.hits) {
            assert_eq!(!r.is_finite(), *h == HitKind::None);
        }
        // Beam pointing forward (+x, yaw 0): the dividing wall 3 m away.
        let i = ((0.0 - s.angle_min) / s.angle_increment).round() as usize;
        if s.hits[i] != HitKind::None {
            assert_eq!(s.hits[i], HitKind::Wall);
            assert!((s.ranges_m[i] - 3.0).abs() < 0.06, "{}", s.ranges_m[i]);
        }
        // Dropouts happen at roughly the configured rate.
        let none = s.hits.iter().filter(|h| **h == HitKind::None).count();
        assert!(none < 40, "{none}");
        // No noise, no dropout: exact geometry.
        let cfg = SimConfig { range_noise_std_m: 0.0, dropout_prob: 0.0, ..SimConfig::default() };
        let mut sim = Sim::new(walled_world(8.0), cfg, 5);
        let p = sim.pose();
        let s = sim.scan();
        for (i, r) in s.ranges_m.iter().enumerate() {
            let a = p[2] + s.angle_min + i as f64 * s.angle_increment;
            let (c, sn) = (a.cos(), a.sin());
            // Expected distance to the box [0,5]×[0,4].
            let tx = if c > 0.0 {
                (5.0 - p[0]) / c
            } else if c < 0.0 {
                -p[0] / c
            } else {
                f64::INFINITY
            };
            let ty = if sn > 0.0 {
                (4.0 - p[1]) / sn
            } else if sn < 0.0 {
                -p[1] / sn
            } else {
                f64::INFINITY
            };
            assert!((*r as f64 - tx.min(ty)).abs() < 1e-4, "beam {i}");
            assert_eq!(s.hits[i], HitKind::Wall);
        }
    }

    #[test]
    fn people_walk_and_are_seen() {
        let mut w = walled_world(8.0);
        w.people.push(crate::Person { path: vec![[1.0, 0.7], [4.0, 0.7]], speed_mps: 1.0, radius_m: 0.25 });
        let mut sim = Sim::new(w, SimConfig::default(), 9);
        let before = sim.people()[0].0;
        sim.step(1.0);
        let after = sim.people()[0].0;
        assert!(dist(before, after) > 0.1);
        let mut seen = false;
        for _ in 0..20 {
            seen |= sim.scan().hits.contains(&HitKind::Person);
            sim.step(0.5);
        }
        assert!(seen);
    }

    #[test]
    fn base_never_touches_anything_among_people() {
        // Apartment, hard: from the living room down the hallway (where a person walks up and
        // down) into bedroom 1, for several seeds (different people phases and jitter).
        let w = World::builtin("apartment", Scenario::Hard).unwrap();
        let path = [[6.5, 24.0], [9.0, 24.0], [10.0, 22.0], [10.0, 4.0], [8.0, 4.0], [6.0, 5.0]];
        for seed in 0..4 {
            let mut sim = Sim::new(w.clone(), SimConfig::default(), seed);
            sim.set_path(&path, Some(0.0));
            let mut status = BaseStatus::Moving;
            for _ in 0..3000 {
                status = sim.step(0.1);
                let p = sim.pose();
                assert!(!sim.collides([p[0], p[1]]), "seed {seed}: collides at {p:?}");
                if status == BaseStatus::Arrived {
                    break;
                }
            }
            assert_eq!(status, BaseStatus::Arrived, "seed {seed}: {:?} at t = {}", sim.pose(), sim.time_s());
        }
    }

    #[test]
    fn start_jitter_is_collision_free_and_seeded() {
        for name in World::builtin_names() {
            for sc in Scenario::ALL {
                let w = World::builtin(name, sc).unwrap();
                for seed in 0..50 {
                    let sim = Sim::new(w.clone(), SimConfig::default(), seed);
                    let p = sim.pose();
                    assert!(!sim.collides([p[0], p[1]]), "{name} {sc} seed {seed}");
                    assert!((p[0] - w.start.pose[0]).abs() <= w.start.jitter_m + 1e-12);
                }
            }
        }
    }

    /// The robot (r = 0.3) at (2, 2), 1 cm below a 1.0 × 0.38 m box (bottom edge y = 2.31).
    fn box_above_start() -> Sim {
        let extra = r#"[[obstacles]]
kind = "furniture"
rect = { center = [2.0, 2.5], size = [1.0, 0.38] }
[[targets]]
rect = { center = [8.0, 3.0], size = [0.5, 0.35] }
"#;
        let sim = Sim::new(room_world("escape test", extra), SimConfig::default(), 1);
        assert!(!sim.collides([2.0, 2.0]));
        sim
    }

    #[test]
    fn base_slides_along_what_it_grazes_and_never_touches_it() {
        // Straight to (3.0, 2.1) the disc would touch the box's bottom edge within 2 cm; the base
        // turns its sub-steps away (as Spot's obstacle avoidance does) and arrives.
        let mut sim = box_above_start();
        sim.set_path(&[[3.0, 2.1]], None);
        let mut status = BaseStatus::Moving;
        for _ in 0..100 {
            status = sim.step(0.1);
            let p = sim.pose();
            assert!(!sim.collides([p[0], p[1]]), "touches at {p:?}");
            assert_ne!(status, BaseStatus::Blocked, "at {p:?}");
            if status == BaseStatus::Arrived {
                break;
            }
        }
        assert_eq!(status, BaseStatus::Arrived);
        // Into the box itself it is still blocked: no turn of up to 60° gets anywhere.
        let mut sim = box_above_start();
        sim.set_path(&[[2.0, 3.0]], None);
        let mut blocked = false;
        for _ in 0..40 {
            blocked |= sim.step(0.1) == BaseStatus::Blocked;
            let p = sim.pose();
            assert!(!sim.collides([p[0], p[1]]) && p[1] < 2.02, "at {p:?}");
        }
        assert!(blocked);
    }

    /// FNV-1a of the first `n` scans (range bits and hits) and poses of `apartment easy`, seed 1,
    /// the base walking a fixed path.
    fn apartment_scan_digest(cfg: SimConfig, n: usize) -> u64 {
        apartment_scan_digest_seeded(cfg, n, 1)
    }

    fn apartment_scan_digest_seeded(cfg: SimConfig, n: usize, seed: u64) -> u64 {
        // The built-in `apartment easy` the digests were taken on (2026-11-25), kept as an example.
        let text = include_str!("../../../examples/worlds/apartment-easy-bedroom-start.toml");
        let w = World::from_toml_str(text, "apartment-easy-bedroom-start.toml").unwrap();
        let mut sim = Sim::new(w, cfg, seed);
        let p = sim.pose();
        sim.set_path(&[[p[0] + 1.0, p[1]], [p[0] + 1.0, p[1] + 1.0]], Some(1.0));
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h ^= b as u64;
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        };
        for _ in 0..n {
            let s = sim.scan();
            for r in &s.ranges_m {
                eat(&r.to_bits().to_le_bytes());
            }
            for k in &s.hits {
                eat(&[*k as u8]);
            }
            for v in sim.pose() {
                eat(&v.to_bits().to_le_bytes());
            }
            sim.step(0.2);
        }
        h
    }

    /// Computed from the simulator before LiDAR profiles, materials, mounts and drift existed
    /// (commit 831efe1): the ideal profile must keep giving today's scans bit for bit.
    const IDEAL_APARTMENT_DIGEST: u64 = 0x31e1_b627_12f8_3d90;

    #[test]
    fn the_ideal_sensor_gives_the_scans_of_before_bit_for_bit() {
        assert_eq!(apartment_scan_digest(SimConfig::default(), 40), IDEAL_APARTMENT_DIGEST);
    }

    /// A 40 × 40 m empty square room, the robot at its centre facing +x, plus `extra`.
    fn big_room(extra: &str) -> World {
        let text = format!(
            r#"name = "big"
time_limit_s = 60
[start]
position = [20.0, 20.0]
[[walls]]
points = [[0, 0], [40, 0], [40, 40], [0, 40]]
closed = true
[[targets]]
rect = {{ center = [2.0, 2.0], size = [0.5, 0.35] }}
{extra}"#
        );
        World::from_toml_str(&text, "big.toml").unwrap()
    }

    #[test]
    fn each_profile_has_its_beams_field_of_view_and_range() {
        let deg = PI / 180.0;
        // (profile, beams, field of view, range_min, range_max)
        let want = [
            (LidarModel::Ideal, 897, 2.0 * PI, 0.1, 30.0),
            (LidarModel::RplidarA2, 800, 2.0 * PI, 0.15, 12.0),
            (LidarModel::RplidarA3, 1600, 2.0 * PI, 0.2, 25.0),
            (LidarModel::HokuyoUtm30lx, 1081, 270.0 * deg, 0.1, 30.0),
            (LidarModel::Vlp16, 897, 2.0 * PI, 0.3, 100.0),
        ];
        for (model, beams, fov, min, max) in want {
            let cfg = SimConfig::default().with_lidar(model);
            let mut sim = Sim::new(walled_world(8.0), cfg, 1);
            let s = sim.scan();
            assert_eq!(s.ranges_m.len(), beams, "{model:?}");
            assert_eq!(s.hits.len(), beams, "{model:?}");
            // 360° scanners: beams · increment = 2π; the Hokuyo: (beams − 1) · increment = 270°.
            let span = if fov < 2.0 * PI { (beams - 1) as f64 } else { beams as f64 } * s.angle_increment;
            assert!((span - fov).abs() < 1e-9, "{model:?}: {span} rad");
            assert!((s.angle_min + fov / 2.0).abs() < 1e-9, "{model:?}: centred on the laser's x axis");
            assert_eq!((s.range_min_m, s.range_max_m), (min, max), "{model:?}");
            for (r, h) in s.ranges_m.iter().zip(&s.hits) {
                assert_eq!(!r.is_finite(), *h == HitKind::None, "{model:?}");
                assert!(!r.is_finite() || (*r as f64 >= min && *r as f64 <= max), "{model:?}: {r}");
            }
            assert_eq!(LidarModel::from_name(model.as_str()), Some(model));
        }
        // The Hokuyo sees nothing behind it: its beams stop at ±135°.
        let cfg = SimConfig::default().with_lidar(LidarModel::HokuyoUtm30lx);
        assert!((cfg.angle_min_rad + cfg.angle_increment_rad * 1080.0 - 135.0 * deg).abs() < 1e-9);
    }

    /// Share of the beams of `n` scans hitting a wall at distance `d` (rotated so the wall's
    /// incidence is `incidence_deg`) that return nothing, on `model` and a wall of `material`.
    fn no_return_rate(model: LidarModel, material: &str, d: f64, incidence_deg: f64, n: usize) -> f64 {
        // A wall 8 m long centred `d` ahead of the robot, turned by the incidence angle.
        let (s, c) = (incidence_deg.to_radians().sin(), incidence_deg.to_radians().cos());
        let (cx, cy) = (20.0 + d, 20.0);
        let (a, b) = ([cx - 4.0 * s, cy + 4.0 * c], [cx + 4.0 * s, cy - 4.0 * c]);
        let extra = format!("[[walls]]\npoints = [[{}, {}], [{}, {}]]\nmaterial = \"{material}\"\n", a[0], a[1], b[0], b[1]);
        let cfg = SimConfig { dropout_prob: 0.0, ..SimConfig::default().with_lidar(model) };
        let mut sim = Sim::new(big_room(&extra), cfg, 7);
        let (mut none, mut total) = (0usize, 0usize);
        for _ in 0..n {
            let scan = sim.scan();
            for (i, r) in scan.ranges_m.iter().enumerate() {
                let a = scan.angle_min + i as f64 * scan.angle_increment;
                // Only the beams within ±2° of the wall's centre: all at about the same range.
                if a.abs() < 2f64.to_radians() {
                    total += 1;
                    none += (*r == f32::INFINITY) as usize;
                }
            }
        }
        assert!(total > 0);
        none as f64 / total as f64
    }

    #[test]
    fn no_returns_grow_with_range_incidence_and_darkness() {
        use LidarModel::RplidarA3;
        // The A3's datasheet: 25 m on white, 10 m on black. A painted wall (ρ 0.5) at normal
        // incidence returns half the time at 25 · √(0.5 / 0.9) = 18.6 m.
        let near = no_return_rate(RplidarA3, "default", 5.0, 0.0, 20);
        let mid = no_return_rate(RplidarA3, "default", 17.0, 0.0, 20);
        let far = no_return_rate(RplidarA3, "default", 19.5, 0.0, 20);
        assert!(near < 0.005, "{near}");
        assert!(near < mid && mid < far && far > 0.5, "{near} {mid} {far}");
        // Incidence: at 70° the same wall at 10 m returns much less often than head-on.
        let head_on = no_return_rate(RplidarA3, "default", 10.0, 0.0, 20);
        let oblique = no_return_rate(RplidarA3, "default", 10.0, 70.0, 20);
        assert!(head_on < 0.03 && oblique > 0.3, "{head_on} {oblique}");
        // Dark: at 8 m a dark wall loses beams a painted one returns.
        let painted = no_return_rate(RplidarA3, "default", 8.0, 0.0, 20);
        let dark = no_return_rate(RplidarA3, "dark", 8.0, 0.0, 20);
        assert!(painted < 0.01 && dark > 0.3, "{painted} {dark}");
        assert!(no_return_rate(RplidarA3, "dark", 4.0, 0.0, 20) < dark, "dark surfaces too lose more beams farther away");
        // The ideal sensor returns from every surface.
        assert_eq!(no_return_rate(LidarModel::Ideal, "dark", 19.5, 70.0, 5), 0.0);
    }

    #[test]
    fn glass_lets_most_beams_through_to_what_is_behind_it() {
        // A pane 3 m ahead, a wall 8 m ahead; beams at 30° off the pane's normal.
        let extra = "[[walls]]\npoints = [[23, 10], [23, 30]]\nmaterial = \"glass\"\n[[walls]]\npoints = [[28, 5], [28, 35]]\n";
        let cfg = SimConfig { dropout_prob: 0.0, ..SimConfig::default().with_lidar(LidarModel::HokuyoUtm30lx) };
        let mut sim = Sim::new(big_room(extra), cfg, 3);
        let (mut behind, mut pane, mut nothing, mut total) = (0, 0, 0, 0);
        for _ in 0..10 {
            let s = sim.scan();
            for (i, r) in s.ranges_m.iter().enumerate() {
                let a = s.angle_min + i as f64 * s.angle_increment;
                if (a.abs() - 30f64.to_radians()).abs() < 1f64.to_radians() {
                    total += 1;
                    let pane_range = 3.0 / a.cos();
                    if !r.is_finite() {
                        nothing += 1;
                    } else if (*r as f64 - pane_range).abs() < 0.2 {
                        pane += 1;
                    } else if (*r as f64 - 8.0 / a.cos()).abs() < 0.2 {
                        assert_eq!(s.hits[i], HitKind::Wall, "the wall behind the pane");
                        behind += 1;
                    }
                }
            }
        }
        assert_eq!(pane, 0, "no return off the pane itself at 30°");
        assert!(behind as f64 > 0.8 * total as f64, "{behind} of {total} through");
        assert!(nothing > 0, "some beams are lost in the glass");
        // Head-on the pane itself returns.
        let mut sim = Sim::new(big_room(extra), cfg_hokuyo_clean(), 3);
        let s = sim.scan();
        let i = ((0.0 - s.angle_min) / s.angle_increment).round() as usize;
        assert!((s.ranges_m[i] - 3.0).abs() < 0.1, "{}", s.ranges_m[i]);
        // The ideal sensor sees glass as a wall.
        let mut sim = Sim::new(big_room(extra), SimConfig { dropout_prob: 0.0, ..SimConfig::default() }, 3);
        let s = sim.scan();
        let i = ((0.0 - s.angle_min) / s.angle_increment).round() as usize;
        assert!((s.ranges_m[i] - 3.0).abs() < 0.1);
    }

    fn cfg_hokuyo_clean() -> SimConfig {
        SimConfig { dropout_prob: 0.0, angular_jitter_rad: 0.0, ..SimConfig::default().with_lidar(LidarModel::HokuyoUtm30lx) }
    }

    #[test]
    fn mixed_pixels_fall_between_foreground_and_background() {
        // A 0.4 m post 3 m ahead of a wall 20 m ahead: its edges are depth edges.
        let extra = "[[obstacles]]\nkind = \"furniture\"\ncircle = { center = [23.0, 20.0], radius = 0.2 }\n";
        let cfg = SimConfig { range_noise_std_m: 0.0, range_noise_per_m: 0.0, ..cfg_hokuyo_clean() };
        let (mut mixed, mut scans) = (0, 0);
        let mut sim = Sim::new(big_room(extra), cfg.clone(), 11);
        for _ in 0..50 {
            let s = sim.scan();
            scans += 1;
            for (r, h) in s.ranges_m.iter().zip(&s.hits) {
                let r = *r as f64;
                if r > 3.2 && r < 19.5 {
                    mixed += 1;
                    assert_ne!(*h, HitKind::None);
                }
            }
        }
        assert!(mixed > 0, "mixed pixels at the post's edges over {scans} scans");
        // Without divergence there are none.
        let mut sim = Sim::new(big_room(extra), SimConfig { beam_divergence_rad: 0.0, ..cfg }, 11);
        for _ in 0..50 {
            assert!(sim.scan().ranges_m.iter().all(|r| !(*r > 3.2 && *r < 19.5)));
        }
    }

    #[test]
    fn a_mounted_laser_sees_a_known_wall_where_it_is_once_its_pose_is_composed() {
        // The robot at (20, 20) facing +y; the laser 0.3 m ahead, 0.1 m left, turned −90°: it
        // faces +x, where the room's wall is at x = 40, 19.7 m from the laser... (x = 20 − 0.1).
        let mut w = big_room("");
        w.start.pose[2] = PI / 2.0;
        let cfg = SimConfig { mount: [0.3, 0.1, -PI / 2.0], dropout_prob: 0.0, range_noise_std_m: 0.0, ..SimConfig::default() };
        let mut sim = Sim::new(w, cfg, 1);
        let lp = sim.laser_pose();
        assert!((lp[0] - 19.9).abs() < 1e-12 && (lp[1] - 20.3).abs() < 1e-12 && lp[2].abs() < 1e-12, "{lp:?}");
        assert_eq!(sim.controller_pose(), lp, "no drift: the odometry frame is the world");
        let s = sim.scan();
        let i = ((0.0 - s.angle_min) / s.angle_increment).round() as usize;
        let a = s.angle_min + i as f64 * s.angle_increment;
        assert!((s.ranges_m[i] as f64 - 20.1 / a.cos()).abs() < 1e-4, "{}", s.ranges_m[i]);
        // Every return, placed by the laser pose, lies on the room's walls.
        for (i, r) in s.ranges_m.iter().enumerate() {
            if s.hits[i] != HitKind::Wall {
                assert_eq!(s.hits[i], HitKind::Target, "only the suitcase in the room");
                continue;
            }
            let a = lp[2] + s.angle_min + i as f64 * s.angle_increment;
            let (x, y) = (lp[0] + *r as f64 * a.cos(), lp[1] + *r as f64 * a.sin());
            let to_wall = x.min(40.0 - x).min(y).min(40.0 - y).abs();
            assert!(to_wall < 1e-3, "beam {i} at ({x}, {y})");
        }
    }

    #[test]
    fn a_goal_in_the_controllers_frame_brings_the_laser_there() {
        // Mount and drift: the base follows the goal in the odometry frame, so the laser's
        // odometry pose ends at the goal (within the base's tolerance).
        let cfg = SimConfig { mount: [0.2, 0.0, 0.3], odom_slip_per_m: 0.05, odom_heading_drift_per_rad: 0.05, ..SimConfig::default() };
        let mut sim = Sim::new(big_room(""), cfg, 4);
        let goal = [25.0, 23.0];
        sim.set_goal_path(&[[22.0, 21.0], goal], Some(1.0));
        let mut status = BaseStatus::Moving;
        for _ in 0..600 {
            status = sim.step(0.1);
            if status == BaseStatus::Arrived {
                break;
            }
        }
        assert_eq!(status, BaseStatus::Arrived);
        let q = sim.controller_pose();
        assert!(dist([q[0], q[1]], goal) < 0.25, "{q:?}");
        assert!(wrap_angle(q[2] - 1.0).abs() < 0.01, "{q:?}");
        // And the true laser is elsewhere: the odometry drifted.
        let t = sim.laser_pose();
        assert!(dist([t[0], t[1]], goal) > 0.05, "{t:?}");
    }

    /// The odometry's position error after driving `metres` straight ahead, then turning
    /// `turn` radians in place.
    fn drift_after(cfg: SimConfig, metres: f64, turn: f64) -> (f64, f64) {
        let mut sim = Sim::new(big_room(""), cfg, 9);
        sim.set_path(&[[20.0 + metres, 20.0]], Some(turn));
        for _ in 0..1000 {
            if sim.step(0.1) == BaseStatus::Arrived {
                break;
            }
        }
        let (p, o) = (sim.pose(), sim.odom_pose());
        (dist([p[0], p[1]], [o[0], o[1]]), wrap_angle(p[2] - o[2]).abs())
    }

    #[test]
    fn odometry_is_exact_without_drift_and_drifts_more_the_farther_it_goes() {
        let exact = SimConfig::default();
        assert_eq!(drift_after(exact.clone(), 10.0, 3.0), (0.0, 0.0));
        let cfg = SimConfig { odom_slip_per_m: 0.02, odom_heading_drift_per_rad: 0.01, ..exact };
        let (two, six, twelve) =
            (drift_after(cfg.clone(), 2.0, 0.0), drift_after(cfg.clone(), 6.0, 0.0), drift_after(cfg.clone(), 12.0, 0.0));
        assert!(two.0 > 0.0 && two.0 < six.0 && six.0 < twelve.0, "{two:?} {six:?} {twelve:?}");
        // 2 % of the distance, the sign and size (0.5–1.5×) from the seed.
        assert!((0.01 * 12.0..=0.03 * 12.0).contains(&twelve.0), "{twelve:?}");
        assert_eq!(twelve.1, 0.0, "no turn, no heading drift");
        // 1 % of the turns: more turning, more heading error.
        let (_, small) = drift_after(cfg.clone(), 2.0, 1.0);
        let (_, large) = drift_after(cfg.clone(), 2.0, 3.0);
        assert!(small > 0.0 && small < large && large <= 0.015 * 3.0 + 1e-9, "{small} {large}");
    }

    #[test]
    fn realistic_scans_are_deterministic_per_seed() {
        let cfg = SimConfig { mount: [0.1, 0.0, 0.0], odom_slip_per_m: 0.02, odom_heading_drift_per_rad: 0.01, ..SimConfig::default() };
        for model in LidarModel::ALL {
            let cfg = cfg.clone().with_lidar(model);
            let (a, b, c) = (
                apartment_scan_digest(cfg.clone(), 10),
                apartment_scan_digest(cfg.clone(), 10),
                apartment_scan_digest_seeded(cfg.clone(), 10, 2),
            );
            assert_eq!(a, b, "{model:?}");
            assert_ne!(a, c, "{model:?}: another seed, other scans");
        }
    }

    #[test]
    fn world_files_name_materials_and_refuse_unknown_ones() {
        let w = room_world("m", "[[walls]]\npoints = [[5, 0], [5, 4]]\nmaterial = \"glass\"\n[[obstacles]]\nkind = \"furniture\"\nmaterial = \"dark\"\ncircle = { center = [8.0, 2.0], radius = 0.3 }\n[[targets]]\nrect = { center = [3.0, 3.0], size = [0.5, 0.35] }\n");
        assert_eq!(w.wall_material(4), Material::Glass);
        assert_eq!(w.wall_material(0), Material::Default);
        assert_eq!(w.obstacles[0].material, Material::Dark);
        let back = World::from_toml_str(&w.to_toml_string(), "back.toml").unwrap();
        assert_eq!(back, w, "materials survive a round trip");
        let bad = "name = \"b\"\ntime_limit_s = 60\n[start]\nposition = [2.0, 2.0]\n[[walls]]\npoints = [[0, 0], [10, 0], [10, 4], [0, 4]]\nclosed = true\nmaterial = \"chrome\"\n[[targets]]\nrect = { center = [3.0, 3.0], size = [0.5, 0.35] }\n";
        let e = World::from_toml_str(bad, "bad.toml").unwrap_err().to_string();
        assert_eq!(e, "bad.toml:8: unknown material \"chrome\" in `material`, expected one of `default`, `dark`, `glass`");
        let bad = bad.replace("material = \"chrome\"", "material = 3");
        let e = World::from_toml_str(&bad, "bad.toml").unwrap_err().to_string();
        assert!(e.starts_with("bad.toml:8:") && e.contains("string"), "{e}");
    }
}
