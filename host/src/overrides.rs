//! `--set name=value`: override controller parameters from the command line, in user units
//! (metres, degrees, seconds, utility weights as decimals).

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
    ("nonmap_viewpoints", "true/false: viewpoints aimed at non-map clusters (lives)"),
    ("nonmap_standoff_m", "distance of a non-map viewpoint from its cluster, metres"),
    ("nonmap_pool_radius_m", "pooling radius of non-map points, metres"),
    ("nonmap_wall_clearance_m", "non-map points nearer a wall point are dropped, metres (0: the rule is off)"),
    ("nonmap_drop_vacated", "true/false: drop non-map points whose place the LiDAR has since seen empty"),
    ("viewpoint_snap_radius_m", "how far from a frontier's anchor its viewpoint may stand, metres"),
];

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

/// Applies one `name=value` to `cfg`.
pub fn apply(cfg: &mut Config, assignment: &str) -> Result<(), String> {
    let (name, v) = assignment.split_once('=').ok_or_else(|| format!("`--set {assignment}`: expected name=value"))?;
    let (name, v) = (name.trim(), v.trim());
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
                "nonmap_viewpoints" | "look_around_here" | "gaze" | "nonmap_drop_vacated" => "true",
                "min_frontier_cells" | "nonmap_block_cap" | "nonmap_view_cap" | "unseen_unknown_eighths" => "5",
                "camera_fov_deg" => "90",
                _ => "1",
            };
            apply(&mut c, &format!("{name}={value}")).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}
