//! The structured search (`lives`): object proposals, their viewpoints, the tour and its
//! hysteresis (issue 28).

mod common;
use common::*;
use firmware::grid::{Cell, GridGeometry, LidarGrid, VisualGrid};
use firmware::planner::proposals::{PROPOSAL_LAMBDA_PER_MILLE, PROPOSAL_MAX_EXTENT_CELLS};
use firmware::planner::schedule::TaskKind;
use firmware::{Config, FrontierSet, NonMapStore, Planner, PlannerKind};

fn geom() -> GridGeometry {
    GridGeometry { origin_x: Config::mm(0), origin_y: Config::mm(0) }
}

/// A 12 × 6 m hall (cells 50..=170 × 50..=110), walls occupied, inside free, with a doorway to
/// unknown space in the east wall.
fn hall() -> Box<LidarGrid> {
    let mut g = Box::new(LidarGrid::new(geom()));
    for y in 50..=110 {
        for x in 50..=170 {
            let edge = x == 50 || x == 170 || y == 50 || y == 110;
            g.grid.set(x, y, if edge { Cell::Occupied } else { Cell::Free });
        }
    }
    for y in 75..85 {
        g.grid.set(170, y, Cell::Unknown);
    }
    g
}

/// Non-map points along a segment from (x0, y0) to (x1, y1) metres, every 0.1 m, each seen
/// `hits` times.
fn points(store: &mut NonMapStore, (x0, y0): (f64, f64), (x1, y1): (f64, f64), hits: usize) {
    let n = (((x1 - x0).powi(2) + (y1 - y0).powi(2)).sqrt() / 0.1).round() as usize;
    for k in 0..=n {
        let t = if n == 0 { 0.0 } else { k as f64 / n as f64 };
        let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
        for _ in 0..hits {
            store.insert(&geom(), Config::mm((x * 1000.0) as i32), Config::mm((y * 1000.0) as i32), Config::mm(50));
        }
    }
}

fn plan(
    planner: &mut Planner,
    cfg: &Config,
    lidar: &LidarGrid,
    store: &NonMapStore,
    robot: (f64, f64, f64),
    current: Option<((i32, i32), firmware::BinaryAngle)>,
) -> Option<firmware::planner::Goal> {
    let vis = Box::new(VisualGrid::new());
    let mut f = Box::new(FrontierSet::new());
    f.compute(lidar, &vis, cfg.min_frontier_cells);
    planner.plan(cfg, lidar, &vis, &f, store, &pose(robot.0, robot.1, robot.2), current, 0).0
}

#[test]
fn a_target_sized_cluster_is_a_proposal_looked_at_from_lambda_times_the_reach_and_a_sofa_is_not() {
    let lidar = hall();
    let mut store = Box::new(NonMapStore::new());
    // A suitcase-sized cluster (0.5 m) 6 m east of the robot, seen over several scans.
    points(&mut store, (14.0, 8.0), (14.5, 8.0), 3);
    // A 2 m sofa: too long for a target.
    points(&mut store, (8.0, 10.0), (10.0, 10.0), 3);
    // One stray return: not enough evidence.
    points(&mut store, (12.0, 6.0), (12.0, 6.0), 1);
    let cfg = Config { planner: PlannerKind::Lives, ..Config::DEFAULT };
    let mut planner = Box::new(Planner::new());
    plan(&mut planner, &cfg, &lidar, &store, (8.05, 8.05, 0.0), None);
    let props = &planner.proposals.proposals;
    assert_eq!(props.len(), 1, "{props:?}");
    let p = props[0];
    assert!(p.extent <= PROPOSAL_MAX_EXTENT_CELLS);
    assert!((140..=145).contains(&p.cell.0) && p.cell.1 == 80, "{p:?}");
    // On the line to the robot, λ · min(camera range, distance) from the proposal: the robot is
    // about 6.2 m away, within the default 4 m camera's reach → λ · 4 m = 2 m (20 cells).
    let range_cells = (Config::DEFAULT.camera_range_m.to_bits() as i64 * 10) >> 16;
    let expect = (PROPOSAL_LAMBDA_PER_MILLE * range_cells / 1000) as i32;
    assert!((p.cell.0 - p.viewpoint.0 - expect).abs() <= 1 && (p.viewpoint.1 - p.cell.1).abs() <= 1, "{p:?}");
    // Facing it (east).
    assert!(p.heading.unsigned_abs() < (1 << 26), "{:?}", p.heading);
    // Without the non-map term (the ablation) no proposal is made.
    let cfg = Config { planner: PlannerKind::LivesNoNonMap, ..Config::DEFAULT };
    let mut planner = Box::new(Planner::new());
    plan(&mut planner, &cfg, &lidar, &store, (8.05, 8.05, 0.0), None);
    assert!(planner.tasks.iter().all(|t| t.kind != TaskKind::Proposal));
}

#[test]
fn the_goal_is_the_first_task_of_a_tour_over_every_task_and_replanning_in_place_keeps_it() {
    let lidar = hall();
    let mut store = Box::new(NonMapStore::new());
    points(&mut store, (14.0, 8.0), (14.5, 8.0), 3);
    for kind in [PlannerKind::Lives, PlannerKind::LivesNoNonMap] {
        let cfg = Config { planner: kind, ..Config::DEFAULT };
        let mut planner = Box::new(Planner::new());
        let goal = plan(&mut planner, &cfg, &lidar, &store, (6.05, 8.05, 0.0), None).expect("a goal");
        let order = planner.tour.best().order.clone();
        assert_eq!(order.len(), planner.tasks.len(), "{kind:?}: every task is in the tour once");
        let mut seen = order.to_vec();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), order.len());
        let first = planner.tasks[order[0] as usize - 1];
        assert_eq!((goal.viewpoint.cell, goal.viewpoint.heading), (first.cell, first.heading), "{kind:?}");
        assert!(planner.distance(goal.viewpoint.cell.0, goal.viewpoint.cell.1) != firmware::planner::UNREACHABLE);
        // The same map, the robot where it was, the goal being pursued: the same goal.
        let again = plan(&mut planner, &cfg, &lidar, &store, (6.05, 8.05, 0.0), Some((goal.viewpoint.cell, goal.viewpoint.heading)))
            .expect("a goal");
        assert_eq!((again.viewpoint.cell, again.viewpoint.heading), (goal.viewpoint.cell, goal.viewpoint.heading), "{kind:?}");
    }
}

#[test]
fn a_closed_room_seen_by_nobody_but_the_lidar_still_gives_the_camera_somewhere_to_look() {
    // No frontier at all (the LiDAR has mapped the whole room), the camera has seen nothing:
    // the room itself is a task.
    let mut lidar = hall();
    for y in 75..85 {
        lidar.grid.set(170, y, Cell::Occupied);
    }
    let store = Box::new(NonMapStore::new());
    let cfg = Config { planner: PlannerKind::LivesNoNonMap, ..Config::DEFAULT };
    let mut planner = Box::new(Planner::new());
    let goal = plan(&mut planner, &cfg, &lidar, &store, (6.05, 8.05, 0.0), None);
    assert!(goal.is_some());
    assert!(planner.tasks.iter().any(|t| matches!(t.kind, TaskKind::Room | TaskKind::VisualFrontier)), "{:?}", planner.tasks);
}
