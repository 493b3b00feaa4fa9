//! Behaviour of the controller core that a user relies on (issue 2's acceptance list).

mod common;
use common::*;
use firmware::frontier::FrontierSource;
use firmware::grid::{Cell, GridGeometry, LidarGrid, VisualGrid};
use firmware::scan::{BeamLabel, BeamScan, RANGE_NO_RETURN};
use firmware::{BinaryAngle, Command, Config, FrontierSet, Inputs, Mode, NonMapStore, Planner, PlannerKind};

fn geom() -> GridGeometry {
    GridGeometry { origin_x: Config::mm(0), origin_y: Config::mm(0) }
}

/// A scan resampled from `ranges_mm`, the first beam at `angle_min`, the others `angle_increment`
/// apart (no labels, the core's range limits).
fn resampled(angle_min: BinaryAngle, angle_increment: BinaryAngle, ranges_mm: &[u16]) -> BeamScan {
    let mut s = BeamScan::new();
    s.resample(&firmware::ScanInput {
        angle_min,
        angle_increment,
        ranges_mm,
        labels: None,
        range_min_mm: 0,
        range_max_mm: firmware::scan::RANGE_LIMIT_MM,
    })
    .unwrap();
    s
}

fn one_beam_scan(angle_deg: i32, range_mm: u16) -> BeamScan {
    resampled(BinaryAngle::from_degrees(angle_deg), BinaryAngle::from_degrees(1), &[range_mm])
}

#[test]
fn a_beam_clears_the_cells_it_crosses_and_marks_its_hit() {
    let mut g = Box::new(LidarGrid::new(geom()));
    // Robot at the centre of cell (100, 100), looking along +x; one beam straight ahead, 3.0 m.
    let p = pose(10.05, 10.05, 0.0);
    let s = one_beam_scan(0, 3000);
    g.integrate(&p, &s, Config::DEFAULT.lidar_max_range_m);
    for x in 100..130 {
        assert_eq!(g.get(x, 100), Cell::Free, "cell ({x}, 100) on the beam");
    }
    assert_eq!(g.get(130, 100), Cell::Occupied, "the hit at 13.05 m");
    assert_eq!(g.get(131, 100), Cell::Unknown, "nothing beyond the hit");
    assert_eq!(g.get(115, 101), Cell::Unknown, "nothing beside the beam");
    assert_eq!(g.grid.count(Cell::Occupied), 1);
    assert_eq!(g.grid.count(Cell::Free), 30);

    // A no-return beam (pointing −y) clears up to the maximum range and marks nothing.
    let s = one_beam_scan(-90, RANGE_NO_RETURN);
    let cfg = Config { lidar_max_range_m: Config::mm(5_000), ..Config::DEFAULT };
    g.integrate(&p, &s, cfg.lidar_max_range_m);
    for y in 50..100 {
        assert_eq!(g.get(100, y), Cell::Free, "cell (100, {y}) on the no-return beam");
    }
    assert_eq!(g.get(100, 49), Cell::Unknown);
    assert_eq!(g.grid.count(Cell::Occupied), 1);

    // A hit seen again later by a grazing beam of the same scan stays occupied.
    let s2 = resampled(BinaryAngle::ZERO, BinaryAngle::from_fraction(1, 897), &[3000, 2950]);
    g.integrate(&p, &s2, Config::DEFAULT.lidar_max_range_m);
    assert_eq!(g.get(130, 100), Cell::Occupied);
}

#[test]
fn a_beam_that_grazes_its_surface_frees_unknown_cells_but_erases_no_occupied_one() {
    // Three neighbouring beams straight ahead from the centre of cell (100, 100); a cell marked
    // occupied by an earlier scan lies on all three, 1.5 m out.
    let p = pose(10.05, 10.05, 0.0);
    let run = |ranges: [u16; 3]| {
        let s = resampled(BinaryAngle::from_fraction(-1, 897), BinaryAngle::from_fraction(1, 897), &ranges);
        let mut g = Box::new(LidarGrid::new(geom()));
        g.grid.set(115, 100, Cell::Occupied);
        g.integrate(&p, &s, Config::DEFAULT.lidar_max_range_m);
        g
    };
    // A surface facing the robot (the neighbours' ranges agree): the stale cell is cleared.
    let g = run([3000, 3000, 3000]);
    assert_eq!(g.get(115, 100), Cell::Free, "a steep beam clears what moved away");
    assert_eq!(g.get(130, 100), Cell::Occupied);
    // A wall seen edge-on (the neighbours' ranges 1 m shorter and longer): it stays occupied,
    // and the unknown cells on the way are freed as before. Its return, between a nearer and a
    // farther neighbour, is one a mixed pixel also gives (`grid::veiling`): it marks nothing.
    let g = run([2000, 3000, 4000]);
    assert_eq!(g.get(115, 100), Cell::Occupied, "a grazing beam does not erase the wall");
    assert_eq!(g.get(110, 100), Cell::Free);
    assert_ne!(g.get(130, 100), Cell::Occupied, "a veiling return marks no cell (the farther neighbour's ray frees it)");
    // A thin object one beam wide (both neighbours farther) is kept.
    let g = run([4000, 3000, 4000]);
    assert_eq!(g.get(130, 100), Cell::Occupied, "a post one beam wide");
    // The threshold: a neighbour more than 28 mm per metre of the beam's own range away; invalid
    // and no-return neighbours say nothing; the beams wrap around the circle.
    let mut s = BeamScan::new();
    let step = (3000 * firmware::grid::GRAZING_STEP_PER_MILLE / 1000) as u16;
    s.ranges_mm[0] = 3000;
    s.ranges_mm[1] = 3000 + step;
    assert!(!firmware::grid::grazing(&s, 0), "at the threshold");
    s.ranges_mm[1] = 3000 + step + 1;
    assert!(firmware::grid::grazing(&s, 0), "just past it");
    s.ranges_mm[1] = RANGE_NO_RETURN;
    assert!(!firmware::grid::grazing(&s, 0));
    s.ranges_mm[firmware::capacity::BEAMS - 1] = 1000;
    assert!(firmware::grid::grazing(&s, 0), "beam 0's other neighbour is the last beam");
}

#[test]
fn a_beam_with_no_return_stops_short_of_the_surface_its_neighbours_see() {
    // A wall 3 m ahead (x = 13.05 m for a robot at 10.05 m facing +x), seen over ±30°, with a
    // dark patch straight ahead that returns nothing for ±2°: as glass, black paint or a wall met
    // edge-on do on a real scanner.
    let p = pose(10.05, 10.05, 0.0);
    let inc = BinaryAngle::from_fraction(1, 897);
    let n = 2 * 75 + 1;
    let ranges: Vec<u16> = (0..n)
        .map(|k| {
            let phi = (k as f64 - 75.0) * std::f64::consts::TAU / 897.0;
            if phi.abs() <= 2f64.to_radians() {
                RANGE_NO_RETURN
            } else {
                (3000.0 / phi.cos()).round() as u16
            }
        })
        .collect();
    let s = resampled(BinaryAngle::from_fraction(-75, 897), inc, &ranges);
    let mut bounds = [0u16; firmware::capacity::BEAMS];
    firmware::grid::no_return_bounds(&s, Config::DEFAULT.lidar_max_range_m, &mut bounds);
    let ahead = BeamScan::beam_of(BinaryAngle::ZERO);
    assert_eq!(s.ranges_mm[ahead], RANGE_NO_RETURN);
    // Bounded at the wall, one cell short: 2.9 m, within a few millimetres.
    assert!((bounds[ahead] as i32 - 2900).abs() <= 5, "bound {} mm", bounds[ahead]);
    let mut g = Box::new(LidarGrid::new(geom()));
    g.integrate(&p, &s, Config::DEFAULT.lidar_max_range_m);
    assert_eq!(g.get(120, 100), Cell::Free, "in front of the wall");
    assert_eq!(g.get(140, 100), Cell::Unknown, "behind the wall: nothing seen there");
    // Open space (no return anywhere) is still cleared out to the range.
    let open = resampled(BinaryAngle::from_fraction(-75, 897), inc, &vec![RANGE_NO_RETURN; n]);
    firmware::grid::no_return_bounds(&open, Config::DEFAULT.lidar_max_range_m, &mut bounds);
    assert!(bounds.iter().all(|&b| b == firmware::grid::NO_BOUND));
    let mut g = Box::new(LidarGrid::new(geom()));
    g.integrate(&p, &open, Config::DEFAULT.lidar_max_range_m);
    assert_eq!(g.get(140, 100), Cell::Free);
    // Two returns a quarter turn or more apart bound nothing (nearly opposite each other, the
    // segment between them would pass through the sensor).
    let mut half = BeamScan::new();
    half.ranges_mm = [RANGE_NO_RETURN; firmware::capacity::BEAMS];
    half.ranges_mm[0] = 2000;
    half.ranges_mm[firmware::capacity::BEAMS / 2 + 1] = 2000;
    firmware::grid::no_return_bounds(&half, Config::DEFAULT.lidar_max_range_m, &mut bounds);
    assert!(bounds.iter().all(|&b| b == firmware::grid::NO_BOUND), "two returns half a turn apart");
    half.ranges_mm[firmware::capacity::BEAMS / 2 + 1] = RANGE_NO_RETURN;
    half.ranges_mm[firmware::capacity::BEAMS / 4] = 2000;
    firmware::grid::no_return_bounds(&half, Config::DEFAULT.lidar_max_range_m, &mut bounds);
    assert!(bounds.iter().all(|&b| b == firmware::grid::NO_BOUND), "a quarter turn apart");
    half.ranges_mm[firmware::capacity::BEAMS / 4 - 1] = 2000;
    firmware::grid::no_return_bounds(&half, Config::DEFAULT.lidar_max_range_m, &mut bounds);
    assert!(bounds[1] != firmware::grid::NO_BOUND, "just under a quarter turn: bounded");
}

#[test]
fn the_camera_does_not_see_through_an_occupied_cell() {
    let mut lidar = Box::new(LidarGrid::new(geom()));
    // Known free ahead of the robot, and a wall 2 m ahead spanning the whole cone.
    for y in 60..141 {
        for x in 100..150 {
            lidar.grid.set(x, y, Cell::Free);
        }
        lidar.grid.set(120, y, Cell::Occupied);
    }
    let mut vis = Box::new(VisualGrid::new());
    let p = pose(10.05, 10.05, 0.0);
    vis.integrate(&lidar, &p, Config::DEFAULT.camera_fov, Config::DEFAULT.camera_range_m);
    assert!(vis.seen(110, 100), "in front of the wall");
    assert_eq!(vis.get(120, 100), Cell::Occupied, "the wall itself is seen");
    for y in 60..141 {
        for x in 121..150 {
            assert!(!vis.seen(x, y), "({x}, {y}) is behind the wall");
        }
    }
    // Without the wall the same cells are seen (the test above is not vacuous).
    for y in 60..141 {
        lidar.grid.set(120, y, Cell::Free);
    }
    vis.integrate(&lidar, &p, Config::DEFAULT.camera_fov, Config::DEFAULT.camera_range_m);
    assert!(vis.seen(125, 100) && vis.seen(135, 100));
    // And nothing outside the 90° cone: straight behind and to the side stay unseen.
    assert!(!vis.seen(95, 100) && !vis.seen(100, 110));
}

/// A closed square room (walls occupied, inside free) with an optional doorway to unknown space.
fn room_grid(door: bool) -> Box<LidarGrid> {
    let mut g = Box::new(LidarGrid::new(geom()));
    for y in 50..=100 {
        for x in 50..=100 {
            let edge = x == 50 || x == 100 || y == 50 || y == 100;
            g.grid.set(x, y, if edge { Cell::Occupied } else { Cell::Free });
        }
    }
    if door {
        for y in 70..80 {
            g.grid.set(100, y, Cell::Unknown);
        }
    }
    g
}

#[test]
fn a_closed_room_has_no_frontier_and_an_open_doorway_has_one() {
    let vis = Box::new(VisualGrid::new());
    let mut f = Box::new(FrontierSet::new());
    f.compute(&room_grid(false), &vis, 8);
    assert_eq!(f.frontiers().iter().filter(|fr| fr.source == FrontierSource::Lidar).count(), 0);

    f.compute(&room_grid(true), &vis, 8);
    let lidar: Vec<_> = f.frontiers().iter().filter(|fr| fr.source == FrontierSource::Lidar).collect();
    assert_eq!(lidar.len(), 1, "{lidar:?}");
    assert_eq!(lidar[0].cells, 10);
    assert_eq!(lidar[0].anchor.0, 99, "the frontier is the free column inside the doorway");
    assert!((70..80).contains(&lidar[0].anchor.1));
    // A doorway narrower than min_frontier_cells is dropped.
    let mut g = room_grid(false);
    for y in 70..73 {
        g.grid.set(100, y, Cell::Unknown);
    }
    f.compute(&g, &vis, 8);
    assert_eq!(f.frontiers().iter().filter(|fr| fr.source == FrontierSource::Lidar).count(), 0);
    assert_eq!(f.stats.dropped_small, 1);
}

/// Room with a doorway; the visual map has seen everything inside, so only the non-map term can
/// tell the four viewpoints apart when the unknown/frontier weights are zero.
fn score_headings(kind: PlannerKind, with_points: bool) -> [i64; 4] {
    score_headings_capped(kind, with_points, 0)
}

/// [`score_headings`] with `nonmap_view_cap` set.
fn score_headings_capped(kind: PlannerKind, with_points: bool, nonmap_view_cap: u16) -> [i64; 4] {
    let lidar = room_grid(true);
    let vis = seen_east_of(51);
    let mut f = Box::new(FrontierSet::new());
    let mut store = Box::new(NonMapStore::new());
    let cfg = Config {
        planner: kind,
        w_unknown_per_cell: Config::weight_milli(0),
        w_frontier_per_cell: Config::weight_milli(0),
        // Only frontier viewpoints here: the test compares the four headings of one site.
        nonmap_viewpoints: false,
        nonmap_view_cap,
        ..Config::DEFAULT
    };
    if with_points {
        // A cluster of non-map points 2 m west of the doorway, inside the room.
        for k in 0..6 {
            store.insert(&geom(), Config::mm(7_800), Config::mm(7_000 + 100 * k), cfg.nonmap_pool_radius_m);
            store.insert(&geom(), Config::mm(7_850), Config::mm(7_050 + 100 * k), cfg.nonmap_pool_radius_m);
        }
        assert!(store.points().len() >= 3);
    }
    f.compute(&lidar, &vis, cfg.min_frontier_cells);
    let mut planner = Box::new(Planner::new());
    let robot = pose(6.05, 6.05, 0.0);
    let (goal, _) = planner.plan(&cfg, &lidar, &vis, &f, &store, &robot, None, 0);
    assert!(goal.is_some());
    let anchor = f.frontiers().iter().find(|fr| fr.source == FrontierSource::Lidar).unwrap().anchor;
    let mut out = [i64::MIN; 4];
    for vp in planner.candidates.iter().filter(|v| v.cell == anchor) {
        let h =
            firmware::planner::HEADINGS.iter().position(|&h| h == vp.heading).expect("a frontier viewpoint faces one of the four headings");
        out[h] = vp.utility;
    }
    assert!(out.iter().all(|&u| u != i64::MIN), "all four viewpoints scored: {out:?}");
    out
}

#[test]
fn non_map_points_make_a_viewpoint_win_under_lives_but_not_multisensor() {
    // Headings: 0 = east (out of the door), 1 = north, 2 = west (towards the points), 3 = south.
    let lives = score_headings(PlannerKind::LivesGreedy, true);
    assert!(lives[2] > lives[0] && lives[2] > lives[1] && lives[2] > lives[3], "{lives:?}");
    let multi = score_headings(PlannerKind::Multisensor, true);
    assert_eq!(multi[2], multi[0], "{multi:?}");
    assert!(multi.iter().all(|&u| u == multi[0]), "{multi:?}");
    // And under lives without points, the west viewpoint has no advantage either.
    let empty = score_headings(PlannerKind::LivesGreedy, false);
    assert!(empty.iter().all(|&u| u == empty[0]), "{empty:?}");
}

#[test]
fn at_most_nonmap_view_cap_points_count_in_one_view() {
    // West (heading 2) sees the cluster; the other headings see none of it.
    let w = Config::DEFAULT.w_nonmap_per_point.to_bits() as i64;
    let uncapped = score_headings_capped(PlannerKind::LivesGreedy, true, 0);
    let points = (uncapped[2] - uncapped[0]) / w;
    assert!(points >= 3 && (uncapped[2] - uncapped[0]) % w == 0, "{points} points in view: {uncapped:?}");
    let capped = score_headings_capped(PlannerKind::LivesGreedy, true, 2);
    assert_eq!(capped[2] - capped[0], 2 * w, "{capped:?}");
    assert_eq!((capped[0], capped[1], capped[3]), (uncapped[0], uncapped[1], uncapped[3]), "views without points are unchanged");
    // A cap above the count changes nothing.
    assert_eq!(score_headings_capped(PlannerKind::LivesGreedy, true, points as u16), uncapped);
}

#[test]
fn an_unreachable_frontier_is_never_chosen() {
    // The robot's closed room (no frontier) and, separately, an enclosed pocket of free space
    // with a big frontier and many non-map points: attractive but unreachable.
    let mut lidar = room_grid(false);
    for y in 200..=240 {
        for x in 200..=240 {
            let edge = x == 200 || y == 200 || y == 240;
            lidar.grid.set(x, y, if edge { Cell::Occupied } else { Cell::Free });
        }
    }
    // x = 240 column left unknown: a 39-cell frontier inside the pocket.
    for y in 201..240 {
        lidar.grid.set(240, y, Cell::Unknown);
    }
    let vis = Box::new(VisualGrid::new());
    let mut store = Box::new(NonMapStore::new());
    for k in 0..20 {
        store.insert(&geom(), Config::mm(22_000 + 50 * k), Config::mm(22_000), Config::mm(200));
    }
    let mut f = Box::new(FrontierSet::new());
    let cfg = Config::DEFAULT;
    let robot = pose(7.55, 7.55, 0.0);
    for kind in PlannerKind::ALL {
        let cfg = Config { planner: kind, ..cfg };
        f.compute(&lidar, &vis, cfg.min_frontier_cells);
        assert!(f.frontiers().iter().any(|fr| fr.source == FrontierSource::Lidar && fr.anchor.0 > 200));
        let mut planner = Box::new(Planner::new());
        let (goal, _) = planner.plan(&cfg, &lidar, &vis, &f, &store, &robot, None, 0);
        if let Some(g) = &goal {
            assert!(g.viewpoint.cell.0 <= 100 && g.viewpoint.cell.1 <= 100, "{kind:?} chose {:?}", g.viewpoint);
        }
        assert!(planner.candidates.iter().all(|c| c.cell.0 <= 100), "{kind:?} scored an unreachable viewpoint");
        // (The `rrt` trees grow from the robot, so they never find the pocket at all. LIVE's
        // route followers look at no frontier: without a route they choose nothing.)
        if kind.is_coverage() {
            assert!(goal.is_none(), "{kind:?} has no route");
            continue;
        }
        assert!(kind == PlannerKind::Rrt || planner.stats.unreachable >= 1, "{kind:?}");
    }
    // With a doorway in the robot's room, its frontier is chosen (and only it).
    let mut lidar2 = room_grid(true);
    for y in 200..=240 {
        for x in 200..240 {
            let edge = x == 200 || y == 200 || y == 240;
            lidar2.grid.set(x, y, if edge { Cell::Occupied } else { Cell::Free });
        }
    }
    f.compute(&lidar2, &vis, cfg.min_frontier_cells);
    let mut planner = Box::new(Planner::new());
    let (goal, _) = planner.plan(&cfg, &lidar2, &vis, &f, &store, &robot, None, 0);
    let g = goal.expect("the doorway frontier is reachable");
    assert!(g.viewpoint.cell.0 <= 100);
    assert!(!g.path.is_empty() && g.path.len() <= firmware::capacity::MAX_PATH_WAYPOINTS);
    // The path starts near the robot and ends at the goal, over traversable cells.
    let last = g.path.last().unwrap();
    assert_eq!((last.0, last.1), (g.pose.x, g.pose.y));
    for &(x, y) in g.path.iter() {
        let (cx, cy) = geom().cell_of(x, y);
        assert!(planner.traversable(cx, cy) || planner.distance(cx, cy) == 0);
    }
}

#[test]
fn explore_lite_trades_distance_against_frontier_size_where_nearest_takes_the_closest() {
    // The robot's room has a small doorway 1 m away (south) and a wide one 4 m away (east).
    let mut lidar = room_grid(false);
    for x in 55..65 {
        lidar.grid.set(x, 50, Cell::Unknown);
    }
    for y in 56..94 {
        lidar.grid.set(100, y, Cell::Unknown);
    }
    let vis = Box::new(VisualGrid::new());
    let store = Box::new(NonMapStore::new());
    let mut f = Box::new(FrontierSet::new());
    let robot = pose(6.05, 6.05, 0.0);
    let mut chosen = Vec::new();
    for kind in [PlannerKind::Nearest, PlannerKind::ExploreLite] {
        let cfg = Config { planner: kind, ..Config::DEFAULT };
        f.compute(&lidar, &vis, cfg.min_frontier_cells);
        let small = f.frontiers().iter().find(|fr| fr.source == FrontierSource::Lidar && fr.anchor.1 < 55).expect("south doorway").anchor;
        let wide = *f.frontiers().iter().find(|fr| fr.source == FrontierSource::Lidar && fr.anchor.0 > 95).expect("east doorway");
        assert_eq!(wide.cells, 38);
        let mut planner = Box::new(Planner::new());
        let (goal, _) = planner.plan(&cfg, &lidar, &vis, &f, &store, &robot, None, 0);
        let g = goal.expect("a goal");
        if kind == PlannerKind::ExploreLite {
            // explore_lite's cost 3·d − cells: about 3·0.9 − 10 for the south doorway, 3·4.2 − 38 for the east one.
            let wide_vp = planner.candidates.iter().find(|c| c.cell == wide.anchor).expect("the east doorway is a candidate");
            let d = ((wide.anchor.0 as f64 - 60.0).powi(2) + (wide.anchor.1 as f64 - 60.0).powi(2)).sqrt() / 10.0;
            let expected = -(3.0 * d - 38.0);
            assert!((wide_vp.utility as f64 / 65536.0 - expected).abs() < 0.01, "{} vs {expected}", wide_vp.utility as f64 / 65536.0);
        }
        chosen.push((g.viewpoint.cell, small, wide.anchor));
    }
    let (nearest, small, _) = chosen[0];
    assert_eq!(nearest, small, "nearest takes the closest frontier");
    let (explore, _, wide) = chosen[1];
    assert_eq!(explore, wide, "explore-lite takes the bigger one a little farther away");
}

fn run_room(ctrl: &mut firmware::Controller, ticks: u32, feed_until: u32) -> Vec<firmware::Outputs> {
    let world = room_world();
    let mut out = Vec::new();
    let mut p = (5.0, 5.0, 0.3);
    for t in 0..ticks {
        let now = t as u64 * 200_000;
        let (ranges, labels) = scan_of(&world, p, 897);
        let feeding = t < feed_until;
        let inputs = Inputs {
            pose: feeding.then(|| pose(p.0, p.1, p.2)),
            scan: feeding.then(|| scan_input(&ranges, Some(&labels))),
            command: (t == 0).then_some(Command::Start),
            ..Inputs::default()
        };
        let o = ctrl.tick(now, &inputs);
        // A crude base: jump 0.1 m along the path each tick.
        if let Some(g) = &o.goal {
            if let Some(&(wx, wy)) = g.path.iter().find(|w| (w.0.to_num::<f64>() - p.0).hypot(w.1.to_num::<f64>() - p.1) > 0.15) {
                let (dx, dy) = (wx.to_num::<f64>() - p.0, wy.to_num::<f64>() - p.1);
                let d = dx.hypot(dy);
                p = (p.0 + dx / d * 0.1, p.1 + dy / d * 0.1, dy.atan2(dx));
            } else {
                p.2 = g.pose.theta.to_radians();
            }
        }
        out.push(o);
    }
    out
}

#[test]
fn the_watchdog_stops_the_robot_and_fresh_data_resumes() {
    let mut c = controller(Config { origin_x_m: Config::mm(0), origin_y_m: Config::mm(0), ..Config::DEFAULT });
    let out = run_room(&mut c, 30, 10);
    assert_eq!(out[9].status.mode, Some(Mode::Exploring));
    assert!(out[9].goal.is_some() && !out[9].stop);
    // Data stops after tick 9 (t = 1.8 s); the watchdog (1.0 s) fires at t > 2.8 s: tick 15.
    assert!(!out[14].stop, "still within the watchdog period");
    assert!(out[15].stop && out[15].goal.is_none());
    assert_eq!(out[15].status.mode, Some(Mode::Stopped));
    assert!(out[29].stop);
    assert_eq!(out[29].status.watchdog_trips, 1);
    // Data flows again: the search resumes.
    let world = room_world();
    let (ranges, labels) = scan_of(&world, (5.0, 5.0, 0.0), 897);
    let o = c.tick(
        30 * 200_000,
        &Inputs { pose: Some(pose(5.0, 5.0, 0.0)), scan: Some(scan_input(&ranges, Some(&labels))), ..Inputs::default() },
    );
    assert_eq!(o.status.mode, Some(Mode::Exploring));
    assert!(!o.stop && o.goal.is_some());
}

#[test]
fn the_same_ticks_give_the_same_outputs() {
    let a = run_room(&mut controller(Config::DEFAULT), 120, 120);
    let b = run_room(&mut controller(Config::DEFAULT), 120, 120);
    assert_eq!(a, b);
    // The run did something: several goals, maps and non-map points.
    let last = a.last().unwrap();
    assert!(last.status.goals >= 2, "{:?}", last.status);
    assert!(last.status.scans == 120);
    let mut c = controller(Config::DEFAULT);
    run_room(&mut c, 120, 120);
    assert!(c.lidar.grid.count(Cell::Free) > 5_000);
    assert!(c.visual.grid.count(Cell::Free) > 500);
}

#[test]
fn bad_scans_are_counted_and_change_nothing() {
    let mut c = controller(Config::DEFAULT);
    let world = room_world();
    let (ranges, labels) = scan_of(&world, (5.0, 5.0, 0.0), 897);
    c.tick(
        0,
        &Inputs {
            pose: Some(pose(5.0, 5.0, 0.0)),
            scan: Some(scan_input(&ranges, Some(&labels))),
            command: Some(Command::Start),
            ..Inputs::default()
        },
    );
    let before = c.lidar.grid.as_bytes().to_vec();
    let bad = scan_input(&ranges, Some(&labels[..10]));
    let o = c.tick(200_000, &Inputs { pose: Some(pose(5.0, 5.0, 0.0)), scan: Some(bad), ..Inputs::default() });
    assert_eq!(o.status.scans_rejected, 1);
    assert!(matches!(o.status.last_scan_error, Some(firmware::ScanError::LabelCountMismatch { .. })));
    assert_eq!(c.lidar.grid.as_bytes(), &before[..]);
    // A pose outside the search area is refused.
    let o = c.tick(400_000, &Inputs { pose: Some(pose(-5.0, 5.0, 0.0)), ..Inputs::default() });
    assert_eq!(o.status.poses_rejected, 1);
    assert_eq!(c.pose(), Some(pose(5.0, 5.0, 0.0)));
    let _ = BeamLabel::Map;
}

#[test]
fn detection_ends_the_search_and_stops_the_robot() {
    let mut c = controller(Config::DEFAULT);
    let world = room_world();
    let (ranges, labels) = scan_of(&world, (5.0, 5.0, 0.0), 897);
    let i = Inputs {
        pose: Some(pose(5.0, 5.0, 0.0)),
        scan: Some(scan_input(&ranges, Some(&labels))),
        command: Some(Command::Start),
        ..Inputs::default()
    };
    assert!(!c.tick(0, &i).stop);
    let o = c.tick(200_000, &Inputs { detection: Some(firmware::Detection { position: None }), ..i });
    assert!(o.stop && o.goal.is_none());
    assert_eq!(o.status.mode, Some(Mode::TargetFound));
}

#[test]
fn a_stage_over_its_budget_is_counted() {
    let tight =
        firmware::config::StageBudgets { lidar_cells: 10, visual_cells: 1_000_000, nonmap_ops: 1_000_000, plan_ops: 10, classify_macs: 0 };
    let mut c = controller(Config { budgets: tight, ..Config::DEFAULT });
    let out = run_room(&mut c, 5, 5);
    let last = out.last().unwrap();
    use firmware::controller::Stage;
    assert_eq!(last.status.overruns_of(Stage::Lidar), 5, "every LiDAR update exceeded 10 cells");
    assert_eq!(last.status.overruns_of(Stage::Visual), 0);
    assert!(last.status.overruns_of(Stage::Plan) >= 1, "the planning step exceeded 10 work units");
    assert_eq!(last.status.overruns_of(Stage::Gaze), 0, "no budget, no overrun");
    assert_eq!(last.status.overruns, [5, 0, last.status.overruns_of(Stage::NonMap), last.status.overruns_of(Stage::Plan), 0]);
    assert!(last.status.cost.of(Stage::Lidar).unwrap() > 10 && last.status.cost.of(Stage::Plan).unwrap() > 10);
    // The stages still ran to completion: a goal exists.
    assert!(last.goal.is_some());
}

#[test]
fn a_goal_blocked_for_too_long_is_blacklisted_and_replaced() {
    let mut c = controller(Config::DEFAULT);
    let world = room_world();
    let p = (5.0, 5.0, 0.0);
    let (ranges, labels) = scan_of(&world, p, 897);
    let tick = |c: &mut firmware::Controller, t: u64, blocked: bool| {
        c.tick(
            t * 200_000,
            &Inputs {
                pose: Some(pose(p.0, p.1, p.2)),
                scan: Some(scan_input(&ranges, Some(&labels))),
                command: (t == 0).then_some(Command::Start),
                base_blocked: blocked,
                ..Inputs::default()
            },
        )
    };
    // A planning step spans two ticks: the first goal comes on the second.
    assert!(tick(&mut c, 0, false).goal.is_none());
    let mut pursued = tick(&mut c, 1, false).goal.expect("a first goal").viewpoint.cell;
    // Blocked for 2 s: waited out (a person passing), nothing blacklisted.
    for t in 2..=11 {
        let o = tick(&mut c, t, true);
        assert_eq!(o.status.blacklisted, 0, "tick {t}");
        if let Some(g) = &o.goal {
            pursued = g.viewpoint.cell;
        }
    }
    // Blocked past 3 s: the goal being pursued is blacklisted and a different one chosen.
    let mut replaced = None;
    for t in 12..=21 {
        let o = tick(&mut c, t, true);
        if o.status.blacklisted > 0 {
            replaced = Some(o);
            break;
        }
        if let Some(g) = &o.goal {
            pursued = g.viewpoint.cell;
        }
    }
    let o = replaced.expect("blacklisted within 4 s of blocking");
    let first = pursued;
    assert!(c.planner.blacklisted().any(|&b| b == first), "{first:?} not in {:?}", c.planner.blacklisted().collect::<Vec<_>>());
    if let Some(g) = o.goal {
        let (dx, dy) = (g.viewpoint.cell.0 - first.0, g.viewpoint.cell.1 - first.1);
        assert!(dx * dx + dy * dy > 25, "the new goal is outside the blacklist radius");
    }
}

/// A visual map in which the camera has seen the room's interior from column `x0` eastwards.
fn seen_east_of(x0: i32) -> Box<VisualGrid> {
    let mut vis = Box::new(VisualGrid::new());
    for y in 51..100 {
        for x in x0..100 {
            vis.grid.set(x, y, Cell::Free);
        }
    }
    vis
}

/// What the gaze tests look at: the room, all free to the LiDAR, which the camera has seen from
/// column `x0` eastwards; no non-map points; a fresh `multisensor` planner; the robot at the
/// room's centre, facing east.
struct GazeScene {
    lidar: Box<LidarGrid>,
    vis: Box<VisualGrid>,
    store: Box<NonMapStore>,
    planner: Box<Planner>,
    robot: firmware::Pose2,
    cfg: Config,
}

fn gaze_scene(x0: i32) -> GazeScene {
    GazeScene {
        lidar: room_grid(false),
        vis: seen_east_of(x0),
        store: Box::new(NonMapStore::new()),
        planner: Box::new(Planner::new()),
        robot: pose(7.55, 7.55, 0.0),
        cfg: Config { planner: PlannerKind::Multisensor, ..Config::DEFAULT },
    }
}

#[test]
fn the_gaze_turns_to_what_is_unseen_and_to_non_map_points() {
    // The camera has seen everything but the west half.
    let GazeScene { lidar, vis, store, mut planner, robot, cfg } = gaze_scene(75);
    let (gaze, work) = planner.gaze(&cfg, &lidar, &vis, &store, &robot, None);
    let (h, _) = gaze.expect("half the room unseen is worth a look");
    assert!(
        (h - firmware::BinaryAngle::HALF).unsigned_abs() <= firmware::BinaryAngle::from_degrees(45).unsigned_abs(),
        "looks west: {h:?}"
    );
    assert!(work > 0);

    // Everything seen: nothing is worth turning for (the camera faces the way it walks).
    let vis = seen_east_of(51);
    assert_eq!(planner.gaze(&cfg, &lidar, &vis, &store, &robot, None).0, None);

    // Non-map points to the north pull the gaze of `lives`, not of `multisensor`.
    let mut store = Box::new(NonMapStore::new());
    for k in 0..8 {
        store.insert(&geom(), Config::mm(7_000 + 150 * k), Config::mm(9_400), cfg.nonmap_pool_radius_m);
    }
    let lives = Config { planner: PlannerKind::Lives, ..Config::DEFAULT };
    let (g, _) = planner.gaze(&lives, &lidar, &vis, &store, &robot, None);
    let (h, _) = g.expect("points in view are worth a look");
    assert!(
        (h - firmware::BinaryAngle::QUARTER).unsigned_abs() <= firmware::BinaryAngle::from_degrees(45).unsigned_abs(),
        "looks north: {h:?}"
    );
    assert_eq!(planner.gaze(&cfg, &lidar, &vis, &store, &robot, None).0, None);
}

#[test]
fn the_gaze_keeps_its_heading_until_another_is_clearly_better_or_it_has_little_left() {
    // The camera has seen all but a strip along the west wall.
    let GazeScene { lidar, vis, store, mut planner, robot, cfg } = gaze_scene(64);
    let step = firmware::BinaryAngle::from_fraction(1, firmware::planner::GAZE_HEADINGS as i64);
    let gain = |planner: &mut Planner, h: firmware::BinaryAngle| {
        // A heading's own gain: what the gaze reports when it keeps that heading.
        planner.gaze(&cfg, &lidar, &vis, &store, &robot, Some(h)).0.filter(|g| g.0 == h).map(|g| g.1)
    };
    let (best, best_gain) = planner.gaze(&cfg, &lidar, &vis, &store, &robot, None).0.expect("the strip is worth a look");
    assert!((best - firmware::BinaryAngle::HALF).unsigned_abs() <= step.unsigned_abs(), "looks west: {best:?}");
    let margin = cfg.gaze_min_gain.to_bits() as i64;
    for i in 0..firmware::planner::GAZE_HEADINGS as i64 {
        let h = firmware::BinaryAngle::from_fraction(i, firmware::planner::GAZE_HEADINGS as i64);
        let (chosen, g) = planner.gaze(&cfg, &lidar, &vis, &store, &robot, Some(h)).0.expect("west is still worth a look");
        if chosen == h && h != best {
            // Kept: it still offers half the least gain, and the best does not beat it by the margin.
            assert!(2 * g >= margin && best_gain < g + margin, "{h:?} kept with {g} against {best_gain}");
        } else {
            assert_eq!((chosen, g), (best, best_gain), "from {h:?}");
        }
    }
    // Both outcomes occur: the headings next to west are kept, east (nothing unseen) is not.
    assert!(gain(&mut planner, best + step).is_some() && gain(&mut planner, best - step).is_some());
    assert_eq!(gain(&mut planner, firmware::BinaryAngle::ZERO), None);
}

#[test]
fn a_robot_inside_the_inflation_leaves_it_by_moving_away_not_along_the_obstacle() {
    // The room with its east doorway, and a low bar (a bed's edge) across it. The robot stands
    // 2 cells (0.2 m) south of the bar's east end, well inside the 0.35 m inflation: where a
    // base that stopped against furniture finds itself. The doorway lies north-east, round the
    // bar's end, so the shortest way out would graze the corner.
    let mut lidar = room_grid(true);
    for y in 70..=72 {
        for x in 60..=80 {
            lidar.grid.set(x, y, Cell::Occupied);
        }
    }
    let occupied: Vec<(i32, i32)> =
        (50..=100).flat_map(|y| (50..=100).map(move |x| (x, y))).filter(|&(x, y)| lidar.get(x, y) == Cell::Occupied).collect();
    let clearance2 = |c: (i32, i32)| occupied.iter().map(|o| (o.0 - c.0).pow(2) + (o.1 - c.1).pow(2)).min().unwrap();
    let vis = Box::new(VisualGrid::new());
    let store = Box::new(NonMapStore::new());
    let mut f = Box::new(FrontierSet::new());
    let robot_cell = (79, 68);
    let robot = pose(7.95, 6.85, 0.0);
    assert_eq!(lidar.geom.cell_of(robot.x, robot.y), robot_cell);
    let own = clearance2(robot_cell);
    assert_eq!(own, 4, "the robot is 2 cells from the bar");
    for kind in [PlannerKind::Lives, PlannerKind::LivesGreedy, PlannerKind::Multisensor, PlannerKind::Nearest] {
        let cfg = Config { planner: kind, ..Config::DEFAULT };
        let inflation = GridGeometry::cells(cfg.robot_radius_m);
        assert!(own < inflation * inflation);
        f.compute(&lidar, &vis, cfg.min_frontier_cells);
        let mut planner = Box::new(Planner::new());
        let (goal, _) = planner.plan(&cfg, &lidar, &vis, &f, &store, &robot, None, 0);
        let goal = goal.unwrap_or_else(|| panic!("{kind:?}: the robot can leave"));
        assert!(goal.viewpoint.cell.0 >= 95, "{kind:?} goes to the doorway: {:?}", goal.viewpoint);
        // Walk the path from the robot in 2 cm steps: until it is out of the inflation it never
        // comes closer to anything than the robot already is.
        let mut from = (robot.x.to_num::<f64>(), robot.y.to_num::<f64>());
        let mut left = false;
        for w in goal.path.iter() {
            let to = (w.0.to_num::<f64>(), w.1.to_num::<f64>());
            let n = ((to.0 - from.0).hypot(to.1 - from.1) / 0.02).ceil().max(1.0) as usize;
            for i in 0..=n {
                let t = i as f64 / n as f64;
                let p = (from.0 + t * (to.0 - from.0), from.1 + t * (to.1 - from.1));
                let c = ((p.0 / 0.1).floor() as i32, (p.1 / 0.1).floor() as i32);
                let c2 = clearance2(c);
                left |= c2 >= inflation * inflation;
                assert!(left || c == robot_cell || c2 > own, "{kind:?}: the path passes {c:?} at clearance² {c2} < {own}: {:?}", goal.path);
            }
            from = to;
        }
        assert!(left, "{kind:?}: the path leaves the inflation");
    }
}

#[test]
fn the_inflation_is_the_robot_radius_exactly_so_a_one_metre_doorway_stays_four_cells_wide() {
    // The room's east doorway (cells y = 70..=79, 1.0 m between the jambs' cell centres at
    // y = 69 and y = 80, 1.1 m apart) opened onto free space. With 0.35 m the cells whose
    // centres are ≥ 0.4 m from both jambs stay traversable: y = 73..=76. A radius rounded up to
    // 4 cells (0.4 m) would leave two, and one noisy hit on a jamb would close the door.
    let mut lidar = room_grid(true);
    for y in 51..100 {
        for x in 100..=110 {
            let c = if x == 100 && !(70..80).contains(&y) { Cell::Occupied } else { Cell::Free };
            lidar.grid.set(x, y, c);
        }
    }
    let cfg = Config::DEFAULT;
    assert_eq!(cfg.robot_radius_m, Config::mm(350));
    let vis = Box::new(VisualGrid::new());
    let store = Box::new(NonMapStore::new());
    let mut f = Box::new(FrontierSet::new());
    f.compute(&lidar, &vis, cfg.min_frontier_cells);
    let mut planner = Box::new(Planner::new());
    let _ = planner.plan(&cfg, &lidar, &vis, &f, &store, &pose(7.55, 7.55, 0.0), None, 0);
    let open: Vec<i32> = (60..90).filter(|&y| planner.traversable(100, y)).collect();
    assert_eq!(open, vec![73, 74, 75, 76]);
    assert!(planner.distance(105, 75) != firmware::planner::UNREACHABLE, "the robot can walk through");
}

#[test]
fn a_doorway_narrower_than_the_clearance_but_wider_than_the_body_is_passed_at_a_cost() {
    // The room's east doorway (free cells y = 70..=75, jambs at y = 69 and y = 76: 0.6 m
    // between their centres, as a 0.1 m map draws a 0.7–0.8 m door) opened onto a free strip
    // x 101..=110 with unknown space east of it. Its middle cells (y = 72, 73) are 0.3 m from
    // the nearer jamb: inside the 0.35 m clearance, outside the 0.25 m body.
    let mut lidar = room_grid(false);
    for y in 51..100 {
        for x in 100..=110 {
            let c = if x == 100 && !(70..=75).contains(&y) { Cell::Occupied } else { Cell::Free };
            lidar.grid.set(x, y, c);
        }
        lidar.grid.set(111, y, Cell::Unknown);
    }
    // The camera has seen the room: what is left to search lies east of the door.
    let vis = seen_east_of(51);
    let store = Box::new(NonMapStore::new());
    let mut f = Box::new(FrontierSet::new());
    let start = pose(7.55, 7.25, 0.0);
    let plan = |cfg: &Config, planner: &mut Planner, f: &mut FrontierSet| {
        f.compute(&lidar, &vis, cfg.min_frontier_cells);
        planner.plan(cfg, &lidar, &vis, f, &store, &start, None, 0).0
    };

    // The default (`lethal_radius_m` at `robot_radius_m`: no band): the door is shut, nothing
    // beyond it is reachable and no goal goes east.
    let tight = Config::DEFAULT;
    assert_eq!(tight.lethal_radius_m, tight.robot_radius_m);
    let mut planner = Box::new(Planner::new());
    let goal = plan(&tight, &mut planner, &mut f);
    assert_eq!(planner.distance(105, 72), firmware::planner::UNREACHABLE);
    assert!(goal.as_ref().is_none_or(|g| g.pose.x < Config::mm(10_000)), "{goal:?}");

    // With the body's 0.25 m as the least clearance: the door's middle cells are the narrow
    // band, passable at five times the cost.
    let cfg = Config { lethal_radius_m: Config::mm(250), ..Config::DEFAULT };
    let goal = plan(&cfg, &mut planner, &mut f).expect("a goal through the door");
    let narrow: Vec<i32> = (68..78).filter(|&y| planner.narrow(100, y)).collect();
    assert_eq!(narrow, vec![72, 73], "the jambs' 0.25 m discs are lethal, the middle two cells narrow");
    assert!((68..78).all(|y| !planner.traversable(100, y)), "no doorway cell is open");
    // Through the door: from (99, 72) to (101, 72) is two straight steps onto narrow cells (25
    // each) where an open floor costs 5 each.
    let (inside, outside) = (planner.distance(99, 72), planner.distance(101, 72));
    assert!(inside != firmware::planner::UNREACHABLE && outside != firmware::planner::UNREACHABLE);
    assert_eq!(outside - inside, 2 * 5 * firmware::planner::NARROW_STEP_FACTOR);
    // The goal stands east of the door, on an open cell, and its straightened path crosses the
    // doorway's column between the jambs' lethal discs.
    let (gx, gy) = lidar.geom.cell_of(goal.pose.x, goal.pose.y);
    assert!(gx > 100 && planner.traversable(gx, gy), "goal cell ({gx}, {gy}) is open and east of the door");
    let cells: Vec<(i32, i32)> = goal.path.iter().map(|p| lidar.geom.cell_of(p.0, p.1)).collect();
    let mut from = lidar.geom.cell_of(start.x, start.y);
    for &to in &cells {
        for (x, y) in firmware::grid::Line::new(from.0, from.1, to.0, to.1) {
            assert!(planner.distance(x, y) != firmware::planner::UNREACHABLE, "the path passes ({x}, {y}): {cells:?}");
            if x == 100 {
                assert!((72..=73).contains(&y), "it crosses the wall's column at y = {y}: {cells:?}");
            }
        }
        from = to;
    }
}

/// `rrt` with no tree point yet, while the map has a reachable frontier at the end of a winding
/// corridor the random trees have not threaded in one planning step: the grid's frontier
/// detector supplies the goal (as in `rrt_exploration`), and the search does not end
/// "exhausted" with frontiers left (issue 29).
#[test]
fn rrt_falls_back_on_the_grids_frontiers_when_its_trees_hold_none() {
    let mut lidar = Box::new(LidarGrid::new(geom()));
    // The robot's room, 50..=100 square, with a 1.2 m opening in its east wall at y 70..82.
    let free = |g: &mut LidarGrid, x0: i32, y0: i32, x1: i32, y1: i32| {
        for y in y0..=y1 {
            for x in x0..=x1 {
                g.grid.set(x, y, Cell::Free);
            }
        }
    };
    for y in 49..=460 {
        for x in 49..=460 {
            lidar.grid.set(x, y, Cell::Occupied);
        }
    }
    free(&mut lidar, 51, 51, 99, 99);
    // A corridor 12 cells wide snaking east, north, west, north, east: about 120 m long.
    free(&mut lidar, 100, 70, 440, 81); // east
    free(&mut lidar, 429, 82, 440, 200); // north
    free(&mut lidar, 120, 189, 428, 200); // west
    free(&mut lidar, 120, 201, 131, 330); // north
    free(&mut lidar, 132, 319, 440, 330); // east, ending in unknown
    for y in 319..=330 {
        lidar.grid.set(441, y, Cell::Unknown);
        lidar.grid.set(442, y, Cell::Unknown);
    }
    let vis = Box::new(VisualGrid::new());
    let store = Box::new(NonMapStore::new());
    let mut f = Box::new(FrontierSet::new());
    let cfg = Config { planner: PlannerKind::Rrt, ..Config::DEFAULT };
    f.compute(&lidar, &vis, cfg.min_frontier_cells);
    let far = |c: (i32, i32)| c.0 > 400 && c.1 > 300;
    assert!(f.frontiers().iter().any(|fr| fr.source == FrontierSource::Lidar && far(fr.anchor)), "the corridor's end is a frontier");
    let robot = pose(7.55, 7.55, 0.0);
    let mut planner = Box::new(Planner::new());
    let (goal, _) = planner.plan(&cfg, &lidar, &vis, &f, &store, &robot, None, 0);
    assert_eq!(planner.rrt.points().count(), 0, "the trees found a point: this test needs them to have none");
    let g = goal.expect("a goal from the grid's frontiers");
    assert!(far(g.viewpoint.cell), "{:?}", g.viewpoint);
    assert_eq!(g.viewpoint.source, firmware::planner::Site::LidarFrontier);
}
