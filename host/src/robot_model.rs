//! The simulated robot and the controller's model of it: the default robot (a Spot with a
//! VLP-16 cut to the scan plane, drifting odometry), the named robots `--robot` picks (the
//! camera's reach), and the controller configuration that follows from the robot's sensors.
//! `crate::overrides` (`--sim`) and `crate::search` build on it.

use crate::sim::{LidarModel, SimConfig};
use firmware::Config;
use serde::Serialize;
use std::fmt;
use std::str::FromStr;

/// The simulated robot a search uses unless `--sim` changes it: the paper's Spot with its
/// Velodyne VLP-16 cut to the scan plane (the `vlp16` profile), mounted 0.10 m ahead of the
/// body's centre (within the 0.10 m of clearance the controller keeps beyond the body), with
/// moderately drifting odometry (2 % of the distance, 1 % of the turns; the seed picks the signs
/// and sizes within ±50 %), and a 0.25 m body (the controller keeps `robot_radius_m` 0.35 m of
/// clearance around it). `docs/sim-sensors.md` says why.
pub fn default_sim() -> SimConfig {
    SimConfig {
        mount: [0.10, 0.0, 0.0],
        odom_slip_per_m: 0.02,
        odom_heading_drift_per_rad: 0.01,
        ..ideal_sim().with_lidar(LidarModel::Vlp16)
    }
}

/// The named simulated robots (`--robot` on `lives search` and `lives eval`): [`default_sim`]
/// with the camera's reach, which the paper does not state, set one way or the other. The
/// controller's model of the camera follows (in the host: the core's default stays as it is).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Robot {
    /// The camera's reach calibrated on the paper's greedy baseline: the reach at which
    /// `multisensor` comes closest to the paper's Multisensor-frontier rows
    /// (`docs/experiments/camera-calibration.md`). The default.
    Calibrated,
    /// The short-sighted camera of before the calibration (4 m, a guess that came with issue 1).
    Short,
}

/// The calibrated robot's camera reach (m): `docs/experiments/camera-calibration.md`.
pub const CALIBRATED_CAMERA_RANGE_M: f64 = 12.0;
/// The short robot's camera reach (m).
pub const SHORT_CAMERA_RANGE_M: f64 = 4.0;

impl Robot {
    /// Both, the default first.
    pub const ALL: [Robot; 2] = [Robot::Calibrated, Robot::Short];

    /// How far this robot's detector sees (m).
    pub fn camera_range_m(self) -> f64 {
        match self {
            Robot::Calibrated => CALIBRATED_CAMERA_RANGE_M,
            Robot::Short => SHORT_CAMERA_RANGE_M,
        }
    }

    /// This robot's simulator settings.
    pub fn sim(self) -> SimConfig {
        SimConfig { camera_range_m: self.camera_range_m(), ..default_sim() }
    }

    /// The name `--robot` takes.
    pub fn as_str(self) -> &'static str {
        match self {
            Robot::Calibrated => "calibrated",
            Robot::Short => "short",
        }
    }
}

impl fmt::Display for Robot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Robot {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Robot::ALL.into_iter().find(|r| r.as_str() == s).ok_or_else(|| format!("unknown robot `{s}` (expected calibrated or short)"))
    }
}

/// The simulated robot of before the LiDAR profiles: the clean `ideal` sensor at the body's
/// centre, exact odometry, a 0.25 m body (`--sim lidar=ideal --sim mount_x_m=0
/// --sim odom_slip_per_m=0 --sim odom_heading_drift_per_rad=0`).
pub fn ideal_sim() -> SimConfig {
    SimConfig { robot_radius_m: 0.25, ..SimConfig::default() }
}

/// The controller's model of the simulated LiDAR's range: the scanner's `range_max`, but no
/// farther than the controller's default (30 m: a 100 m VLP-16 still inserts and clears only
/// 30 m out, as before).
pub fn controller_model(base: &Config, sim: &SimConfig) -> Config {
    let cap = Config::DEFAULT.lidar_max_range_m.to_num::<f64>();
    match fixed_point::meters_from_f64(sim.lidar_max_range_m.min(cap)) {
        Some(m) => Config { lidar_max_range_m: m, ..*base },
        None => *base,
    }
}
