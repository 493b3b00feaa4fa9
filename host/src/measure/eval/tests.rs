//! Tests of the parent module (`eval.rs`).

use super::*;

fn result(planner: &str, found: bool, t: f64) -> SearchResult {
    SearchResult {
        world: "apartment".into(),
        scenario: "easy".into(),
        planner: planner.into(),
        seed: 1,
        found,
        time_s: if found { t } else { 120.0 },
        path_m: 10.0,
        ticks: 1,
        time_limit_s: 120.0,
        outcome: if found { "found" } else { "time-limit" }.into(),
        goals: 1,
        blacklisted: 0,
        blocked: 0,
        collisions: 0,
        labels: "none".into(),
        targets: vec![],
        motion: None,
        lidar_saw_target_s: None,
        target_in_camera_reach_s: None,
        classifier: None,
        sim: None,
        oracle_s: None,
        live: None,
    }
}

#[test]
fn failures_count_as_the_limit_and_the_ci_uses_students_t() {
    let mut rs = [result("a", true, 30.0), result("a", false, 0.0), result("a", true, 60.0), result("b", true, 10.0)];
    rs[0].lidar_saw_target_s = Some(5.0);
    rs[1].lidar_saw_target_s = Some(8.0);
    // Trial 2 failed with the target once within the camera's reach; trial 1 found it.
    rs[0].target_in_camera_reach_s = Some(20.0);
    rs[1].target_in_camera_reach_s = Some(9.0);
    // Two of `a`'s trials scored a classifier: 14 beams pooled, 9 right, 2 of 4 non-map found.
    rs[0].classifier = Some(LabelScore::from_confusion([[5, 1], [1, 1]]));
    rs[2].classifier = Some(LabelScore::from_confusion([[2, 2], [1, 1]]));
    let cells = summarise(&rs);
    assert_eq!(cells.len(), 2);
    let a = &cells[0];
    assert_eq!((a.trials, a.found), (3, 2));
    assert!((a.mean_time_s - 70.0).abs() < 1e-9);
    // sd of [30, 120, 60] = 45.83; t(2) = 4.303; 4.303 · 45.83 / √3 = 113.85
    assert!((a.ci95_s - 113.85).abs() < 0.05, "{}", a.ci95_s);
    assert_eq!(cells[1].ci95_s, 0.0);
    let md = markdown_table(&cells);
    assert!(md.contains("| apartment easy | 120 s | 70.0 (67 %) | 10.0 (100 %) |"), "{md}");
    assert!(csv(&cells).lines().nth(1).unwrap().starts_with("a,apartment,easy,3,2,0.6667,70.000"));
    // The LiDAR sighting: 2 of 3 trials, mean 6.5 s; none in `b`.
    assert_eq!((a.lidar_sighted, a.mean_lidar_sighting_s), (2, 6.5));
    assert_eq!((a.missed_in_reach, cells[1].missed_in_reach), (1, 0));
    assert!(md.contains("| 2 | 6.5 | 1 | 64.3 % / 50.0 % |") && md.contains("| 0 | — | 0 | — |"), "{md}");
    assert!(csv(&cells).lines().nth(1).unwrap().ends_with(",2,6.500,1,0.6429,0.5000,0,,,"));
    assert!(csv(&cells).lines().nth(2).unwrap().ends_with(",0,,0,,,0,,,"));
    assert!(!md.contains("oracle, mean"), "no oracle table without oracles");
    // The classifier's score pools the beams of the trials that have one.
    assert_eq!(a.labels.map(|l| l.beams), Some(14));
    assert_eq!(cells[1].labels, None);
}

#[test]
fn the_oracle_ratio_counts_failures_at_the_limit_and_floors_the_oracle_at_a_tick() {
    let mut rs = [result("a", true, 30.0), result("a", false, 0.0), result("a", true, 1.0), result("b", true, 10.0)];
    rs[0].oracle_s = Some(10.0); // 30 / 10 = 3
    rs[1].oracle_s = Some(60.0); // a failure: the limit 120 / 60 = 2
    rs[2].oracle_s = Some(0.0); // seen from the start: 1 / 0.2 = 5
    let cells = summarise(&rs);
    let a = &cells[0];
    assert_eq!(a.oracle_trials, 3);
    assert!((a.oracle_ratio - 10.0 / 3.0).abs() < 1e-12, "{}", a.oracle_ratio);
    assert!((a.mean_oracle_s - 70.0 / 3.0).abs() < 1e-12);
    assert_eq!((cells[1].oracle_trials, cells[1].oracle_ratio.is_nan()), (0, true));
    let md = markdown_table(&cells);
    assert!(md.contains("| setting | oracle, mean | a | b |"), "{md}");
    assert!(md.contains("| apartment easy | 23.3 s | 3.33 ± "), "{md}");
    assert!(md.contains(" | — |\n"), "{md}");
    assert!(csv(&cells).lines().nth(1).unwrap().ends_with(",3,23.333,3.3333,3.7949"), "{}", csv(&cells));
}

#[test]
fn oracles_are_computed_once_per_trial_and_shared_by_the_planners() {
    // Two planners, two seeds on one small world: four results, two oracles.
    let world = World::random_scenario(3, Scenario::Easy);
    let specs: Vec<SearchSpec> = [PlannerChoice::Nearest, PlannerChoice::Multisensor]
        .into_iter()
        .flat_map(|p| (1..=2).map(move |seed| (p, seed)))
        .map(|(p, seed)| SearchSpec::new("random-3", world.clone(), Scenario::Easy, p, seed))
        .collect();
    let mut rs: Vec<SearchResult> = specs.iter().map(|_| result("x", true, 5.0)).collect();
    attach_oracles(&specs, &mut rs, 2);
    let o: Vec<f64> = rs.iter().map(|r| r.oracle_s.expect("every trial has one")).collect();
    assert_eq!((o[0], o[1]), (o[2], o[3]), "the same trial, the same oracle, whatever the planner");
    let direct = crate::sim::oracle::oracle(&specs[1].world, &specs[1].sim, 2).unwrap().time_s;
    assert_eq!(o[1], direct);
    assert!(o.iter().all(|&t| t >= 0.0 && t < world.time_limit_s), "{o:?}");
}

#[test]
fn heldout_seeds_are_disjoint_from_tunes_and_split_into_easy_and_hard() {
    // `lives tune` has used worlds 1-384 and refuses the held-out range (cli/tune.rs); the
    // datasets 1-1200.
    assert!(!overlaps_heldout(1, 384) && !overlaps_heldout(1, 1200));
    assert!(overlaps_heldout(1, HELDOUT_FIRST_SEED) && overlaps_heldout(HELDOUT_FIRST_SEED + 999, u64::MAX));
    assert!(!overlaps_heldout(HELDOUT_FIRST_SEED + HELDOUT_MAX_WORLDS, u64::MAX));
    // The default tune range (`--worlds 48 --first-world 1`) is outside.
    assert!(!overlaps_heldout(1, 48));
    let specs =
        heldout_specs(0, 5, &[PlannerChoice::Nearest, PlannerChoice::Lives], firmware::classifier::EMBEDDED_GEO_MODEL, |_| Ok(())).unwrap();
    assert_eq!(specs.len(), 10);
    let seeds: Vec<u64> = specs.iter().step_by(2).map(|s| s.seed).collect();
    assert_eq!(seeds, (HELDOUT_FIRST_SEED..HELDOUT_FIRST_SEED + 5).collect::<Vec<_>>());
    let scen: Vec<&str> = specs.iter().step_by(2).map(|s| s.scenario_label()).collect();
    assert_eq!(scen, ["easy", "hard", "easy", "hard", "easy"]);
    assert!(specs.iter().all(|s| s.world_name == HELDOUT_WORLD));
    assert_eq!(specs[0].world, World::random_scenario(HELDOUT_FIRST_SEED, Scenario::Easy));
    assert!(specs[1].model.is_some() && specs[0].model.is_none(), "lives runs the classifier");
    assert!(heldout_specs(0, HELDOUT_MAX_WORLDS + 1, &[PlannerChoice::Nearest], &[], |_| Ok(())).is_err());
    assert!(heldout_specs(HELDOUT_MAX_WORLDS - 2, 3, &[PlannerChoice::Nearest], &[], |_| Ok(())).is_err());
    assert!(heldout_specs(u64::MAX, 3, &[PlannerChoice::Nearest], &[], |_| Ok(())).is_err());
    // A second set: worlds 3 and 4 are the same worlds, in the same scenarios, as in the first.
    let second = heldout_specs(3, 2, &[PlannerChoice::Nearest], &[], |_| Ok(())).unwrap();
    let first = heldout_specs(0, 5, &[PlannerChoice::Nearest], &[], |_| Ok(())).unwrap();
    assert_eq!(
        second.iter().map(|s| (s.seed, s.scenario_label())).collect::<Vec<_>>(),
        [(HELDOUT_FIRST_SEED + 3, "hard"), (HELDOUT_FIRST_SEED + 4, "easy")]
    );
    assert_eq!((&second[0].world, &second[1].world), (&first[3].world, &first[4].world));
}

#[test]
fn tune_scores_the_defaults_and_pairs_every_assignment_with_them() {
    // `w_dist_per_m=1` is the default: the same searches, so a paired difference of exactly 0.
    let grid = vec![parse_grid_axis("w_dist_per_m=1,8").unwrap()];
    let scores =
        tune(&grid, &[PlannerChoice::Multisensor], &Scenario::ALL, 1..=2, 2, firmware::classifier::EMBEDDED_GEO_MODEL, |_, _| {}).unwrap();
    assert_eq!(scores.len(), 3, "the defaults and the two grid values");
    assert!(scores.iter().all(|s| s.searches == 4), "2 worlds × 2 scenarios × 1 planner");
    for s in &scores {
        assert_eq!(s.per_search.len(), 4);
        assert!((s.per_search.iter().sum::<f64>() / 4.0 - s.mean_normalised_time).abs() < 1e-12);
        assert!(s.per_search.iter().all(|x| (0.0..=1.0).contains(x)));
    }
    let find = |sets: &[&str]| scores.iter().find(|s| s.sets == sets).unwrap();
    let (base, same, far) = (find(&[]), find(&["w_dist_per_m=1"]), find(&["w_dist_per_m=8"]));
    assert_eq!((base.vs_defaults, base.vs_defaults_ci95), (0.0, 0.0));
    assert_eq!(same.mean_normalised_time, base.mean_normalised_time);
    assert_eq!((same.vs_defaults, same.vs_defaults_ci95), (0.0, 0.0));
    let d = far.mean_normalised_time - base.mean_normalised_time;
    assert!((far.vs_defaults - d).abs() < 1e-12, "the mean of the differences is the difference of the means");
    assert!(scores.windows(2).all(|w| w[0].mean_normalised_time <= w[1].mean_normalised_time), "best first");
}

#[test]
fn the_claims_are_checked_per_trial_against_the_same_seeds() {
    let mk = |planner: &str, scenario: &str, seed: u64, found: bool, t: f64| {
        let mut r = result(planner, found, t);
        r.scenario = scenario.into();
        r.seed = seed;
        if !found {
            r.time_s = if scenario == "hard" { 180.0 } else { 120.0 };
        }
        r.time_limit_s = r.time_s.max(r.time_limit_s);
        r
    };
    let rs = vec![
        mk("multisensor", "hard", 1, true, 100.0),
        mk("multisensor", "hard", 2, true, 120.0),
        mk("lives", "hard", 1, true, 80.0),
        mk("lives", "hard", 2, false, 0.0),
        mk("nearest", "hard", 1, true, 90.0),
        mk("nearest", "hard", 2, true, 90.0),
    ];
    let md = claims(&rs).expect("lives and multisensor ran");
    // lives: 1 of 2 found; hard mean (80 + 180) / 2 = 130 vs 110: 1.182×; paired −20 and +60.
    assert!(md.contains("| 100 % success in every setting | no: apartment hard 1/2 |"), "{md}");
    assert!(md.contains("1.182× (130.0 s vs 110.0 s; paired Δ +20.0 ± "), "{md}");
    assert!(md.contains("over 2 trials"), "{md}");
    assert!(md.contains("no, 1 of 1: apartment hard vs nearest (130.0 ≥ 90.0 s)"), "{md}");
    assert!(claims(&rs[4..]).is_none(), "nothing to check without lives and multisensor");
}

#[test]
fn grids_expand_to_every_combination() {
    let g = vec![parse_grid_axis("a=1,2").unwrap(), parse_grid_axis("b=x").unwrap()];
    assert_eq!(grid_assignments(&g), vec![vec!["a=1".to_string(), "b=x".into()], vec!["a=2".into(), "b=x".into()]]);
    assert!(parse_grid_axis("a").is_err());
    assert!(parse_grid_axis("a=").is_err());
}

#[test]
fn a_batch_returns_results_in_spec_order_whatever_the_threads() {
    let world = World::random(3);
    let specs: Vec<SearchSpec> = (1..=4)
        .map(|seed| {
            let mut s = SearchSpec::new("random-3", world.clone(), Scenario::Easy, PlannerChoice::Nearest, seed);
            s.world.time_limit_s = 10.0;
            s
        })
        .collect();
    let one = run_batch(&specs, 1, |_| {}).unwrap();
    let two = run_batch(&specs, 2, |_| {}).unwrap();
    assert_eq!(one, two);
    assert_eq!(one.iter().map(|r| r.seed).collect::<Vec<_>>(), vec![1, 2, 3, 4]);
}
