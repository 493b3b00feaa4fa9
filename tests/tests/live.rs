//! LIVE (issue 32, docs/live.md): a known building's map and route, in process, over the link,
//! and from the command line.

use firmware::node::TimeMode;
use firmware::Config;
use host::link::{mem_pair, run_bridge, BridgeOptions, NodeOptions, NodeProcess, Source};
use host::search::{self, PlannerChoice, SearchSpec};
use host::sim::{Scenario, World};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

mod common;

/// `hallway easy` with its true map (as `lives eval --known-map` runs it).
fn known_spec(planner: PlannerChoice, seed: u64) -> SearchSpec {
    let world = World::builtin("hallway", Scenario::Easy).expect("built-in");
    let mut specs = vec![SearchSpec::new("hallway", world, Scenario::Easy, planner, seed)];
    host::measure::eval::give_true_maps(&mut specs).expect("the true map");
    specs.remove(0)
}

#[test]
fn live_finds_the_target_and_reports_its_route_and_the_search_maps_entropy() {
    let run = search::run(&known_spec(PlannerChoice::Live, 1), |_| {});
    let r = &run.result;
    assert!(r.found, "{r:?}");
    assert_eq!(r.labels, "known-map");
    let l = r.live.as_ref().expect("a known-map search reports LIVE's side");
    assert_eq!(l.route_footprint.as_deref(), Some("lidar"));
    assert!(l.route_waypoints > 3 && l.route_coverage > 0.95, "{l:?}");
    assert_eq!(l.route_waypoints, run.controller.planner.route.waypoints().len());
    // The search map: its entropy starts at the map's free cells and only falls.
    assert!(l.entropy_start_bits > 10_000 && l.entropy_end_bits < l.entropy_start_bits, "{l:?}");
    assert!(l.entropy.windows(2).all(|p| p[1][1] <= p[0][1] && p[1][0] > p[0][0]), "{:?}", l.entropy);
    // The known-map classifier labelled the scans: walls are LTFs, the target and clutter STFs.
    assert!(l.features[0] > 10 * l.features[1] && l.features[1] > 0, "{:?}", l.features);
    // The baselines follow their own routes, without priority waypoints.
    for (p, fp) in [(PlannerChoice::VisualCpp, "camera"), (PlannerChoice::LidarCpp, "lidar")] {
        let b = search::run(&known_spec(p, 1), |_| {}).result;
        let bl = b.live.expect("live summary");
        assert_eq!((bl.route_footprint.as_deref(), bl.priority_waypoints), (Some(fp), 0), "{p}");
    }
}

#[test]
fn live_over_the_link_decides_as_the_in_process_search() {
    // The map rows and the route travel as `MapRow` and `Route` messages; the node's controller
    // then decides exactly as the in-process one.
    let sp = known_spec(PlannerChoice::Live, 2);
    let inproc = search::run(&sp, |_| {});
    let (mut node_end, mut bridge_end) = mem_pair();
    let stop_node = AtomicBool::new(false);
    let stop_bridge = AtomicBool::new(false);
    let _hung = common::hang_guard("live over the link", Duration::from_secs(600));
    let bopts = BridgeOptions {
        max_wall: Some(Duration::from_secs(300)),
        retry_timeout: Duration::from_millis(5),
        ..BridgeOptions::new(TimeMode::Lockstep)
    };
    let (r, report) = std::thread::scope(|s| {
        let _stop = common::StopOnDrop(&[&stop_node, &stop_bridge]);
        let node = s.spawn(|| {
            let mut p = NodeProcess::new(Config::DEFAULT, NodeOptions::new(TimeMode::Lockstep)).expect("no model");
            p.run(&mut node_end, &stop_node);
            p.report()
        });
        let r = run_bridge(&mut bridge_end, Source::Sim(sp.clone()), &bopts, &stop_bridge).expect("a session");
        std::thread::sleep(Duration::from_millis(300));
        stop_node.store(true, Ordering::Relaxed);
        (r, node.join().expect("node thread"))
    });
    assert!(inproc.result.found);
    assert_eq!(r.goals, inproc.goals, "the node decided otherwise than the in-process controller");
    assert_eq!(r.trajectory, inproc.trajectory);
    // The waypoint manager's counts are not on the wire; everything else is the same.
    assert_eq!(r.result, search::SearchResult { live: None, classifier: None, ..inproc.result.clone() });
    assert_eq!(report.link.dropped(), 0);
}

#[test]
fn the_command_line_runs_live_on_an_exported_map_and_refuses_it_without_one() {
    let dir = std::env::temp_dir().join(format!("lives-live-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let yaml = dir.join("hallway.yaml");
    let st = Command::new(common::lives()).args(["map", "export", "hallway"]).arg(&yaml).status().unwrap();
    assert!(st.success());
    let out = Command::new(common::lives())
        .args(["search", "--world", "hallway", "--planner", "live", "--json", "--map"])
        .arg(&yaml)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["found"], true);
    assert!(v["live"]["route_waypoints"].as_u64().unwrap() > 3, "{}", v["live"]);
    assert!(v["live"]["entropy"].as_array().unwrap().len() >= 2);
    // Without a map: a clear error, exit status 2.
    let out = Command::new(common::lives()).args(["search", "--world", "hallway", "--planner", "live"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("`live` searches a known building") && err.contains("--map"), "{err}");
    // And `lives eval` will not run it without --known-map.
    let out = Command::new(common::lives()).args(["eval", "--planners", "live", "--trials", "1", "--heldout", "0"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}
