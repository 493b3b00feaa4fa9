//! `lives sim-serve`: `lives search`'s simulator with the brain outside, over JSON lines — one
//! tick line out on stdout, one answer line back on stdin (docs/ros2.md; the simulated robot
//! `clients/python/ros2_sim_robot.py` relays them to and from `lives ros2`).
//!
//! The source is exactly `lives search`'s ([`host::search::SearchSpec::sim_source`]), so a run
//! whose answers come from a controller configured as `lives search` configures its own (the
//! hello line's `lives_ros2_args`) is the same run: its closing `{"result": …}` line is what
//! `lives search --json` prints (but `classifier`: the controller's labels do not travel back).

use super::common::{load_spec, RobotArgs, RunArgs};
use firmware::scan::{RANGE_INVALID, RANGE_NO_RETURN};
use firmware::{BinaryAngle, Config, Meters};
use host::run::{controller_config, drive, Act, Answer, Brain, End, Ended, Frame, TICK_US};
use host::search::{SearchResult, SearchSpec};
use serde_json::{json, Value};
use std::io::{BufRead, Write};
use std::process::ExitCode;

/// Serve `lives search`'s simulator over stdin/stdout JSON lines to an outside brain (`lives
/// ros2` through `clients/python/ros2_sim_robot.py`): a hello line, then one line per tick, each
/// answered by one line on stdin; `{"result": …}` at the end, as `lives search --json` prints it.
#[derive(clap::Args)]
pub struct SimServeArgs {
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    robot: RobotArgs,
}

pub fn run(args: SimServeArgs) -> Result<ExitCode, String> {
    let mut spec = load_spec(&args.run)?;
    args.robot.configure(&mut spec)?;
    // As `lives search` without `--model`: `lives` runs the committed geometric classifier.
    spec.model = host::io::model_file::model_option(None, false)?;
    if spec.sim_labels() {
        return Err(format!(
            "`{}` runs on the simulator's ground-truth labels, which cannot travel over ROS (a LaserScan has no per-beam labels); \
             serve `lives` (the classifier labels the scans) or a planner without labels",
            spec.planner
        ));
    }
    let (mut ros2_args, origin) = lives_ros2_args(&spec)?;
    if let Some(map) = &args.run.map {
        // LIVE's known map: `lives ros2` loads the same file, placed at the same origin.
        ros2_args.extend(["--map".to_string(), map.display().to_string()]);
    }
    let hello = json!({"hello": {
        "world": spec.world_name, "scenario": spec.scenario_label(), "seed": spec.seed, "planner": spec.planner.to_string(),
        "period_us": TICK_US, "origin": origin, "range_invalid": RANGE_INVALID, "range_no_return": RANGE_NO_RETURN,
        "lives_ros2_args": ros2_args,
    }});
    let mut brain = StdioBrain { input: std::io::stdin().lock(), output: std::io::stdout().lock(), ticks: 0, goals: 0, blacklisted: 0 };
    brain.line(&hello)?;
    let mut source = spec.sim_source();
    let ended = match drive(&mut source, &mut brain, &mut []) {
        Ok(ended) => ended,
        Err(Stdio::Closed) => Ended { end: End::Stopped, ticks: brain.ticks },
        Err(Stdio::Bad(e)) => return Err(e),
    };
    let result = SearchResult::simulated(&spec, &source, ended, brain.goals, brain.blacklisted, spec.classifier(), None);
    // As `lives search --json` prints it (its fields in their order), inside `{"result": …}`.
    let result = serde_json::to_string(&result).map_err(|e| e.to_string())?;
    brain.line(format_args!("{{\"result\":{result}}}"))?;
    Ok(ExitCode::SUCCESS)
}

/// The arguments that make `lives ros2`'s controller the one `lives search` runs for `spec`, and
/// the grid's origin: `--origin`, `--planner`, and a `--set` for every parameter that differs
/// from `lives ros2`'s own defaults (the core's, without scan matching).
pub fn lives_ros2_args(spec: &SearchSpec) -> Result<(Vec<String>, [f64; 2]), String> {
    let kind = spec.planner.kind();
    let cfg = controller_config(&spec.controller, &spec.world, kind);
    let base = host::link::robot::REAL_ROBOT_CONFIG.with_planner(kind);
    let origin = [metres(cfg.origin_x_m), metres(cfg.origin_y_m)];
    let mut args = vec!["--origin".to_string(), format!("{},{}", origin[0], origin[1]), "--planner".into(), spec.planner.to_string()];
    let mut check = Config { origin_x_m: cfg.origin_x_m, origin_y_m: cfg.origin_y_m, ..base };
    for (name, p) in host::overrides::settable().filter(|(_, p)| (p.get)(&cfg) != (p.get)(&base)) {
        let set = format!("{name}={}", host::overrides::value(&cfg, p));
        host::overrides::apply(&mut check, &set)?;
        args.extend(["--set".to_string(), set]);
    }
    if check != cfg {
        return Err(format!(
            "the controller's configuration cannot be written as `lives ros2` arguments ({args:?}):\n{cfg:?}\nvs\n{check:?}"
        ));
    }
    Ok((args, origin))
}

/// `m` to the millimetre (the grid's origin is on the 0.1 m lattice), or exactly if that is not
/// the same fixed-point value.
fn metres(m: Meters) -> f64 {
    let mm = (m.to_num::<f64>() * 1000.0).round() / 1000.0;
    if fixed_point::meters_from_f64(mm) == Some(m) {
        mm
    } else {
        m.to_num()
    }
}

/// Why the outside brain cannot go on.
enum Stdio {
    /// stdin closed: the run ends there (stopped).
    Closed,
    /// A line that is not an answer, or stdout failed.
    Bad(String),
}

/// The brain at the other end of stdin/stdout.
struct StdioBrain<R, W> {
    input: R,
    output: W,
    /// Tick lines answered.
    ticks: u32,
    /// The controller's goal and blacklist counts, as its answers last gave them.
    goals: u32,
    blacklisted: u32,
}

impl<R: BufRead, W: Write> StdioBrain<R, W> {
    fn line(&mut self, v: impl std::fmt::Display) -> Result<(), String> {
        writeln!(self.output, "{v}").and_then(|()| self.output.flush()).map_err(|e| format!("stdout: {e}"))
    }
}

impl<R: BufRead, W: Write> Brain for StdioBrain<R, W> {
    type Error = Stdio;

    fn think(&mut self, frame: &Frame) -> Result<Answer, Stdio> {
        self.line(tick_line(self.ticks, frame)).map_err(Stdio::Bad)?;
        let mut text = String::new();
        match self.input.read_line(&mut text) {
            Ok(0) => return Err(Stdio::Closed),
            Ok(_) => {}
            Err(e) => return Err(Stdio::Bad(format!("stdin: {e}"))),
        }
        let answer = parse_answer(text.trim_end(), &mut self.goals, &mut self.blacklisted)
            .map_err(|e| Stdio::Bad(format!("answer to tick {}: {e}: {}", self.ticks, text.trim_end())))?;
        self.ticks += 1;
        Ok(answer)
    }
}

/// A tick's line (see the module docs).
fn tick_line(tick: u32, frame: &Frame) -> Value {
    let pose = frame.pose.map(|p| {
        let (x, y, yaw) = p.to_f64();
        ([x, y, yaw], [(yaw / 2.0).sin(), (yaw / 2.0).cos()])
    });
    let s = &frame.scan;
    json!({
        "tick": tick, "t_us": frame.t_us, "pose": pose.map(|p| p.0), "quat": pose.map(|p| p.1),
        "scan": {
            "angle_min": s.angle_min.to_radians(), "angle_increment": s.angle_increment.to_radians(),
            "range_min": s.range_min_mm as f64 / 1000.0, "range_max": s.range_max_mm as f64 / 1000.0, "ranges_mm": s.ranges_mm,
        },
        "detection": frame.detection, "blocked": frame.base_blocked,
    })
}

/// An angle snapped to the core's binary-angle lattice (so that a quaternion round trip is exact).
fn snapped(v: &Value, what: &str) -> Result<Option<f64>, String> {
    if v.is_null() {
        return Ok(None);
    }
    let rad = v.as_f64().ok_or_else(|| format!("{what} must be radians or null, got {v}"))?;
    Ok(Some(BinaryAngle::from_radians(rad).ok_or_else(|| format!("{what} {rad} is not an angle"))?.to_radians()))
}

/// One act: `{"path":[[x,y],…],"yaw":RAD|null}`, `{"stop":true}` or `{"gaze":RAD|null}`.
fn parse_act(v: &Value) -> Result<Act, String> {
    let unknown =
        || format!("unknown act {v}: expected {{\"path\":[[x,y],…],\"yaw\":RAD|null}}, {{\"stop\":true}} or {{\"gaze\":RAD|null}}");
    let o = v.as_object().ok_or_else(unknown)?;
    let keys: Vec<&str> = o.keys().map(String::as_str).collect();
    match keys[..] {
        ["stop"] if o["stop"] == Value::Bool(true) => Ok(Act::Stop),
        ["gaze"] => Ok(Act::Gaze(snapped(&o["gaze"], "gaze")?)),
        ["path"] | ["path", "yaw"] => {
            let points: Vec<[f64; 2]> = serde_json::from_value(o["path"].clone()).map_err(|e| format!("path: {e}"))?;
            Ok(Act::Path(points, snapped(o.get("yaw").unwrap_or(&Value::Null), "yaw")?))
        }
        _ => Err(unknown()),
    }
}

/// An answer line; `goals` and `blacklisted` (the controller's counts, optional) are updated
/// when it gives them.
fn parse_answer(line: &str, goals: &mut u32, blacklisted: &mut u32) -> Result<Answer, String> {
    let v: Value = serde_json::from_str(line).map_err(|e| format!("not JSON ({e})"))?;
    let o = v.as_object().ok_or("expected an object {\"acts\":[…],\"end\":…}")?;
    if let Some(k) = o.keys().find(|k| !["acts", "end", "goals", "blacklisted"].contains(&k.as_str())) {
        return Err(format!("unknown field `{k}`"));
    }
    let acts = o.get("acts").and_then(Value::as_array).ok_or("`acts` must be a list")?;
    let acts = acts.iter().map(parse_act).collect::<Result<Vec<_>, _>>()?;
    let end = match o.get("end").unwrap_or(&Value::Null) {
        Value::Null => None,
        e => Some(match e.as_str() {
            Some("found") => End::Found,
            Some("exhausted") => End::Exhausted,
            Some("stopped") => End::Stopped,
            _ => return Err(format!("`end` must be null, \"found\", \"exhausted\" or \"stopped\", got {e}")),
        }),
    };
    for (name, count) in [("goals", goals), ("blacklisted", blacklisted)] {
        if let Some(n) = o.get(name) {
            *count = n.as_u64().and_then(|n| u32::try_from(n).ok()).ok_or_else(|| format!("`{name}` must be a count, got {n}"))?;
        }
    }
    Ok(Answer { command: None, end, acts })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn answers_parse_and_bad_ones_are_named() {
        let (mut g, mut b) = (0, 0);
        let a = parse_answer(
            r#"{"acts":[{"path":[[1,2],[3.5,4]],"yaw":0.5},{"stop":true},{"gaze":null}],"end":null,"goals":3}"#,
            &mut g,
            &mut b,
        )
        .unwrap();
        let yaw = BinaryAngle::from_radians(0.5).unwrap().to_radians();
        assert_eq!(a.acts, vec![Act::Path(vec![[1.0, 2.0], [3.5, 4.0]], Some(yaw)), Act::Stop, Act::Gaze(None)]);
        assert_eq!((a.end, g, b), (None, 3, 0));
        assert_eq!(parse_answer(r#"{"acts":[],"end":"found"}"#, &mut g, &mut b).unwrap().end, Some(End::Found));
        for (bad, says) in [
            ("{", "not JSON"),
            ("[]", "expected an object"),
            (r#"{"acts":[{"jump":1}],"end":null}"#, "unknown act"),
            (r#"{"acts":[{"stop":false}],"end":null}"#, "unknown act"),
            (r#"{"acts":[{"gaze":"left"}],"end":null}"#, "gaze must be radians"),
            (r#"{"acts":[],"end":"lost"}"#, "`end` must be"),
            (r#"{"acts":[],"end":null,"why":1}"#, "unknown field `why`"),
            (r#"{"end":null}"#, "`acts` must be a list"),
            (r#"{"acts":[{"path":[[1]]}],"end":null}"#, "path:"),
        ] {
            let e = parse_answer(bad, &mut g, &mut b).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn the_ros2_arguments_give_lives_ros2_the_controller_lives_search_runs() {
        use host::search::PlannerChoice;
        use host::sim::{Scenario, World};
        for world in ["apartment", "office"] {
            for planner in PlannerChoice::ALL {
                let w = World::builtin(world, Scenario::Easy).unwrap();
                let mut spec = SearchSpec::new(world, w, Scenario::Easy, planner, 1);
                host::search::Robot::Calibrated.apply(&mut spec).unwrap();
                let (args, origin) = lives_ros2_args(&spec).unwrap();
                assert_eq!(args[0..2], ["--origin".to_string(), format!("{},{}", origin[0], origin[1])]);
                assert!(args.iter().any(|a| a == "scan_matching=true"), "{args:?}");
            }
        }
    }
}
