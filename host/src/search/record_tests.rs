//! Recording a simulated search ([`super::record_search`]): what the MCAP file holds, and that
//! recording does not change the run.

use crate::io::record::*;
use crate::search::{self, record_search, PlannerChoice, SearchSpec};
use crate::sim::{Scenario, World};
use base64::Engine as _;
use firmware::grid::GridGeometry;
use firmware::grid::{Cell, PackedGrid};
use firmware::scan::{BeamLabel, BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use firmware::Pose2;
use serde_json::Value;
use std::path::Path;
use std::path::PathBuf;
use std::time::Duration;

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("lives-record-{}-{name}", std::process::id()))
}

fn spec() -> SearchSpec {
    let w = World::builtin("apartment", Scenario::Easy).expect("built-in world");
    SearchSpec::new("apartment", w, Scenario::Easy, PlannerChoice::LivesGt, 1)
}

/// A search long enough to fill several chunks of 100 messages (the easy one ends in seconds).
fn long_spec() -> SearchSpec {
    let w = World::builtin("apartment", Scenario::Hard).expect("built-in world");
    SearchSpec::new("apartment", w, Scenario::Hard, PlannerChoice::LivesGt, 1)
}

/// One message as the streaming reader returns it: topic, schema name, schema encoding, message
/// encoding, log time, JSON.
type StreamMessage = (String, String, String, String, u64, Value);

/// Every message the streaming reader gets before the file ends or breaks, and whether it ended in
/// an error.
fn read_stream(bytes: &[u8]) -> (Vec<StreamMessage>, bool) {
    let mut out = Vec::new();
    let stream = match mcap::MessageStream::new(bytes) {
        Ok(s) => s,
        Err(_) => return (out, true),
    };
    for m in stream {
        match m {
            Ok(m) => {
                let schema = m.channel.schema.as_ref().expect("every channel has a schema");
                let json: Value = serde_json::from_slice(&m.data).expect("every message is JSON");
                out.push((
                    m.channel.topic.clone(),
                    schema.name.clone(),
                    schema.encoding.clone(),
                    m.channel.message_encoding.clone(),
                    m.log_time,
                    json,
                ));
            }
            Err(_) => return (out, true),
        }
    }
    (out, false)
}

fn count(msgs: &[(String, String, String, String, u64, Value)], topic: &str) -> usize {
    msgs.iter().filter(|m| m.0 == topic).count()
}

#[test]
fn a_recorded_search_reads_back_with_every_topic_schema_and_count() {
    let path = tmp("full.mcap");
    let mut rec = Recorder::create(&path, RecordOptions::default()).unwrap();
    let (run, recorded) = record_search(&spec(), Some(&mut rec), |_| {}).unwrap();
    recorded.unwrap();
    let summary = rec.finish().unwrap();
    let bytes = std::fs::read(&path).unwrap();
    std::fs::remove_file(&path).ok();
    let (msgs, broken) = read_stream(&bytes);
    assert!(!broken, "a finished recording reads to its end");
    assert_eq!(msgs.len() as u64, summary.total_messages());

    let r = &run.result;
    assert!(r.found, "{r:?}");
    let ticks = r.ticks as usize;
    for topic in [topics::TF, topics::POSE, topics::SCAN, topics::STATUS] {
        assert_eq!(count(&msgs, topic), ticks, "{topic}: one per tick");
    }
    // Grids at t = 0, 1, 2 … s and at the detection.
    let grids = (ticks - 1) / 5 + 1 + usize::from(!(ticks - 1).is_multiple_of(5));
    for topic in [topics::LIDAR_GRID, topics::VISUAL_GRID, topics::NONMAP] {
        assert_eq!(count(&msgs, topic), grids, "{topic}");
    }
    assert_eq!(count(&msgs, topics::GOAL), r.goals as usize);
    assert_eq!(count(&msgs, topics::GOAL), run.goals.len());
    assert_eq!(count(&msgs, topics::PATH), r.goals as usize);
    assert_eq!(count(&msgs, topics::DETECTION), 1);
    assert_eq!(count(&msgs, topics::LABELS), 0, "no node, no node labels");
    let last = msgs.iter().rev().find(|m| m.0 == topics::STATUS).unwrap();
    let plans = last.5["plans"].as_u64().unwrap() as usize;
    assert!(plans >= r.goals as usize);
    assert_eq!(count(&msgs, topics::FRONTIERS), plans);
    assert_eq!(count(&msgs, topics::CANDIDATES), plans);
    assert_eq!(last.5["mode"], "TargetFound");

    for (topic, name, enc, menc, t_ns, json) in &msgs {
        let want = CHANNELS.iter().find(|c| c.0 == topic).expect("known topic").1;
        assert_eq!((name.as_str(), enc.as_str(), menc.as_str()), (want, "jsonschema", "json"), "{topic}");
        if let Some(ts) = json.get("timestamp") {
            let ns = ts["sec"].as_u64().unwrap() * 1_000_000_000 + ts["nsec"].as_u64().unwrap();
            assert_eq!(ns, *t_ns, "{topic}: stamped at its log time");
        }
    }
    // The goal recorded first is the run's first decision.
    let goal = msgs.iter().find(|m| m.0 == topics::GOAL).unwrap();
    let geom = run.controller.lidar.geom;
    let (gx, gy) = (goal.5["pose"]["position"]["x"].as_f64().unwrap(), goal.5["pose"]["position"]["y"].as_f64().unwrap());
    let cell = geom.cell_of(fixed_point::meters_from_f64(gx).unwrap(), fixed_point::meters_from_f64(gy).unwrap());
    assert_eq!(cell, run.goals[0].0);
    // The last grid is the controller's final LiDAR map, cropped: its known cells are all there.
    let grid = msgs.iter().rev().find(|m| m.0 == topics::LIDAR_GRID).unwrap();
    let data = base64::engine::general_purpose::STANDARD.decode(grid.5["data"].as_str().unwrap()).unwrap();
    let known = data.iter().filter(|&&b| b as i8 != -1).count() as u32;
    let g = &run.controller.lidar.grid;
    assert_eq!(known, g.count(Cell::Free) + g.count(Cell::Occupied));
}

#[test]
fn recording_does_not_change_the_run() {
    let plain = search::run(&spec(), |_| {});
    let path = tmp("same.mcap");
    let mut rec = Recorder::create(&path, RecordOptions::default()).unwrap();
    let (recorded, ok) = record_search(&spec(), Some(&mut rec), |_| {}).unwrap();
    ok.unwrap();
    drop(rec);
    std::fs::remove_file(&path).ok();
    assert_eq!(serde_json::to_string(&plain.result).unwrap(), serde_json::to_string(&recorded.result).unwrap());
    assert_eq!(plain.goals, recorded.goals);
    assert_eq!(plain.trajectory, recorded.trajectory);
}

#[test]
fn a_crash_loses_only_the_messages_after_the_last_flushed_chunk() {
    // Chunks every 100 messages and (practically) never by wall time: where the file ends is
    // deterministic.
    let path = tmp("crash.mcap");
    let opts = RecordOptions { flush_every: Duration::from_secs(3600), flush_every_messages: 100, ..RecordOptions::default() };
    let mut rec = Recorder::create(&path, opts).unwrap();
    let (_, ok) = record_search(&long_spec(), Some(&mut rec), |_| {}).unwrap();
    ok.unwrap();
    let total = rec.summary().total_messages();
    let lost = rec.unflushed_messages();
    assert!(lost < 100 && total >= 300, "{total} recorded, {lost} unflushed: several chunks flushed");
    // The process dies here: the file is what is on disk now (no summary, no footer).
    let crashed = std::fs::read(&path).unwrap();
    std::mem::forget(rec);
    std::fs::remove_file(&path).ok();
    let (msgs, broken) = read_stream(&crashed);
    assert!(broken, "an unfinished file has no footer");
    assert_eq!(msgs.len() as u64, total - lost, "every message up to the last flushed chunk");
    assert_eq!(msgs.len() % 100, 0);
    // In order and complete up to there: one pose per tick from t = 0.
    let poses: Vec<u64> = msgs.iter().filter(|m| m.0 == topics::POSE).map(|m| m.4).collect();
    assert!(poses.iter().enumerate().all(|(i, &t)| t == i as u64 * 200_000_000));
}

#[test]
fn with_a_zero_wall_time_bound_every_message_is_on_disk_at_once() {
    let path = tmp("wall.mcap");
    let opts = RecordOptions { flush_every: Duration::ZERO, flush_every_messages: u64::MAX, ..RecordOptions::default() };
    let mut rec = Recorder::create(&path, opts).unwrap();
    let pose = Pose2::from_f64(1.0, 2.0, 0.5).unwrap();
    for k in 0..5u64 {
        rec.record_pose(k * 200_000, &pose).unwrap();
        assert_eq!(rec.unflushed_messages(), 0);
        let (msgs, _) = read_stream(&std::fs::read(&path).unwrap());
        assert_eq!(msgs.len() as u64, 2 * (k + 1), "tf and pose of every tick so far");
    }
    rec.finish().unwrap();
    std::fs::remove_file(&path).ok();
}

#[test]
fn grids_are_cropped_to_the_known_area_in_the_map_frame() {
    let path = tmp("grid.mcap");
    let mut rec = Recorder::create(&path, RecordOptions::default()).unwrap();
    let geom =
        GridGeometry { origin_x: fixed_point::meters_from_f64(-10.0).unwrap(), origin_y: fixed_point::meters_from_f64(5.0).unwrap() };
    let (mut lidar, mut visual) = (PackedGrid::new(), PackedGrid::new());
    lidar.set(100, 40, Cell::Free);
    lidar.set(103, 42, Cell::Occupied);
    visual.set(99, 41, Cell::Free);
    rec.record_grids(7_000_000, &geom, &lidar, &visual).unwrap();
    rec.record_grids(7_200_000, &geom, &PackedGrid::new(), &PackedGrid::new()).unwrap();
    let summary = rec.finish().unwrap();
    assert_eq!(summary.messages.get(topics::LIDAR_GRID), Some(&1), "an all-unknown map is not recorded");
    let (msgs, _) = read_stream(&std::fs::read(&path).unwrap());
    std::fs::remove_file(&path).ok();
    let decode = |topic: &str| {
        let m = msgs.iter().find(|m| m.0 == topic).unwrap();
        (m.5.clone(), base64::engine::general_purpose::STANDARD.decode(m.5["data"].as_str().unwrap()).unwrap())
    };
    let (g, data) = decode(topics::LIDAR_GRID);
    // Columns 99..=103, rows 40..=42.
    assert_eq!((g["column_count"].as_u64(), g["row_stride"].as_u64(), data.len()), (Some(5), Some(5), 15));
    assert!((g["pose"]["position"]["x"].as_f64().unwrap() - (-10.0 + 9.9)).abs() < 1e-4);
    assert!((g["pose"]["position"]["y"].as_f64().unwrap() - (5.0 + 4.0)).abs() < 1e-4);
    assert_eq!(g["frame_id"], "map");
    assert_eq!(g["fields"][0]["name"], "occupancy");
    let at = |d: &[u8], x: usize, y: usize| d[(y - 40) * 5 + (x - 99)] as i8;
    assert_eq!((at(&data, 100, 40), at(&data, 103, 42), at(&data, 99, 41)), (0, 100, -1));
    let (_, vdata) = decode(topics::VISUAL_GRID);
    assert_eq!((at(&vdata, 99, 41), at(&vdata, 100, 40)), (0, -1));
}

#[test]
fn scan_points_sit_in_the_laser_frame_coloured_by_label_without_invalid_beams() {
    let path = tmp("scan.mcap");
    let mut rec = Recorder::create(&path, RecordOptions::default()).unwrap();
    let mut scan = BeamScan::new();
    scan.ranges_mm = [RANGE_INVALID; firmware::capacity::BEAMS];
    scan.ranges_mm[0] = 2000; // −π: behind the robot
    scan.labels[0] = BeamLabel::NonMap;
    scan.ranges_mm[1] = RANGE_NO_RETURN;
    let quarter = firmware::capacity::BEAMS / 4; // about −π/2: to the right
    scan.ranges_mm[quarter] = 1000;
    scan.labels[quarter] = BeamLabel::Map;
    rec.record_scan(400_000, &scan).unwrap();
    rec.finish().unwrap();
    let (msgs, _) = read_stream(&std::fs::read(&path).unwrap());
    std::fs::remove_file(&path).ok();
    let m = &msgs.iter().find(|m| m.0 == topics::SCAN).unwrap().5;
    assert_eq!(m["frame_id"], "laser");
    let stride = m["point_stride"].as_u64().unwrap() as usize;
    let data = base64::engine::general_purpose::STANDARD.decode(m["data"].as_str().unwrap()).unwrap();
    assert_eq!(data.len(), 2 * stride, "two returns; invalid and no-return beams left out");
    let f = |p: &[u8], o: usize| f32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]]);
    let (a, b) = (&data[..stride], &data[stride..]);
    assert!((f(a, 0) + 2.0).abs() < 1e-3 && f(a, 4).abs() < 1e-3, "({}, {})", f(a, 0), f(a, 4));
    assert_eq!(&a[12..17], &[2, 255, 140, 0, 255], "non-map: label 2, orange");
    assert!(f(b, 0).abs() < 0.01 && (f(b, 4) + 1.0).abs() < 1e-3, "({}, {})", f(b, 0), f(b, 4));
    assert_eq!(b[12], 1, "map");
}

#[test]
fn an_uncreatable_file_is_an_error_not_a_panic() {
    let e = Recorder::create(Path::new("/nonexistent-dir/x.mcap"), RecordOptions::default()).unwrap_err();
    assert!(matches!(e, RecordError::Create { .. }), "{e}");
    assert!(e.to_string().contains("/nonexistent-dir/x.mcap"));
}
