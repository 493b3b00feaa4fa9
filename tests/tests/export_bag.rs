//! `lives export-bag` (issue 27): the Intel CARMEN log written as a ROS 2 bag a real robot would
//! record (12 m `range_max` with `+inf` readings, odometry starting 3 scans late, the laser
//! mounted 0.1 m / 0.05 m off the base and turned 90°) replays into the CARMEN replay's map.

use firmware::Cell;
use host::io::export_bag::{self, ExportOptions};
use host::io::replay::{self, ReplayOptions, ReplayRun};

mod common;

fn occupied(run: &ReplayRun) -> Vec<(i32, i32)> {
    let n = firmware::capacity::GRID_CELLS as i32;
    let mut v = Vec::new();
    for y in 0..n {
        for x in 0..n {
            if run.controller.lidar.get(x, y) == Cell::Occupied {
                v.push((x, y));
            }
        }
    }
    v
}

/// The share of `a`'s cells with an occupied cell of `b` within one cell (both grids share the
/// origin: the same trajectory places them).
fn overlap(a: &[(i32, i32)], b: &ReplayRun) -> f64 {
    let hit =
        a.iter().filter(|&&(x, y)| (-1..=1).any(|dy| (-1..=1).any(|dx| b.controller.lidar.get(x + dx, y + dy) == Cell::Occupied))).count();
    hit as f64 / a.len() as f64
}

/// The log and its bag replayed with the same range (CARMEN replay's 10 m), and the log's poses
/// as they are (the bag's odometry is the log's corrected pose: scan matching, on for bags by
/// default, would move them; docs/experiments/real-lidar-maps.md).
fn replay_both(log: &std::path::Path, bag: &std::path::Path) -> (ReplayRun, ReplayRun) {
    let opts = ReplayOptions {
        model: None,
        max_range_m: Some(replay::CARMEN_MAX_RANGE_M),
        scan_matching: Some(false),
        ..ReplayOptions::default()
    };
    (replay::replay(log, &opts).unwrap(), replay::replay(bag, &opts).unwrap())
}

#[test]
fn the_intel_log_exported_as_a_bag_replays_into_the_same_map() {
    let log = common::root().join("tests/data/carmen/intel-corrected.log.gz");
    let dir = std::env::temp_dir().join(format!("lives-export-bag-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bag = dir.join("intel.mcap");
    let s = export_bag::export(&log, &bag, &ExportOptions::default()).unwrap();
    assert_eq!((s.scans, s.odometry), (910, 907));
    assert!(s.inf_readings > 0);
    let carmen_log = replay::read_log(&log).unwrap();
    let bag_log = replay::read_log(&bag).unwrap();
    assert_eq!((bag_log.scans.len(), bag_log.unplaced.no_odometry_yet), (907, 3));
    // Each bag scan's laser pose is the log's (the mount undone and redone), each beam points
    // where it did (the angles turned by the mount's yaw), and every reading at or beyond 12 m
    // is +inf.
    for (b, c) in bag_log.scans.iter().zip(&carmen_log.scans[3..]) {
        assert!((b.pose[0] - c.pose[0]).abs() < 1e-6 && (b.pose[1] - c.pose[1]).abs() < 1e-6, "{:?} {:?}", b.pose, c.pose);
        let world = |s: &replay::ScanRecord| s.pose[2] + s.angle_min;
        let turn = (world(b) - world(c)).rem_euclid(std::f64::consts::TAU);
        assert!(turn.min(std::f64::consts::TAU - turn) < 1e-6, "{} vs {}", world(b), world(c));
        assert!((b.angle_increment - c.angle_increment).abs() < 1e-7);
        for (rb, rc) in b.ranges_m.iter().zip(&c.ranges_m) {
            match *rc {
                r if r.is_nan() => assert!(rb.is_nan()),
                r if r >= 12.0 => assert_eq!(*rb, f32::INFINITY),
                r if r < 0.1 => assert!(rb.is_nan(), "below range_min: discarded"),
                r => assert_eq!(*rb, r),
            }
        }
    }
    let (from_carmen, from_bag) = replay_both(&log, &bag);
    let r = &from_bag.report;
    assert_eq!(r.scans_used, from_carmen.report.scans_used - 3);
    assert_eq!((r.rejected.no_odometry_yet, r.scans_rejected), (3, 3), "{:?}", r.rejected);
    assert_eq!(r.grid_origin, from_carmen.report.grid_origin);
    let (c_occ, b_occ) = (occupied(&from_carmen), occupied(&from_bag));
    let (c_in_b, b_in_c) = (overlap(&c_occ, &from_bag), overlap(&b_occ, &from_carmen));
    eprintln!(
        "occupied cells: CARMEN {} bag {}; CARMEN's within a cell of the bag's {:.4}, the bag's of CARMEN's {:.4}",
        c_occ.len(),
        b_occ.len(),
        c_in_b,
        b_in_c
    );
    assert!(c_in_b >= 0.95 && b_in_c >= 0.95, "{c_in_b} {b_in_c}");
}

/// The corrected CSAIL log's time stamps stand still (2 distinct among 406 scans): a bag stamped
/// with them would have every odometry message jump (and replay rejects such jumps), which no
/// robot records. The export stamps it as replay plays the log, one scan per tick, and the bag
/// replays into the CARMEN replay's map (the rolling window moving as it does).
#[test]
fn a_log_whose_stamps_stand_still_is_exported_one_scan_per_tick() {
    let log = common::root().join("tests/data/carmen/csail-corrected.log.gz");
    let dir = std::env::temp_dir().join(format!("lives-export-bag-csail-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bag = dir.join("csail.mcap");
    let s = export_bag::export(&log, &bag, &ExportOptions::default()).unwrap();
    assert!(s.synthetic_stamps);
    let carmen_log = replay::read_log(&log).unwrap();
    assert!(replay::stamps_stand_still(&carmen_log.scans).1);
    let bag_log = replay::read_log(&bag).unwrap();
    assert_eq!((bag_log.scans.len(), bag_log.unplaced.no_odometry_yet), (403, 3));
    assert!(!replay::stamps_stand_still(&bag_log.scans).1);
    for (k, w) in bag_log.scans.windows(2).enumerate() {
        assert!((w[1].t_s - w[0].t_s - 0.2).abs() < 1e-6, "scan {k}: {} then {}", w[0].t_s, w[1].t_s);
    }
    let (from_carmen, from_bag) = replay_both(&log, &bag);
    let r = &from_bag.report;
    assert_eq!(r.scans_used, from_carmen.report.scans_used - 3);
    assert!(!r.warnings.iter().any(|w| w.contains("odometry_jump") && !w.contains(": 0 odometry_jump")), "{:?}", r.warnings);
    // The grid starts on the first pose used (the bag's fourth scan), so the windows may sit a
    // few cells apart: compare the occupied cells where they are in the world.
    assert_eq!(r.window_shifts, from_carmen.report.window_shifts);
    let moved = |cells: Vec<(i32, i32)>, from: &ReplayRun, to: &ReplayRun| -> Vec<(i32, i32)> {
        let (gf, gt) = (from.controller.lidar.geom, to.controller.lidar.geom);
        cells
            .into_iter()
            .map(|(x, y)| {
                let (wx, wy) = gf.center_of(x, y);
                gt.cell_of(wx, wy)
            })
            .collect()
    };
    let (c_occ, b_occ) = (moved(occupied(&from_carmen), &from_carmen, &from_bag), moved(occupied(&from_bag), &from_bag, &from_carmen));
    let (c_in_b, b_in_c) = (overlap(&c_occ, &from_bag), overlap(&b_occ, &from_carmen));
    eprintln!("occupied cells: CARMEN {} bag {}; {:.4} {:.4}", c_occ.len(), b_occ.len(), c_in_b, b_in_c);
    assert!(c_in_b >= 0.95 && b_in_c >= 0.95, "{c_in_b} {b_in_c}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The exported bag decodes with the ROS 2 message decoder Foxglove and rosbag2 use (the PyPI
/// `mcap-ros2-support` package: the bag's own `ros2msg` schemas, CDR payloads), which
/// `scripts/test.sh` installs with the `mcap` reader in `target/py-mcap` (or `LIVES_PYTHON`).
#[test]
fn the_exported_bag_decodes_with_the_ros2_message_definitions_it_carries() {
    let py =
        std::env::var("LIVES_PYTHON").unwrap_or_else(|_| common::root().join("target/py-mcap/bin/python").to_string_lossy().into_owned());
    let ok = std::process::Command::new(&py).args(["-c", "import mcap, mcap_ros2"]).status().is_ok_and(|s| s.success());
    assert!(ok, "`{py}` cannot import mcap and mcap_ros2: run ./scripts/test.sh (it installs them), or set LIVES_PYTHON to a python with `pip install mcap mcap-ros2-support`");
    let log = common::root().join("tests/data/carmen/aces-corrected.log.gz");
    let bag = std::env::temp_dir().join(format!("lives-export-bag-ros2-{}.mcap", std::process::id()));
    export_bag::export(&log, &bag, &ExportOptions::default()).unwrap();
    let out = std::process::Command::new(&py).arg(common::root().join("tests/python/check_ros2_bag.py")).arg(&bag).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(
        lines,
        [
            "nav_msgs/msg/Odometry 437 frame=odom child=base_link",
            "sensor_msgs/msg/LaserScan 440 frame=laser range_max=12.0 beams=180",
            "tf2_msgs/msg/TFMessage 1 parent=base_link child=laser",
        ],
        "{stdout}"
    );
}
