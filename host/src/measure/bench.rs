//! `lives bench`: host wall-clock timings of the core's stages on a realistic map.
//!
//! The map comes from a real simulated search (office, hard scenario, `lives-gt`, seed 1) stopped
//! after `explore_s` virtual seconds, so the grids, non-map points and frontiers are what the
//! controller actually sees mid-search. Each stage is repeated and the median reported. These are
//! measurements, not assertions: nothing here fails on a slow machine.

use crate::search::{self, PlannerChoice, SearchSpec};
use crate::sim::{Scenario, World};
use firmware::grid::Cell;
use std::time::Instant;

fn median_ms(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2] * 1e3
}

fn time<F: FnMut()>(reps: usize, mut f: F) -> f64 {
    let reps = reps.max(1);
    let mut v = Vec::with_capacity(reps);
    for _ in 0..reps {
        let t = Instant::now();
        f();
        v.push(t.elapsed().as_secs_f64());
    }
    median_ms(v)
}

/// Runs the benchmark and prints a table.
pub fn run(reps: usize, explore_s: f64, searches: bool) {
    let mut world = World::builtin("office", Scenario::Hard).expect("built-in office world");
    world.time_limit_s = explore_s;
    let spec = SearchSpec::new("office", world, Scenario::Hard, PlannerChoice::LivesGt, 1);
    let mut run = search::run(&spec, |_| {});
    let ctrl = &mut run.controller;
    let pose = ctrl.pose().expect("the search produced a pose");
    let cfg = *ctrl.config();
    let beams = ctrl.beams().clone();
    let free = ctrl.lidar.grid.count(Cell::Free);
    let occ = ctrl.lidar.grid.count(Cell::Occupied);
    let seen = ctrl.visual.grid.count(Cell::Free) + ctrl.visual.grid.count(Cell::Occupied);

    let mut lidar = Box::new(ctrl.lidar.clone());
    let mut lidar_work = 0;
    let t_lidar = time(reps, || lidar_work = lidar.integrate(&pose, &beams, cfg.lidar_max_range_m).work);
    // The scan matcher on the same scan against the same map, from the pose 10 cm and 1° off (a
    // step's worth of drift and more), after a 10 cm, 2° motion.
    let mut matcher = Box::new(firmware::matcher::ScanMatcher::new());
    let off = firmware::Pose2::new(
        pose.x.saturating_add(fixed_point::Meters::from_bits(6554)),
        pose.y,
        pose.theta + firmware::BinaryAngle::from_degrees(1),
    );
    let mut match_work = 0;
    let motion = firmware::matcher::Motion { dist_mm: 100, turn_mdeg: 2_000 };
    let t_match = time(reps, || {
        let _ = matcher.match_scan(&ctrl.lidar, &ctrl.lidar.geom, &off, &beams, cfg.lidar_max_range_m, motion);
        match_work = matcher.stats.last_work;
    });
    let mut visual = Box::new(ctrl.visual.clone());
    let mut visual_work = 0;
    let t_visual = time(reps, || visual_work = visual.integrate(&ctrl.lidar, &pose, cfg.camera_fov, cfg.camera_range_m));
    let current = ctrl.goal().map(|g| (g.viewpoint.cell, g.viewpoint.heading));
    let mut plan_work = 0;
    let mut candidates = 0;
    let c = &mut **ctrl;
    let t_plan = time(reps, || {
        plan_work = c.frontiers.compute(&c.lidar, &c.visual, cfg.min_frontier_cells);
        let _ = c.planner.plan(&cfg, &c.lidar, &c.visual, &c.frontiers, &c.nonmap, &pose, current, 0);
        plan_work += c.planner.stats.work;
        candidates = c.planner.stats.candidates;
    });
    let t_frontiers = time(reps, || {
        c.frontiers.compute(&c.lidar, &c.visual, cfg.min_frontier_cells);
    });

    // The int8 classifier on the same scan (the committed model, read in place).
    let mut classifier = Box::new(firmware::classifier::Classifier::new(firmware::classifier::ClassifierConfig {
        feedback: firmware::classifier::LabelFeedback::Raw,
    }));
    let mut classify_work = 0;
    let t_classify = match firmware::classifier::ModelView::parse(firmware::classifier::EMBEDDED_MODEL) {
        Ok(model) => {
            classifier.set_model(model);
            let mut labels = [firmware::scan::BeamLabel::Unlabelled; firmware::capacity::BEAMS];
            Some(time(reps, || classify_work = classifier.classify(&pose, &beams, &mut labels)))
        }
        Err(_) => None,
    };

    // The geometric classifier (the default for `lives`): its features and int8 MLP through the
    // firmware, and the same MLP in f32 on the same features (weights dequantised from the blob).
    let mut geo_work = 0;
    let (t_geo, t_geo_float) = match firmware::classifier::geo::GeoView::parse(firmware::classifier::EMBEDDED_GEO_MODEL) {
        Ok(model) => {
            use firmware::classifier::geo::{GeoScratch, GEO_FEATURES, GEO_HIDDEN};
            classifier.set_geo_model(model);
            let mut labels = [firmware::scan::BeamLabel::Unlabelled; firmware::capacity::BEAMS];
            let t_int8 = time(reps, || geo_work = classifier.classify(&pose, &beams, &mut labels));
            let mut scratch = Box::new(GeoScratch::new());
            scratch.prepare(&beams.ranges_mm);
            let feats: Vec<[f32; GEO_FEATURES]> =
                (0..firmware::capacity::BEAMS).map(|b| scratch.features(&beams.ranges_mm, b).map(|v| v as f32 / 127.0)).collect();
            let w1: Vec<[f32; GEO_FEATURES]> =
                (0..GEO_HIDDEN).map(|j| std::array::from_fn(|i| model.hidden_weights(j)[i] as i8 as f32 / 127.0)).collect();
            let w2: Vec<f32> = model.output_weights().chunks_exact(2).map(|v| i16::from_le_bytes([v[0], v[1]]) as f32 / 32_767.0).collect();
            let t_f32 = time(reps, || {
                let mut map = 0usize;
                for x in &feats {
                    let o: f32 = w1.iter().zip(&w2).map(|(row, v)| v * row.iter().zip(x).map(|(a, b)| a * b).sum::<f32>().tanh()).sum();
                    map += (o >= 0.0) as usize;
                }
                std::hint::black_box(map);
            });
            (Some(t_int8), Some(t_f32))
        }
        Err(_) => (None, None),
    };

    // The float reference of the same network (`host::learn::model`, f32, the committed model's
    // shapes; the weights do not change the time) on the same scan, filled history.
    let float_model = crate::learn::model::FloatModel::random(1);
    let mut history = crate::learn::model::FloatHistory::new(float_model.norm);
    for _ in 0..firmware::classifier::HISTORY {
        history.push_scan(&pose, &beams.ranges_mm);
        history.push_labels(&[1.0; firmware::capacity::BEAMS]);
    }
    let inputs = history.inputs();
    let t_float = time(reps, || {
        std::hint::black_box(float_model.forward(std::hint::black_box(&inputs)));
    });

    // The map-based ground-truth labeller (training labels) on 20 scans of a procedural
    // building, with its 10-scan history full: the time per scan.
    let t_labeller = {
        let world = World::random(11);
        let mut sim = crate::sim::Sim::new(world.clone(), crate::sim::SimConfig::default(), 1);
        let mut scans = Vec::new();
        for _ in 0..20 {
            scans.push((sim.pose(), sim.scan()));
            sim.step(0.2);
        }
        time(reps, || {
            let mut lab = crate::learn::labeller::Labeller::for_world(&world, crate::learn::labeller::LabellerConfig::default());
            for (p, sc) in &scans {
                std::hint::black_box(lab.label_scan(*p, sc));
            }
        }) / scans.len() as f64
    };

    println!(
        "map: office hard after {explore_s:.0} s of lives-gt search: {free} free, {occ} occupied LiDAR cells; {seen} camera-seen cells;"
    );
    println!(
        "     {} non-map points, {} frontiers, {candidates} candidate viewpoints (512 x 512 grid, 0.10 m)",
        c.nonmap.points().len(),
        c.frontiers.frontiers().len()
    );
    println!("{:<36} {:>12} {:>14}", "stage (host, release)", "median ms", "work units");
    match t_classify {
        Some(t) => println!("{:<36} {:>12.3} {:>14}", "classify (int8, embedded model)", t, classify_work),
        None => println!("{:<36} {:>12} {:>14}", "classify (int8, embedded model)", "no model", ""),
    }
    println!("{:<36} {:>12.3} {:>14}", "classify (f32 reference, host)", t_float, "");
    match (t_geo, t_geo_float) {
        (Some(t), Some(f)) => {
            println!("{:<36} {:>12.3} {:>14}", "classify geometric (int8, default)", t, geo_work);
            println!("{:<36} {:>12.3} {:>14}", "classify geometric (f32 MLP only)", f, "");
        }
        _ => println!("{:<36} {:>12} {:>14}", "classify geometric (int8)", "no model", ""),
    }
    println!("{:<36} {:>12.3} {:>14}", "labeller (ground truth, per scan)", t_labeller, "");
    println!("{:<36} {:>12.3} {:>14}", "LiDAR update (897 beams)", t_lidar, lidar_work);
    println!("{:<36} {:>12.3} {:>14}", "scan matching (160 points)", t_match, match_work);
    println!("{:<36} {:>12.3} {:>14}", "visual update (camera cone)", t_visual, visual_work);
    println!("{:<36} {:>12.3} {:>14}", "frontiers (both maps)", t_frontiers, "");
    println!("{:<36} {:>12.3} {:>14}", "full planning step (frontiers+plan)", t_plan, plan_work);
    let vlp = crate::io::sensors::vlp16::default_recording();
    match crate::io::sensors::vlp16::bench_decode(&vlp, reps) {
        Some(b) => println!(
            "{:<36} {:>12.3} {:>14}",
            format!("VLP-16 decode+bin ({} packets)", b.packets),
            b.median_ms,
            format!("{:.0} pkt/s", b.packets_per_s)
        ),
        None => println!("{:<36} {:>12} {:>14}", "VLP-16 decode+bin", "no data", vlp.display()),
    }
    println!("({reps} repetitions each; median)");

    if searches {
        println!();
        // `apartment hard`: full-length searches (most run to the 180 s limit), where the
        // easy ones end in seconds. `lives` runs the committed int8 classifier every scan, as
        // `lives search` does.
        println!("{:<28} {:>10} {:>10} {:>12}", "search (apartment hard)", "sim s", "wall s", "x real time");
        let planners = [PlannerChoice::LivesGt, PlannerChoice::Lives];
        let specs = crate::measure::eval::eval_specs(
            &["apartment".to_string()],
            &[Scenario::Hard],
            &planners,
            5,
            firmware::classifier::EMBEDDED_GEO_MODEL,
            |_| Ok(()),
        )
        .expect("the built-in apartment");
        for planner in planners {
            let (mut sim_total, mut wall_total) = (0.0, 0.0);
            for spec in specs.iter().filter(|s| s.planner == planner) {
                let seed = spec.seed;
                let t = Instant::now();
                let Ok(r) = search::try_run(spec, |_| {}) else {
                    println!("{planner} seed {seed}: the committed model does not validate");
                    continue;
                };
                let wall = t.elapsed().as_secs_f64();
                let sim_s = r.result.ticks as f64 * crate::run::TICK_US as f64 / 1e6;
                sim_total += sim_s;
                wall_total += wall;
                println!("{:<28} {:>10.1} {:>10.3} {:>12.0}", format!("{planner} seed {seed}"), sim_s, wall, sim_s / wall);
            }
            println!("{:<28} {:>10.1} {:>10.3} {:>12.0}", format!("{planner} total"), sim_total, wall_total, sim_total / wall_total);
        }
    }
}
