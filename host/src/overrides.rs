//! `--set name=value`: override controller parameters from the command line, in user units
//! (metres, degrees, seconds, utility weights as decimals). `--sim name=value`: the simulated
//! robot and its sensors ([`apply_sim`]). Both check the controller's configuration afterwards
//! with the core's own [`Config::validate`], so a value the core cannot work with (a 3 km
//! viewpoint snap radius, a camera that sees nothing) is refused here, naming its range, instead of
//! stopping the search.

use crate::sim::{LidarModel, SimConfig};
use firmware::config::Weight;
use firmware::{BinaryAngle, Config};

/// Parameters `--set` accepts, with their units.
pub const NAMES: &[(&str, &str)] = &[
    ("w_dist_per_m", "utility per metre of path"),
    ("w_unknown_per_cell", "utility per camera-unseen cell in the cone"),
    ("w_surface_per_ray", "utility per cone ray ending on an unseen surface"),
    ("w_frontier_per_cell", "utility per frontier cell near the path"),
    ("w_nonmap_per_point", "utility per non-map point in the cone"),
    ("switch_margin", "utility a new goal must gain over the current one"),
    ("replan_interval_s", "seconds between replans"),
    ("goal_timeout_s", "seconds without progress before a goal is blacklisted"),
    ("robot_radius_m", "clearance kept from occupied cells, metres"),
    ("camera_range_m", "camera range, metres"),
    ("camera_fov_deg", "camera field of view, degrees"),
    ("min_frontier_cells", "smallest frontier kept, cells"),
    ("unseen_unknown_eighths", "weight of LiDAR-unknown cells in the unseen term, eighths (8 = paper)"),
    ("nonmap_block_cap", "non-map points counted per 0.8 m block (0 = all)"),
    ("nonmap_view_cap", "non-map points counted in one view (0 = all)"),
    ("look_around_here", "true/false: score turning in place at the robot's cell"),
    ("gaze", "true/false: look while walking (camera faces the best heading, not the travel direction)"),
    ("gaze_min_gain", "least view utility worth turning the camera for while walking"),
    ("scan_matching", "true/false: correct odometry drift by matching each scan against the LiDAR grid"),
    ("nonmap_viewpoints", "true/false: viewpoints aimed at non-map clusters (lives)"),
    ("nonmap_standoff_m", "distance of a non-map viewpoint from its cluster, metres"),
    ("nonmap_pool_radius_m", "pooling radius of non-map points, metres"),
    ("nonmap_wall_clearance_m", "non-map points nearer a wall point are dropped, metres (0: the rule is off)"),
    ("nonmap_drop_vacated", "true/false: drop non-map points whose place the LiDAR has since seen empty"),
    ("viewpoint_snap_radius_m", "how far from a frontier's anchor its viewpoint may stand, metres"),
];

/// Settings `--sim` accepts: the simulated base, LiDAR and camera, with their units. The
/// defaults are [`crate::search::SearchSpec::new`]'s (`lives params` prints them).
pub const SIM_NAMES: &[(&str, &str)] = &[
    (
        "lidar",
        "LiDAR profile: ideal, rplidar-a2, rplidar-a3, hokuyo-utm30lx or vlp16 (docs/sim-sensors.md); sets beams, field of view, range, noise, no-returns; give it before other LiDAR settings",
    ),
    ("white_range_m", "no-return model: range at which a white target at normal incidence returns half the time, metres, in [0, 200] (0: every surface returns, glass included)"),
    ("angular_jitter_deg", "standard deviation of each firing's direction around its nominal one, degrees, in [0, 1]"),
    ("beam_divergence_mrad", "full beam divergence for mixed pixels at depth edges, milliradians, in [0, 50] (0: none)"),
    ("mount_x_m", "the laser's position on the base, metres ahead of its centre, in [-1, 1]"),
    ("mount_y_m", "the laser's position on the base, metres left of its centre, in [-1, 1]"),
    ("mount_yaw_deg", "the laser's rotation on the base, degrees, in [-180, 180]"),
    ("odom_slip_per_m", "odometry's scale error, metres per metre driven, in [0, 0.5]; the seed picks sign and size within ±50 %"),
    ("odom_heading_drift_per_rad", "odometry's heading error, radians per radian turned, in [0, 0.5]; the seed picks sign and size within ±50 %"),
    ("speed_mps", "the base's top speed, m/s, in (0, 5]"),
    ("turn_rate_rps", "the base's top turn rate, rad/s, in (0, 10]"),
    ("range_noise_std_m", "standard deviation of the LiDAR's Gaussian range noise, metres, in [0, 1]"),
    ("dropout_prob", "probability that a LiDAR beam returns nothing, in [0, 1]"),
    ("lidar_max_range_m", "LiDAR range, metres, in [1, 100]; the controller's LiDAR model follows"),
    ("camera_range_m", "how far the detector sees, metres, in (0, 30]; the controller's camera model follows"),
    ("camera_fov_deg", "the camera's field of view, degrees, in [1, 359]; the controller's camera model follows"),
    ("detect_min_visible_fraction", "share of a target's outline that must be in view and unoccluded to detect it, in (0, 1]"),
    (
        "robot_radius_m",
        "the simulated body's radius for collisions, metres, in [0.05, 1]; the controller's clearance follows (0.10 m more)",
    ),
];

/// `v` as a number in `lo..=hi` (or `lo` excluded when `open_lo`).
fn in_range(name: &str, v: &str, lo: f64, hi: f64, open_lo: bool) -> Result<f64, String> {
    let x = num(name, v)?;
    let above = if open_lo { x > lo } else { x >= lo };
    if !(above && x <= hi) {
        let open = if open_lo { '(' } else { '[' };
        return Err(format!("`{name}`: expected a value in {open}{lo}, {hi}], got {}", v.trim()));
    }
    Ok(x)
}

/// `cfg` after `name=v` was applied to `before`: kept if the core can work with it, else put
/// back and refused naming the setting and the range the core allows.
fn validated(cfg: &mut Config, before: Config, name: &str, v: &str) -> Result<(), String> {
    cfg.validate().map_err(|e| {
        *cfg = before;
        if e.field == name {
            format!("`{name}`: expected a value in {}, got {v}", e.allowed)
        } else {
            format!("`{name}={v}`: the controller's {e}")
        }
    })
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
    let (sim_before, cfg_before) = (sim.clone(), *cfg);
    set_sim(sim, cfg, name, v)?;
    validated(cfg, cfg_before, name, v).inspect_err(|_| *sim = sim_before)
}

fn set_sim(sim: &mut SimConfig, cfg: &mut Config, name: &str, v: &str) -> Result<(), String> {
    let deg = std::f64::consts::PI / 180.0;
    match name {
        "lidar" => {
            let model = LidarModel::from_name(v).ok_or_else(|| {
                let names: Vec<&str> = LidarModel::ALL.iter().map(|m| m.as_str()).collect();
                format!("`{name}`: unknown LiDAR profile `{v}`, expected one of {}", names.join(", "))
            })?;
            *sim = sim.clone().with_lidar(model);
            *cfg = crate::robot_model::controller_model(cfg, sim);
        }
        "white_range_m" => sim.white_range_m = in_range(name, v, 0.0, 200.0, false)?,
        "angular_jitter_deg" => sim.angular_jitter_rad = in_range(name, v, 0.0, 1.0, false)? * deg,
        "beam_divergence_mrad" => sim.beam_divergence_rad = in_range(name, v, 0.0, 50.0, false)? / 1000.0,
        "mount_x_m" => sim.mount[0] = in_range(name, v, -1.0, 1.0, false)?,
        "mount_y_m" => sim.mount[1] = in_range(name, v, -1.0, 1.0, false)?,
        "mount_yaw_deg" => sim.mount[2] = in_range(name, v, -180.0, 180.0, false)? * deg,
        "odom_slip_per_m" => sim.odom_slip_per_m = in_range(name, v, 0.0, 0.5, false)?,
        "odom_heading_drift_per_rad" => sim.odom_heading_drift_per_rad = in_range(name, v, 0.0, 0.5, false)?,
        "speed_mps" => sim.speed_mps = in_range(name, v, 0.0, 5.0, true)?,
        "turn_rate_rps" => sim.turn_rate_rps = in_range(name, v, 0.0, 10.0, true)?,
        "range_noise_std_m" => sim.range_noise_std_m = in_range(name, v, 0.0, 1.0, false)?,
        "dropout_prob" => sim.dropout_prob = in_range(name, v, 0.0, 1.0, false)?,
        "lidar_max_range_m" => {
            let (x, m) = (in_range(name, v, 1.0, 100.0, false)?, meters(name, v)?);
            (sim.lidar_max_range_m, cfg.lidar_max_range_m) = (x, m);
        }
        "camera_range_m" => {
            let (x, m) = (in_range(name, v, 0.0, 30.0, true)?, meters(name, v)?);
            (sim.camera_range_m, cfg.camera_range_m) = (x, m);
        }
        "camera_fov_deg" => {
            let d = in_range(name, v, 1.0, 359.0, false)?;
            let a = BinaryAngle::from_radians(d.to_radians()).ok_or_else(|| format!("`{name}`: {d}° is not an angle"))?;
            (sim.camera_fov_rad, cfg.camera_fov) = (d.to_radians(), a);
        }
        "detect_min_visible_fraction" => sim.detect_min_visible_fraction = in_range(name, v, 0.0, 1.0, true)?,
        "robot_radius_m" => {
            // The controller keeps the same margin around the body as with the defaults
            // (0.35 m of clearance around a 0.25 m body).
            let x = in_range(name, v, 0.05, 1.0, false)?;
            let margin = Config::DEFAULT.robot_radius_m.to_num::<f64>() - crate::robot_model::default_sim().robot_radius_m;
            let m = fixed_point::meters_from_f64(x + margin).ok_or_else(|| format!("`{name}`: {x} m is out of range"))?;
            (sim.robot_radius_m, cfg.robot_radius_m) = (x, m);
        }
        _ => {
            let known: Vec<&str> = SIM_NAMES.iter().map(|n| n.0).collect();
            return Err(format!("unknown simulator setting `{name}`; known: {}", known.join(", ")));
        }
    }
    Ok(())
}

fn num(name: &str, v: &str) -> Result<f64, String> {
    let x: f64 = v.parse().map_err(|_| format!("`{name}`: `{v}` is not a number"))?;
    if !x.is_finite() {
        return Err(format!("`{name}`: `{v}` is not finite"));
    }
    Ok(x)
}

fn meters(name: &str, v: &str) -> Result<fixed_point::Meters, String> {
    let x = num(name, v)?;
    if x < 0.0 {
        return Err(format!("`{name}`: must not be negative, got {x}"));
    }
    fixed_point::meters_from_f64(x).ok_or_else(|| format!("`{name}`: {x} m is out of range"))
}

fn weight(name: &str, v: &str) -> Result<Weight, String> {
    let x = num(name, v)?;
    if !(0.0..30_000.0).contains(&x) {
        return Err(format!("`{name}`: expected a weight in [0, 30000), got {x}"));
    }
    Ok(Weight::from_num(x))
}

fn micros(name: &str, v: &str) -> Result<u64, String> {
    let x = num(name, v)?;
    if !(0.0..1e6).contains(&x) {
        return Err(format!("`{name}`: expected seconds in [0, 1e6), got {x}"));
    }
    Ok((x * 1e6).round() as u64)
}

/// Applies one `name=value` to `cfg`. A value the core cannot work with ([`Config::validate`]) is
/// refused with its range, and `cfg` stays as it was.
pub fn apply(cfg: &mut Config, assignment: &str) -> Result<(), String> {
    let (name, v) = assignment.split_once('=').ok_or_else(|| format!("`--set {assignment}`: expected name=value"))?;
    let (name, v) = (name.trim(), v.trim());
    let before = *cfg;
    set(cfg, name, v)?;
    validated(cfg, before, name, v)
}

/// The value of `--set` parameter `name` in `cfg`, in the units `--set` takes (`None` for an
/// unknown name). `lives params` prints the defaults with it.
pub fn get(cfg: &Config, name: &str) -> Option<String> {
    // Q16.16 metres to the millimetre (0.35 is stored as 0.350006...).
    let m = |x: fixed_point::Meters| format!("{}", (x.to_num::<f64>() * 1000.0).round() / 1000.0);
    let s = |us: u64| format!("{}", us as f64 / 1e6);
    Some(match name {
        "w_dist_per_m" => cfg.w_dist_per_m.to_string(),
        "w_unknown_per_cell" => cfg.w_unknown_per_cell.to_string(),
        "w_surface_per_ray" => cfg.w_surface_per_ray.to_string(),
        "w_frontier_per_cell" => cfg.w_frontier_per_cell.to_string(),
        "w_nonmap_per_point" => cfg.w_nonmap_per_point.to_string(),
        "switch_margin" => cfg.switch_margin.to_string(),
        "replan_interval_s" => s(cfg.replan_interval_us),
        "goal_timeout_s" => s(cfg.goal_timeout_us),
        "robot_radius_m" => m(cfg.robot_radius_m),
        "camera_range_m" => m(cfg.camera_range_m),
        "camera_fov_deg" => format!("{:.1}", cfg.camera_fov.to_radians().to_degrees()),
        "min_frontier_cells" => cfg.min_frontier_cells.to_string(),
        "unseen_unknown_eighths" => cfg.unseen_unknown_eighths.to_string(),
        "nonmap_block_cap" => cfg.nonmap_block_cap.to_string(),
        "nonmap_view_cap" => cfg.nonmap_view_cap.to_string(),
        "look_around_here" => cfg.look_around_here.to_string(),
        "gaze" => cfg.gaze.to_string(),
        "scan_matching" => cfg.scan_matching.to_string(),
        "gaze_min_gain" => cfg.gaze_min_gain.to_string(),
        "nonmap_viewpoints" => cfg.nonmap_viewpoints.to_string(),
        "nonmap_standoff_m" => m(cfg.nonmap_standoff_m),
        "nonmap_pool_radius_m" => m(cfg.nonmap_pool_radius_m),
        "nonmap_wall_clearance_m" => m(cfg.nonmap_wall_clearance_m),
        "nonmap_drop_vacated" => cfg.nonmap_drop_vacated.to_string(),
        "viewpoint_snap_radius_m" => m(cfg.viewpoint_snap_radius_m),
        _ => return None,
    })
}

/// The value of `--sim` setting `name` in `sim`, in the units `--sim` takes (`None` for an
/// unknown name).
pub fn get_sim(sim: &SimConfig, name: &str) -> Option<String> {
    let r6 = |x: f64| format!("{}", (x * 1e6).round() / 1e6 + 0.0);
    Some(match name {
        "lidar" => sim.lidar.as_str().to_string(),
        "white_range_m" => sim.white_range_m.to_string(),
        "angular_jitter_deg" => r6(sim.angular_jitter_rad.to_degrees()),
        "beam_divergence_mrad" => r6(sim.beam_divergence_rad * 1000.0),
        "mount_x_m" => sim.mount[0].to_string(),
        "mount_y_m" => sim.mount[1].to_string(),
        "mount_yaw_deg" => r6(sim.mount[2].to_degrees()),
        "odom_slip_per_m" => sim.odom_slip_per_m.to_string(),
        "odom_heading_drift_per_rad" => sim.odom_heading_drift_per_rad.to_string(),
        "speed_mps" => sim.speed_mps.to_string(),
        "turn_rate_rps" => sim.turn_rate_rps.to_string(),
        "range_noise_std_m" => sim.range_noise_std_m.to_string(),
        "dropout_prob" => sim.dropout_prob.to_string(),
        "lidar_max_range_m" => sim.lidar_max_range_m.to_string(),
        "camera_range_m" => sim.camera_range_m.to_string(),
        "camera_fov_deg" => format!("{:.1}", sim.camera_fov_rad.to_degrees()),
        "detect_min_visible_fraction" => sim.detect_min_visible_fraction.to_string(),
        "robot_radius_m" => sim.robot_radius_m.to_string(),
        _ => return None,
    })
}

fn set(cfg: &mut Config, name: &str, v: &str) -> Result<(), String> {
    match name {
        "w_dist_per_m" => cfg.w_dist_per_m = weight(name, v)?,
        "w_unknown_per_cell" => cfg.w_unknown_per_cell = weight(name, v)?,
        "w_surface_per_ray" => cfg.w_surface_per_ray = weight(name, v)?,
        "w_frontier_per_cell" => cfg.w_frontier_per_cell = weight(name, v)?,
        "w_nonmap_per_point" => cfg.w_nonmap_per_point = weight(name, v)?,
        "switch_margin" => cfg.switch_margin = weight(name, v)?,
        "replan_interval_s" => cfg.replan_interval_us = micros(name, v)?,
        "goal_timeout_s" => cfg.goal_timeout_us = micros(name, v)?,
        "robot_radius_m" => cfg.robot_radius_m = meters(name, v)?,
        "camera_range_m" => cfg.camera_range_m = meters(name, v)?,
        "camera_fov_deg" => {
            let d = num(name, v)?;
            if !(1.0..=359.0).contains(&d) {
                return Err(format!("`{name}`: expected degrees in [1, 359], got {d}"));
            }
            cfg.camera_fov = BinaryAngle::from_radians(d.to_radians()).ok_or("bad angle")?;
        }
        "min_frontier_cells" => cfg.min_frontier_cells = v.parse().map_err(|_| format!("`{name}`: `{v}` is not a cell count"))?,
        "unseen_unknown_eighths" => {
            cfg.unseen_unknown_eighths =
                v.parse().ok().filter(|e| *e <= 8).ok_or_else(|| format!("`{name}`: expected 0 to 8, got `{v}`"))?
        }
        "nonmap_block_cap" => cfg.nonmap_block_cap = v.parse().map_err(|_| format!("`{name}`: `{v}` is not a count (0-255)"))?,
        "nonmap_view_cap" => cfg.nonmap_view_cap = v.parse().map_err(|_| format!("`{name}`: `{v}` is not a count (0-65535)"))?,
        "look_around_here" => cfg.look_around_here = v.parse().map_err(|_| format!("`{name}`: expected true or false"))?,
        "gaze" => cfg.gaze = v.parse().map_err(|_| format!("`{name}`: expected true or false"))?,
        "scan_matching" => cfg.scan_matching = v.parse().map_err(|_| format!("`{name}`: expected true or false"))?,
        "gaze_min_gain" => cfg.gaze_min_gain = weight(name, v)?,
        "nonmap_viewpoints" => cfg.nonmap_viewpoints = v.parse().map_err(|_| format!("`{name}`: expected true or false"))?,
        "nonmap_standoff_m" => cfg.nonmap_standoff_m = meters(name, v)?,
        "nonmap_pool_radius_m" => cfg.nonmap_pool_radius_m = meters(name, v)?,
        "nonmap_wall_clearance_m" => cfg.nonmap_wall_clearance_m = meters(name, v)?,
        "nonmap_drop_vacated" => cfg.nonmap_drop_vacated = v.parse().map_err(|_| format!("`{name}`: expected true or false"))?,
        "viewpoint_snap_radius_m" => cfg.viewpoint_snap_radius_m = meters(name, v)?,
        _ => {
            let known: Vec<&str> = NAMES.iter().map(|n| n.0).collect();
            return Err(format!("unknown parameter `{name}`; known: {}", known.join(", ")));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn applies_known_and_rejects_bad() {
        let mut c = Config::DEFAULT;
        apply(&mut c, "w_dist_per_m=2.5").unwrap();
        assert_eq!(c.w_dist_per_m, Weight::from_num(2.5));
        apply(&mut c, "camera_fov_deg = 60").unwrap();
        assert!((c.camera_fov.to_radians() - 60f64.to_radians()).abs() < 1e-6);
        apply(&mut c, "nonmap_viewpoints=false").unwrap();
        assert!(!c.nonmap_viewpoints);
        for bad in ["w_dist_per_m", "w_dist_per_m=abc", "w_dist_per_m=NaN", "robot_radius_m=-1", "nope=1", "camera_fov_deg=0"] {
            assert!(apply(&mut c, bad).is_err(), "{bad}");
        }
        for (name, _) in NAMES {
            let value = match *name {
                "nonmap_viewpoints" | "look_around_here" | "gaze" | "nonmap_drop_vacated" | "scan_matching" => "true",
                "min_frontier_cells" | "nonmap_block_cap" | "nonmap_view_cap" | "unseen_unknown_eighths" => "5",
                "camera_fov_deg" => "90",
                _ => "1",
            };
            apply(&mut c, &format!("{name}={value}")).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }

    #[test]
    fn every_setting_reads_back_what_was_set_and_defaults_round_trip() {
        for (name, _) in NAMES {
            let d = get(&Config::DEFAULT, name).unwrap_or_else(|| panic!("{name} has no value"));
            // Setting a parameter to its printed default changes nothing.
            let mut c = Config::DEFAULT;
            apply(&mut c, &format!("{name}={d}")).unwrap_or_else(|e| panic!("{name}={d}: {e}"));
            assert_eq!(get(&c, name), Some(d.clone()), "{name}");
        }
        let sim = crate::robot_model::default_sim();
        for (name, _) in SIM_NAMES {
            let d = get_sim(&sim, name).unwrap_or_else(|| panic!("{name} has no value"));
            let (mut s, mut c) = (sim.clone(), Config::DEFAULT);
            apply_sim(&mut s, &mut c, &format!("{name}={d}")).unwrap_or_else(|e| panic!("{name}={d}: {e}"));
            assert_eq!(get_sim(&s, name), Some(d.clone()), "{name}");
        }
        assert_eq!(get(&Config::DEFAULT, "nope"), None);
        assert_eq!(get_sim(&sim, "nope"), None);
    }

    #[test]
    fn values_the_core_cannot_work_with_are_refused_with_their_range() {
        // The audit's values: each overflowed or hung the planner or the non-map store, or (a
        // camera seeing nothing, a robot 6 m wide) searched for nothing.
        let mut c = Config::DEFAULT;
        for (bad, range) in [
            ("viewpoint_snap_radius_m=3000", "[0, 5] m"),
            ("viewpoint_snap_radius_m=500", "[0, 5] m"),
            ("viewpoint_snap_radius_m=350", "[0, 5] m"),
            ("robot_radius_m=5000", "[0, 1.5] m"),
            ("robot_radius_m=3", "[0, 1.5] m"),
            ("nonmap_wall_clearance_m=500", "[0, 2] m"),
            ("nonmap_wall_clearance_m=32767", "[0, 2] m"),
            ("nonmap_wall_clearance_m=300", "[0, 2] m"),
            ("camera_range_m=0", "(0, 51.2] m"),
            ("nonmap_pool_radius_m=0", "[0.01, 2] m"),
            ("nonmap_standoff_m=52", "[0, 51.2] m"),
        ] {
            let e = apply(&mut c, bad).unwrap_err();
            let (name, value) = bad.split_once('=').unwrap();
            assert_eq!(e, format!("`{name}`: expected a value in {range}, got {value}"));
        }
        assert_eq!(c, Config::DEFAULT, "a refused value changes nothing");
        // The ends of the ranges, and every value the docs use, are fine.
        for good in [
            "viewpoint_snap_radius_m=5",
            "viewpoint_snap_radius_m=1.5",
            "robot_radius_m=1.5",
            "robot_radius_m=0",
            "nonmap_wall_clearance_m=2",
            "nonmap_wall_clearance_m=0.25",
            "camera_range_m=51.2",
            "camera_range_m=5",
            "nonmap_pool_radius_m=0.01",
            "nonmap_standoff_m=51.2",
        ] {
            apply(&mut c, good).unwrap_or_else(|e| panic!("{good}: {e}"));
        }
        // `--sim` leaves the controller's model in range too: its largest body (1 m) is a
        // clearance of 1.1 m.
        let (mut sim, mut c) = (SimConfig::default(), Config::DEFAULT);
        apply_sim(&mut sim, &mut c, "robot_radius_m=1").unwrap();
        assert_eq!(c.validate(), Ok(()));
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
        for (name, _) in SIM_NAMES {
            let value = match *name {
                "camera_fov_deg" | "lidar_max_range_m" | "white_range_m" => "45",
                "lidar" => "hokuyo-utm30lx",
                _ => "0.5",
            };
            apply_sim(&mut sim, &mut c, &format!("{name}={value}")).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}
