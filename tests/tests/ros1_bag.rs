//! ROS 1 bags (format 2.0; issue 31): `tests/data/ros1/` holds the Intel log written as a ROS 2
//! bag by `lives export-bag` and converted to ROS 1 by a third party's tool (`rosbags-convert
//! --dst-typestore ros1_noetic`, PyPI `rosbags` 0.11.9: ROS 1 serialisation with `seq` in every
//! header, ROS 1 type names), with bz2, lz4 and uncompressed chunks. Replayed, each gives the
//! scans, the map and the goals the ROS 2 bag of the same log gives; damaged copies keep what came
//! before the damage and name its byte.

use host::io::export_bag::{self, ExportOptions};
use host::io::replay::{self, LogFormat, ReplayError, ReplayOptions, ScanRecord};
use std::path::PathBuf;

mod common;

fn data(name: &str) -> PathBuf {
    common::root().join("tests/data/ros1").join(name)
}

fn opts() -> ReplayOptions {
    ReplayOptions { model: None, max_range_m: Some(replay::CARMEN_MAX_RANGE_M), scan_matching: Some(false), ..ReplayOptions::default() }
}

/// Two scans are the same but for where in the file they came from.
fn same_scan(a: &ScanRecord, b: &ScanRecord) -> bool {
    let ranges = a.ranges_m.len() == b.ranges_m.len()
        && a.ranges_m.iter().zip(&b.ranges_m).all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()));
    a.t_s == b.t_s
        && a.pose == b.pose
        && a.angle_min == b.angle_min
        && a.angle_increment == b.angle_increment
        && a.range_limits_m == b.range_limits_m
        && ranges
}

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lives-ros1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn the_intel_ros1_bag_replays_as_its_ros2_bag_does() {
    let mcap = temp("intel.mcap");
    export_bag::export(&common::root().join("tests/data/carmen/intel-corrected.log.gz"), &mcap, &ExportOptions::default()).unwrap();
    let ros2 = replay::read_log(&mcap).unwrap();
    let ros1 = replay::read_log(&data("intel-bz2.bag")).unwrap();
    assert_eq!(ros1.format, LogFormat::Ros1Bag);
    assert!(ros1.error.is_none() && ros1.bad_records.total == 0, "{:?}", ros1.error);
    assert_eq!((ros1.scans.len(), ros1.odometry, ros1.unplaced.no_odometry_yet), (907, 907, 3));
    assert_eq!(ros1.scans.len(), ros2.scans.len());
    for (a, b) in ros1.scans.iter().zip(&ros2.scans) {
        assert!(same_scan(a, b), "{a:?}\n{b:?}");
    }
    let mut sources = ros1.sources.clone();
    sources.sort();
    assert_eq!(sources, ["/odom (nav_msgs/Odometry)", "/scan (sensor_msgs/LaserScan)", "/tf_static (tf2_msgs/TFMessage)"]);
    let a = replay::replay(&data("intel-bz2.bag"), &opts()).unwrap();
    let b = replay::replay(&mcap, &opts()).unwrap();
    assert_eq!(a.report.format, LogFormat::Ros1Bag);
    assert_eq!((a.report.scans_used, a.report.grid.occupied, a.report.grid.free), (907, b.report.grid.occupied, b.report.grid.free));
    assert_eq!(a.report.goals, b.report.goals);
    assert!(a.report.grid.occupied > 5000, "{}", a.report.grid.occupied);
}

#[test]
fn lz4_bz2_and_uncompressed_chunks_give_the_same_scans() {
    let lz4 = replay::read_log(&data("intel-120-lz4.bag")).unwrap();
    let none = replay::read_log(&data("intel-120-none.bag")).unwrap();
    let bz2 = replay::read_log(&data("intel-bz2.bag")).unwrap();
    assert_eq!(lz4.scans.len(), 117, "120 scans, 3 before the first odometry");
    assert_eq!(none.scans.len(), 117);
    for ((a, b), c) in lz4.scans.iter().zip(&none.scans).zip(&bz2.scans) {
        assert!(same_scan(a, b) && same_scan(a, c), "{a:?}\n{b:?}\n{c:?}");
    }
}

/// The bytes of the uncompressed 120-scan bag, and where its messages' records start (every
/// `op=\x02` header field is 4 bytes after its record's header length).
fn plain() -> Vec<u8> {
    std::fs::read(data("intel-120-none.bag")).unwrap()
}

#[test]
fn a_truncated_bag_keeps_every_scan_before_the_cut_and_names_the_byte() {
    let bytes = plain();
    let file = temp("cut.bag");
    let mut last = 0;
    for k in 1..=40 {
        let cut = 13 + (bytes.len() - 13) * k / 41;
        std::fs::write(&file, &bytes[..cut]).unwrap();
        let log = replay::read_log(&file).unwrap();
        // The scans of whole chunks before the cut are kept, more the later the cut.
        assert!(log.scans.len() >= last, "cut at {cut}: {} scans after {last}", log.scans.len());
        last = log.scans.len();
        if let Some(e) = &log.error {
            let (ReplayError::Bag { offset, .. } | ReplayError::BagChunk { offset, .. }) = e else { panic!("{e:?}") };
            assert!(*offset < cut as u64, "{e}");
            assert!(e.to_string().contains("truncated"), "{e}");
        }
    }
    assert!(last > 90, "{last} scans at the last cut");
}

#[test]
fn a_damaged_chunk_is_skipped_and_counted_and_the_chunks_after_it_read() {
    let mut bytes = std::fs::read(data("intel-bz2.bag")).unwrap();
    let whole = replay::read_log(&data("intel-bz2.bag")).unwrap().scans;
    // Damage the compressed data in the middle of the file (inside one bz2 chunk).
    let mid = bytes.len() / 2;
    for b in &mut bytes[mid..mid + 64] {
        *b ^= 0x5a;
    }
    let file = temp("damaged.bag");
    std::fs::write(&file, &bytes).unwrap();
    let log = replay::read_log(&file).unwrap();
    assert_eq!(log.bad_records.total, 1, "{:?}", log.bad_records);
    let first = log.bad_records.first.first().expect("named");
    assert!(matches!(first, ReplayError::BagChunk { .. }), "{first:?}");
    assert!(first.to_string().contains("damaged chunk, skipped"), "{first}");
    assert!(log.error.is_none(), "{:?}", log.error);
    // Fewer scans, and every one of them is one of the whole bag's: before and after the chunk.
    assert!(log.scans.len() < whole.len() && log.scans.len() > whole.len() / 2, "{} of {}", log.scans.len(), whole.len());
    assert!(log.scans.iter().all(|s| whole.iter().any(|w| same_scan(s, w))));
    assert!(log.scans.last().map(|s| s.t_s) == whole.last().map(|s| s.t_s), "the chunks after the damage are read");
}

#[test]
fn a_message_that_does_not_decode_costs_itself_only() {
    let mut bytes = plain();
    let good = replay::read_log(&data("intel-120-none.bag")).unwrap();
    // The fifth scan's `ranges` count, made larger than the message: find the scan messages by
    // their header (seq 0, then the stamp) and the `laser` frame id that follows.
    let pattern = b"\x05\x00\x00\x00laser";
    let at: Vec<usize> = bytes.windows(pattern.len()).enumerate().filter(|(_, w)| w == pattern).map(|(i, _)| i).collect();
    assert!(at.len() >= 120, "{} scan headers", at.len());
    // frame_id, then 7 float32 fields, then the ranges count.
    let count = at[10] + pattern.len() + 7 * 4;
    bytes[count..count + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let file = temp("bad-message.bag");
    std::fs::write(&file, &bytes).unwrap();
    let log = replay::read_log(&file).unwrap();
    assert!(log.error.is_none(), "{:?}", log.error);
    assert_eq!(log.bad_records.total, 1);
    let e = log.bad_records.first[0].to_string();
    assert!(e.contains("ranges") && e.contains("claims 4294967295 elements"), "{e}");
    assert_eq!(log.scans.len(), good.scans.len() - 1);
}

#[test]
fn an_mcap_file_of_ros1_encoded_messages_replays_as_the_ros1_bag() {
    // Foxglove and `mcap convert` keep a ROS 1 bag's messages as they are in MCAP: channels
    // encoded `ros1`, schemas `ros1msg` with the ROS 1 type names.
    let bag = data("intel-120-lz4.bag");
    let contents = host::io::replay::rosbag::read_bag1(&bag, &std::fs::read(&bag).unwrap());
    assert!(contents.error.is_none() && !contents.messages.is_empty());
    let path = temp("ros1.mcap");
    let opts = mcap::WriteOptions::new().compression(Some(mcap::Compression::Lz4)).chunk_size(Some(8192)).profile("ros1");
    let mut w = opts.create(std::io::BufWriter::new(std::fs::File::create(&path).unwrap())).unwrap();
    let mut channels = std::collections::BTreeMap::new();
    for (seq, m) in contents.messages.iter().enumerate() {
        let ty = contents.topics.iter().find(|(t, _)| *t == m.topic).map(|(_, ty)| ty.clone()).unwrap();
        let id = *channels.entry(m.topic.clone()).or_insert_with(|| {
            let schema = w.add_schema(&ty, "ros1msg", b"").unwrap();
            w.add_channel(schema, &m.topic, "ros1", &std::collections::BTreeMap::new()).unwrap()
        });
        let header = mcap::records::MessageHeader { channel_id: id, sequence: seq as u32, log_time: m.t_ns, publish_time: m.t_ns };
        w.write_to_known_channel(&header, &m.data).unwrap();
    }
    w.finish().unwrap();
    let from_mcap = replay::read_log(&path).unwrap();
    let from_bag = replay::read_log(&bag).unwrap();
    assert_eq!(from_mcap.format, LogFormat::Ros2Mcap);
    assert_eq!(from_mcap.scans.len(), 117);
    for (a, b) in from_mcap.scans.iter().zip(&from_bag.scans) {
        assert!(same_scan(a, b), "{a:?}\n{b:?}");
    }
}
