//! `--set name=value`: override controller parameters from the command line, in user units
//! (metres, degrees, seconds, utility weights as decimals). `--sim name=value`: the simulated
//! robot and its sensors ([`apply_sim`]). Both check the controller's configuration afterwards
//! with the core's own [`Config::validate`], so a value the core cannot work with (a 3 km
//! viewpoint snap radius, a camera that sees nothing) is refused here, naming its range, instead of
//! stopping the search.
//!
//! The names, units, parsing and listing come from the core's parameter table
//! ([`firmware::config::PARAMS`]: the rows with a `--set` name) and the simulator's
//! ([`SIM_PARAMS`]); `lives params` prints both ([`listing`]).

use firmware::config::{ParamInfo, Unit, Weight, PARAMS};
use firmware::{BinaryAngle, Config};
use fixed_point::Meters;

pub mod listing;
mod sim;

pub use listing::{params_markdown, run_params, ParamsArgs};
pub use sim::{apply_sim, get_sim, Scale, SimParam, SimValue, SIM_PARAMS};

/// `N` finite numbers separated by commas (`X,Y`, `X,Y,YAW`: a command line's point or pose),
/// white space around each allowed; `None` for anything else.
///
/// ```
/// assert_eq!(host::overrides::finite_numbers::<2>(" -20, 25.6"), Some([-20.0, 25.6]));
/// assert_eq!(host::overrides::finite_numbers::<2>("1,2,3"), None);
/// assert_eq!(host::overrides::finite_numbers::<3>("1,nan,0"), None);
/// ```
pub fn finite_numbers<const N: usize>(text: &str) -> Option<[f64; N]> {
    let v: Vec<f64> = text.split(',').map(|t| t.trim().parse::<f64>().ok().filter(|v| v.is_finite())).collect::<Option<_>>()?;
    v.try_into().ok()
}

/// The parameters `--set` accepts, by their `--set` names, in the table's order.
pub fn settable() -> impl Iterator<Item = (&'static str, &'static ParamInfo)> {
    PARAMS.iter().filter_map(|p| Some((p.set_name?, p)))
}

/// The parameter `--set` knows as `name`.
fn param(name: &str) -> Option<&'static ParamInfo> {
    settable().find(|(n, _)| *n == name).map(|(_, p)| p)
}

/// `cfg` after `name=v` was applied to `before`: kept if the core can work with it, else put
/// back and refused naming the setting and the range the core allows (`field` is the
/// configuration's field that `name` sets).
fn validated(cfg: &mut Config, before: Config, field: &str, name: &str, v: &str) -> Result<(), String> {
    cfg.validate().map_err(|e| {
        *cfg = before;
        if e.field == field {
            // A value inside the range the fixed point cannot hold (1e-6 m is 0 in Q16.16) says so.
            let tiny = v.trim().parse::<f64>().is_ok_and(|x| x != 0.0 && x.abs() < 1.0 / 65536.0);
            let why = if tiny { " (it rounds to 0: the controller's numbers are multiples of 1/65536)" } else { "" };
            format!("`{name}`: expected a value in {}, got {v}{why}", e.allowed)
        } else {
            format!("`{name}={v}`: the controller's {e}")
        }
    })
}

fn num(name: &str, v: &str) -> Result<f64, String> {
    let x: f64 = v.parse().map_err(|_| format!("`{name}`: `{v}` is not a number"))?;
    if !x.is_finite() {
        return Err(format!("`{name}`: `{v}` is not finite"));
    }
    Ok(x)
}

/// `x` metres as [`Meters`].
fn meters(name: &str, x: f64) -> Result<Meters, String> {
    if x < 0.0 {
        return Err(format!("`{name}`: must not be negative, got {x}"));
    }
    fixed_point::meters_from_f64(x).ok_or_else(|| format!("`{name}`: {x} m is out of range"))
}

/// What `--set` takes for a weight, beyond [`Config::validate`]'s range.
pub const SET_WEIGHTS: &str = "[0, 30000)";
/// What `--set` takes for a time, in seconds.
pub const SET_SECONDS: &str = "[0, 1e6)";
/// What `--set` takes for an angle, in degrees.
pub const SET_DEGREES: &str = "[1, 359]";

/// `v`, written in `p`'s unit, as the number [`ParamInfo::set`] takes.
fn parse(p: &ParamInfo, name: &str, v: &str) -> Result<i64, String> {
    Ok(match p.unit {
        Unit::Metres => meters(name, num(name, v)?)?.to_bits().into(),
        Unit::Weight => {
            let x = num(name, v)?;
            if !(0.0..30_000.0).contains(&x) {
                return Err(format!("`{name}`: expected a weight in {SET_WEIGHTS}, got {x}"));
            }
            Weight::from_num(x).to_bits().into()
        }
        Unit::Seconds => {
            let x = num(name, v)?;
            if !(0.0..1e6).contains(&x) {
                return Err(format!("`{name}`: expected seconds in {SET_SECONDS}, got {x}"));
            }
            (x * 1e6).round() as i64
        }
        Unit::Degrees => {
            let d = num(name, v)?;
            if !(1.0..=359.0).contains(&d) {
                return Err(format!("`{name}`: expected degrees in {SET_DEGREES}, got {d}"));
            }
            BinaryAngle::from_radians(d.to_radians()).ok_or("bad angle")?.0.into()
        }
        Unit::Count => v.parse::<u64>().ok().and_then(|n| i64::try_from(n).ok()).ok_or_else(|| not_a_count(p, name, v))?,
        Unit::Flag => v.parse::<bool>().map_err(|_| format!("`{name}`: expected true or false"))?.into(),
        Unit::Planner | Unit::Budgets => return Err(format!("`{name}` is not set with `--set`")),
    })
}

fn not_a_count(p: &ParamInfo, name: &str, v: &str) -> String {
    format!("`{name}`: `{v}` is not a count ({}-{})", p.raw_range.0, p.raw_range.1)
}

/// Applies one `name=value` to `cfg`. A value the core cannot work with ([`Config::validate`]) is
/// refused with its range, and `cfg` stays as it was.
pub fn apply(cfg: &mut Config, assignment: &str) -> Result<(), String> {
    let (name, v) = assignment.split_once('=').ok_or_else(|| format!("`--set {assignment}`: expected name=value"))?;
    let (name, v) = (name.trim(), v.trim());
    let p = param(name).ok_or_else(|| {
        let known: Vec<&str> = settable().map(|(n, _)| n).collect();
        format!("unknown parameter `{name}`; known: {}", known.join(", "))
    })?;
    let before = *cfg;
    if !(p.set)(cfg, parse(p, name, v)?) {
        return Err(not_a_count(p, name, v));
    }
    validated(cfg, before, p.field, name, v)
}

/// The value of `--set` parameter `name` in `cfg`, in the units `--set` takes (`None` for an
/// unknown name). `lives params` prints the defaults with it.
pub fn get(cfg: &Config, name: &str) -> Option<String> {
    Some(value(cfg, param(name)?))
}

/// The value of parameter `p` in `cfg`, in the units people write it in.
pub fn value(cfg: &Config, p: &ParamInfo) -> String {
    let Some(raw) = (p.get)(cfg) else {
        let b = cfg.budgets;
        return format!("{}, {}, {}, {}, {}", b.lidar_cells, b.visual_cells, b.nonmap_ops, b.plan_ops, b.classify_macs);
    };
    let bits = raw as i32;
    match p.unit {
        // Q16.16 metres to the millimetre (0.35 is stored as 0.350006...).
        Unit::Metres => format!("{}", (Meters::from_bits(bits).to_num::<f64>() * 1000.0).round() / 1000.0),
        Unit::Weight => Weight::from_bits(bits).to_string(),
        Unit::Seconds => format!("{}", raw as f64 / 1e6),
        Unit::Degrees => format!("{:.1}", BinaryAngle(bits).to_radians().to_degrees()),
        Unit::Planner => format!("{:?}", firmware::PlannerKind::ALL[raw as usize]).to_lowercase(),
        Unit::Count | Unit::Budgets => raw.to_string(),
        Unit::Flag => (raw != 0).to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::SimConfig;

    #[test]
    fn every_parameter_of_the_table_is_set_by_its_name_reads_back_and_is_in_docs_params_md() {
        let docs = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/params.md")).unwrap();
        for p in PARAMS {
            assert!(docs.contains(&format!("| `{}` |", p.field)), "{} is listed", p.field);
        }
        for p in SIM_PARAMS {
            assert!(docs.contains(&format!("| `{}` |", p.name)), "{} is listed", p.name);
        }
        for (name, p) in settable() {
            assert!(docs.contains(&format!("| `{name}` |")), "{name} is listed");
            // A value other than the default, written in the parameter's unit, is taken...
            let default = get(&Config::DEFAULT, name).unwrap();
            let (c, printed) = ["1", "2", "0.5", "5", "45", "true", "false", "0"]
                .into_iter()
                .find_map(|v| {
                    let mut c = Config::DEFAULT;
                    apply(&mut c, &format!("{name}={v}")).ok()?;
                    Some((c, get(&c, name).unwrap())).filter(|(_, printed)| *printed != default)
                })
                .unwrap_or_else(|| panic!("{name}: no value other than the default is taken"));
            // ... changes that field and no other, and reads back as it was set.
            let mut back = c;
            assert!((p.set)(&mut back, (p.get)(&Config::DEFAULT).unwrap()));
            assert_eq!(back, Config::DEFAULT, "{name} sets {} alone", p.field);
            let mut again = Config::DEFAULT;
            apply(&mut again, &format!("{name}={printed}")).unwrap();
            assert_eq!(get(&again, name), Some(printed), "{name}");
        }
    }

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
        for (name, _) in settable() {
            let value = match name {
                "nonmap_viewpoints" | "look_around_here" | "gaze" | "nonmap_drop_vacated" | "scan_matching" | "scan_match_field" => "true",
                "min_frontier_cells" | "nonmap_block_cap" | "nonmap_view_cap" | "unseen_unknown_eighths" => "5",
                "camera_fov_deg" => "90",
                _ => "1",
            };
            apply(&mut c, &format!("{name}={value}")).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }

    #[test]
    fn every_setting_reads_back_what_was_set_and_defaults_round_trip() {
        for (name, _) in settable() {
            let d = get(&Config::DEFAULT, name).unwrap_or_else(|| panic!("{name} has no value"));
            // Setting a parameter to its printed default changes nothing.
            let mut c = Config::DEFAULT;
            apply(&mut c, &format!("{name}={d}")).unwrap_or_else(|e| panic!("{name}={d}: {e}"));
            assert_eq!(get(&c, name), Some(d.clone()), "{name}");
        }
        let sim = crate::robot_model::default_sim();
        for name in SIM_PARAMS.iter().map(|p| p.name) {
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
}
