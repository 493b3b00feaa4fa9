//! `--sim name=value`: the simulated robot and its sensors, from one table ([`SIM_PARAMS`]) that
//! gives each setting's name, unit, accepted range, field of [`SimConfig`] and description;
//! applying, reading back and listing all go through it.

use super::{meters, num, validated};
use crate::sim::{LidarModel, SimConfig};
use firmware::{BinaryAngle, Config};

/// How a `--sim` number is written against the [`SimConfig`] field it sets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// As it is.
    Same,
    /// Degrees, for a field in radians.
    Degrees,
    /// Thousandths (milliradians), for a field in radians.
    Milli,
}

impl Scale {
    fn to_field(self, x: f64) -> f64 {
        match self {
            Scale::Same => x,
            Scale::Degrees => x.to_radians(),
            Scale::Milli => x / 1000.0,
        }
    }

    fn written(self, x: f64) -> f64 {
        match self {
            Scale::Same => x,
            Scale::Degrees => x.to_degrees(),
            Scale::Milli => x * 1000.0,
        }
    }
}

/// What a setting sets.
#[derive(Clone, Copy)]
pub enum SimValue {
    /// The LiDAR profile ([`LidarModel`]): every LiDAR field at once, and the controller's range.
    Lidar,
    /// One number of [`SimConfig`].
    Number(fn(&mut SimConfig) -> &mut f64),
}

/// What a setting also sets in the controller's configuration: `(cfg, name, value as written)`.
pub type Follow = fn(&mut Config, &str, f64) -> Result<(), String>;

/// One `--sim` setting.
#[derive(Clone, Copy)]
pub struct SimParam {
    /// Its name.
    pub name: &'static str,
    /// Its unit, as `lives params` prints it.
    pub unit: &'static str,
    /// The values it accepts, `(lo, hi, lo_open)`: [lo, hi], or (lo, hi] when `lo_open`.
    pub range: Option<(f64, f64, bool)>,
    /// One line saying what it does.
    pub summary: &'static str,
    /// What it sets.
    pub value: SimValue,
    /// How the number is written against the field.
    pub scale: Scale,
    /// What it also sets in the controller's model of the robot, from the value as written
    /// (`follows` says so in the listing).
    pub follow: Option<Follow>,
}

impl SimParam {
    /// A number of [`SimConfig`]: its name, unit, accepted values `(lo, hi, lo_open)` and field;
    /// written as it is, nothing else set. [`SimParam::about`] says what it does.
    const fn number(name: &'static str, unit: &'static str, range: (f64, f64, bool), field: fn(&mut SimConfig) -> &mut f64) -> SimParam {
        SimParam { name, unit, range: Some(range), summary: "", value: SimValue::Number(field), scale: Scale::Same, follow: None }
    }

    /// Written in `scale` against its field.
    const fn scaled(self, scale: Scale) -> SimParam {
        SimParam { scale, ..self }
    }

    /// The line that says what it does.
    const fn about(self, summary: &'static str) -> SimParam {
        SimParam { summary, ..self }
    }

    /// Also sets the controller's model of the robot ([`SimParam::follow`]).
    const fn follows(self, follow: Follow) -> SimParam {
        SimParam { follow: Some(follow), ..self }
    }
}

/// Settings `--sim` accepts: the simulated base, LiDAR and camera. The defaults are
/// [`crate::search::SearchSpec::new`]'s (`lives params` prints them).
pub const SIM_PARAMS: &[SimParam] = &[
    SimParam {
        name: "lidar",
        unit: "profile",
        range: None,
        summary: "LiDAR profile (docs/sim-sensors.md); sets beams, field of view, range, noise, no-returns; give it before other LiDAR settings",
        value: SimValue::Lidar,
        scale: Scale::Same,
        follow: None,
    },
    SimParam::number("white_range_m", "m", (0.0, 200.0, false), |s| &mut s.white_range_m)
        .about("no-return model: range at which a white target at normal incidence returns half the time (0: every surface returns, glass included)"),
    SimParam::number("angular_jitter_deg", "°", (0.0, 1.0, false), |s| &mut s.angular_jitter_rad)
        .scaled(Scale::Degrees)
        .about("standard deviation of each firing's direction around its nominal one"),
    SimParam::number("beam_divergence_mrad", "mrad", (0.0, 50.0, false), |s| &mut s.beam_divergence_rad)
        .scaled(Scale::Milli)
        .about("full beam divergence for mixed pixels at depth edges (0: none)"),
    SimParam::number("mount_x_m", "m", (-1.0, 1.0, false), |s| &mut s.mount[0])
        .about("the laser's position on the base, ahead of its centre"),
    SimParam::number("mount_y_m", "m", (-1.0, 1.0, false), |s| &mut s.mount[1])
        .about("the laser's position on the base, left of its centre"),
    SimParam::number("mount_yaw_deg", "°", (-180.0, 180.0, false), |s| &mut s.mount[2])
        .scaled(Scale::Degrees)
        .about("the laser's rotation on the base"),
    SimParam::number("odom_slip_per_m", "m/m", (0.0, 0.5, false), |s| &mut s.odom_slip_per_m)
        .about("odometry's scale error per metre driven; the seed picks sign and size within ±50 %"),
    SimParam::number("odom_heading_drift_per_rad", "rad/rad", (0.0, 0.5, false), |s| &mut s.odom_heading_drift_per_rad)
        .about("odometry's heading error per radian turned; the seed picks sign and size within ±50 %"),
    SimParam::number("speed_mps", "m/s", (0.0, 5.0, true), |s| &mut s.speed_mps).about("the base's top speed"),
    SimParam::number("turn_rate_rps", "rad/s", (0.0, 10.0, true), |s| &mut s.turn_rate_rps).about("the base's top turn rate"),
    SimParam::number("range_noise_std_m", "m", (0.0, 1.0, false), |s| &mut s.range_noise_std_m)
        .about("standard deviation of the LiDAR's Gaussian range noise"),
    SimParam::number("dropout_prob", "fraction", (0.0, 1.0, false), |s| &mut s.dropout_prob)
        .about("probability that a LiDAR beam returns nothing"),
    SimParam::number("lidar_max_range_m", "m", (1.0, 100.0, false), |s| &mut s.lidar_max_range_m)
        .about("LiDAR range; the controller's LiDAR model follows")
        .follows(|cfg, name, x| {
            cfg.lidar_max_range_m = meters(name, x)?;
            Ok(())
        }),
    SimParam::number("camera_range_m", "m", (0.0, 30.0, true), |s| &mut s.camera_range_m)
        .about("how far the detector sees; the controller's camera model follows")
        .follows(|cfg, name, x| {
            cfg.camera_range_m = meters(name, x)?;
            Ok(())
        }),
    SimParam::number("camera_fov_deg", "°", (1.0, 359.0, false), |s| &mut s.camera_fov_rad)
        .scaled(Scale::Degrees)
        .about("the camera's field of view; the controller's camera model follows")
        .follows(|cfg, name, d| {
            cfg.camera_fov = BinaryAngle::from_radians(d.to_radians()).ok_or_else(|| format!("`{name}`: {d}° is not an angle"))?;
            Ok(())
        }),
    SimParam::number("detect_min_visible_fraction", "fraction", (0.0, 1.0, true), |s| &mut s.detect_min_visible_fraction)
        .about("share of a target's outline that must be in view and unoccluded to detect it"),
    SimParam::number("robot_radius_m", "m", (0.05, 1.0, false), |s| &mut s.robot_radius_m)
        .about("the simulated body's radius for collisions; the controller's clearance and least clearance follow (0.10 m more)")
        .follows(|cfg, name, x| {
            // The controller keeps the same margins around the body as with the defaults
            // (0.35 m of clearance around a 0.25 m body; `lethal_radius_m` as far from the body
            // as its default is: 0.35 m, so no narrow band).
            let body = crate::robot_model::default_sim().robot_radius_m;
            let follow = |default: fixed_point::Meters| {
                fixed_point::meters_from_f64(x + default.to_num::<f64>() - body).ok_or_else(|| format!("`{name}`: {x} m is out of range"))
            };
            cfg.robot_radius_m = follow(Config::DEFAULT.robot_radius_m)?;
            cfg.lethal_radius_m = follow(Config::DEFAULT.lethal_radius_m)?;
            Ok(())
        }),
];

impl SimParam {
    /// The range as the errors and the listing write it: `[0, 200]`, `(0, 5]`.
    pub fn range_text(&self) -> String {
        match self.range {
            Some((lo, hi, open)) => format!("{}{lo}, {hi}]", if open { '(' } else { '[' }),
            None => LidarModel::ALL.iter().map(|m| m.as_str()).collect::<Vec<_>>().join(", "),
        }
    }

    /// Its value in `sim`, as `--sim` takes it.
    pub fn get(&self, sim: &SimConfig) -> String {
        match self.value {
            SimValue::Lidar => sim.lidar.as_str().to_string(),
            SimValue::Number(field) => {
                let x = *field(&mut sim.clone());
                match self.scale {
                    Scale::Same => x.to_string(),
                    scale => format!("{}", (scale.written(x) * 1e6).round() / 1e6 + 0.0),
                }
            }
        }
    }

    /// Sets it to `v` in `sim` (and its model in `cfg`); on an error neither changes.
    fn set(&self, sim: &mut SimConfig, cfg: &mut Config, v: &str) -> Result<(), String> {
        let name = self.name;
        match self.value {
            SimValue::Lidar => {
                let model = LidarModel::from_name(v)
                    .ok_or_else(|| format!("`{name}`: unknown LiDAR profile `{v}`, expected one of {}", self.range_text()))?;
                *sim = sim.clone().with_lidar(model);
                *cfg = crate::robot_model::controller_model(cfg, sim);
            }
            SimValue::Number(field) => {
                let x = num(name, v)?;
                if let Some((lo, hi, open)) = self.range {
                    if !((if open { x > lo } else { x >= lo }) && x <= hi) {
                        return Err(format!("`{name}`: expected a value in {}, got {}", self.range_text(), v.trim()));
                    }
                }
                if let Some(follow) = self.follow {
                    follow(cfg, name, x)?;
                }
                *field(sim) = self.scale.to_field(x);
            }
        }
        Ok(())
    }
}

/// Applies one `name=value` to the simulated robot `sim`. The LiDAR's range, the camera's range
/// and field of view and the body's size describe the robot the controller drives, so they also
/// set the controller's model of them in `cfg` (its clearance keeps the default 0.10 m margin
/// around the body); a later `--set` may still change the model alone. A setting that leaves
/// the controller's configuration out of its ranges ([`Config::validate`]) is refused and
/// changes nothing.
pub fn apply_sim(sim: &mut SimConfig, cfg: &mut Config, assignment: &str) -> Result<(), String> {
    let (name, v) = assignment.split_once('=').ok_or_else(|| format!("`--sim {assignment}`: expected name=value"))?;
    let (name, v) = (name.trim(), v.trim());
    let p = SIM_PARAMS.iter().find(|p| p.name == name).ok_or_else(|| {
        let known: Vec<&str> = SIM_PARAMS.iter().map(|p| p.name).collect();
        format!("unknown simulator setting `{name}`; known: {}", known.join(", "))
    })?;
    let (sim_before, cfg_before) = (sim.clone(), *cfg);
    p.set(sim, cfg, v)?;
    validated(cfg, cfg_before, name, name, v).inspect_err(|_| *sim = sim_before)
}

/// The value of `--sim` setting `name` in `sim`, in the units `--sim` takes (`None` for an
/// unknown name).
pub fn get_sim(sim: &SimConfig, name: &str) -> Option<String> {
    Some(SIM_PARAMS.iter().find(|p| p.name == name)?.get(sim))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_setting_says_what_it_does() {
        for p in SIM_PARAMS {
            assert!(!p.summary.is_empty(), "`{}` has no `about`", p.name);
        }
    }

    #[test]
    fn degrees_are_the_radians_the_simulator_took_before_the_table() {
        for i in -3600..=3600 {
            let x = i as f64 / 10.0;
            assert_eq!(Scale::Degrees.to_field(x), x * (std::f64::consts::PI / 180.0), "{x}");
        }
    }

    #[test]
    fn a_lidar_profile_sets_the_scanner_and_the_controllers_range_model() {
        let (mut sim, mut c) = (crate::robot_model::default_sim(), Config::DEFAULT);
        apply_sim(&mut sim, &mut c, "lidar=rplidar-a2").unwrap();
        assert_eq!((sim.beams, sim.lidar_min_range_m, sim.lidar_max_range_m), (800, 0.15, 12.0));
        assert_eq!(c.lidar_max_range_m, fixed_point::Meters::from_num(12), "the controller's LiDAR model follows");
        assert_eq!(sim.mount, crate::robot_model::default_sim().mount, "the mount and odometry are the robot's, not the scanner's");
        apply_sim(&mut sim, &mut c, "lidar=vlp16").unwrap();
        assert_eq!(sim.lidar_max_range_m, 100.0);
        assert_eq!(c.lidar_max_range_m, Config::DEFAULT.lidar_max_range_m, "a 100 m scanner is modelled out to the default 30 m");
        apply_sim(&mut sim, &mut c, "lidar=ideal").unwrap();
        for s in ["mount_x_m=0", "odom_slip_per_m=0", "odom_heading_drift_per_rad=0"] {
            apply_sim(&mut sim, &mut c, s).unwrap();
        }
        assert_eq!(sim, crate::robot_model::ideal_sim(), "ideal and no drift is the robot of before the profiles");
        apply_sim(&mut sim, &mut c, "mount_yaw_deg=-90").unwrap();
        assert!((sim.mount[2] + std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert_eq!(get_sim(&sim, "mount_yaw_deg").as_deref(), Some("-90"));
    }

    #[test]
    fn sim_settings_apply_to_the_robot_and_its_model_and_reject_bad() {
        let (mut sim, mut c) = (SimConfig::default(), Config::DEFAULT);
        apply_sim(&mut sim, &mut c, "speed_mps=0.25").unwrap();
        assert_eq!(sim.speed_mps, 0.25);
        apply_sim(&mut sim, &mut c, " camera_range_m = 8 ").unwrap();
        assert_eq!(sim.camera_range_m, 8.0);
        assert_eq!(c.camera_range_m, fixed_point::Meters::from_num(8), "the controller's camera model follows");
        apply_sim(&mut sim, &mut c, "camera_fov_deg=60").unwrap();
        assert!((sim.camera_fov_rad - 60f64.to_radians()).abs() < 1e-12);
        assert!((c.camera_fov.to_radians() - 60f64.to_radians()).abs() < 1e-6);
        apply_sim(&mut sim, &mut c, "lidar_max_range_m=12").unwrap();
        assert_eq!((sim.lidar_max_range_m, c.lidar_max_range_m), (12.0, fixed_point::Meters::from_num(12)));
        apply_sim(&mut sim, &mut c, "dropout_prob=0").unwrap();
        apply_sim(&mut sim, &mut c, "robot_radius_m=0.4").unwrap();
        assert_eq!(sim.robot_radius_m, 0.4);
        assert!((c.robot_radius_m.to_num::<f64>() - 0.5).abs() < 1e-4, "clearance 0.10 m more than the body");
        assert!((c.lethal_radius_m.to_num::<f64>() - 0.5).abs() < 1e-4, "least clearance as far from the body as by default");
        assert_eq!(sim.dropout_prob, 0.0);
        let before = (sim.clone(), c);
        for bad in [
            "speed_mps",
            "speed_mps=0",
            "speed_mps=-1",
            "speed_mps=inf",
            "speed_mps=NaN",
            "dropout_prob=1.5",
            "range_noise_std_m=-0.1",
            "camera_fov_deg=360",
            "camera_range_m=0",
            "detect_min_visible_fraction=0",
            "robot_radius_m=2",
            "beams=16",
            "lidar=rplidar",
            "lidar=",
            "white_range_m=-1",
            "mount_x_m=2",
            "mount_yaw_deg=NaN",
            "odom_slip_per_m=0.6",
            "odom_heading_drift_per_rad=-0.1",
            "angular_jitter_deg=5",
            "beam_divergence_mrad=100",
        ] {
            let e = apply_sim(&mut sim, &mut c, bad).unwrap_err();
            assert!(e.contains(bad.split('=').next().unwrap()) || e.contains("name=value"), "{bad}: {e}");
        }
        assert_eq!((sim, c), before, "a rejected setting changes nothing");
        let e = apply_sim(&mut SimConfig::default(), &mut Config { ..Config::DEFAULT }, "lidar=rplidar").unwrap_err();
        assert_eq!(e, "`lidar`: unknown LiDAR profile `rplidar`, expected one of ideal, rplidar-a2, rplidar-a3, hokuyo-utm30lx, vlp16");
        let (mut sim, mut c) = (SimConfig::default(), Config::DEFAULT);
        for name in SIM_PARAMS.iter().map(|p| p.name) {
            let value = match name {
                "camera_fov_deg" | "lidar_max_range_m" | "white_range_m" => "45",
                "lidar" => "hokuyo-utm30lx",
                _ => "0.5",
            };
            apply_sim(&mut sim, &mut c, &format!("{name}={value}")).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}
