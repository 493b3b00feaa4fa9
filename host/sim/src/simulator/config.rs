//! The simulated sensors and base: LiDAR profiles and every setting of [`SimConfig`].

use std::f64::consts::PI;

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
