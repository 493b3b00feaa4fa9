//! `lives ros2` on a ROS 2 graph (issue 31), against an independent DDS implementation: PyPI
//! `cyclonedds` (which `scripts/test.sh` installs in `target/py-mcap`, or `LIVES_PYTHON`),
//! on loopback only (`tests/ros2/netns.sh`: a private network namespace when allowed).
//!
//! * a bag played onto the graph one scan at a time (`clients/python/ros2_play_bag.py`) gives
//!   back, as `nav_msgs/OccupancyGrid`, the LiDAR map `lives replay` makes of the same bag;
//! * the simulated robot (`clients/python/ros2_sim_robot.py`: `lives sim-serve` relayed over DDS)
//!   finds the target with the goals `lives search` chooses, and bad input on the graph is
//!   rejected by name while the search goes on.

mod common;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

fn python() -> String {
    let py =
        std::env::var("LIVES_PYTHON").unwrap_or_else(|_| common::root().join("target/py-mcap/bin/python").to_string_lossy().into_owned());
    let ok = Command::new(&py).args(["-c", "import cyclonedds, mcap_ros2"]).status().is_ok_and(|s| s.success());
    assert!(
        ok,
        "`{py}` cannot import cyclonedds and mcap_ros2: run ./scripts/test.sh (it installs them), or set LIVES_PYTHON to a python \
         with `pip install cyclonedds==11.0.1 mcap mcap-ros2-support`"
    );
    py
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lives-ros2-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn q(p: &Path) -> String {
    format!("'{}'", p.display())
}

/// Runs `lives ros2 ARGS` in the background and `PEER` in the foreground in one loopback-only
/// network, on DDS domain `domain` (the tests run at once: without a network namespace of their
/// own, the domain keeps them apart); returns (lives' stdout, lives' stderr, the peer's stdout, the peer's exit code).
fn pair(dir: &Path, domain: u8, lives_args: &str, peer: &str) -> (String, String, String, i32) {
    let _guard = common::hang_guard("lives ros2 and its peer", Duration::from_secs(600));
    let (lo, le, po) = (dir.join("lives.out"), dir.join("lives.err"), dir.join("peer.out"));
    let script = format!(
        "export ROS_DOMAIN_ID={domain}; {} ros2 --localhost {lives_args} --json >{} 2>{} & pid=$!; {peer} >{}; rc=$?; \
         t=0; while kill -0 $pid 2>/dev/null && [ $t -lt 100 ]; do sleep 0.2; t=$((t+1)); done; kill $pid 2>/dev/null; wait $pid; exit $rc",
        q(common::lives()),
        q(&lo),
        q(&le),
        q(&po)
    );
    let st = Command::new(common::root().join("tests/ros2/netns.sh")).arg(&script).status().expect("netns.sh runs");
    let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
    (read(&lo), read(&le), read(&po), st.code().unwrap_or(-1))
}

/// The JSON document `text` is, or the last line of it that is one.
fn json_line(text: &str) -> Value {
    if let Ok(v) = serde_json::from_str::<Value>(text) {
        return v;
    }
    text.lines().rev().find_map(|l| serde_json::from_str::<Value>(l).ok()).unwrap_or_else(|| panic!("no JSON line in {text:?}"))
}

/// The first 400 scans of the Intel Research Lab log (`tests/data/carmen`), exported as a robot
/// records them (`lives export-bag`: `+inf` readings, odometry from the fourth scan on, the
/// laser mounted rotated), played onto the graph; the grid that comes back is `lives replay`'s
/// of the same bag, cell for cell in its counts; the three scans before the odometry are
/// rejected by name rather than drawn at a made-up origin; and when the odometry ends with a goal
/// out, the base is stopped with the reason on the status topic.
#[test]
fn a_bag_played_on_the_graph_gives_back_the_map_lives_replay_makes() {
    let py = python();
    let dir = scratch("bag");
    let log = dir.join("intel400.log");
    let text = {
        use std::io::Read as _;
        let mut s = String::new();
        flate2::read::GzDecoder::new(std::fs::File::open(common::root().join("tests/data/carmen/intel-corrected.log.gz")).unwrap())
            .read_to_string(&mut s)
            .unwrap();
        s
    };
    let mut kept = String::new();
    let mut scans = 0;
    for line in text.lines() {
        if line.starts_with("FLASER") || line.starts_with("ODOM") {
            kept.push_str(line);
            kept.push('\n');
            scans += line.starts_with("FLASER") as usize;
            if scans == 400 {
                break;
            }
        }
    }
    std::fs::write(&log, kept).unwrap();
    let bag = dir.join("intel400.mcap");
    let st = Command::new(common::lives()).arg("export-bag").arg(&log).arg(&bag).output().unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    let replay = Command::new(common::lives()).arg("replay").arg(&bag).arg("--json").output().unwrap();
    let replay = json_line(&String::from_utf8_lossy(&replay.stdout));
    let o = &replay["grid_origin"];
    let args = format!("--lockstep --continuous --max-idle 5 --origin={},{}", o[0], o[1]);
    // A 2 s dropout of every sensor after the 200th scan: the watchdog stops the base, and the
    // first answer after it sends the goal the controller still pursues again.
    let peer = format!("{py} {} {} --pause-after 200 --pause-s 2", q(&common::root().join("clients/python/ros2_play_bag.py")), q(&bag));
    let (lives_out, lives_err, peer_out, rc) = pair(&dir, 11, &args, &peer);
    let played = json_line(&peer_out);
    assert_eq!(rc, 0, "the player failed: {peer_out}\nlives: {lives_out}\n{lives_err}");
    assert_eq!(played["scans"], 400);
    assert_eq!(played["unanswered"], 0, "{played}");
    assert_eq!(played["rejected"], serde_json::json!({ "no-odometry-yet": 3 }), "{played}");
    let map = &played["maps"]["lidar_map"];
    assert_eq!(map["frame"], "odom");
    assert_eq!(map["resolution"], 0.1);
    assert_eq!((map["width"].as_u64(), map["height"].as_u64()), (Some(512), Some(512)));
    assert_eq!(map["occupied"], replay["grid"]["occupied"], "walls: ROS 2 {map} vs replay {}", replay["grid"]);
    assert_eq!(map["free"], replay["grid"]["free"], "free: ROS 2 {map} vs replay {}", replay["grid"]);
    assert!(played["maps"]["camera_map"]["free"].as_u64().unwrap() > 0, "{played}");
    // The dropout, then the bag's odometry ends with a goal out: each time the watchdog stops
    // the base and says why.
    assert_eq!(played["stops"], serde_json::json!(["stale-odometry", "stale-odometry"]), "{played}");
    // The goal held before the dropout goes out again once odometry comes again: with the first
    // answer after it, or the second if the bag's order placed that scan on odometry sent before
    // the dropout. Nothing else acts in between, and no third stop follows (a resend with stale
    // odometry would be stopped again at once).
    let (before, after) = (&played["before_pause"], &played["after_pause"]);
    assert!(before["goal"].is_array(), "a goal was out before the dropout: {played}");
    assert_eq!(after["goal"], before["goal"], "{played}");
    assert_eq!(after["acts"], serde_json::json!(["path", "resent"]), "{played}");
    assert!(after["ticks"].as_u64().is_some_and(|t| (1..=2).contains(&t)), "{played}");
    let run = json_line(&lives_out);
    assert_eq!(run["ticks"], 397, "{run}");
    assert_eq!(run["received"]["scan"], 400, "{run}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `lives search --json` for `args`, without the classifier's per-beam scores (they stay in the
/// controller, on the other side of the graph).
fn search_result(args: &[&str]) -> Value {
    let out = Command::new(common::lives()).arg("search").args(args).arg("--json").output().unwrap();
    assert!(out.status.success() || out.status.code() == Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let mut v = json_line(&String::from_utf8_lossy(&out.stdout));
    v.as_object_mut().unwrap().remove("classifier");
    v
}

/// The simulated robot (`lives sim-serve ARGS` relayed over cyclonedds) against `lives ros2
/// --lockstep` configured as the hello line says: the peer's summary, and `lives ros2`'s.
fn simulated(name: &str, domain: u8, args: &[&str], peer_opts: &str) -> (Value, Value) {
    let py = python();
    let dir = scratch(name);
    let hello = Command::new(common::lives()).arg("sim-serve").args(args).stdin(std::process::Stdio::null()).output().unwrap();
    let hello = json_line(String::from_utf8_lossy(&hello.stdout).lines().next().unwrap_or_default());
    let ros2_args: Vec<String> =
        hello["hello"]["lives_ros2_args"].as_array().unwrap().iter().map(|a| format!("'{}'", a.as_str().unwrap())).collect();
    let peer = format!(
        "{py} {} --lives {} {peer_opts} -- {}",
        q(&common::root().join("clients/python/ros2_sim_robot.py")),
        q(common::lives()),
        args.join(" ")
    );
    let (lives_out, lives_err, peer_out, rc) = pair(&dir, domain, &format!("--lockstep {}", ros2_args.join(" ")), &peer);
    let robot = json_line(&peer_out);
    assert_eq!(rc, 0, "the simulated robot failed: {peer_out}\nlives ros2: {lives_out}\n{lives_err}");
    let _ = std::fs::remove_dir_all(&dir);
    (robot, json_line(&lives_out))
}

/// Through ROS 2 the search is `lives search`'s, tick for tick: the same outcome, time, path,
/// goal count and motion (so the same goals), with every message type on the graph in both
/// directions (scans, odometry, tf, tf_static, detections of both kinds and the blocked flag in;
/// goals, plans, status, both grids and markers out).
#[test]
fn the_simulated_robot_finds_the_target_through_ros2_as_lives_search_does() {
    // Detections as vision_msgs/Detection2DArray, then as geometry_msgs/PointStamped on `target`.
    for (args, detection) in [
        (["--world", "apartment", "--seed", "1", "--planner", "lives"], "detections"),
        (["--world", "office", "--seed", "2", "--planner", "nearest"], "target"),
    ] {
        let expected = search_result(&args);
        let (robot, run) = simulated("sim", 12, &args, &format!("--detection-topic {detection}"));
        let mut got = robot["result"].clone();
        got.as_object_mut().unwrap().remove("classifier");
        assert_eq!(got, expected, "{args:?}: through ROS 2 {robot}");
        assert_eq!(robot["ticks"], run["ticks"], "{run}");
        assert!(robot["goals_received"].as_u64().unwrap() > expected["goals"].as_u64().unwrap(), "{robot}");
        for topic in ["lidar_map", "camera_map", "markers"] {
            assert!(robot["maps"][topic].as_u64().unwrap() > 0, "{topic}: {robot}");
        }
        for topic in ["scan", "odom", "tf", "tf_static", "base_blocked"] {
            assert!(run["received"][topic].as_u64().unwrap() > 0, "{topic}: {run}");
        }
        if expected["found"] == true {
            assert!(run["received"][detection].as_u64().unwrap() > 0, "{run}");
        }
        assert_eq!(run["rejected"], serde_json::json!({}), "{run}");
    }
}

/// A robot with a 3D LiDAR publishes `sensor_msgs/PointCloud2` on `points` and no LaserScan:
/// `lives ros2` cuts each cloud to its planar scan and searches with it. (Not tick for tick
/// `lives search`: a cloud holds no "no return" readings, so less space is cleared.)
#[test]
fn a_robot_with_a_point_cloud_and_no_laser_scan_is_searched_with_through_ros2() {
    let args = ["--world", "apartment", "--seed", "1", "--planner", "lives"];
    let (robot, run) = simulated("cloud", 14, &args, "--scan-as-cloud");
    assert_eq!(robot["result"]["found"], true, "{robot}");
    assert_eq!(robot["ticks"], run["ticks"], "{run}");
    assert!(run["received"]["points"].as_u64().unwrap() > 0, "{run}");
    assert!(run["received"].get("scan").is_none(), "{run}");
    assert_eq!(run["rejected"], serde_json::json!({}), "{run}");
}

/// Bad input on the graph — a scan with `angle_increment` 0, ranges and intensities of
/// different lengths, a NaN odometry pose, a scan in an unknown frame, a `tf` loop, a publisher
/// whose QoS cannot match — is rejected by name on the status topic, and the search goes on to
/// the same result.
#[test]
fn bad_input_on_the_graph_is_rejected_by_name_and_the_search_goes_on() {
    let args = ["--world", "apartment", "--seed", "1", "--planner", "lives"];
    let kinds = ["zero-increment", "length-mismatch", "nan-pose", "unknown-frame", "tf-loop", "incompatible-qos"];
    let bad: String = kinds.iter().map(|k| format!(" --publish-bad {k}")).collect();
    let (robot, run) = simulated("bad", 13, &args, &bad);
    let mut names: Vec<&str> = robot["rejections"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    names.sort_unstable();
    assert_eq!(
        names,
        ["incompatible-qos", "pose-not-finite", "scan-angle-increment", "scan-length-mismatch", "tf-loop", "unknown-frame"],
        "{robot}"
    );
    let mut got = robot["result"].clone();
    got.as_object_mut().unwrap().remove("classifier");
    assert_eq!(got, search_result(&args), "{robot}");
    assert_eq!(run["rejected"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum::<u64>(), 6, "{run}");
}

/// LIVE on a robot's ROS 2 graph (`lives ros2 --map`): the known map seeds the grid and labels
/// the scans, and the coverage route is planned from where the first scan is placed. Not tick
/// for tick `lives search --map`: `lives search` plans the route from the base's true pose, the
/// robot from its laser's (0.1 m ahead on the simulated robot), so the routes may differ.
#[test]
fn live_with_a_known_map_searches_through_ros2() {
    let dir = scratch("live-map");
    let map = dir.join("apartment-hard.yaml");
    let st = Command::new(common::lives()).args(["map", "export", "apartment", "--scenario", "hard"]).arg(&map).status().unwrap();
    assert!(st.success());
    let map = map.to_string_lossy().into_owned();
    let args = ["--world", "apartment", "--scenario", "hard", "--seed", "1", "--planner", "live", "--map", map.as_str()];
    let expected = search_result(&args);
    assert_eq!(expected["found"], true, "{expected}");
    let (robot, run) = simulated("live", 15, &args, "");
    assert_eq!(robot["result"]["found"], true, "{robot}");
    assert_eq!(robot["ticks"], run["ticks"], "{run}");
    assert_eq!(run["rejected"], serde_json::json!({}), "{run}");
    // The route came from the map: the robot's first goal is a route waypoint, which the
    // controller sends before it has seen anything beyond its first scan.
    assert!(run["goals"].as_array().unwrap().len() >= 2, "{run}");
}

/// A team of a robot on its ROS 2 graph (`lives ros2 --team-robot 0`, the simulated robot
/// relayed over DDS) and a simulated robot process (`lives team --real-time --as-robot 1`), with
/// their coordinator started on its own (`lives team --external`), all in real time: the
/// coordinator shares the known map's route out between them, the target is found, every robot
/// is stopped, and no goal ever came from an assignment older than the one its robot had heard
/// named.
#[test]
fn a_robot_on_ros2_and_a_simulated_one_search_as_a_team_with_an_external_coordinator() {
    let py = python();
    let dir = scratch("team");
    let _guard = common::hang_guard("a team over ROS 2", Duration::from_secs(600));
    let map = dir.join("apartment-hard.yaml");
    let st = Command::new(common::lives()).args(["map", "export", "apartment", "--scenario", "hard"]).arg(&map).status().unwrap();
    assert!(st.success());
    let world = format!("--world apartment --scenario hard --seed 1 --planner live --map {}", q(&map));
    let sim_args: Vec<String> = ["--world", "apartment", "--scenario", "hard", "--seed", "1", "--planner", "live", "--map"]
        .iter()
        .map(|s| s.to_string())
        .chain([map.to_string_lossy().into_owned()])
        .collect();
    let hello = Command::new(common::lives()).arg("sim-serve").args(&sim_args).stdin(std::process::Stdio::null()).output().unwrap();
    let hello = json_line(String::from_utf8_lossy(&hello.stdout).lines().next().unwrap_or_default());
    let ros2_args: Vec<String> =
        hello["hello"]["lives_ros2_args"].as_array().unwrap().iter().map(|a| format!("'{}'", a.as_str().unwrap())).collect();
    let origin = hello["hello"]["origin"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap().to_string()).collect::<Vec<_>>().join(",");
    let (co, ce, lo, le, so, pe) = (
        dir.join("coord.out"),
        dir.join("coord.err"),
        dir.join("lives.out"),
        dir.join("lives.err"),
        dir.join("sim.err"),
        dir.join("peer.out"),
    );
    let bin = q(common::lives());
    let script = format!(
        "export ROS_DOMAIN_ID=16; \
         {bin} team --external --robots 2 --origin={origin} --speedup 4 --link-timeout 20 {world} --json >{co} 2>{ce} & coord=$!; \
         {bin} team --real-time --speedup 4 --robots 2 --as-robot 1 {world} 2>{so} & sim=$!; \
         {bin} ros2 --localhost --lockstep --team-robot 0 {ros2} --json >{lo} 2>{le} & node=$!; \
         {py} {relay} --lives {bin} --timeout 120 --pace 4 -- {sim_args} >{pe} 2>&1 & peer=$!; \
         wait $coord; rc=$?; \
         t=0; while kill -0 $node 2>/dev/null && [ $t -lt 100 ]; do sleep 0.2; t=$((t+1)); done; \
         kill $node $peer $sim 2>/dev/null; wait; exit $rc",
        co = q(&co),
        ce = q(&ce),
        so = q(&so),
        lo = q(&lo),
        le = q(&le),
        pe = q(&pe),
        ros2 = ros2_args.join(" "),
        relay = q(&common::root().join("clients/python/ros2_sim_robot.py")),
        sim_args = sim_args.iter().map(|a| format!("'{a}'")).collect::<Vec<_>>().join(" "),
    );
    let st = Command::new(common::root().join("tests/ros2/netns.sh")).arg(&script).status().expect("netns.sh runs");
    let read = |p: &std::path::Path| std::fs::read_to_string(p).unwrap_or_default();
    let all = || {
        format!(
            "coordinator: {}\n{}\nlives ros2: {}\n{}\nsimulated robot: {}\nrelay: {}",
            read(&co),
            read(&ce),
            read(&lo),
            read(&le),
            read(&so),
            read(&pe)
        )
    };
    assert_eq!(st.code(), Some(0), "{}", all());
    let v: Value = serde_json::from_str(&read(&co)).unwrap_or_else(|e| panic!("{e}: {}", all()));
    assert_eq!(v["transport"], "dds-realtime");
    assert_eq!(v["map"], "known-map");
    assert_eq!(v["found"], true, "{}", all());
    assert_eq!(v["stale_goals"], 0, "{}", all());
    for i in 0..2 {
        let r = &v["per_robot"][i];
        assert!(r["waypoints_assigned"].as_u64().unwrap() > 0, "robot {i}: {}", all());
        assert!(r["bytes_up"].as_u64().unwrap() > 0 && r["bytes_down"].as_u64().unwrap() > 0, "robot {i}: {}", all());
        assert!(r.get("lost_s").is_none(), "robot {i} lost: {}", all());
    }
    // The robot on ROS 2 ended with the team: it found the target, or was told to stop.
    let node = json_line(&read(&lo));
    assert!(node["end"] == "found" || node["end"] == "stopped", "{}", all());
    assert!(node["ticks"].as_u64().unwrap() > 0, "{}", all());
}
