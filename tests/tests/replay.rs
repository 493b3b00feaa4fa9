//! `lives replay` end to end (issue 8 part 2): the real CARMEN logs in `tests/data/carmen/`,
//! damaged copies of them, and ROS 2 bags (MCAP and sqlite3) made here with the same crates
//! replay reads them with.

use firmware::Cell;
use host::io::replay::cdr::{self, Header, LaserScan, Odometry, Time, Transform, TransformStamped};
use host::io::replay::{self, Location, LogFormat, ReplayError, ReplayOptions, ReplayReport, ReplayRun};
use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

mod common;

fn carmen(name: &str) -> PathBuf {
    common::root().join("tests/data/carmen").join(name)
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lives-replay-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn no_classifier() -> ReplayOptions {
    ReplayOptions { model: None, ..ReplayOptions::default() }
}

fn gunzip(path: &Path) -> String {
    let mut text = String::new();
    flate2::read::MultiGzDecoder::new(std::fs::File::open(path).unwrap()).read_to_string(&mut text).unwrap();
    text
}

fn gzip(text: &str) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(text.as_bytes()).unwrap();
    e.finish().unwrap()
}

/// The state of the cell holding world point (x, y).
fn cell_at(run: &ReplayRun, x: f64, y: f64) -> Cell {
    let geom = run.controller.lidar.geom;
    let (cx, cy) = geom.cell_of(fixed_point::meters_from_f64(x).unwrap(), fixed_point::meters_from_f64(y).unwrap());
    run.controller.lidar.get(cx, cy)
}

/// The states of the 3 × 3 cells around world point (x, y) (a hit computed in fixed point may
/// land in a neighbour of the cell the float geometry predicts).
fn around(run: &ReplayRun, x: f64, y: f64) -> Vec<Cell> {
    let mut out = Vec::new();
    for dy in [-0.1, 0.0, 0.1] {
        for dx in [-0.1, 0.0, 0.1] {
            out.push(cell_at(run, x + dx, y + dy));
        }
    }
    out
}

fn occupied_near(run: &ReplayRun, x: f64, y: f64) -> bool {
    around(run, x, y).contains(&Cell::Occupied)
}

#[test]
fn the_first_intel_flaser_line_reads_as_checked_by_hand() {
    let text = gunzip(&carmen("intel-corrected.log.gz"));
    let line = text.lines().find(|l| l.starts_with("FLASER")).unwrap();
    let Some(replay::carmen::CarmenRecord::Scan(s)) = replay::carmen::parse_line(line).unwrap() else { panic!("not a scan") };
    // `FLASER 180 1.09 1.08 1.08 … 1.23 0.600266 -0.0320327 -0.354665 0.600266 -0.0320327 -0.354665 32.9068 pippo 32.9068`
    assert_eq!(s.ranges_m.len(), 180);
    assert_eq!(&s.ranges_m[..4], &[1.09, 1.08, 1.08, 1.07]);
    assert_eq!(s.ranges_m[179], 1.23);
    assert_eq!(s.laser_pose, [0.600266, -0.0320327, -0.354665]);
    assert_eq!(s.t_s, 32.9068);
    assert_eq!(s.angle_min, -std::f64::consts::FRAC_PI_2);
    assert!((s.angle_increment - 1f64.to_radians()).abs() < 1e-15);
    // And the first ODOM line: the robot at the origin at t = 0.000246 s.
    let odom = text.lines().find(|l| l.starts_with("ODOM")).unwrap();
    assert_eq!(
        replay::carmen::parse_line(odom).unwrap(),
        Some(replay::carmen::CarmenRecord::Odom { t_s: 0.000246, pose: [0.0, 0.0, 0.0] })
    );
}

/// A whole real log replayed into a building's map: all `scans` read were used, over
/// `duration_s` of log, with at least `min_occupied` (and fewer than 30 000) wall cells, free
/// space, 20 goals or more and no error.
fn assert_replays_into_a_building_map(r: &ReplayReport, scans: u32, duration_s: f64, min_occupied: u32) {
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (scans, scans, 0), "{r:?}");
    assert!((r.duration_s - duration_s).abs() < 0.01, "{}", r.duration_s);
    // Speed is a measurement, not a test: `lives replay` prints the wall/log ratio.
    eprintln!("replay took {:.2} s for {:.0} s of log", r.wall_s, r.duration_s);
    assert!((min_occupied..30_000).contains(&r.grid.occupied), "{:?}", r.grid);
    // 42 524 free cells since the evidence grid: "no return" no longer clears through walls (the
    // free-space leak fell from 70 % to 26 %, docs/experiments/real-lidar-maps.md).
    assert!(r.grid.free > 35_000, "{:?}", r.grid);
    assert!(r.goals.len() >= 20, "{} goals", r.goals.len());
    assert!(!r.exceeds_grid && r.error.is_none());
}

#[test]
fn intel_replays_into_a_building_map() {
    let run = replay::replay(&carmen("intel-corrected.log.gz"), &ReplayOptions::default()).unwrap();
    let r = &run.report;
    assert_eq!(r.format, LogFormat::CarmenGzip);
    assert_eq!(r.odometry, 14_541);
    // The Intel lab is ≈ 26 × 26 m; walls are thousands of cells, free space > 10 000 m²·100.
    assert_replays_into_a_building_map(r, 910, 2691.3, 2_000);
    assert_eq!(r.labels, "int8-classifier");
    // The robot's own cells are free: it drove there.
    let p = run.trajectory[run.trajectory.len() / 2];
    assert_eq!(cell_at(&run, p[0], p[1]), Cell::Free);
    // Goals are ordered in time within the log.
    assert!(r.goals.windows(2).all(|w| w[0].t_s <= w[1].t_s) && r.goals.last().unwrap().t_s <= r.duration_s);
}

#[test]
fn freiburg_079_replays_into_a_building_map() {
    let run = replay::replay(&carmen("freiburg-079-corrected.log.gz"), &ReplayOptions::default()).unwrap();
    assert_replays_into_a_building_map(&run.report, 4791, 1062.46, 1_000);
}

#[test]
fn a_truncated_gzip_log_names_the_offset_and_keeps_the_scans_before() {
    let bytes = std::fs::read(carmen("intel-corrected.log.gz")).unwrap();
    let cut = bytes.len() / 3;
    let path = tmp("intel-truncated.log.gz");
    std::fs::write(&path, &bytes[..cut]).unwrap();
    let run = replay::replay(&path, &no_classifier()).unwrap();
    let r = &run.report;
    let Some(ReplayError::Gzip { file, lines, offset, .. }) = &run.error else { panic!("{:?}", run.error) };
    assert_eq!(file, &path);
    assert!(*offset <= cut as u64 && *offset > cut as u64 / 2, "offset {offset} of {cut}");
    assert!(*lines > 1000, "{lines} lines before the damage");
    // About a third of the scans, all of them used.
    assert!((150..500).contains(&r.scans_read), "{}", r.scans_read);
    assert_eq!(r.scans_used, r.scans_read);
    assert!(r.grid.occupied > 500, "{:?}", r.grid);
    let msg = r.error.as_deref().unwrap();
    assert!(msg.contains("intel-truncated.log.gz") && msg.contains(&format!("byte {offset}")), "{msg}");
}

#[test]
fn a_corrupt_line_is_skipped_and_named_and_the_scans_around_it_are_used() {
    let text = gunzip(&carmen("intel-corrected.log.gz"));
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    // Break the 101st FLASER line: its x becomes `1.2.3`.
    let (idx, _) = lines.iter().enumerate().filter(|(_, l)| l.starts_with("FLASER")).nth(100).unwrap();
    let mut toks: Vec<&str> = lines[idx].split(' ').collect();
    toks[2 + 180] = "1.2.3";
    lines[idx] = toks.join(" ");
    let path = tmp("intel-corrupt.log");
    std::fs::write(&path, lines.join("\n")).unwrap();
    let run = replay::replay(&path, &no_classifier()).unwrap();
    assert!(run.error.is_none(), "{:?}", run.error);
    assert_eq!(run.bad_records.total, 1);
    let ReplayError::CarmenLine { file, line, error } = &run.bad_records.first[0] else { panic!("{:?}", run.bad_records) };
    assert_eq!((file, *line), (&path, idx + 1));
    assert_eq!(error, &replay::carmen::LineError::BadNumber { kind: replay::carmen::LineKind::Flaser, field: "x", token: "1.2.3".into() });
    let r = &run.report;
    assert_eq!(r.format, LogFormat::Carmen);
    // Every other scan, before and after the line.
    assert_eq!((r.scans_read, r.scans_used), (909, 909));
    assert_eq!(r.skipped_records.by_reason, BTreeMap::from([("bad_number", 1)]));
    assert!(r.skipped_records.first[0].contains(&format!("intel-corrupt.log:{}: FLASER x `1.2.3`", idx + 1)), "{:?}", r.skipped_records);
    // The same log gzip-compressed gives the same scans.
    let gz = tmp("intel-corrupt.log.gz");
    std::fs::write(&gz, gzip(&lines.join("\n"))).unwrap();
    let run2 = replay::replay(&gz, &no_classifier()).unwrap();
    assert!(matches!(run2.bad_records.first[..], [ReplayError::CarmenLine { line, .. }] if line == idx + 1));
    assert_eq!(run2.report.scans_used, 909);
    assert_eq!((run2.report.grid, &run2.report.goals), (r.grid, &r.goals));
}

/// The ACES log with lines broken the ways real logs break: an ODOM x of `nan`, a FLASER beam
/// count one short, a FLASER time stamp of 1e300, and (`not_text`) a NEFF line that is not
/// UTF-8. Returns the log and the broken lines (1-based, in that order).
fn aces_with_bad_lines(not_text: bool) -> (Vec<u8>, Vec<usize>) {
    let text = gunzip(&carmen("aces-corrected.log.gz"));
    let mut lines: Vec<Vec<u8>> = text.lines().map(|l| l.as_bytes().to_vec()).collect();
    let starts = |lines: &[Vec<u8>], kind: &str| -> Vec<usize> {
        lines.iter().enumerate().filter(|(_, l)| l.starts_with(kind.as_bytes())).map(|(i, _)| i).collect()
    };
    let (flaser, odom) = (starts(&lines, "FLASER "), starts(&lines, "ODOM ")[4000]);
    let mut set = |i: usize, field: Option<usize>, to: &str| {
        let line = String::from_utf8(lines[i].clone()).unwrap();
        let mut t: Vec<&str> = line.split(' ').collect();
        let k = field.unwrap_or(t.len() - 3);
        t[k] = to;
        lines[i] = t.join(" ").into_bytes();
    };
    set(odom, Some(1), "nan");
    set(flaser[100], Some(1), "179");
    set(flaser[300], None, "1e300");
    let mut at = vec![odom + 1, flaser[100] + 1, flaser[300] + 1];
    if not_text {
        let neff = flaser[50] + lines[flaser[50]..].iter().position(|l| l.starts_with(b"NEFF ")).unwrap();
        lines[neff] = b"NEFF \xff".to_vec();
        at.push(neff + 1);
    }
    (lines.join(&b'\n'), at)
}

#[test]
fn bad_lines_are_skipped_counted_by_reason_and_the_rest_of_the_log_replays() {
    let (bytes, at) = aces_with_bad_lines(true);
    let path = tmp("aces-bad-lines.log");
    std::fs::write(&path, &bytes).unwrap();
    let run = replay::replay(&path, &no_classifier()).unwrap();
    let r = &run.report;
    assert!(run.error.is_none() && r.error.is_none(), "{:?}", run.error);
    // 440 scans less the two broken FLASER lines, all used: none lost after a bad line.
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (438, 438, 0), "{r:?}");
    assert_eq!(r.odometry, 7813);
    assert_eq!(r.skipped_records.total, 4);
    let reasons = BTreeMap::from([("bad_number", 1), ("count_mismatch", 1), ("not_text", 1), ("out_of_range", 1)]);
    assert_eq!(r.skipped_records.by_reason, reasons);
    let lines: Vec<usize> = run
        .bad_records
        .first
        .iter()
        .map(|e| match e {
            ReplayError::CarmenLine { line, .. } | ReplayError::NotText { line, .. } => *line,
            e => panic!("{e:?}"),
        })
        .collect();
    let mut want = at.clone();
    want.sort();
    assert_eq!(lines, want);
    let first = &r.skipped_records.first;
    assert!(first.iter().any(|m| m.ends_with(&format!(":{}: ODOM x `nan` is not a valid number", at[0]))), "{first:?}");
    assert!(
        first.iter().any(|m| m.contains(&format!(":{}: FLASER beam count 179 does not match the number of fields", at[1]))),
        "{first:?}"
    );
    assert!(first.iter().any(|m| m.ends_with(&format!(":{}: not UTF-8 text", at[3]))), "{first:?}");
    assert!(first.iter().any(|m| m.contains("FLASER ipc_timestamp `1e300` is out of range")), "{first:?}");
    // The duration is the log's own, not 1e300 s.
    assert!((r.duration_s - 1365.63).abs() < 0.01, "{}", r.duration_s);
}

/// Issue 29: a NUL byte in the first 4 KiB of a CARMEN log rejected the whole file ("not a CARMEN
/// log ..."); anywhere, it costs its line only, named with its line and column, plain or gzip.
#[test]
fn a_nul_byte_anywhere_in_a_carmen_log_costs_its_line_only() {
    let text = gunzip(&carmen("aces-corrected.log.gz"));
    let clean = tmp("aces-clean-nul.log");
    std::fs::write(&clean, &text).unwrap();
    let whole = replay::replay(&clean, &no_classifier()).unwrap().report;
    let lines: Vec<&str> = text.lines().collect();
    let first_flaser = lines.iter().position(|l| l.starts_with("FLASER ")).unwrap();
    assert!(lines[..4].iter().map(|l| l.len() + 1).sum::<usize>() < 4096, "line 4 is in the first 4 KiB");
    for (name, line) in [("head", 3), ("deep", first_flaser + 2000)] {
        let mut bytes: Vec<Vec<u8>> = lines.iter().map(|l| l.as_bytes().to_vec()).collect();
        let is_scan = bytes[line].starts_with(b"FLASER ");
        bytes[line][12] = 0;
        let joined = bytes.join(&b'\n');
        for gz in [false, true] {
            let path = tmp(&format!("aces-nul-{name}{}", if gz { ".log.gz" } else { ".log" }));
            std::fs::write(&path, if gz { gzip(std::str::from_utf8(&joined).unwrap()) } else { joined.clone() }).unwrap();
            let run = replay::replay(&path, &no_classifier()).unwrap();
            assert!(run.error.is_none(), "{name}: {:?}", run.error);
            let r = &run.report;
            assert_eq!(r.scans_read, whole.scans_read - is_scan as u32, "{name} gz={gz}");
            assert_eq!(r.skipped_records.by_reason, BTreeMap::from([("not_text", 1)]), "{name} gz={gz}");
            let shown = &r.skipped_records.first[0];
            assert!(shown.ends_with(&format!(":{}: not text: a NUL byte at column 13", line + 1)), "{shown}");
        }
    }
}

#[test]
fn lives_replay_reports_skipped_lines_and_exits_1_with_everything_written() {
    let (bytes, at) = aces_with_bad_lines(false);
    let path = tmp("aces-bad-lines-cli.log");
    std::fs::write(&path, bytes).unwrap();
    let png = tmp("aces-bad-lines.png");
    let out = std::process::Command::new(common::lives())
        .args(["replay", "--no-classifier", "--json", "--png"])
        .arg(&png)
        .arg(&path)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "not clean: status 1");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("the JSON is written");
    assert_eq!(v["skipped_records"]["total"], 3);
    assert_eq!(v["scans_used"], 438);
    assert_eq!(v["error"], serde_json::Value::Null);
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000, "the picture is written");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("warning: {}:{}: ODOM x `nan` is not a valid number (skipped)", path.display(), at[0])), "{err}");
    assert!(err.contains("error:") && err.contains("3 bad records skipped (1 bad_number, 1 count_mismatch, 1 out_of_range)"), "{err}");
    // A clean log: status 0, nothing on stderr.
    let clean = tmp("aces-head.log");
    std::fs::write(&clean, gunzip(&carmen("aces-corrected.log.gz")).lines().take(2000).collect::<Vec<_>>().join("\n")).unwrap();
    let out = std::process::Command::new(common::lives()).args(["replay", "--no-classifier"]).arg(&clean).output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.stderr.is_empty(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn one_stray_pose_neither_moves_the_grid_nor_loses_the_other_scans() {
    let text = gunzip(&carmen("aces-corrected.log.gz"));
    let clean = tmp("aces-clean.log");
    std::fs::write(&clean, &text).unwrap();
    let log = replay::read_log(&clean).unwrap();
    let clean_origin = replay::grid_origin(replay::place_grid(&log.scans).unwrap().bounds);
    // One FLASER x of 1e9 (beyond the core's ±32 767 m) and one y of −5 000 m (in range, far
    // from the rest): before, the first put the grid's origin at 0 while the JSON said
    // 499999963.9, and 265 of the 440 scans fell outside the grid.
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let flaser: Vec<usize> = lines.iter().enumerate().filter(|(_, l)| l.starts_with("FLASER")).map(|(i, _)| i).collect();
    for (k, field, to) in [(200, 2 + 180, "1e9"), (300, 3 + 180, "-5000")] {
        let mut t: Vec<&str> = lines[flaser[k]].split(' ').collect();
        t[field] = to;
        lines[flaser[k]] = t.join(" ");
    }
    let path = tmp("aces-stray.log");
    std::fs::write(&path, lines.join("\n")).unwrap();
    let r = replay::replay(&path, &no_classifier()).unwrap().report;
    assert_eq!(r.grid_origin, clean_origin);
    assert_eq!(r.rejected, replay::Rejected { stray_pose: 2, ..Default::default() });
    assert_eq!((r.scans_read, r.scans_used), (440, 438));
    assert!(!r.exceeds_grid);
    let w = r.warnings.iter().find(|w| w.contains("strays far")).expect("a warning");
    assert!(w.contains(&format!("line {} at (1e9, ", flaser[200] + 1)) && w.contains(&format!("line {} at (", flaser[300] + 1)), "{w}");
}

#[test]
fn damage_before_any_scan_is_an_error_naming_the_file() {
    let path = tmp("broken-first.log");
    std::fs::write(&path, "ODOM 0 0 0 0 0 0 1.0 h 1.0\nFLASER 3 1 2\n").unwrap();
    let e = replay::replay(&path, &no_classifier()).err().expect("no scans");
    let ReplayError::NoGoodScans { skipped: 1, first, .. } = &e else { panic!("{e:?}") };
    assert!(matches!(**first, ReplayError::CarmenLine { line: 2, .. }), "{e:?}");
    assert!(e.to_string().contains("broken-first.log:2:"), "{e}");
    // Every laser position beyond the core's ±32 767 m (UTM coordinates): said, not an empty map.
    let utm = tmp("utm.log");
    std::fs::write(&utm, "FLASER 2 1 2 500000.5 4000000.25 0 0 0 0 1.0 h 1.0\nFLASER 2 1 2 500001 4000000 0 0 0 0 2.0 h 2.0\n").unwrap();
    let e = replay::replay(&utm, &no_classifier()).err().expect("no usable pose");
    assert!(matches!(e, ReplayError::PosesOutOfRange { scans: 2, at: Location::Line(1), .. }), "{e:?}");
    assert!(
        e.to_string().ends_with(
            "none of the 2 scans has a laser position within the core's ±32767 m: the first is at (500000.5, 4.00000025e6) (line 1)"
        ),
        "{e}"
    );
    // A gzip stream cut before the first scan: its damage is the error.
    let gz = tmp("broken-first.log.gz");
    std::fs::write(&gz, &std::fs::read(carmen("intel-corrected.log.gz")).unwrap()[..600]).unwrap();
    assert!(matches!(replay::replay(&gz, &no_classifier()).err(), Some(ReplayError::Gzip { .. })));
    let missing = replay::replay(Path::new("/nonexistent/log.gz"), &no_classifier()).err().unwrap();
    assert!(matches!(missing, ReplayError::Io { .. }));
}

#[test]
fn robotlaser1_lines_replay_exactly_like_the_flaser_lines_they_restate() {
    // The first 200 FLASER lines of the Intel log, and the same scans as ROBOTLASER1 lines
    // (start −π/2, 1° resolution, 80 m maximum, no remissions): the same map, the same goals.
    let text = gunzip(&carmen("intel-corrected.log.gz"));
    let flaser: Vec<&str> = text.lines().filter(|l| l.starts_with("FLASER")).take(200).collect();
    let mut robotlaser = Vec::new();
    for l in &flaser {
        let t: Vec<&str> = l.split_whitespace().collect();
        let n: usize = t[1].parse().unwrap();
        let ranges = t[2..2 + n].join(" ");
        let pose = t[2 + n..5 + n].join(" ");
        let (ts, host, lts) = (t[8 + n], t[9 + n], t[10 + n]);
        robotlaser.push(format!(
            "ROBOTLASER1 0 {} {} {} 80.0 0.01 0 {n} {ranges} 0 {pose} {pose} 0 0 0.5 0.2 0 {ts} {host} {lts}",
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI,
            std::f64::consts::PI / 180.0
        ));
    }
    let (a, b) = (tmp("flaser.log"), tmp("robotlaser1.log"));
    std::fs::write(&a, flaser.join("\n")).unwrap();
    std::fs::write(&b, robotlaser.join("\n")).unwrap();
    let ra = replay::replay(&a, &no_classifier()).unwrap().report;
    let rb = replay::replay(&b, &no_classifier()).unwrap().report;
    assert_eq!(rb.sources, vec!["ROBOTLASER1".to_string()]);
    assert_eq!((ra.scans_used, rb.scans_used), (200, 200));
    assert_eq!(ra.grid, rb.grid);
    assert_eq!(ra.goals, rb.goals);
    assert!(ra.grid.occupied > 500 && !ra.goals.is_empty(), "{:?}", ra.grid);
}

/// The first 200 FLASER lines of the Intel log as CARMEN's newer logger writes a robot without
/// poses in its laser lines: `RAWLASER1` (with `remission_mode` when `header` is 7, without when
/// 6) and, at each scan's stamp, an `ODOM` line with the robot's pose, the laser sitting at
/// `mount` (forward, left, turn) on it, given by `PARAM` lines.
fn as_rawlaser1(flaser: &[&str], mount: [f64; 3], header: usize) -> String {
    let [fx, fy, fa] = mount;
    let mut out = vec![
        format!("PARAM robot_frontlaser_offset {fx} nohost 0"),
        format!("PARAM robot_frontlaser_side_offset {fy} nohost 0"),
        format!("PARAM robot_frontlaser_angular_offset {fa} nohost 0"),
    ];
    for l in flaser {
        let t: Vec<&str> = l.split_whitespace().collect();
        let n: usize = t[1].parse().unwrap();
        let p: Vec<f64> = t[2 + n..5 + n].iter().map(|v| v.parse().unwrap()).collect();
        let th = p[2] - fa;
        let (x, y) = (p[0] - (fx * th.cos() - fy * th.sin()), p[1] - (fx * th.sin() + fy * th.cos()));
        let (ts, host, lts) = (t[8 + n], t[9 + n], t[10 + n]);
        out.push(format!("ODOM {x} {y} {th} 0 0 0 {ts} {host} {lts}"));
        let mode = if header == 7 { " 0" } else { "" };
        out.push(format!(
            "RAWLASER1 0 {} {} {} 80.0 0.01{mode} {n} {} 0 {ts} {host} {lts}",
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI,
            std::f64::consts::PI / 180.0,
            t[2..2 + n].join(" ")
        ));
    }
    out.join("\n")
}

#[test]
fn rawlaser1_lines_placed_by_odom_replay_like_the_flaser_lines_they_restate() {
    let text = gunzip(&carmen("intel-corrected.log.gz"));
    let flaser: Vec<&str> = text.lines().filter(|l| l.starts_with("FLASER")).take(200).collect();
    let a = tmp("flaser-200.log");
    std::fs::write(&a, flaser.join("\n")).unwrap();
    let ra = replay::replay(&a, &no_classifier()).unwrap().report;
    for (mount, header) in [([0.0, 0.0, 0.0], 7), ([0.25, -0.1, 0.3], 6)] {
        let b = tmp(&format!("rawlaser1-{header}.log"));
        std::fs::write(&b, as_rawlaser1(&flaser, mount, header)).unwrap();
        let rb = replay::replay(&b, &no_classifier()).unwrap().report;
        assert_eq!(rb.sources, vec!["ODOM".to_string(), "RAWLASER1".to_string()], "{:?}", rb.warnings);
        assert_eq!((ra.scans_used, rb.scans_used), (200, 200));
        assert_eq!(ra.grid, rb.grid, "mount {mount:?}");
        assert_eq!(ra.goals, rb.goals);
        assert_eq!(rb.warnings.iter().any(|w| w.contains("origin, facing forward")), mount == [0.0; 3], "{:?}", rb.warnings);
    }
    assert!(ra.grid.occupied > 500 && !ra.goals.is_empty(), "{:?}", ra.grid);
    // The logger also writes each scan with its pose (ROBOTLASER1, here FLASER): those are
    // mapped, the RAWLASER1 repeats counted, not integrated twice.
    let both = format!("{}\n{}", flaser.join("\n"), as_rawlaser1(&flaser, [0.0; 3], 7));
    let c = tmp("flaser-and-rawlaser1.log");
    std::fs::write(&c, both).unwrap();
    let rc = replay::replay(&c, &no_classifier()).unwrap().report;
    assert_eq!((rc.scans_used, rc.grid, &rc.goals), (200, ra.grid, &ra.goals));
    assert!(rc.warnings.iter().any(|w| w.contains("200 RAWLASER1 lines repeat")), "{:?}", rc.warnings);
}

#[test]
fn rawlaser1_scans_without_odometry_around_them_are_counted_not_placed_at_the_origin() {
    let text = gunzip(&carmen("intel-corrected.log.gz"));
    let flaser: Vec<&str> = text.lines().filter(|l| l.starts_with("FLASER")).take(100).collect();
    let log = as_rawlaser1(&flaser, [0.0; 3], 7);
    let lines: Vec<&str> = log.lines().collect();
    // The first 10 scans lose their ODOM line (before the first odometry); scans 50–59 too,
    // a gap of 2 s (more than 0.5 s from the nearest odometry); and one ODOM line jumps 100 m.
    let mut kept = Vec::new();
    let (mut scan, mut jumped) = (0, false);
    for l in lines {
        if l.starts_with("RAWLASER1") {
            scan += 1;
        }
        if l.starts_with("ODOM") && (scan < 10 || (50..60).contains(&scan)) {
            continue;
        }
        if l.starts_with("ODOM") && scan == 80 && !jumped {
            jumped = true;
            let t: Vec<&str> = l.split_whitespace().collect();
            let x: f64 = t[1].parse().unwrap();
            kept.push(format!("ODOM {} {}", x + 100.0, t[2..].join(" ")));
            continue;
        }
        kept.push(l.to_string());
    }
    let path = tmp("rawlaser1-gaps.log");
    std::fs::write(&path, kept.join("\n")).unwrap();
    let run = replay::replay(&path, &no_classifier()).unwrap();
    let r = &run.report;
    assert_eq!(r.rejected.no_odometry_yet, 10, "{:?}", r.rejected);
    assert!(r.rejected.stale_pose >= 8, "{:?}", r.rejected);
    assert_eq!(r.transforms_rejected.odometry_jump, 1, "{:?}", r.transforms_rejected);
    assert_eq!(r.scans_used + r.rejected.no_odometry_yet + r.rejected.stale_pose, 100);
    assert!(r.warnings.iter().any(|w| w.contains("before the first ODOM line")), "{:?}", r.warnings);
    // No scan was drawn at the origin or 100 m off: every grid cell it marked is near the others.
    assert!(r.grid.occupied > 200, "{:?}", r.grid);
}

#[test]
fn time_stamps_that_do_not_advance_are_replaced_by_the_core_tick() {
    // As in the CSAIL log, whose stamps are printed as `1.13486e+09`.
    let text = gunzip(&carmen("intel-corrected.log.gz"));
    let lines: Vec<String> = text
        .lines()
        .filter(|l| l.starts_with("FLASER"))
        .take(50)
        .map(|l| {
            let mut t: Vec<&str> = l.split_whitespace().collect();
            let k = t.len();
            t[k - 3] = "1.13486e+09";
            t[k - 1] = "1.13486e+09";
            t.join(" ")
        })
        .collect();
    let path = tmp("flat-time.log");
    std::fs::write(&path, lines.join("\n")).unwrap();
    let r = replay::replay(&path, &no_classifier()).unwrap().report;
    assert!((r.duration_s - 49.0 * 0.2).abs() < 1e-9, "{}", r.duration_s);
    assert!(r.warnings.iter().any(|w| w.contains("do not advance")), "{:?}", r.warnings);
    assert!(r.plans > 1, "the controller's clock advanced: {} plans", r.plans);
}

// ---- ROS 2 bags ----------------------------------------------------------------------------

/// The robot stands still at (1, 2) facing +x (odometry `odom` → `base_link`); the laser is
/// mounted 0.5 m ahead and 0.2 m left of the base, 0.3 m up, turned +90° (it looks along +y):
/// it sits at (1.5, 2.2) facing +y. Its scans: 21 beams from −0.1 rad in 0.01 rad steps; the
/// middle beam (angle 0) sees a wall at 3 m, i.e. at (1.5, 5.2) in the world. Beams 0–4 have no
/// return (+inf), beam 5 is NaN, beam 6 −inf (too close), beams 16–20 read 25 m, beyond
/// `range_max` (20 m): "nothing within 20 m" (REP 117 as issue 27 reads it), like +inf.
const SCANS: u32 = 30;
const MOUNT: [f64; 3] = [0.5, 0.2, 0.3];

fn laser_scan(i: u32, frame: &str) -> LaserScan {
    let mut ranges = vec![3.0f32; 21];
    ranges[..5].fill(f32::INFINITY);
    ranges[5] = f32::NAN;
    ranges[6] = f32::NEG_INFINITY;
    ranges[16..].fill(25.0);
    LaserScan {
        header: Header { stamp: Time { sec: 10 + i as i32 / 5, nanosec: (i % 5) * 200_000_000 }, frame_id: frame.into() },
        angle_min: -0.1,
        angle_max: 0.1,
        angle_increment: 0.01,
        time_increment: 0.0,
        scan_time: 0.2,
        range_min: 0.05,
        range_max: 20.0,
        ranges,
        intensities: vec![],
    }
}

fn mount(rotation: [f64; 4]) -> Vec<u8> {
    cdr::encode_tf_message(&[TransformStamped {
        header: Header { stamp: Time::default(), frame_id: "base_link".into() },
        child_frame_id: "laser".into(),
        transform: Transform { translation: MOUNT, rotation },
    }])
}

fn odometry(i: u32) -> Vec<u8> {
    cdr::encode_odometry(&Odometry {
        header: Header { stamp: Time { sec: 10 + i as i32 / 5, nanosec: (i % 5) * 200_000_000 }, frame_id: "odom".into() },
        child_frame_id: "base_link".into(),
        pose: Transform::planar(1.0, 2.0, 0.0),
    })
}

/// `(topic, type, receive time ns, CDR)` of the test bag, in receive order. `tf_static` comes
/// after the first scan (it holds for the whole bag).
fn bag_messages(mount_rotation: [f64; 4]) -> Vec<(&'static str, &'static str, u64, Vec<u8>)> {
    let mut m = Vec::new();
    for i in 0..SCANS {
        let t = 10_000_000_000 + i as u64 * 200_000_000;
        m.push(("/odom", "nav_msgs/msg/Odometry", t, odometry(i)));
        m.push(("/scan", "sensor_msgs/msg/LaserScan", t + 1_000_000, cdr::encode_laser_scan(&laser_scan(i, "laser"))));
        if i == 0 {
            m.push(("/tf_static", "tf2_msgs/msg/TFMessage", t + 2_000_000, mount(mount_rotation)));
        }
    }
    m
}

/// Yaw +90° about z.
const YAW_90: [f64; 4] = [0.0, 0.0, std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2];

fn write_mcap(path: &Path, messages: &[(&str, &str, u64, Vec<u8>)], chunk_size: u64) {
    let opts = mcap::WriteOptions::new().compression(Some(mcap::Compression::Zstd)).chunk_size(Some(chunk_size)).profile("ros2");
    write_mcap_with(path, messages, opts);
}

/// `messages` written to an MCAP bag named `name` (64 kB chunks) and replayed without a
/// classifier.
fn replayed(name: &str, messages: &[(&str, &str, u64, Vec<u8>)]) -> ReplayRun {
    let path = tmp(name);
    write_mcap(&path, messages, 1 << 16);
    replay::replay(&path, &no_classifier()).unwrap()
}

/// `messages` (topic, type, time, CDR bytes) written with `opts`, one channel per topic.
fn write_mcap_with(path: &Path, messages: &[(&str, &str, u64, Vec<u8>)], opts: mcap::WriteOptions) {
    let mut w = opts.create(std::io::BufWriter::new(std::fs::File::create(path).unwrap())).unwrap();
    let mut channels = BTreeMap::new();
    for (seq, (topic, ty, t, data)) in messages.iter().enumerate() {
        let id = *channels.entry(*topic).or_insert_with(|| {
            let schema = w.add_schema(ty, "ros2msg", b"").unwrap();
            w.add_channel(schema, topic, "cdr", &BTreeMap::new()).unwrap()
        });
        let header = mcap::records::MessageHeader { channel_id: id, sequence: seq as u32, log_time: *t, publish_time: *t };
        w.write_to_known_channel(&header, data).unwrap();
    }
    w.finish().unwrap();
}

fn write_db3(path: &Path, messages: &[(&str, &str, u64, Vec<u8>)]) {
    let _ = std::fs::remove_file(path);
    let db = rusqlite::Connection::open(path).unwrap();
    // rosbag2's sqlite3 schema (version 4, Jazzy).
    db.execute_batch(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
         INSERT INTO schema VALUES (4, 'jazzy');
         CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
         CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL, type_description_hash TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);",
    )
    .unwrap();
    let mut ids: BTreeMap<&str, i64> = BTreeMap::new();
    for (topic, ty, t, data) in messages {
        let n = ids.len() as i64 + 1;
        let id = *ids.entry(topic).or_insert_with(|| {
            db.execute("INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '', '')", rusqlite::params![n, topic, ty]).unwrap();
            n
        });
        db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)", rusqlite::params![id, *t as i64, data]).unwrap();
    }
}

fn assert_mounted_scan(run: &ReplayRun) {
    let r = &run.report;
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (SCANS, SCANS, 0), "{r:?}");
    assert_eq!(r.odometry, SCANS);
    // From the first odometry to the last scan, 1 ms after the last odometry.
    assert!((r.duration_s - 0.2 * (SCANS - 1) as f64 - 0.001).abs() < 1e-6, "{}", r.duration_s);
    // The laser's pose is the base's composed with the mount.
    assert_eq!(r.trajectory_bounds, [[1.5, 2.2], [1.5, 2.2]]);
    // The wall the middle beam sees lands at (1.5, 5.2): not at (1.0, 5.0) (mount translation
    // ignored) nor at (4.5, 2.2) (mount rotation ignored).
    assert!(occupied_near(run, 1.5, 5.2));
    let between = around(run, 1.5, 4.0);
    assert!(between.contains(&Cell::Free) && !between.contains(&Cell::Occupied), "between laser and wall");
    assert!(!occupied_near(run, 1.0, 5.0));
    assert!(!occupied_near(run, 4.5, 2.2));
    // No return (+inf, beams 0–4 at −0.1…−0.06 rad) clears to the scan's 20 m range_max, not
    // to the core's 30 m clearing range; the 25 m readings beyond range_max (beams 16–20) do
    // the same and mark nothing.
    let dir = |a: f64, d: f64| (1.5 + d * (std::f64::consts::FRAC_PI_2 + a).cos(), 2.2 + d * (std::f64::consts::FRAC_PI_2 + a).sin());
    for a in [-0.08, 0.08] {
        let (x, y) = dir(a, 10.0);
        assert!(around(run, x, y).contains(&Cell::Free), "a no-return beam clears beyond the wall's range ({a} rad)");
        let (x, y) = dir(a, 19.5);
        assert!(around(run, x, y).contains(&Cell::Free), "... out to range_max ({a} rad)");
        let (x, y) = dir(a, 21.0);
        assert!(around(run, x, y).iter().all(|c| *c == Cell::Unknown), "... and not beyond it ({a} rad)");
    }
    let (x, y) = dir(0.08, 25.0);
    assert!(!occupied_near(run, x, y), "a reading beyond range_max marks nothing");
}

#[test]
fn an_mcap_bag_replays_with_the_laser_mount_applied() {
    let path = tmp("mounted.mcap");
    write_mcap(&path, &bag_messages(YAW_90), 4096);
    let log = replay::read_log(&path).unwrap();
    assert_eq!(log.format, LogFormat::Ros2Mcap);
    let s = &log.scans[0];
    assert!((s.pose[0] - 1.5).abs() < 1e-12 && (s.pose[1] - 2.2).abs() < 1e-12, "{:?}", s.pose);
    assert!((s.pose[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    assert_eq!((s.angle_min, s.angle_increment), (-0.1f32 as f64, 0.01f32 as f64));
    // As recorded, with the scan's limits: the range rule applies when the scan is encoded.
    assert!(s.ranges_m[5].is_nan() && s.ranges_m[6] == f32::NEG_INFINITY && s.ranges_m[16] == 25.0, "NaN, −inf, > range_max");
    assert_eq!((s.ranges_m[0], s.ranges_m[10]), (f32::INFINITY, 3.0));
    assert_eq!(s.range_limits_m[1], 20.0);
    assert!(matches!(s.at, Location::Offset(_)));
    assert!(log.warnings.is_empty(), "{:?}", log.warnings);
    let run = replay::replay(&path, &no_classifier()).unwrap();
    assert!(run.error.is_none(), "{:?}", run.error);
    assert_eq!(run.report.format, LogFormat::Ros2Mcap);
    assert_mounted_scan(&run);
    assert!(!run.report.goals.is_empty(), "the controller planned on the bag");
}

/// Odometry whose frames are left empty (some drivers do): it moves the frame the laser's fixed
/// transforms end in (`base_link`), from `odom`, and the bag replays as with the frames named.
#[test]
fn odometry_with_empty_frame_names_moves_the_body_the_laser_is_mounted_on() {
    let unnamed: Vec<_> = bag_messages(YAW_90)
        .into_iter()
        .map(|(topic, ty, t, data)| {
            if topic != "/odom" {
                return (topic, ty, t, data);
            }
            let mut o = cdr::decode_odometry(&data, cdr::Wire::Cdr).unwrap();
            o.child_frame_id.clear();
            o.header.frame_id.clear();
            (topic, ty, t, cdr::encode_odometry(&o))
        })
        .collect();
    let run = replayed("unnamed-odometry.mcap", &unnamed);
    assert_mounted_scan(&run);
    let w = run
        .report
        .warnings
        .iter()
        .find(|w| w.contains("/odom leaves its frames empty"))
        .unwrap_or_else(|| panic!("{:?}", run.report.warnings));
    assert!(w.contains("`odom` → `base_link`"), "{w}");
    assert_same_grid(&run, &replayed("named-odometry.mcap", &bag_messages(YAW_90)));
}

/// One scanner published on two topics (raw and filtered, every second scan filtered): the
/// topic with more messages is used, once; a second scanner in a frame of its own is used too.
#[test]
fn a_scanner_published_on_two_topics_is_integrated_once() {
    let mut m = bag_messages(YAW_90);
    for i in (0..SCANS).step_by(2) {
        let t = 10_000_000_000 + i as u64 * 200_000_000;
        m.push(("/scan_filtered", "sensor_msgs/msg/LaserScan", t + 1_500_000, cdr::encode_laser_scan(&laser_scan(i, "laser"))));
    }
    m.sort_by_key(|(_, _, t, _)| *t);
    let run = replayed("two-topics.mcap", &m);
    let r = &run.report;
    assert_eq!((r.scans_read, r.scans_used, r.rejected.duplicate_topic), (SCANS + SCANS / 2, SCANS, SCANS / 2), "{r:?}");
    let note = r.warnings.iter().find(|w| w.contains("frame `laser`")).unwrap_or_else(|| panic!("{:?}", r.warnings));
    assert!(note.contains("topics /scan and /scan_filtered (15)") && note.contains("/scan's 30 messages are used"), "{note}");
    // The same map as the bag without the second topic.
    let single = replayed("one-topic.mcap", &bag_messages(YAW_90));
    assert_same_grid(&run, &single);
    // A second scanner in its own frame (`rear`, mounted as `laser` is): both are used.
    let mut m = bag_messages(YAW_90);
    for i in 0..SCANS {
        let t = 10_000_000_000 + i as u64 * 200_000_000;
        m.push(("/scan_rear", "sensor_msgs/msg/LaserScan", t + 1_500_000, cdr::encode_laser_scan(&laser_scan(i, "rear"))));
    }
    let rear = cdr::encode_tf_message(&[TransformStamped {
        header: Header { stamp: Time::default(), frame_id: "base_link".into() },
        child_frame_id: "rear".into(),
        transform: Transform { translation: MOUNT, rotation: YAW_90 },
    }]);
    m.push(("/tf_static", "tf2_msgs/msg/TFMessage", 10_000_000_000 + 2_500_000, rear));
    m.sort_by_key(|(_, _, t, _)| *t);
    let run = replayed("two-scanners.mcap", &m);
    assert_eq!((run.report.scans_used, run.report.rejected.duplicate_topic), (2 * SCANS, 0), "{:?}", run.report);
}

/// Two replays' LiDAR grids hold the same cells.
fn assert_same_grid(a: &ReplayRun, b: &ReplayRun) {
    let n = firmware::capacity::GRID_CELLS as i32;
    let differ =
        (0..n).flat_map(|y| (0..n).map(move |x| (x, y))).filter(|&(x, y)| a.controller.lidar.get(x, y) != b.controller.lidar.get(x, y));
    assert_eq!(differ.count(), 0);
    assert!(a.controller.lidar.grid.count(Cell::Occupied) > 0);
}

/// A dense scanner (2 880 beams over 360°, 0.125° apart: a SICK microScan3, an RPLidar S2, a
/// 3D LiDAR flattened at that step): every beam reads 4 m but one, a post 1.5 m ahead.
fn dense_bag() -> Vec<(&'static str, &'static str, u64, Vec<u8>)> {
    const N: usize = 2880;
    let inc = 2.0 * std::f32::consts::PI / N as f32;
    let mut m = bag_messages(YAW_90);
    for (_, ty, _, data) in m.iter_mut().filter(|(topic, ..)| *topic == "/scan") {
        assert_eq!(*ty, "sensor_msgs/msg/LaserScan");
        let mut ranges = vec![4.0f32; N];
        ranges[N / 2] = 1.5; // angle 0: straight ahead of the laser
        let header = cdr::decode_laser_scan(data, cdr::Wire::Cdr).unwrap().header;
        let scan = LaserScan {
            header,
            angle_min: -std::f32::consts::PI,
            angle_max: std::f32::consts::PI - inc,
            angle_increment: inc,
            ranges,
            ..laser_scan(0, "laser")
        };
        *data = cdr::encode_laser_scan(&scan);
    }
    m
}

#[test]
fn a_scanner_denser_than_the_core_takes_is_combined_and_keeps_a_post_one_beam_wide() {
    let run = replayed("dense.mcap", &dense_bag());
    let r = &run.report;
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (SCANS, SCANS, 0), "{r:?}");
    assert_eq!(r.beams_combined, [SCANS, 3], "2 880 beams, 3 to one");
    assert!(r.warnings.iter().any(|w| w.contains("combined")), "{:?}", r.warnings);
    // The laser at (1.5, 2.2) faces +y: the post at (1.5, 3.7), the ring at 4 m.
    assert!(occupied_near(&run, 1.5, 3.7), "the post one beam wide is kept");
    assert!(occupied_near(&run, 1.5 - 4.0, 2.2) && occupied_near(&run, 1.5, 2.2 - 4.0), "the ring");
    let before = around(&run, 1.5, 3.0);
    assert!(before.contains(&Cell::Free) && !before.contains(&Cell::Occupied), "free before the post");
}

#[test]
fn odometry_that_tf_also_carries_is_not_merged_with_it() {
    // A robot publishing the wheel odometry on a topic and the EKF's estimate on `tf`, both
    // `odom` → `base_link`: the wheels have drifted 0.4 m. Merged, the laser's pose would jump
    // between the two from one sample to the next; tf's alone are used.
    let mut m = Vec::new();
    for (topic, ty, t, data) in bag_messages(YAW_90) {
        if topic != "/odom" {
            m.push((topic, ty, t, data));
            continue;
        }
        let o = cdr::decode_odometry(&data, cdr::Wire::Cdr).unwrap();
        let mut drifted = o.clone();
        drifted.pose.translation[0] += 0.4;
        m.push(("/odom", ty, t, cdr::encode_odometry(&drifted)));
        // The EKF publishes 50 ms before each wheel odometry message (and each scan).
        let mut header = o.header.clone();
        let ns = header.stamp.sec as i64 * 1_000_000_000 + header.stamp.nanosec as i64 - 50_000_000;
        header.stamp = Time { sec: (ns / 1_000_000_000) as i32, nanosec: (ns % 1_000_000_000) as u32 };
        let tf = TransformStamped { header, child_frame_id: o.child_frame_id.clone(), transform: o.pose };
        m.push(("/tf", "tf2_msgs/msg/TFMessage", t - 50_000_000, cdr::encode_tf_message(&[tf])));
    }
    let run = replayed("odom-and-tf.mcap", &m);
    let r = &run.report;
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (SCANS, SCANS, 0), "{r:?}");
    assert_eq!(r.trajectory_bounds, [[1.5, 2.2], [1.5, 2.2]], "every scan at tf's pose, none at the wheels' (1.9, 2.2)");
    assert!(occupied_near(&run, 1.5, 5.2) && !occupied_near(&run, 1.9, 5.2));
    assert_eq!(run.report.transforms_rejected.superseded, SCANS);
    assert!(
        run.report.warnings.iter().any(|w| w.contains("odom → base_link comes from tf and from odometry topic /odom")),
        "{:?}",
        run.report.warnings
    );
}

/// The test bag with a 3D LiDAR's `sensor_msgs/PointCloud2` on `/points` (frame `laser`) in
/// place of (`keep_scans` false) or beside its LaserScans: a ring of points 4 m out in the
/// horizontal plane every 0.25°, a post 1.5 m straight ahead, and a ceiling 2 m above the
/// sensor (a ring at 3 m radius, 34° up: no part of the cut).
fn cloud_bag(keep_scans: bool, mount_rotation: [f64; 4]) -> Vec<(&'static str, &'static str, u64, Vec<u8>)> {
    let mut points: Vec<[f32; 3]> = (0..1440)
        .flat_map(|i| {
            let a = (i as f32 * 0.25).to_radians();
            [[4.0 * a.cos(), 4.0 * a.sin(), 0.02], [3.0 * a.cos(), 3.0 * a.sin(), 2.0]]
        })
        .collect();
    points.push([1.5, 0.0, -0.01]);
    let mut m = Vec::new();
    for (topic, ty, t, data) in bag_messages(mount_rotation) {
        if topic == "/scan" {
            let header = cdr::decode_laser_scan(&data, cdr::Wire::Cdr).unwrap().header;
            m.push(("/points", "sensor_msgs/msg/PointCloud2", t, replay::rosbag::encode_xyz_cloud(&header, &points)));
            if !keep_scans {
                continue;
            }
        }
        m.push((topic, ty, t, data));
    }
    m
}

#[test]
fn a_bag_of_point_clouds_replays_as_their_planar_cuts() {
    let run = replayed("clouds.mcap", &cloud_bag(false, YAW_90));
    let r = &run.report;
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (SCANS, SCANS, 0), "{r:?}");
    assert!(r.warnings.iter().any(|w| w.contains("point clouds (/points) cut to planar scans")), "{:?}", r.warnings);
    // The laser at (1.5, 2.2) faces +y: the post at (1.5, 3.7), the ring 4 m out.
    assert!(occupied_near(&run, 1.5, 3.7), "the post");
    assert!(occupied_near(&run, 1.5 - 4.0, 2.2) && occupied_near(&run, 1.5, 2.2 - 4.0), "the ring");
    assert!(!occupied_near(&run, 1.5 - 3.0, 2.2) && !occupied_near(&run, 1.5, 2.2 - 3.0), "the ceiling is not a wall");
}

#[test]
fn clouds_beside_laser_scans_are_not_used_and_a_tilted_cloud_is_refused_by_name() {
    let both = replayed("clouds-and-scans.mcap", &cloud_bag(true, YAW_90));
    let r = &both.report;
    assert_eq!((r.scans_read, r.scans_used), (SCANS, SCANS), "the LaserScans only: {r:?}");
    assert!(
        r.warnings.iter().any(|w| w.contains("point clouds (/points) not used: the bag's LaserScan topics (/scan) are")),
        "{:?}",
        r.warnings
    );
    assert_mounted_scan(&both);
    // The sensor pitched 90° (x forward turned up, as a camera's optical frame is turned).
    let pitched = [0.0, std::f64::consts::FRAC_1_SQRT_2, 0.0, std::f64::consts::FRAC_1_SQRT_2];
    let path = tmp("tilted-clouds.mcap");
    write_mcap(&path, &cloud_bag(false, pitched), 1 << 16);
    let e = replay::replay(&path, &no_classifier()).err().expect("no scan to replay").to_string();
    assert!(
        e.contains(&format!("no laser scans to replay: none could be placed: {SCANS} point clouds in a frame tilted from level")),
        "{e}"
    );
}

#[test]
fn a_bag_directory_of_zstd_compressed_files_replays_as_the_files_would() {
    // `ros2 bag record --compression-mode file --compression-format zstd`: each storage file
    // compressed whole, `bag_0.db3.zstd`, beside `metadata.yaml`.
    let dir = tmp("zstd-bag");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let db3 = tmp("plain.db3");
    write_db3(&db3, &bag_messages(YAW_90));
    let packed = zstd::bulk::compress(&std::fs::read(&db3).unwrap(), 3).unwrap();
    std::fs::write(dir.join("bag_0.db3.zstd"), packed).unwrap();
    std::fs::write(dir.join("metadata.yaml"), "rosbag2_bagfile_information:\n  compression_format: zstd\n  compression_mode: FILE\n")
        .unwrap();
    let run = replay::replay(&dir, &no_classifier()).unwrap();
    assert_eq!(run.report.format, LogFormat::Ros2Sqlite3);
    assert!(run.error.is_none(), "{:?}", run.error);
    assert_mounted_scan(&run);
    assert!(run.report.warnings.iter().any(|w| w.contains("decompressed (zstd")), "{:?}", run.report.warnings);
    let plain = replay::replay(&db3, &no_classifier()).unwrap().report;
    assert_eq!((plain.grid, plain.goals.clone()), (run.report.grid, run.report.goals.clone()));
}

#[test]
fn a_truncated_zstd_compressed_mcap_keeps_the_scans_before_the_damage() {
    // The dense scanner's bag with noisy ranges (346 kB that zstd cannot squeeze into one
    // 128 kB block), in chunks of 16 kB, so the damage is not in the first block or chunk.
    let mut m = dense_bag();
    let mut noise = 1u32;
    for (_, _, _, data) in m.iter_mut().filter(|(topic, ..)| *topic == "/scan") {
        let mut s = cdr::decode_laser_scan(data, cdr::Wire::Cdr).unwrap();
        for r in s.ranges.iter_mut().filter(|r| **r == 4.0) {
            noise = noise.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *r += (noise >> 16) as f32 * 1e-6;
        }
        *data = cdr::encode_laser_scan(&s);
    }
    let mcap = tmp("for-zstd.mcap");
    write_mcap(&mcap, &m, 16 * 1024);
    let packed = zstd::stream::encode_all(std::fs::File::open(&mcap).unwrap(), 3).unwrap();
    let cut = tmp("cut.mcap.zstd");
    std::fs::write(&cut, &packed[..packed.len() * 3 / 4]).unwrap();
    let run = replay::replay(&cut, &no_classifier()).unwrap();
    let used = run.report.scans_used;
    assert!(used > 0 && used < SCANS, "{used}");
    assert!(run.error.is_some(), "the MCAP's own truncation is named");
    assert!(run.report.warnings.iter().any(|w| w.contains("zstd stream is damaged")), "{:?}", run.report.warnings);
    // Cut inside its first block, nothing decompresses: the error says so.
    std::fs::write(&cut, &packed[..6]).unwrap();
    let e = replay::replay(&cut, &no_classifier()).err().expect("nothing to replay").to_string();
    assert!(e.contains("compressed with zstd: its zstd stream is damaged after 0 decompressed bytes"), "{e}");
}

/// A map_server map (0.05 m cells, origin `origin`, 60 × 180 cells) whose occupied cells are
/// the `walls`, `[x0, x1, y]` in metres (horizontal runs, one cell thick); free elsewhere.
fn floor_map(dir: &Path, origin: [f64; 2], walls: &[[f64; 3]]) -> PathBuf {
    let (w, h, res) = (60usize, 180usize, 0.05);
    let mut px = vec![254u8; w * h];
    for &[x0, x1, y] in walls {
        let row = ((y - origin[1]) / res).floor() as usize;
        for col in ((x0 - origin[0]) / res).floor() as usize..=((x1 - origin[0]) / res).floor() as usize {
            px[(h - 1 - row) * w + col] = 0;
        }
    }
    let mut pgm = format!("P5\n{w} {h}\n255\n").into_bytes();
    pgm.extend(px);
    std::fs::write(dir.join("floor.pgm"), pgm).unwrap();
    let yaml = dir.join("floor.yaml");
    std::fs::write(
        &yaml,
        format!(
            "image: floor.pgm\nresolution: {res}\norigin: [{}, {}, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
            origin[0], origin[1]
        ),
    )
    .unwrap();
    yaml
}

fn floor_args(bag: &Path, map: &Path, pose: Option<&str>) -> host::measure::mapcheck::MapcheckArgs {
    host::measure::mapcheck::MapcheckArgs {
        file: Some(bag.to_path_buf()),
        reference: None,
        align: None,
        floor_map: Some(map.to_path_buf()),
        floor_map_pose: pose.map(str::to_string),
        relations: None,
        json: true,
        png: None,
        no_classifier: true,
        model: None,
        max_range: None,
        set: Vec::new(),
        world: None,
        scenario: None,
        planner: None,
        seed: None,
        robot: None,
        sim: Vec::new(),
    }
}

#[test]
fn a_bag_is_scored_against_a_floor_map_on_the_walls_its_viewpoints_see() {
    // The test bag's laser at (1.5, 2.2) faces +y and hits a wall 3 m ahead, x 1.35–1.59 m. The
    // floor map has that wall (cells x 1.40–1.55 m, y 5.2 m) and one hidden behind it (y 8 m),
    // which the robot could not see.
    let dir = tmp("floor");
    std::fs::create_dir_all(&dir).unwrap();
    let bag = dir.join("bag.mcap");
    write_mcap(&bag, &bag_messages(YAW_90), 4096);
    let walls = [[1.41, 1.54, 5.2], [1.41, 1.54, 8.0]];
    let (r, clean) = host::measure::mapcheck::check_log(&bag, &floor_args(&bag, &floor_map(&dir, [0.0, 0.0], &walls), None)).unwrap();
    assert!(clean);
    assert_eq!(r.reference.kind, "floor-map");
    let m = &r.map;
    // The seen wall: 2 grid cells (0.1 m) along x; the hidden one (2 more) does not count.
    assert_eq!((m.recovered_cells, m.reference_wall_cells), (2, 2), "{m:?}");
    assert_eq!(m.phantom_cells, 0, "{m:?}");
    // The same map drawn 1 m to the left and placed back by --floor-map-pose: the same figures.
    let shifted = [[0.41, 0.54, 5.2], [0.41, 0.54, 8.0]];
    let (r2, _) =
        host::measure::mapcheck::check_log(&bag, &floor_args(&bag, &floor_map(&dir, [0.0, 0.0], &shifted), Some("1,0,0"))).unwrap();
    assert_eq!(r2.map, r.map);
    // The same image with its origin turned 0.3 rad (map_server's yaw), placed back by a pose
    // turned −0.3 rad: the same figures.
    let yaml = floor_map(&dir, [0.0, 0.0], &walls);
    let text = std::fs::read_to_string(&yaml).unwrap().replace("origin: [0, 0, 0.0]", "origin: [0, 0, 0.3]");
    assert!(text.contains("0.3]"), "{text}");
    std::fs::write(&yaml, text).unwrap();
    let pose = format!("0,0,{}", (-0.3f64).to_degrees());
    let (r4, _) = host::measure::mapcheck::check_log(&bag, &floor_args(&bag, &yaml, Some(&pose))).unwrap();
    assert_eq!(r4.map, r.map);
    // Without the pose, the map's wall is 1 m off: lost, and the grid's wall a phantom.
    let (r3, _) = host::measure::mapcheck::check_log(&bag, &floor_args(&bag, &floor_map(&dir, [0.0, 0.0], &shifted), None)).unwrap();
    assert_eq!(r3.map.recovered_cells, 0, "{:?}", r3.map);
    assert_eq!(r3.map.phantom_cells, r3.map.occupied_cells);
    let e = host::measure::mapcheck::check_log(&bag, &floor_args(&bag, &dir.join("floor.yaml"), Some("1,nan,0"))).err().unwrap();
    assert!(e.contains("three finite numbers"), "{e}");
}

/// The test bag with its odometry's child frame renamed (`base_footprint`), so that no transform
/// joins the odometry's tree to the laser's (`base_link` → `laser`); or (`None`) without odometry.
fn bag_with_odometry_child(child: Option<&str>) -> PathBuf {
    let mut m = Vec::new();
    for (topic, ty, t, data) in bag_messages(YAW_90) {
        match (topic, child) {
            ("/odom", None) => {}
            ("/odom", Some(child)) => {
                let mut o = cdr::decode_odometry(&data, cdr::Wire::Cdr).unwrap();
                o.child_frame_id = child.into();
                m.push((topic, ty, t, cdr::encode_odometry(&o)));
            }
            _ => m.push((topic, ty, t, data)),
        }
    }
    let path = tmp(&format!("odometry-child-{}.mcap", child.unwrap_or("none")));
    write_mcap(&path, &m, 4096);
    path
}

#[test]
fn scans_placed_by_fixed_transforms_alone_are_refused_when_odometry_moves_another_tree() {
    // Before: all 30 scans drawn at the mount's offset (0.5, 0.2) from a made-up origin, silently.
    let e = replay::replay(&bag_with_odometry_child(Some("base_footprint")), &no_classifier()).err().expect("nothing placed").to_string();
    assert!(e.contains(&format!("none could be placed: {SCANS} whose frame no odometry or transform places")), "{e}");
    assert!(e.contains("only fixed transforms place it (in `base_link`)") && e.contains("odom → base_footprint"), "{e}");
    // A bag in which nothing moves is a sensor that stood still: placed, and said so.
    let run = replay::replay(&bag_with_odometry_child(None), &no_classifier()).unwrap();
    assert_eq!(run.report.scans_used, SCANS);
    assert_eq!(run.report.trajectory_bounds, [[0.5, 0.2], [0.5, 0.2]]);
    assert!(run.report.warnings.iter().any(|w| w.contains("a sensor that stood still")), "{:?}", run.report.warnings);
}

#[test]
fn a_replay_can_be_recorded_and_the_recording_reads_back() {
    let bag = tmp("for-record.mcap");
    write_mcap(&bag, &bag_messages(YAW_90), 4096);
    let out = tmp("replay-recording.mcap");
    let opts = ReplayOptions { record: Some(out.clone()), ..no_classifier() };
    let run = replay::replay(&bag, &opts).unwrap();
    let rec = run.report.record.clone().expect("recorded");
    assert_eq!(rec.error, None);
    let bytes = std::fs::read(&out).unwrap();
    let mut topics = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        *topics.entry(m.unwrap().channel.topic.clone()).or_insert(0u64) += 1;
    }
    assert_eq!(topics.values().sum::<u64>(), rec.messages);
    assert_eq!(topics.get("/lives/goal").copied().unwrap_or(0), run.report.goals.len() as u64, "{topics:?}");
    assert!(topics.get("/lives/lidar_grid").is_some_and(|&n| n >= 1), "{topics:?}");
    // Recording only reads: the replay is the same without it.
    let plain = replay::replay(&bag, &no_classifier()).unwrap().report;
    assert_eq!((plain.grid, plain.goals.clone()), (run.report.grid, run.report.goals.clone()));
}

#[test]
fn a_sqlite3_bag_replays_with_the_laser_mount_applied() {
    let path = tmp("mounted.db3");
    write_db3(&path, &bag_messages(YAW_90));
    let run = replay::replay(&path, &no_classifier()).unwrap();
    assert!(run.error.is_none(), "{:?}", run.error);
    assert_eq!(run.report.format, LogFormat::Ros2Sqlite3);
    assert_mounted_scan(&run);
}

/// Issue 29: a `messages` row whose `topic_id` is a REAL (or whose `data` is TEXT) stopped
/// reading ("Invalid column type Real at index: 1, name: topic_id"); it is skipped and counted,
/// and the rows after it are read.
#[test]
fn a_sqlite3_row_of_the_wrong_type_is_skipped_and_counted() {
    let path = tmp("wrong-type.db3");
    let msgs = bag_messages(YAW_90);
    write_db3(&path, &msgs);
    let scan_rows: Vec<i64> = msgs.iter().enumerate().filter(|(_, m)| m.0 == "/scan").map(|(i, _)| i as i64 + 1).collect();
    let conn = rusqlite::Connection::open(&path).unwrap();
    conn.execute("UPDATE messages SET topic_id = 1.5 WHERE id = ?1", [scan_rows[7]]).unwrap();
    conn.execute("UPDATE messages SET data = 'text' WHERE id = ?1", [scan_rows[20]]).unwrap();
    drop(conn);
    let run = replay::replay(&path, &no_classifier()).unwrap();
    assert!(run.error.is_none(), "{:?}", run.error);
    assert_eq!(run.report.scans_read, SCANS - 2);
    assert_eq!(run.report.skipped_records.by_reason, BTreeMap::from([("bad_row", 2)]));
    let [ReplayError::SqliteRow { row: a, reason: why_a, .. }, ReplayError::SqliteRow { row: b, .. }] = &run.bad_records.first[..] else {
        panic!("{:?}", run.bad_records)
    };
    assert_eq!((*a, *b), (scan_rows[7] as u64, scan_rows[20] as u64));
    assert!(why_a.contains("topic_id"), "{why_a}");
    let shown = run.bad_records.first[0].to_string();
    assert!(shown.contains(&format!("wrong-type.db3: messages row {a} (in id order) skipped")), "{shown}");
    assert!(occupied_near(&run, 1.5, 5.2), "the rows around them are used");
}

#[test]
fn an_upside_down_laser_sees_the_world_mirrored() {
    // Rolled by π about x (z down): a beam at +a in the laser frame points to −a in the world.
    let mut msgs = bag_messages([1.0, 0.0, 0.0, 0.0]);
    for m in msgs.iter_mut().filter(|m| m.0 == "/scan") {
        let mut s = laser_scan(0, "laser");
        s.ranges = vec![f32::NAN; 21];
        s.ranges[20] = 2.0; // +0.1 rad in the laser frame
        m.3 = cdr::encode_laser_scan(&s);
    }
    let path = tmp("flipped.db3");
    write_db3(&path, &msgs);
    let run = replay::replay(&path, &no_classifier()).unwrap();
    // The laser at (1.5, 2.2) facing +x; the hit at angle −0.1 rad, 2 m away.
    let (x, y) = (1.5 + 2.0 * (-0.1f64).cos(), 2.2 + 2.0 * (-0.1f64).sin());
    assert!(occupied_near(&run, x, y));
    assert!(!occupied_near(&run, x, 2.2 + 2.0 * 0.1f64.sin()), "not the unmirrored point");
}

#[test]
fn a_truncated_mcap_bag_names_the_offset_and_keeps_the_scans_before() {
    let path = tmp("whole.mcap");
    write_mcap(&path, &bag_messages(YAW_90), 2048);
    let bytes = std::fs::read(&path).unwrap();
    let cut = bytes.len() * 6 / 10;
    let cut_path = tmp("cut.mcap");
    std::fs::write(&cut_path, &bytes[..cut]).unwrap();
    let run = replay::replay(&cut_path, &no_classifier()).unwrap();
    let Some(ReplayError::Bag { file, offset, reason }) = &run.error else { panic!("{:?}", run.error) };
    assert_eq!(file, &cut_path);
    assert!(*offset < cut as u64, "the damaged record starts before the cut: {offset} vs {cut}");
    assert!(reason.contains("truncated"), "{reason}");
    let r = &run.report;
    assert!(r.scans_read > 0 && r.scans_read < SCANS, "{} scans before the damage", r.scans_read);
    assert_eq!(r.scans_used, r.scans_read);
    assert!(occupied_near(&run, 1.5, 5.2), "the scans before the damage were used");
    assert!(r.error.as_deref().unwrap().contains(&format!("cut.mcap: byte {offset}")));
    // Corrupt bytes inside a compressed chunk after the first third: that chunk is skipped and
    // counted at its offset, the scans before and after it kept (before: reading stopped there).
    let (chunk_at, chunk_len) =
        records(&bytes).into_iter().find(|&(op, at, _)| op == 0x06 && at > bytes.len() / 3).map(|(_, at, len)| (at, len)).unwrap();
    let mut bad = bytes.clone();
    let mid = chunk_at + 9 + chunk_len / 2;
    for b in &mut bad[mid..mid + 16] {
        *b ^= 0x5a;
    }
    let (run, reason) = replay_skipping_one_chunk("corrupt.mcap", &bad, chunk_at);
    assert!(reason.starts_with("damaged Chunk record, skipped: its zstd data"), "{reason}");
    assert_eq!(run.report.skipped_records.by_reason, BTreeMap::from([("damaged_chunk", 1)]));
    let in_chunk = scans_in_chunk(&path, &bytes, chunk_at);
    assert!(in_chunk > 0);
    assert_eq!(run.report.scans_read, SCANS - in_chunk, "every scan outside the damaged chunk is read");
}

/// Replays the MCAP file `bytes`, written as `name`: it reads to its end with one damage, the
/// chunk at byte `chunk_at` named and skipped. The run, and why the chunk was skipped.
fn replay_skipping_one_chunk(name: &str, bytes: &[u8], chunk_at: usize) -> (ReplayRun, String) {
    let path = tmp(name);
    std::fs::write(&path, bytes).unwrap();
    let run = replay::replay(&path, &no_classifier()).unwrap();
    assert!(run.error.is_none(), "{:?}", run.error);
    let [ReplayError::BagChunk { offset, reason, .. }] = &run.bad_records.first[..] else { panic!("{:?}", run.bad_records) };
    assert_eq!(*offset, chunk_at as u64);
    let reason = reason.clone();
    (run, reason)
}

/// How many `/scan` messages of the MCAP file `bytes` (at `path`) are in the chunk at byte `at`.
fn scans_in_chunk(path: &Path, bytes: &[u8], at: usize) -> u32 {
    let c = host::io::replay::rosbag::read_mcap(path, bytes);
    assert!(c.error.is_none() && c.bad.total == 0, "{:?} {:?}", c.error, c.bad);
    c.messages.iter().filter(|m| m.topic == "/scan" && m.at == Location::Offset(at as u64)).count() as u32
}

/// Issue 29: one bit flipped inside a zstd chunk's compressed bytes made the `mcap` crate's chunk
/// reader allocate what the damaged stream said ("memory allocation of 3835153973647651646 bytes
/// failed", SIGABRT, or "capacity overflow"). Every single-bit flip of one chunk's compressed
/// bytes: no panic, the chunk either reads as before or is skipped and named by its offset, and
/// every message outside it is kept.
#[test]
fn any_bit_flipped_in_a_zstd_chunk_costs_that_chunk_at_most() {
    let path = tmp("flips.mcap");
    write_mcap(&path, &bag_messages(YAW_90), 2048);
    let bytes = std::fs::read(&path).unwrap();
    let whole = host::io::replay::rosbag::read_mcap(&path, &bytes);
    assert!(whole.error.is_none() && whole.bad.total == 0);
    let chunks: Vec<(u8, usize, usize)> = records(&bytes).into_iter().filter(|r| r.0 == 0x06).collect();
    assert!(chunks.len() >= 3, "{} chunks", chunks.len());
    let (_, chunk_at, chunk_len) = chunks[1];
    let compression_len = u32::from_le_bytes(bytes[chunk_at + 9 + 28..chunk_at + 9 + 32].try_into().unwrap()) as usize;
    let data_at = chunk_at + 9 + 40 + compression_len;
    let outside =
        |c: &host::io::replay::rosbag::BagContents| c.messages.iter().filter(|m| m.at != Location::Offset(chunk_at as u64)).count();
    let (mut skipped, mut same) = (0, 0);
    for byte in data_at..chunk_at + 9 + chunk_len {
        for bit in 0..8 {
            let mut b = bytes.clone();
            b[byte] ^= 1 << bit;
            let c = host::io::replay::rosbag::read_mcap(&path, &b);
            assert!(c.error.is_none(), "byte {byte} bit {bit}: {:?}", c.error);
            assert_eq!(outside(&c), outside(&whole), "byte {byte} bit {bit}");
            match &c.bad.first[..] {
                [] => {
                    assert_eq!(c.messages.len(), whole.messages.len(), "byte {byte} bit {bit}");
                    same += 1;
                }
                [ReplayError::BagChunk { offset, .. }] => {
                    assert_eq!(*offset, chunk_at as u64);
                    skipped += 1;
                }
                other => panic!("byte {byte} bit {bit}: {other:?}"),
            }
        }
    }
    assert!(skipped > 0, "{skipped} flips skipped the chunk, {same} changed nothing");
}

/// The input that aborted `lives replay` before (issue 29), kept in the fuzz corpus: it reads
/// with its damaged chunk named and skipped.
#[test]
fn the_mcap_that_aborted_replay_reads_with_the_chunk_skipped() {
    let path = common::root().join("fuzz/corpus/mcap/regression-zstd-bitflip-alloc.mcap");
    let run = replay::replay(&path, &no_classifier()).unwrap();
    assert!(run.error.is_none(), "{:?}", run.error);
    assert_eq!(run.report.skipped_records.by_reason, BTreeMap::from([("damaged_chunk", 1)]));
    assert!(run.report.scans_read > 0);
}

#[test]
fn an_undecodable_message_is_skipped_and_the_messages_after_it_are_used() {
    // Scan 12's CDR encapsulation becomes 0x0009 (no such representation), in an MCAP and in a
    // sqlite3 bag: before, reading stopped there and the 17 scans after it were lost.
    let mut msgs = bag_messages(YAW_90);
    let k = msgs.iter().enumerate().filter(|(_, m)| m.0 == "/scan").nth(12).unwrap().0;
    msgs[k].3[1] = 0x09;
    let (mcap_path, db3_path) = (tmp("bad-message.mcap"), tmp("bad-message.db3"));
    write_mcap(&mcap_path, &msgs, 4096);
    write_db3(&db3_path, &msgs);
    for path in [&mcap_path, &db3_path] {
        let run = replay::replay(path, &no_classifier()).unwrap();
        assert!(run.error.is_none(), "{:?}", run.error);
        let r = &run.report;
        assert_eq!((r.scans_read, r.scans_used), (SCANS - 1, SCANS - 1), "{path:?}");
        assert_eq!(r.skipped_records.by_reason, BTreeMap::from([("undecodable_message", 1)]));
        let [ReplayError::Message { topic, at, error, .. }] = &run.bad_records.first[..] else { panic!("{:?}", run.bad_records) };
        assert_eq!(topic, "/scan");
        assert!(error.to_string().contains("unknown CDR encapsulation 0x0009"), "{error}");
        if path == &db3_path {
            assert_eq!(*at, Location::Row(k as i64 + 1));
        }
        assert!(occupied_near(&run, 1.5, 5.2));
    }
}

/// An MCAP file without compression, its messages top-level or (`chunks`) in uncompressed chunks
/// of about 2 kB: bytes a test can edit.
fn write_plain_mcap(path: &Path, messages: &[(&str, &str, u64, Vec<u8>)], chunks: bool) {
    let opts = mcap::WriteOptions::new().compression(None).use_chunks(chunks).chunk_size(Some(2048)).profile("ros2");
    write_mcap_with(path, messages, opts);
}

/// `bytes` with the record length at `at` (a record's offset) set to `len`.
fn with_record_length(bytes: &[u8], at: usize, len: u64) -> Vec<u8> {
    let mut b = bytes.to_vec();
    b[at + 1..at + 9].copy_from_slice(&len.to_le_bytes());
    b
}

#[test]
fn a_wrong_mcap_record_length_names_the_record_and_what_it_needed() {
    let path = tmp("plain.mcap");
    write_plain_mcap(&path, &bag_messages(YAW_90), false);
    let bytes = std::fs::read(&path).unwrap();
    let (_, at, len) = records(&bytes).into_iter().filter(|r| r.0 == 0x05).nth(30).unwrap();
    let replay_of = |name: &str, b: &[u8]| {
        let p = tmp(name);
        std::fs::write(&p, b).unwrap();
        let run = replay::replay(&p, &no_classifier()).unwrap();
        assert!(run.report.scans_read > 0 && run.report.scans_read < SCANS, "{}", run.report.scans_read);
        assert_eq!(run.report.scans_used, run.report.scans_read);
        match run.error {
            Some(ReplayError::Bag { offset, reason, .. }) => (offset, reason),
            e => panic!("{e:?}"),
        }
    };
    // Too short for a Message's fixed fields (before: `cannot parse Message record: Record parse
    // failed`).
    let (offset, reason) = replay_of("short-message.mcap", &with_record_length(&bytes, at, 10));
    assert_eq!(offset, at as u64);
    assert_eq!(
        reason,
        "Message record of 10 bytes is shorter than the 22 bytes of its channel id, sequence, log time and publish time \
         (a wrong record length)"
    );
    // Too long: the next record header falls inside this message's data.
    let (offset, reason) = replay_of("long-message.mcap", &with_record_length(&bytes, at, len as u64 + 40));
    assert_eq!(offset, (at + 9 + len + 40) as u64);
    assert!(reason.starts_with("no MCAP record starts here (opcode 0x"), "{reason}");
    assert!(reason.ends_with(&format!("the Message record at byte {at} has a wrong length")), "{reason}");
    // Inside an uncompressed chunk: the record's own byte (before: `damaged Chunk record: Record
    // parse failed`). The chunk's CRC is zeroed (unchecked) so the crate reads its records.
    let chunked = tmp("plain-chunks.mcap");
    write_plain_mcap(&chunked, &bag_messages(YAW_90), true);
    let bytes = std::fs::read(&chunked).unwrap();
    let (_, chunk_at, _) = records(&bytes).into_iter().filter(|r| r.0 == 0x06).nth(3).unwrap();
    let first = chunk_at + 9 + 40;
    let inner = first + 9 + u64::from_le_bytes(bytes[first + 1..first + 9].try_into().unwrap()) as usize;
    assert_eq!(bytes[inner], 0x05, "the chunk's second record is a message");
    let mut bad = with_record_length(&bytes, inner, 10);
    bad[chunk_at + 9 + 24..chunk_at + 9 + 28].fill(0);
    // The chunk's own length is intact: the rest of it is skipped, the chunks after it read.
    let (run, reason) = replay_skipping_one_chunk("short-chunked-message.mcap", &bad, chunk_at);
    assert!(
        reason.starts_with(&format!(
            "damaged Chunk record, the rest of it skipped: its record at byte {inner}: Message record of 10 bytes is shorter than the 22"
        )),
        "{reason}"
    );
    let lost = scans_in_chunk(&chunked, &bytes, chunk_at);
    assert!(run.report.scans_read >= SCANS - lost && run.report.scans_read < SCANS, "{}", run.report.scans_read);
}

/// The top-level records of an MCAP file: (opcode, offset, body length).
fn records(bytes: &[u8]) -> Vec<(u8, usize, usize)> {
    let mut out = Vec::new();
    let mut pos = 8;
    while pos + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
        out.push((bytes[pos], pos, len));
        pos += 9 + len;
    }
    out
}

#[test]
fn a_truncated_sqlite3_bag_names_the_row_and_keeps_the_scans_before() {
    // 200 scans of 1000 beams (4 kB each): the messages table spans many pages.
    let mut msgs = Vec::new();
    msgs.push(("/tf_static", "tf2_msgs/msg/TFMessage", 1, mount(YAW_90)));
    for i in 0..200u32 {
        let t = 10_000_000_000 + i as u64 * 200_000_000;
        msgs.push(("/odom", "nav_msgs/msg/Odometry", t, odometry(i)));
        let mut s = laser_scan(i, "laser");
        s.angle_min = -1.0;
        s.angle_increment = 0.002;
        s.ranges = vec![3.0; 1000];
        msgs.push(("/scan", "sensor_msgs/msg/LaserScan", t + 1, cdr::encode_laser_scan(&s)));
    }
    let path = tmp("long.db3");
    write_db3(&path, &msgs);
    let bytes = std::fs::read(&path).unwrap();
    let cut_path = tmp("long-cut.db3");
    std::fs::write(&cut_path, &bytes[..bytes.len() / 2]).unwrap();
    let run = replay::replay(&cut_path, &no_classifier()).unwrap();
    let Some(ReplayError::Sqlite { file, after_row, .. }) = &run.error else { panic!("{:?}", run.error) };
    assert_eq!(file, &cut_path);
    let r = &run.report;
    assert!(r.scans_read > 10 && r.scans_read < 200, "{} scans before the damage", r.scans_read);
    // Rows: 1 the mount, then odometry and scan in turn (scan k at row 1 + 2k): the last row read
    // is the last scan's or the odometry after it.
    let n = r.scans_read as i64;
    assert!(matches!(*after_row, Some(row) if row == 1 + 2 * n || row == 2 + 2 * n), "{after_row:?} after {n} scans");
    assert!(r.error.as_deref().unwrap().contains("long-cut.db3: sqlite error after messages row"));
}

/// A bag as a real robot records one, with what goes wrong on one: the scanner starts 3 scans
/// before the odometry, the robot drives +x at 1 m/s, one odometry message jumps 100 m, one is
/// stamped before the one before it, a `tf` message would close a loop of frames, one scan is
/// stamped backwards, and the odometry then stops for 2 s while the scanner runs on.
#[test]
fn bag_poses_are_interpolated_and_bad_poses_are_named_rejections() {
    let stamp = |t_ns: u64| Time { sec: (t_ns / 1_000_000_000) as i32, nanosec: (t_ns % 1_000_000_000) as u32 };
    let odom_at = |t_ns: u64, x: f64| {
        cdr::encode_odometry(&Odometry {
            header: Header { stamp: stamp(t_ns), frame_id: "odom".into() },
            child_frame_id: "base_link".into(),
            pose: Transform::planar(x, 2.0, 0.0),
        })
    };
    let scan_at = |t_ns: u64| {
        let mut s = laser_scan(0, "laser");
        s.header.stamp = stamp(t_ns);
        cdr::encode_laser_scan(&s)
    };
    let base = 10_000_000_000u64;
    let mut m = vec![("/tf_static", "tf2_msgs/msg/TFMessage", base, mount(YAW_90))];
    // Scans every 100 ms from `base`, stamped 30 ms after each odometry message of 100 ms steps
    // that starts 3 scans later; received 5 ms after their stamp.
    for i in 0..40u64 {
        let t_scan = base + i * 100_000_000 + 30_000_000;
        let t_odom = base + i * 100_000_000;
        let x = 1.0 + (t_odom - base) as f64 / 1e9;
        if (3..30).contains(&i) {
            let x = if i == 10 { x + 100.0 } else { x };
            m.push(("/odom", "nav_msgs/msg/Odometry", t_odom + 1_000_000, odom_at(t_odom, x)));
        }
        if i == 12 {
            // Stamped before the message before it (i = 11): refused.
            m.push(("/odom", "nav_msgs/msg/Odometry", t_odom + 2_000_000, odom_at(t_odom - 150_000_000, x)));
        }
        if i == 15 {
            let tf = cdr::encode_tf_message(&[TransformStamped {
                header: Header { stamp: stamp(t_odom), frame_id: "laser".into() },
                child_frame_id: "odom".into(),
                transform: Transform::IDENTITY,
            }]);
            m.push(("/tf", "tf2_msgs/msg/TFMessage", t_odom + 3_000_000, tf));
        }
        // Scan 20 is stamped 150 ms early, before scan 19.
        let stamped = if i == 20 { t_scan - 150_000_000 } else { t_scan };
        m.push(("/scan", "sensor_msgs/msg/LaserScan", t_scan + 5_000_000, scan_at(stamped)));
    }
    let path = tmp("bad-poses.mcap");
    write_mcap(&path, &m, 4096);
    let log = replay::read_log(&path).unwrap();
    assert_eq!((log.unplaced.no_odometry_yet, log.unplaced.scan_stamp_backwards), (3, 1), "{:?}", log.warnings);
    // The odometry's last sample is stamped 30 ms before scan 29; scans 30–33 are within 0.5 s
    // of it, 34–39 are not.
    assert_eq!(log.unplaced.stale_pose, 6, "{:?}", log.warnings);
    let t = log.transforms_rejected;
    assert_eq!((t.odometry_jump, t.stamp_backwards, t.tf_loop, t.invalid), (1, 1, 1, 0), "{t:?}");
    // Interpolated to the scan's stamp (30 ms after the odometry's, between two samples 0.1 m
    // apart): x = base + mount, the mount turned the laser to +y and put it 0.5 m ahead.
    for s in &log.scans {
        let i = ((s.t_s * 1e9).round() as u64 - 5_000_000 - base) / 100_000_000;
        if (3..29).contains(&i) && i != 20 {
            let want_x = 1.0 + i as f64 * 0.1 + 0.03 + 0.5;
            assert!((s.pose[0] - want_x).abs() < 1e-9, "scan {i}: {:?} wants x {want_x}", s.pose);
            assert!((s.pose[1] - 2.2).abs() < 1e-9 && (s.pose[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        }
    }
    let run = replay::replay(&path, &no_classifier()).unwrap();
    let r = &run.report;
    assert_eq!(
        r.rejected,
        replay::Rejected { no_odometry_yet: 3, stale_pose: 6, stamp_backwards: 1, ..Default::default() },
        "{:?}",
        r.warnings
    );
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (40, 30, 10));
    assert_eq!(r.transforms_rejected, t);
    assert!(r.warnings.iter().any(|w| w.contains("before the first odometry")), "{:?}", r.warnings);
    assert!(r.warnings.iter().any(|w| w.contains("1 odometry_jump") && w.contains("1 tf_loop")), "{:?}", r.warnings);
    // Nothing was drawn at the mount offset from the origin (where the first scans would have
    // been put), nor 100 m away.
    assert!(r.trajectory_bounds[0][0] >= 1.8 && r.trajectory_bounds[1][0] < 4.5, "{:?}", r.trajectory_bounds);
}

/// Buildings larger than the grid (issue 27, item 6): the CSAIL trajectories (43 × 58 m corrected,
/// 51 × 43 m raw) do not fit the 51.2 m grid. The grid starts on the first pose and the core's
/// rolling window follows the laser: every scan is used (7 of the raw log's and 27 of the
/// corrected log's were rejected `outside_grid` with a fixed grid), and the final window holds
/// the robot's last stretch of corridor.
#[test]
fn csail_logs_larger_than_the_grid_are_followed_by_the_window() {
    for (name, scans) in [("csail-corrected.log.gz", 406), ("raw/mit-csail-raw.clf.gz", 1988)] {
        let run = replay::replay(&carmen(name), &ReplayOptions::default()).unwrap();
        let r = &run.report;
        assert!(r.exceeds_grid, "{name}");
        assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (scans, scans, 0), "{name}: {:?}", r.rejected);
        assert!(r.window_shifts >= 1, "{name}");
        assert_eq!(r.window_shifts, run.controller.lidar.window.shifts);
        let g = run.controller.lidar.geom;
        let round3 = |v: f64| (v * 1000.0).round() / 1000.0;
        assert_eq!(r.final_grid_origin, [round3(g.origin_x.to_num::<f64>()), round3(g.origin_y.to_num::<f64>())]);
        let first = run.poses[0].pose;
        assert_eq!(r.grid_origin, replay::grid_origin([[first[0], first[1]]; 2]), "{name}: placed on the first pose");
        // The robot's last cells are in the final window, and free: it drove there.
        let p = run.trajectory[run.trajectory.len() - 1];
        assert_eq!(cell_at(&run, p[0], p[1]), Cell::Free, "{name}");
        assert!(r.warnings.iter().any(|w| w.contains("window moved")), "{name}: {:?}", r.warnings);
    }
}

/// The VLP-16 captures replay (issue 27): one scan per rotation from the ±1° band, each placed
/// at the origin (a capture holds no pose, which a warning says), mapped with the scanner's own
/// 0.3–100 m limits.
#[test]
fn vlp16_captures_replay_one_scan_per_rotation_at_the_origin() {
    for (name, scans) in [("velodyne_vlp16.pcap", 2), ("einride_vlp16_recording.bin", 14)] {
        let path = common::root().join("tests/data/velodyne").join(name);
        let log = replay::read_log(&path).unwrap();
        assert_eq!(log.format, LogFormat::Vlp16, "{name}");
        assert_eq!(log.scans.len(), scans, "{name}");
        assert!(log.scans.iter().all(|s| s.pose == [0.0; 3] && s.range_limits_m == [0.3, 100.0]), "{name}");
        let run = replay::replay(&path, &no_classifier()).unwrap();
        let r = &run.report;
        assert_eq!((r.scans_used, r.scans_rejected), (scans as u32, 0), "{name}");
        assert!(r.grid.occupied > 200 && r.grid.free > 10_000, "{name}: {:?}", r.grid);
        assert!(r.warnings.iter().any(|w| w.contains("holds no pose")), "{name}: {:?}", r.warnings);
    }
}

/// A VLP-16 capture cut short: the scans before the cut are replayed and the damage is the
/// replay's error (exit status 1, as for every format), naming the file once and the byte.
#[test]
fn a_truncated_vlp16_capture_keeps_the_scans_before_and_is_named_damage() {
    let bytes = std::fs::read(common::root().join("tests/data/velodyne/einride_vlp16_recording.bin")).unwrap();
    let cut_path = tmp("cut-vlp16.bin");
    std::fs::write(&cut_path, &bytes[..bytes.len() / 2 + 100]).unwrap();
    let run = replay::replay(&cut_path, &no_classifier()).unwrap();
    let msg = run.error.as_ref().expect("the cut is damage").to_string();
    let name = cut_path.display().to_string();
    assert!(msg.starts_with(&format!("{name}: the capture's reading stopped early: byte ")), "{msg}");
    assert_eq!(msg.matches(&name).count(), 1, "{msg}");
    assert!(run.report.scans_used >= 5 && run.report.scans_used < 14, "{}", run.report.scans_used);
    let out = std::process::Command::new(common::lives()).args(["replay", cut_path.to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
}

/// Bad scans in a bag (issue 27): a `range_max` of 0, a `range_max` below `range_min`, no beams
/// and a NaN `angle_min` are each a counted rejection with its own name, and every good scan
/// before and after them is mapped.
#[test]
fn bad_scans_in_a_bag_are_named_rejections_and_lose_nothing_good() {
    let mut m = bag_messages(YAW_90);
    // Scans 5, 10, 15 and 20 go bad, each its own way.
    for (k, msg) in m.iter_mut().filter(|msg| msg.0 == "/scan").enumerate() {
        let mut s = laser_scan(k as u32, "laser");
        match k {
            5 => s.range_max = 0.0,
            10 => (s.range_min, s.range_max) = (5.0, 2.0),
            15 => s.ranges.clear(),
            20 => s.angle_min = f32::NAN,
            _ => {}
        }
        msg.3 = cdr::encode_laser_scan(&s);
    }
    let path = tmp("bad-scans.mcap");
    write_mcap(&path, &m, 4096);
    let run = replay::replay(&path, &no_classifier()).unwrap();
    let r = &run.report;
    assert_eq!((r.scans_read, r.scans_used, r.scans_rejected), (SCANS, SCANS - 4, 4), "{:?}", r.rejected);
    assert_eq!((r.rejected.bad_angles, r.rejected.controller), (1, 3), "{:?}", r.rejected);
    let want: BTreeMap<&str, u32> = [("bad_range_limits", 2), ("empty", 1)].into_iter().collect();
    assert_eq!(r.controller_rejections, want);
    // The good scans still drew the wall ahead of the laser.
    assert!(occupied_near(&run, 1.5, 5.2));
}

/// Issue 29: a negative number given as a separate argument (`--max-range -1`) was refused as
/// an unexpected argument; it is read as the value and range-checked like any other.
#[test]
fn a_negative_value_is_read_and_range_checked() {
    let log = carmen("aces-corrected.log.gz");
    for (value, shown) in [("-1", "-1"), ("-1e3", "-1000"), ("-0.5", "-0.5")] {
        let out = std::process::Command::new(common::lives()).args(["replay", "--max-range", value]).arg(&log).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{value}: {err}");
        assert!(
            err.contains(&format!("error: --max-range {shown}: expected metres above the minimum range and at most")),
            "{value}: {err}"
        );
        assert!(!err.contains("unexpected argument"), "{err}");
    }
    // `--flag=-1` was always read; a separate positive value still is.
    let out = std::process::Command::new(common::lives()).args(["replay", "--max-range", "100"]).arg(&log).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("--max-range 100: expected metres"));
}

/// Found by the coverage-guided campaign (issue 29): an Attachment record whose declared lengths
/// exceed its body made the `mcap` crate's parser panic ("slice index starts at 34 but ends at
/// 31"). Replay reads nothing from attachments: it steps over them by their length, and the file
/// is an error at its missing footer like any other truncated bag.
#[test]
fn a_damaged_attachment_record_is_stepped_over_not_a_panic() {
    let path = common::root().join("fuzz/corpus/mcap/regression-attachment-slice-panic.mcap");
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes[8], 0x09, "an Attachment record first");
    let c = host::io::replay::rosbag::read_mcap(&path, &bytes);
    assert!(c.messages.is_empty());
    let shown = c.error.as_ref().map(|e| e.to_string()).unwrap_or_default();
    assert!(shown.contains("regression-attachment-slice-panic.mcap: byte"), "{shown}");
    let out = std::process::Command::new(common::lives()).args(["replay", "--no-classifier"]).arg(&path).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
}
