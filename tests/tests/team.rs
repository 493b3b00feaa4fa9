//! Teams (issue 32, item 5; docs/team.md): a team of one is the single-robot search; a robot
//! whose link is cut has its waypoints re-assigned and the team still finds the target, with
//! no goal from a stale assignment; the same team in one process and as separate processes
//! over DDS on loopback gives the same search; bad input is named.

use host::search::{self, PlannerChoice, SearchSpec};
use host::sim::{Scenario, World};
use host::team::{self, TeamSpec};
use serde_json::Value;
use std::process::Command;
use std::time::Duration;

mod common;

fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("lives-team-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn q(p: &std::path::Path) -> String {
    format!("'{}'", p.display())
}

fn spec(world: &str, scenario: Scenario, planner: PlannerChoice, seed: u64, map: bool) -> SearchSpec {
    let w = World::builtin(world, scenario).expect("built-in");
    let mut specs = vec![SearchSpec::new(world, w, scenario, planner, seed)];
    // The robot `lives team` and `lives eval` simulate by default.
    search::Robot::Calibrated.apply(&mut specs[0]).expect("the calibrated robot");
    if map {
        host::measure::eval::give_true_maps(&mut specs).expect("the true map");
    }
    specs.remove(0)
}

#[test]
fn a_team_of_one_is_the_single_robot_search_tick_for_tick() {
    for (planner, map) in [(PlannerChoice::Live, true), (PlannerChoice::Multisensor, false)] {
        let s = spec("hallway", Scenario::Easy, planner, 1, map);
        let single = search::run(&s, |_| {}).result;
        let t = team::local::run(&TeamSpec::new(s, 1)).expect("a team of one");
        assert_eq!((t.found, t.time_s), (single.found, single.time_s), "{planner}: {t:?}");
        assert_eq!(t.per_robot[0].path_m, single.path_m, "{planner}");
        assert_eq!(t.ticks, single.ticks, "{planner}");
        assert_eq!((t.stale_goals, t.reassignments), (0, 0));
    }
}

#[test]
fn starts_are_spaced_clear_and_deterministic() {
    let s = spec("office", Scenario::Hard, PlannerChoice::Live, 3, false);
    let a = team::starts(&s, 3).expect("room for three");
    assert_eq!(a, team::starts(&s, 3).unwrap());
    assert_eq!(a[0], host::sim::Sim::new(s.world.clone(), s.sim.clone(), s.seed).pose(), "robot 0 starts as the single robot does");
    for i in 0..3 {
        assert!(s.world.disc_is_clear([a[i][0], a[i][1]], s.sim.robot_radius_m), "start {i} {:?}", a[i]);
        for j in 0..i {
            assert!((a[i][0] - a[j][0]).hypot(a[i][1] - a[j][1]) >= team::START_SPACING_M - 1e-9, "{i} {j}");
        }
    }
    assert!(team::starts(&s, 200).unwrap_err().contains("room for"));
}

#[test]
fn a_robot_whose_link_is_cut_has_its_waypoints_reassigned_and_the_team_still_finds_the_target() {
    let s = spec("hallway", Scenario::Hard, PlannerChoice::Live, 2, true);
    let whole = team::local::run(&TeamSpec::new(s.clone(), 2)).unwrap();
    let cut = team::local::run(&TeamSpec { kill: Some((1, 10.0)), ..TeamSpec::new(s, 2) }).unwrap();
    assert!(cut.found, "{cut:?}");
    assert_eq!(cut.found_by, Some(0));
    assert_eq!(cut.per_robot[1].lost_s, Some(10.0));
    // The survivor was given the route's rest once: one re-assignment, and every goal after it
    // came from it.
    assert_eq!(cut.reassignments, 1, "{cut:?}");
    assert_eq!(cut.stale_goals, 0);
    assert!(cut.per_robot[0].waypoints_assigned > whole.per_robot[0].waypoints_assigned, "{cut:?} vs {whole:?}");
    assert_eq!(whole.reassignments, 0);
}

/// `lives team ARGS --json` inside a loopback-only network (tests/ros2/netns.sh).
fn lives_team(args: &str) -> (Option<Value>, String, i32) {
    let _guard = common::hang_guard("lives team", Duration::from_secs(600));
    let dir = scratch(&format!("{:x}", args.len() * 7919 + args.bytes().map(|b| b as usize).sum::<usize>()));
    let (o, e) = (dir.join("out"), dir.join("err"));
    let script = format!("{} team {args} >{} 2>{}", q(common::lives()), q(&o), q(&e));
    let st = Command::new(common::root().join("tests/ros2/netns.sh")).arg(&script).status().expect("netns.sh runs");
    let out = std::fs::read_to_string(&o).unwrap_or_default();
    (serde_json::from_str(&out).ok(), std::fs::read_to_string(&e).unwrap_or_default(), st.code().unwrap_or(-1))
}

#[test]
fn the_team_over_dds_as_separate_processes_is_the_team_in_one_process() {
    let args = "--world hallway --scenario hard --seed 2 --planner live --known-map --robots 3 --kill 1@10 --link-timeout 3";
    let s = spec("hallway", Scenario::Hard, PlannerChoice::Live, 2, true);
    let local = team::local::run(&TeamSpec { kill: Some((1, 10.0)), ..TeamSpec::new(s, 3) }).unwrap();
    let (v, err, rc) = lives_team(&format!("{args} --processes --domain 21 --json"));
    let v = v.unwrap_or_else(|| panic!("no JSON from lives team --processes (exit {rc}): {err}"));
    assert_eq!(v["transport"], "dds");
    assert_eq!(v["found"], local.found, "{v}");
    assert_eq!(v["time_s"].as_f64(), Some(local.time_s), "{v}");
    assert_eq!(v["found_by"].as_u64(), local.found_by.map(|r| r as u64));
    assert_eq!(v["ticks"].as_u64(), Some(local.ticks as u64));
    assert_eq!(v["stale_goals"], 0);
    assert_eq!(v["per_robot"][1]["lost_s"].as_f64(), Some(10.0), "{v}");
    for i in 0..3 {
        assert_eq!(v["per_robot"][i]["path_m"].as_f64(), Some(local.per_robot[i].path_m), "robot {i}");
        // Bandwidth is measured on the wire: every robot sent and received something.
        assert!(v["per_robot"][i]["bytes_up"].as_u64().unwrap() > 0 && v["per_robot"][i]["bytes_down"].as_u64().unwrap() > 0);
    }
}

#[test]
fn bad_team_input_is_named() {
    let (_, err, rc) = lives_team("--world hallway --robots 9");
    assert!(rc != 0 && err.contains("--robots 9"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --kill 2@5");
    assert!(rc != 0 && err.contains("--kill 2@5"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --kill x");
    assert!(rc != 0 && err.contains("ROBOT@SECONDS"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --planner live --robots 2");
    assert!(rc != 0 && err.contains("known building"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --sim-for 2:speed_mps=1");
    assert!(rc != 0 && err.contains("--sim-for 2:speed_mps=1"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --sim-for 1:speed=1");
    assert!(rc != 0 && err.contains("robot 1") && err.contains("speed"), "{rc} {err}");
    // Refused even when the team runs in one process and would not use it.
    for bad in ["nan", "-1", "0"] {
        let (_, err, rc) = lives_team(&format!("--world hallway --robots 2 --link-timeout {bad}"));
        assert!(rc == 2 && err.contains("--link-timeout"), "{bad}: {rc} {err}");
    }
}

#[test]
fn a_second_process_announcing_a_robot_is_refused_by_name() {
    let _guard = common::hang_guard("lives team with a duplicate robot", Duration::from_secs(600));
    let dir = scratch("duplicate");
    let (o, e) = (dir.join("out"), dir.join("err"));
    let args = "--world hallway --scenario hard --seed 2 --planner live --known-map --robots 2";
    // The team, and a rogue process that announces itself as robot 1 too.
    let script = format!(
        "{bin} team {args} --as-robot 1 --domain 22 >/dev/null 2>&1 & rogue=$!; \
         {bin} team {args} --processes --domain 22 >{o} 2>{e}; rc=$?; kill $rogue 2>/dev/null; wait $rogue; exit $rc",
        bin = q(common::lives()),
        o = q(&o),
        e = q(&e)
    );
    let st = Command::new(common::root().join("tests/ros2/netns.sh")).arg(&script).status().expect("netns.sh runs");
    let err = std::fs::read_to_string(&e).unwrap_or_default();
    assert_eq!(st.code(), Some(2), "{err}");
    assert!(err.contains("robot 1 is announced twice"), "{err}");
}

#[test]
fn lives_search_robots_runs_the_team_with_the_map_file() {
    let dir = scratch("search-robots");
    let map = dir.join("hallway-hard.yaml");
    let st = Command::new(common::lives()).args(["map", "export", "hallway", "--scenario", "hard"]).arg(&map).status().unwrap();
    assert!(st.success());
    let out = Command::new(common::lives())
        .args([
            "search",
            "--world",
            "hallway",
            "--scenario",
            "hard",
            "--seed",
            "2",
            "--planner",
            "live",
            "--robots",
            "2",
            "--json",
            "--map",
        ])
        .arg(&map)
        .output()
        .unwrap();
    let v: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stderr)));
    let local = team::local::run(&TeamSpec::new(spec("hallway", Scenario::Hard, PlannerChoice::Live, 2, true), 2)).unwrap();
    // The exported map file is the true map `--known-map` gives: the same search.
    assert_eq!((v["robots"].as_u64(), v["time_s"].as_f64(), v["found"].as_bool()), (Some(2), Some(local.time_s), Some(local.found)), "{v}");
    assert_eq!(v["map"], "known-map");
}

/// The same team in real time (`--real-time`): no lockstep, each process on its own clock
/// (4 simulated seconds a wall second). The cut robot is found silent and its work shared out,
/// the team finds the target, and no goal came from an assignment older than the one its robot
/// had heard named.
#[test]
fn the_team_in_real_time_survives_a_cut_link_and_finds_the_target() {
    let args = "--world hallway --scenario hard --seed 2 --planner live --known-map --robots 3 --kill 1@10 --link-timeout 2 \
                --processes --real-time --speedup 4 --domain 23 --json";
    let (v, err, rc) = lives_team(args);
    let v = v.unwrap_or_else(|| panic!("no JSON from lives team --real-time (exit {rc}): {err}"));
    assert_eq!(v["transport"], "dds-realtime");
    assert_eq!(v["found"], true, "{v}");
    assert_eq!(v["stale_goals"], 0, "{v}");
    // Lost once it had been silent for the link timeout: 2 s of wall time, 8 s of the team's.
    let lost = v["per_robot"][1]["lost_s"].as_f64().unwrap_or_else(|| panic!("robot 1 not lost: {v}"));
    assert!((10.0..=40.0).contains(&lost), "{v}");
    assert!(v["reassignments"].as_u64().unwrap() >= 2, "the two survivors get the rest: {v}");
    for i in 0..3 {
        assert!(v["per_robot"][i]["bytes_up"].as_u64().unwrap() > 0 && v["per_robot"][i]["bytes_down"].as_u64().unwrap() > 0);
    }
    // --real-time runs over DDS only; --speedup only with it.
    let (_, err, rc) = lives_team("--world hallway --robots 2 --real-time");
    assert!(rc == 2 && err.contains("--processes"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --processes --real-time --speedup 0");
    assert!(rc == 2 && err.contains("--speedup 0"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --external");
    assert!(rc == 2 && err.contains("--origin"), "{rc} {err}");
}

/// In real time a link that drops and comes back (robot 2's process frozen for 8 s of wall
/// time at the team's 20 s): the robot is lost and its work shared out; when it answers again
/// (if its DDS streams stalled, it joins the team's topics anew after 10 s without an order) it
/// is taken in where it stands
/// and what is left is shared out among all three; the team finds the target with no stale goal.
#[test]
fn in_real_time_a_robot_whose_link_comes_back_is_taken_in_again() {
    let args = "--world hallway --scenario hard --seed 2 --planner live --known-map --robots 3 --link-timeout 3 \
                --processes --real-time --speedup 2 --pause 2@20:8 --domain 24 --json";
    let (v, err, rc) = lives_team(args);
    let v = v.unwrap_or_else(|| panic!("no JSON from lives team --pause (exit {rc}): {err}"));
    assert_eq!(v["found"], true, "{v}");
    assert_eq!(v["stale_goals"], 0, "{v}");
    let r2 = &v["per_robot"][2];
    let lost = r2["lost_s"].as_f64().unwrap_or_else(|| panic!("robot 2 not lost: {v}"));
    let back = r2["rejoined_s"].as_f64().unwrap_or_else(|| panic!("robot 2 not taken in again: {v}\n{err}"));
    assert!(lost >= 20.0 && back > lost, "{v}");
    // Two shares when it was lost, three when it came back.
    assert!(v["reassignments"].as_u64().unwrap() >= 5, "{v}");
    assert!(r2["waypoints_done"].as_u64().unwrap() > 0 || r2["path_m"].as_f64().unwrap() > 5.0, "it went on searching: {v}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --pause 1@5:2");
    assert!(rc == 2 && err.contains("--pause"), "{rc} {err}");
    let (_, err, rc) = lives_team("--world hallway --robots 2 --processes --real-time --pause 1@5:x");
    assert!(rc == 2 && err.contains("ROBOT@SECONDS:WALL_SECONDS"), "{rc} {err}");
}
