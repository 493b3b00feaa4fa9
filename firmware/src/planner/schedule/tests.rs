extern crate std;
use super::*;
use crate::config::Config;
use crate::grid::LidarGrid;
use fixed_point::Pose2;
use std::boxed::Box;

fn geom() -> GridGeometry {
    GridGeometry { origin_x: Config::mm(0), origin_y: Config::mm(0) }
}

/// A 24 × 3 m hall (cells 20..=260 × 50..=80), walls occupied, inside free: one region end to
/// end, as the apartment's hallway and the living room it opens into are.
fn hall() -> Box<LidarGrid> {
    let mut g = Box::new(LidarGrid::new(geom()));
    for y in 50..=80 {
        for x in 20..=260 {
            let edge = x == 20 || x == 260 || y == 50 || y == 80;
            g.grid.set(x, y, if edge { Cell::Occupied } else { Cell::Free });
        }
    }
    g
}

/// A LiDAR frontier task standing at `cell` in region `room`.
fn frontier_task(cell: (i32, i32), room: Option<u8>) -> Task {
    Task {
        anchor: cell,
        cell,
        room,
        heading: BinaryAngle::ZERO,
        kind: TaskKind::LidarFrontier,
        class: u8::MAX,
        path_units: 0,
        view: super::super::view::View::default(),
        utility: 0,
    }
}

#[test]
fn a_regions_other_frontier_continues_the_pursuit_only_if_the_goal_is_on_its_way() {
    let cfg = Config { planner: PlannerKind::Lives, ..Config::DEFAULT };
    let lidar = hall();
    let mut planner = Box::new(Planner::new());
    // The robot at cell (140, 65), pursuing a goal 6 m east of it, at (200, 65), in region 1.
    let pose = Pose2::new(Config::mm(14_050), Config::mm(6_550), BinaryAngle::ZERO);
    planner.prepare(&cfg, &lidar, &pose);
    assert_eq!(planner.distance(140, 65), 0);
    let goal = (200, 65);
    let (east, west, by_goal) = (frontier_task((230, 65), Some(1)), frontier_task((40, 65), Some(1)), frontier_task((205, 70), Some(1)));

    // Beyond the goal: the way to it passes the goal (no detour).
    assert!(planner.on_the_way(goal, &east).0);
    // Within the match radius of the goal: always.
    assert!(planner.on_the_way(goal, &by_goal).0);
    // 10 m behind the robot: going there through the goal is a 12 m detour.
    assert!(!planner.on_the_way(goal, &west).0);

    // Region 1's best frontier is now the western one: it is not the goal being pursued (it would
    // inherit the 20 m hysteresis and turn the robot round), and nothing else of the step is.
    planner.tasks.clear();
    planner.tasks.push(west).unwrap();
    planner.tasks.push(frontier_task((120, 60), Some(2))).unwrap();
    assert_eq!(planner.find_task(goal, TaskKind::LidarFrontier, Some(1), Some((goal, BinaryAngle::ZERO))).0, None);
    // Region 1's best frontier beyond the goal continues it (the room's next gap).
    planner.tasks[0] = east;
    assert_eq!(planner.find_task(goal, TaskKind::LidarFrontier, Some(1), Some((goal, BinaryAngle::ZERO))).0, Some(0));
    // The goal's own frontier, its anchor moved by less than the match radius, whatever its region.
    planner.tasks[0] = Task { anchor: (210, 65), ..frontier_task(goal, None) };
    assert_eq!(planner.find_task(goal, TaskKind::LidarFrontier, Some(1), Some((goal, BinaryAngle::ZERO))).0, Some(0));
}

#[test]
fn the_goals_own_frontier_stays_a_task_when_its_regions_best_is_not_on_the_way() {
    let cfg = Config { planner: PlannerKind::Lives, ..Config::DEFAULT };
    let lidar = hall();
    let mut planner = Box::new(Planner::new());
    // The robot at cell (140, 65), pursuing the frontier at (200, 65) in region 1.
    let pose = Pose2::new(Config::mm(14_050), Config::mm(6_550), BinaryAngle::ZERO);
    planner.prepare(&cfg, &lidar, &pose);
    let goal = (200, 65);
    planner.last_goal = Some((goal, goal, TaskKind::LidarFrontier));
    planner.last_goal_room = Some(1);
    let current = Some((goal, BinaryAngle::ZERO));
    let with_utility = |t: Task, u: i64| Task { utility: u, ..t };
    let mut best = [i64::MIN; crate::capacity::MAX_ROOMS + 1];
    best[1] = 10;

    // The region's best is now 10 m behind the robot: the goal's own frontier (its anchor moved
    // by 0.5 m) is kept beside it.
    let own = Task { anchor: (203, 66), ..frontier_task(goal, Some(1)) };
    planner.task_pool.clear();
    planner.task_pool.push(with_utility(frontier_task((40, 65), Some(1)), 10)).unwrap();
    planner.task_pool.push(with_utility(own, 5)).unwrap();
    assert_eq!(planner.pursued_frontier(0, current, &best).0, Some(1));
    // A frontier at the goal's place whose best view now faces the other way is not the goal's
    // own: nothing kept, and the match by place does not continue the goal with it.
    planner.task_pool[1] = with_utility(Task { heading: BinaryAngle::from_degrees(180), ..own }, 5);
    assert_eq!(planner.pursued_frontier(0, current, &best).0, None);
    planner.tasks.clear();
    planner.tasks.push(planner.task_pool[1]).unwrap();
    assert_eq!(planner.find_task(goal, TaskKind::LidarFrontier, Some(1), current).0, None);
    planner.task_pool[1] = with_utility(own, 5);
    // Not pursuing anything (the controller's goal is elsewhere): nothing kept.
    assert_eq!(planner.pursued_frontier(0, Some(((100, 65), BinaryAngle::ZERO)), &best).0, None);

    // The region's best lies beyond the goal: it continues the goal, nothing else kept.
    planner.task_pool[0] = with_utility(frontier_task((230, 65), Some(1)), 10);
    assert_eq!(planner.pursued_frontier(0, current, &best).0, None);

    // The goal's frontier is gone (resolved): nothing to keep, the choice is free.
    planner.task_pool[0] = with_utility(frontier_task((40, 65), Some(1)), 10);
    planner.task_pool[1] = with_utility(frontier_task((120, 75), Some(1)), 5);
    assert_eq!(planner.pursued_frontier(0, current, &best).0, None);
}
