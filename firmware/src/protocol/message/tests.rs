extern crate std;

use super::*;
use crate::capacity::BEAMS;
use crate::config::PlannerKind;
use crate::controller::{Command, Detection, Mode, Outputs, Status};
use crate::planner::Goal;
use crate::planner::{Site, Viewpoint};
use crate::scan::RANGE_NO_RETURN;
use crate::scan::{BeamLabel, BeamScan, ScanError, ScanInput};
use fixed_point::{BinaryAngle, Meters, Pose2};

#[test]
fn a_pose_crosses_losslessly() {
    let p = Pose2::new(Meters::from_bits(-1), Meters::from_bits(i32::MAX), BinaryAngle::HALF);
    let m = PoseMsg::from_pose(9, &p);
    assert_eq!((m.t_us, m.x, m.y, m.theta), (9, -1, i32::MAX, i32::MIN));
    assert_eq!(m.pose(), p);
}

#[test]
fn a_scan_is_lent_to_the_core_without_copying() {
    let ranges = [1000u16, 0, RANGE_NO_RETURN, 2500];
    let labels = [BeamLabel::Map, BeamLabel::Unlabelled, BeamLabel::Unlabelled, BeamLabel::NonMap];
    let input = ScanInput {
        angle_min: BinaryAngle::HALF,
        angle_increment: BinaryAngle::from_fraction(1, 4),
        ranges_mm: &ranges,
        labels: Some(&labels),
        range_min_mm: 100,
        range_max_mm: 12_000,
    };
    let m = ScanMsg::from_scan_input(5, &input).unwrap();
    assert_eq!((m.range_min_mm, m.range_max_mm), (100, 12_000));
    let back = m.scan_input();
    assert_eq!(back.ranges_mm.as_ptr(), m.ranges_mm.as_ptr(), "borrowed, not copied");
    assert_eq!((back.angle_min, back.angle_increment), (input.angle_min, input.angle_increment));
    assert_eq!((back.range_min_mm, back.range_max_mm), (100, 12_000));
    assert_eq!((back.ranges_mm, back.labels), (&ranges[..], Some(&labels[..])));
    let mut beams = BeamScan::new();
    assert_eq!(beams.resample(&back), Ok(2));

    let bad = ScanInput { labels: Some(&labels[..3]), ..input };
    assert_eq!(ScanMsg::from_scan_input(5, &bad), Err(WireError::LabelCountMismatch));
}

#[test]
fn enums_map_both_ways() {
    for c in [Command::Start, Command::Stop, Command::Reset] {
        assert_eq!(Command::from(WireCommand::from(c)), c);
    }
    for m in [Mode::Idle, Mode::Exploring, Mode::TargetFound, Mode::Exhausted, Mode::Stopped] {
        assert_eq!(Mode::from(WireMode::from(m)), m);
    }
    for p in PlannerKind::ALL {
        assert_eq!(WirePlanner::from(p), p);
    }
    let d = Detection { position: Some((Meters::from_bits(3), Meters::from_bits(-4))) };
    assert_eq!(DetectionMsg::from_detection(1, &d).detection(), d);
    assert_eq!(
        WireScanError::from(ScanError::LabelCountMismatch { ranges: 5, labels: 4 }),
        WireScanError::LabelCountMismatch { ranges: 5, labels: 4 }
    );
}

fn goal() -> Goal {
    let vp = Viewpoint {
        cell: (10, 20),
        heading: BinaryAngle::QUARTER,
        source: Site::LidarFrontier,
        utility: -123_456,
        path_units: 50,
        unseen: 1,
        surface: 0,
        frontier_near_path: 2,
        nonmap: 3,
    };
    let mut path = heapless::Vec::new();
    path.push((Meters::from_num(1), Meters::from_num(2))).unwrap();
    path.push((Meters::from_num(1), Meters::from_num(3))).unwrap();
    Goal {
        pose: Pose2::new(Meters::from_num(1), Meters::from_num(3), BinaryAngle::QUARTER),
        viewpoint: vp,
        path,
        path_length_m: Meters::from_num(2),
    }
}

#[test]
fn a_tick_becomes_goal_stop_and_status_messages() {
    let mut status = Status { mode: Some(Mode::Exploring), ticks: 10, goals: 4, ..Status::default() };
    let link = LinkCounters { frames_ok: 7, ..LinkCounters::default() };
    let out = Outputs { goal: Some(goal()), new_goal: true, stop: false, status };
    let msgs: std::vec::Vec<_> = output_messages(1_000, &out, link).collect();
    assert_eq!(msgs.len(), 2);
    let CoreToHost::Goal(g) = &msgs[0] else { panic!("{msgs:?}") };
    assert_eq!((g.seq, g.pose(), g.utility), (4, goal().pose, -123_456));
    assert_eq!(g.waypoints().collect::<std::vec::Vec<_>>(), goal().path.to_vec());
    let CoreToHost::Status(s) = &msgs[1] else { panic!("{msgs:?}") };
    assert_eq!((s.t_us, s.mode, s.ticks, s.goals, s.link), (1_000, WireMode::Exploring, 10, 4, link));

    status.mode = Some(Mode::TargetFound);
    status.last_scan_error = Some(ScanError::Empty);
    let out = Outputs { goal: None, new_goal: false, stop: true, status };
    let msgs: std::vec::Vec<_> = output_messages(2_000, &out, link).collect();
    assert_eq!(msgs[0], CoreToHost::Stop(StopMsg { mode: WireMode::TargetFound }));
    let CoreToHost::Status(s) = &msgs[1] else { panic!("{msgs:?}") };
    assert_eq!(s.last_scan_error, Some(WireScanError::Empty));
    assert_eq!(msgs.len(), 2);
}

#[test]
fn labels_of_the_beam_grid() {
    let mut beams = BeamScan::new();
    beams.labels[3] = BeamLabel::NonMap;
    let m = LabelsMsg::from_beams(8, &beams);
    assert_eq!(m.labels.len(), BEAMS);
    assert_eq!((m.labels[3], m.labels[4]), (BeamLabel::NonMap, BeamLabel::Unlabelled));
}

#[test]
fn worst_case_sizes() {
    assert_eq!(MAX_HOST_TO_CORE_LEN, 3332);
    assert_eq!(MAX_GOAL_LEN, 677);
    assert_eq!(MAX_LABELS_LEN, 910);
    assert_eq!((varint_len(0), varint_len(127), varint_len(128), varint_len(u64::MAX)), (1, 1, 2, 10));
}
