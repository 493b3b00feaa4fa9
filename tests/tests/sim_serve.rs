//! `lives sim-serve`: `lives search`'s simulator with the brain at the other end of stdin/stdout
//! (issue 31; the simulated robot `clients/python/ros2_sim_robot.py` relays it over ROS 2).

mod common;
use common::{lives, root};
use firmware::{BinaryAngle, Config, Controller, Pose2};
use host::run::range::EncodedScan;
use host::run::{Act, Brain, Frame, InProcess};
use host::search::PlannerChoice;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};

/// `world` (an example world file) with its time limit set to `limit_s`, in a file of its own.
fn short_world(world: &str, limit_s: f64, tag: &str) -> PathBuf {
    let text = std::fs::read_to_string(root().join("examples/worlds").join(format!("{world}.toml"))).unwrap();
    let text: String = text
        .lines()
        .map(|l| if l.starts_with("time_limit_s") { format!("time_limit_s = {limit_s}") } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n");
    let path = std::env::temp_dir().join(format!("lives-sim-serve-{}-{tag}.toml", std::process::id()));
    std::fs::write(&path, text).unwrap();
    path
}

fn serve(args: &[&str]) -> Child {
    Command::new(lives())
        .arg("sim-serve")
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lives sim-serve starts")
}

fn json_line(r: &mut impl BufRead) -> Value {
    let mut line = String::new();
    r.read_line(&mut line).unwrap();
    serde_json::from_str(&line).unwrap_or_else(|e| panic!("{e}: {line:?}"))
}

#[test]
fn a_brain_that_always_stops_runs_to_the_time_limit_and_a_bad_answer_is_refused() {
    let world = short_world("apartment-easy-beside-start", 2.0, "stop");
    let w = world.to_str().unwrap();
    let mut child = serve(&["--world", w, "--planner", "nearest", "--seed", "3"]);
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut stdin = child.stdin.take().unwrap();
    let hello = json_line(&mut out)["hello"].clone();
    assert_eq!((hello["planner"].as_str(), hello["seed"].as_u64(), hello["period_us"].as_u64()), (Some("nearest"), Some(3), Some(200_000)));
    assert_eq!((hello["range_invalid"].as_u64(), hello["range_no_return"].as_u64()), (Some(0), Some(65_535)));
    let args: Vec<&str> = hello["lives_ros2_args"].as_array().unwrap().iter().map(|a| a.as_str().unwrap()).collect();
    assert_eq!(args[..4], ["--origin", &format!("{},{}", hello["origin"][0], hello["origin"][1]), "--planner", "nearest"]);
    let mut ticks = 0;
    let result = loop {
        let v = json_line(&mut out);
        if let Some(r) = v.get("result") {
            break r.clone();
        }
        assert_eq!(v["tick"], ticks);
        assert_eq!(v["t_us"], ticks * 200_000);
        let (pose, quat) = (&v["pose"], &v["quat"]);
        let yaw = pose[2].as_f64().unwrap();
        assert!(
            (quat[0].as_f64().unwrap() - (yaw / 2.0).sin()).abs() < 1e-12 && (quat[1].as_f64().unwrap() - (yaw / 2.0).cos()).abs() < 1e-12
        );
        assert!(v["scan"]["ranges_mm"].as_array().unwrap().len() > 100);
        writeln!(stdin, r#"{{"acts":[{{"stop":true}}],"end":null}}"#).unwrap();
        ticks += 1;
    };
    assert!(child.wait().unwrap().success());
    // Ten ticks of 200 ms, standing still, to the time limit.
    assert_eq!(
        (result["ticks"].as_u64(), result["time_s"].as_f64(), result["outcome"].as_str()),
        (Some(10), Some(2.0), Some("time-limit"))
    );
    assert_eq!((result["path_m"].as_f64(), result["goals"].as_u64(), result["found"].as_bool()), (Some(0.0), Some(0), Some(false)));
    assert_eq!(ticks, 10);

    // A malformed answer: exit 2 and a message that names the tick and the fault, no panic.
    for (bad, says) in [("{\"acts\":[{\"jump\":true}],\"end\":null}", "unknown act"), ("nonsense", "not JSON")] {
        let mut child = serve(&["--world", w, "--planner", "nearest"]);
        let mut out = BufReader::new(child.stdout.take().unwrap());
        json_line(&mut out);
        json_line(&mut out);
        writeln!(child.stdin.as_mut().unwrap(), "{bad}").unwrap();
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("answer to tick 0") && err.contains(says) && !err.contains("panicked"), "{err}");
    }
    // Ground-truth labels cannot travel over ROS.
    let o = serve(&["--world", w, "--planner", "lives-gt"]).wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("ground-truth labels"));
    std::fs::remove_file(world).ok();
}

/// The controller `lives ros2` builds from the hello line's `lives_ros2_args`.
fn ros2_controller(args: &[&str]) -> Box<Controller> {
    let planner: PlannerChoice = args[3].parse().unwrap();
    assert_eq!((args[0], args[2]), ("--origin", "--planner"));
    let mut cfg = Config { scan_matching: false, ..Config::DEFAULT }.with_planner(planner.kind());
    let (x, y) = args[1].split_once(',').unwrap();
    cfg.origin_x_m = fixed_point::meters_from_f64(x.parse().unwrap()).unwrap();
    cfg.origin_y_m = fixed_point::meters_from_f64(y.parse().unwrap()).unwrap();
    for pair in args[4..].chunks(2) {
        assert_eq!(pair[0], "--set");
        host::overrides::apply(&mut cfg, pair[1]).unwrap();
    }
    let mut ctrl = Box::new(Controller::new(cfg));
    if planner.uses_classifier() {
        ctrl.set_model(firmware::classifier::EMBEDDED_GEO_MODEL).unwrap();
    }
    ctrl
}

/// A tick line as the frame it came from, as a ROS 2 node receives it (ranges in metres, REP 117).
fn frame(v: &Value, hello: &Value) -> Frame {
    let s = &v["scan"];
    let f = |x: &Value| x.as_f64().unwrap();
    let limits = host::run::range::RangeLimits::new(f(&s["range_min"]), f(&s["range_max"]));
    let ranges = s["ranges_mm"].as_array().unwrap().iter().map(|r| match r.as_u64().unwrap() {
        r if r == hello["range_invalid"].as_u64().unwrap() => f64::NAN,
        r if r == hello["range_no_return"].as_u64().unwrap() => f64::INFINITY,
        // As float32, as a LaserScan carries it.
        r => (r as f32 / 1000.0) as f64,
    });
    let p = &v["pose"];
    Frame {
        t_us: v["t_us"].as_u64().unwrap(),
        pose: if p.is_null() { None } else { Pose2::from_f64(f(&p[0]), f(&p[1]), f(&p[2])) },
        base_pose: [0.0; 3],
        time_s: 0.0,
        // As float32, as a LaserScan carries them.
        scan: EncodedScan::new(f(&s["angle_min"]) as f32 as f64, f(&s["angle_increment"]) as f32 as f64, ranges, &limits).unwrap(),
        labels: false,
        detection: v["detection"].as_bool().unwrap(),
        base_blocked: v["blocked"].as_bool().unwrap(),
    }
}

/// A controller answering `lives sim-serve`'s lines, configured only from its hello line, runs the
/// search `lives search` runs: the same result (but the classifier's score, which stays with the
/// controller).
#[test]
fn a_controller_configured_from_the_hello_line_runs_the_search_lives_search_runs() {
    let world = short_world("apartment-easy-bedroom-start", 40.0, "same");
    let w = world.to_str().unwrap();
    for planner in ["nearest", "lives"] {
        let args = ["--world", w, "--planner", planner, "--seed", "1"];
        let mut child = serve(&args);
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut stdin = child.stdin.take().unwrap();
        let hello = json_line(&mut out)["hello"].clone();
        let ros2_args: Vec<&str> = hello["lives_ros2_args"].as_array().unwrap().iter().map(|a| a.as_str().unwrap()).collect();
        let mut brain = InProcess::new(ros2_controller(&ros2_args));
        let served = loop {
            let v = json_line(&mut out);
            if let Some(r) = v.get("result") {
                break r.clone();
            }
            let a = brain.think(&frame(&v, &hello)).unwrap();
            let acts: Vec<Value> = a
                .acts
                .iter()
                .map(|act| match act {
                    Act::Stop => json!({"stop": true}),
                    Act::Path(p, yaw) => json!({"path": p, "yaw": yaw}),
                    Act::Gaze(g) => json!({"gaze": g}),
                    Act::Wander => unreachable!("a search never wanders"),
                })
                .collect();
            let end = a.end.map(|e| format!("{e:?}").to_lowercase());
            let status = brain.outputs().unwrap().status;
            let line = json!({"acts": acts, "end": end, "goals": status.goals, "blacklisted": status.blacklisted});
            writeln!(stdin, "{line}").unwrap();
        };
        assert!(child.wait().unwrap().success());
        let o = Command::new(lives()).arg("search").arg("--json").args(args).output().unwrap();
        let mut searched: Value = serde_json::from_slice(&o.stdout).unwrap();
        if planner == "lives" {
            assert!(searched["classifier"].is_object() && served.get("classifier").is_none());
            searched.as_object_mut().unwrap().remove("classifier");
        }
        assert_eq!(served, searched, "{planner}");
        assert!(served["ticks"].as_u64().unwrap() > 100 && served["goals"].as_u64().unwrap() > 2, "{served}");
    }
    std::fs::remove_file(world).ok();
}

#[test]
fn binary_angles_survive_a_json_round_trip() {
    for b in [0, 1, 12_345, -77_777, i32::MAX / 3] {
        let a = BinaryAngle(b);
        let back: f64 = serde_json::from_str(&serde_json::to_string(&a.to_radians()).unwrap()).unwrap();
        assert_eq!(BinaryAngle::from_radians(back), Some(a));
    }
}
