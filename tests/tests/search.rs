//! End-to-end: the simulator and the controller core in lockstep (issue 3's acceptance tests).

mod common;
use host::search::{self, PlannerChoice, SearchSpec};
use host::sim::{Scenario, World};

fn spec(world: &str, scenario: Scenario, planner: PlannerChoice, seed: u64) -> SearchSpec {
    SearchSpec::new(world, World::builtin(world, scenario).expect("built-in world"), scenario, planner, seed)
}

/// The built-in `apartment easy` of 2026-11-25 (`examples/worlds/apartment-easy-bedroom-start.toml`):
/// a short search (the suitcase in view from the start room's door), the world the tests below
/// were measured on before the built-in was defined again from the paper's words.
fn bedroom_start(planner: PlannerChoice, seed: u64) -> SearchSpec {
    SearchSpec::new("apartment-easy-bedroom-start", example_world("apartment-easy-bedroom-start"), Scenario::Easy, planner, seed)
}

#[test]
fn lives_gt_finds_the_target_in_the_bedroom_start_apartment_seed_1() {
    let run = search::run(&bedroom_start(PlannerChoice::LivesGt, 1), |_| {});
    let r = &run.result;
    assert!(r.found, "{r:?}");
    assert!(r.time_s <= r.time_limit_s);
    assert_eq!(r.outcome, "found");
    // The detection happened within camera range of the target.
    let at = run.found_at.expect("found_at");
    let t = r.targets[0];
    assert!((at[0] - t[0]).hypot(at[1] - t[1]) <= 4.5, "found at {at:?}, target {t:?}");
    // Where the time went: every stepped tick is moving, turning or still (the detecting tick
    // is not stepped), and the LiDAR saw the suitcase before the camera did.
    let m = r.motion.expect("a simulated run reports its motion");
    let stepped_s = (r.ticks - 1) as f64 * host::run::TICK_US as f64 / 1e6;
    assert!((m.moving_s + m.turning_s + m.still_s - stepped_s).abs() < 1e-6, "{m:?} vs {stepped_s} s");
    assert!(m.moving_s > m.turning_s && m.moving_s > m.still_s, "{m:?}");
    let seen = r.lidar_saw_target_s.expect("the LiDAR saw the target");
    assert!(seen < r.time_s, "LiDAR {seen} s, camera {} s", r.time_s);
    // The camera detects within its range, so the target was within its reach by then.
    let reach = r.target_in_camera_reach_s.expect("within the camera's reach before the detection");
    assert!(seen <= reach && reach <= r.time_s, "LiDAR {seen} s, reach {reach} s, camera {} s", r.time_s);
}

#[test]
fn every_planner_finds_the_target_in_the_bedroom_start_apartment_seeds_1_to_10() {
    // Issue 3's acceptance as it was measured on the built-in `apartment easy` of 2026-11-25 (now
    // examples/worlds/apartment-easy-bedroom-start.toml): the four planners the issue names,
    // seeds 1-10, each within the 120 s limit, on the 4 m camera of then.
    let planners = [PlannerChoice::LivesGt, PlannerChoice::Lives, PlannerChoice::Multisensor, PlannerChoice::Nearest];
    // As `lives eval` runs them: `lives` on the committed int8 classifier.
    let specs: Vec<SearchSpec> = planners
        .iter()
        .flat_map(|&p| (1..=10).map(move |seed| (p, seed)))
        .map(|(p, seed)| {
            let mut s = bedroom_start(p, seed);
            if p == PlannerChoice::Lives {
                s.model = Some(firmware::classifier::EMBEDDED_GEO_MODEL);
            }
            s
        })
        .collect();
    assert_eq!(specs.len(), 40);
    let mut missed = Vec::new();
    for s in &specs {
        let planner = s.planner;
        let r = search::try_run(s, |_| {}).expect("the committed model validates").result;
        assert_eq!(r.time_limit_s, 120.0);
        assert_eq!(r.labels == "int8-classifier", planner == PlannerChoice::Lives, "{planner}: {}", r.labels);
        if !(r.found && r.time_s <= r.time_limit_s) {
            missed.push(format!("{planner} seed {}: {} at {} s", s.seed, r.outcome, r.time_s));
        }
    }
    assert!(missed.is_empty(), "not found: {missed:?}");
}

#[test]
fn the_suitcase_the_lidar_sees_at_once_behind_the_start_is_found_despite_a_walking_persons_trail() {
    // The paper's showcase (examples/worlds/apartment-suitcase-behind.toml): the LiDAR sees the
    // suitcase at once, 6 m behind the start, while a person walks past. With the non-map
    // points a person left where they no longer stand, the greedy `lives-gt` once walked to that
    // trail and never came back (its seed 2); the rule that drops them (`nonmap_drop_vacated`,
    // the default; unit-tested in `firmware::nonmap`) fixed it. Since a planning step spans two
    // ticks (issue 28) that seed no longer walks to the trail even without the rule, so only the
    // outcome is checked, for the structured and the greedy planner.
    let world = example_world("apartment-suitcase-behind");
    for kind in [firmware::PlannerKind::Lives, firmware::PlannerKind::LivesGreedy] {
        let mut s = SearchSpec::new("apartment-suitcase-behind", world.clone(), Scenario::Easy, PlannerChoice::LivesGt, 2);
        s.controller.planner = kind;
        let r = search::run(&s, |_| {}).result;
        assert_eq!(r.lidar_saw_target_s, Some(0.0), "{kind:?}: {r:?}");
        assert!(r.found, "{kind:?}: {r:?}");
    }
}

fn example_world(name: &str) -> World {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../examples/worlds/{name}.toml"));
    World::load(&path).expect("the example world loads")
}

/// Asserts that `example` is `base` with only its name, bounds and the target's places changed.
fn assert_only_the_places_differ(example: &World, mut base: World, what: &str) {
    base.name = example.name.clone();
    base.bounds = example.bounds;
    assert_eq!(base.targets.len(), 1);
    assert_eq!(example.targets.len(), 1);
    base.targets[0].shape = example.targets[0].shape.clone();
    base.targets[0].candidates = example.targets[0].candidates.clone();
    assert_eq!(*example, base, "{what}");
}

/// `examples/worlds/apartment-easy-hallway-start.toml` (the built-in `apartment easy` before
/// 2026-11-25), checked to share everything but the start and the target's places with
/// `apartment-easy-bedroom-start.toml` (the built-in from 2026-11-25 to 2026-11-26): if the floor
/// plan, the furniture, the clutter or the person change there, the figures measured on the
/// two no longer compare.
#[test]
fn the_hallway_start_example_is_the_bedroom_start_apartment_from_the_junction() {
    let example = example_world("apartment-easy-hallway-start");
    let mut bedroom = example_world("apartment-easy-bedroom-start");
    assert_ne!(bedroom.start, example.start, "one starts in bedroom 2, the other at the junction");
    assert_eq!(example.start.pose[..2], [10.0, 13.0]);
    assert_eq!(bedroom.start.pose[..2], [5.0, 17.5]);
    bedroom.start = example.start.clone();
    assert_only_the_places_differ(
        &example,
        bedroom,
        "examples/worlds/apartment-easy-hallway-start.toml has drifted from apartment-easy-bedroom-start.toml",
    );
}

/// The built-in `apartment easy` is `apartment hard` with fewer objects and the suitcase
/// nearer (the paper's words; the rule's own test is in host/sim/src/builtin.rs): the world
/// `lives eval` runs, not one of the examples.
#[test]
fn the_builtin_apartment_easy_is_hard_with_fewer_objects_and_a_nearer_target() {
    let easy = World::builtin("apartment", Scenario::Easy).unwrap();
    let hard = World::builtin("apartment", Scenario::Hard).unwrap();
    assert_eq!(easy.start, hard.start);
    assert!(easy.obstacles.len() < hard.obstacles.len() && easy.obstacles.iter().all(|o| hard.obstacles.contains(o)));
    assert_ne!(easy, example_world("apartment-easy-bedroom-start"));
}

/// `examples/worlds/NAME.toml`, checked to be `apartment-easy-hallway-start.toml` with only the
/// target's places changed. Re-export it (`lives worlds --export` of that file's world is the
/// file itself) and set the target's places again.
fn hallway_start_variant(name: &str) -> World {
    let example = example_world(name);
    let what = format!("examples/worlds/{name}.toml has drifted from apartment-easy-hallway-start.toml");
    assert_only_the_places_differ(&example, example_world("apartment-easy-hallway-start"), &what);
    example
}

#[test]
fn the_suitcase_behind_example_is_the_hallway_start_with_the_target_fixed() {
    let example = hallway_start_variant("apartment-suitcase-behind");
    assert_eq!(example.targets[0].shape.center(), [9.35, 7.0], "the hallway place, 6 m behind the start");
    assert!(example.targets[0].candidates.is_empty());
}

#[test]
fn the_beside_start_example_is_the_hallway_start_with_closer_places() {
    let example = hallway_start_variant("apartment-easy-beside-start");
    let hallway = example_world("apartment-easy-hallway-start");
    // The hallway place and the study's door place are the hallway start's; the other two are
    // in the rooms beside the start.
    assert_eq!(example.targets[0].shape, hallway.targets[0].shape);
    assert_eq!(example.targets[0].candidates[1], hallway.targets[0].candidates[1]);
    let start = example.start.pose;
    let far = |p: [f64; 2]| (p[0] - start[0]).hypot(p[1] - start[1]);
    for p in example.targets[0].positions() {
        assert!(far(p) <= 6.1, "{p:?} is {} m from the start", far(p));
    }
    // The hallway start's bedroom 2 and dining room places, north of the start behind doors, are left out.
    let north = |w: &World| w.targets[0].positions().iter().filter(|p| p[1] > start[1] + 1.0).count();
    assert_eq!((north(&hallway), north(&example)), (2, 0));
}

#[test]
fn a_classifier_run_scores_its_labels_against_the_simulators_truth() {
    // The bedroom-start apartment, seed 9: a short run (the suitcase is in view from the start
    // room's door).
    let mut s = bedroom_start(PlannerChoice::Lives, 9);
    s.model = Some(firmware::classifier::EMBEDDED_GEO_MODEL);
    let r = search::try_run(&s, |_| {}).expect("the committed model validates").result;
    assert_eq!(r.labels, "int8-classifier");
    let c = r.classifier.expect("a classifier run scores its labels");
    // Every beam of every scan with a return is scored: 897 per tick at most.
    assert!(c.beams > 0 && c.beams <= r.ticks as u64 * 897, "{c:?} over {} ticks", r.ticks);
    // Better than chance and not perfect: a real comparison, not a copy of the truth.
    assert!(c.accuracy > 0.6 && c.accuracy < 1.0, "{c:?}");
    assert!((0.0..=1.0).contains(&c.nonmap_recall) && (0.0..=1.0).contains(&c.nonmap_precision), "{c:?}");
    // Runs on the simulator's own labels have nothing to score.
    let gt = search::run(&bedroom_start(PlannerChoice::LivesGt, 9), |_| {}).result;
    assert_eq!(gt.classifier, None);
}

#[test]
fn the_same_seed_gives_the_same_result_and_decisions() {
    for planner in [PlannerChoice::Lives, PlannerChoice::Nearest] {
        let a = search::run(&spec("apartment", Scenario::Easy, planner, 3), |_| {});
        let b = search::run(&spec("apartment", Scenario::Easy, planner, 3), |_| {});
        assert_eq!(serde_json::to_string(&a.result).unwrap(), serde_json::to_string(&b.result).unwrap());
        assert_eq!(a.goals, b.goals, "{planner}: the goal sequence differs");
        assert_eq!(a.trajectory, b.trajectory);
        assert!(a.goals.len() >= 2, "{planner}: the run made decisions");
    }
    // A different seed gives a different run (the seed is really used).
    let c = search::run(&spec("apartment", Scenario::Easy, PlannerChoice::Lives, 4), |_| {});
    let a = search::run(&spec("apartment", Scenario::Easy, PlannerChoice::Lives, 3), |_| {});
    assert_ne!(a.trajectory, c.trajectory);
}

#[test]
fn the_base_never_enters_an_obstacle_during_a_search() {
    for (world, scenario, planner, seed) in
        [("apartment", Scenario::Hard, PlannerChoice::Multisensor, 2), ("office", Scenario::Easy, PlannerChoice::Nearest, 5)]
    {
        // `collisions` counts the ticks at whose end the robot disc overlapped a wall, an
        // obstacle or a person, checked against the true world at that moment.
        let run = search::run(&spec(world, scenario, planner, seed), |_| {});
        assert!(run.trajectory.len() > 50);
        assert!(run.result.path_m > 5.0, "{world}: the robot moved");
        assert_eq!(run.result.collisions, 0, "{world} {planner}: {:?}", run.result);
        // Static geometry, along the whole trajectory after the fact.
        for p in &run.trajectory {
            assert!(
                run.sim.world().disc_is_clear(*p, run.sim.config().robot_radius_m),
                "{world} {planner}: robot inside an obstacle at {p:?}"
            );
        }
    }
}

#[test]
fn every_built_in_world_runs_with_every_planner() {
    for &world in World::builtin_names() {
        for scenario in [Scenario::Easy, Scenario::Hard] {
            let mut s = spec(world, scenario, PlannerChoice::Multisensor, 1);
            // A short search: the point is that every world loads and the loop runs.
            s.world.time_limit_s = 10.0;
            let run = search::run(&s, |_| {});
            assert!(run.result.ticks >= 2, "{world} {scenario}");
            assert!(run.controller.lidar.grid.count(firmware::Cell::Free) > 1000, "{world} {scenario}: the LiDAR map grew");
        }
    }
}

#[test]
fn pictures_render_for_every_planner() {
    // Regression: the dashed goal path of this run once stalled the renderer on float rounding.
    let dir = std::env::temp_dir().join(format!("lives-pictures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for planner in [PlannerChoice::Multisensor, PlannerChoice::Lives, PlannerChoice::Nearest] {
        let run = search::run(&spec("apartment", Scenario::Easy, planner, 1), |_| {});
        let path = dir.join(format!("{planner}.png"));
        host::search::picture::write_png(&run, &path, "test").unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..4], b"\x89PNG");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn lives_refuses_a_setting_the_controller_cannot_work_with_naming_its_range() {
    // Each once stopped the search (an overflow in the planner, exit 101) or ran a robot whose
    // camera sees nothing; now `lives` refuses them before it starts, as it does a bad `--sim`.
    for (args, says) in [
        (&["search", "--set", "viewpoint_snap_radius_m=3000"][..], "`viewpoint_snap_radius_m`: expected a value in [0, 5] m, got 3000"),
        (&["search", "--set", "camera_range_m=0"][..], "`camera_range_m`: expected a value in (0, 51.2] m, got 0"),
        (&["search", "--robot", "long"][..], "unknown robot `long` (expected calibrated or short)"),
        (&["eval", "--robot", "long"][..], "unknown robot `long` (expected calibrated or short)"),
        (&["tune", "--grid", "w_dist_per_m=1", "--first-world", "1000050"][..], "overlap the held-out worlds 1000001..1001001"),
        (&["dataset", "--out", "/tmp/never-written", "--seed", "999999", "--worlds", "5"][..], "overlap the held-out worlds"),
        (&["tune", "--grid", "robot_radius_m=0.35,5000"][..], "`robot_radius_m`: expected a value in [0, 1.5] m, got 5000"),
    ] {
        let out = std::process::Command::new(common::lives()).args(args).output().expect("lives runs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}
