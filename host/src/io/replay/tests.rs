use super::*;

#[test]
fn formats_are_detected_from_content() {
    assert_eq!(detect(&[0x1f, 0x8b, 8, 0]), Some(LogFormat::CarmenGzip));
    assert_eq!(detect(b"\x89MCAP0\r\n\x01"), Some(LogFormat::Ros2Mcap));
    assert_eq!(detect(b"SQLite format 3\0rest"), Some(LogFormat::Ros2Sqlite3));
    assert_eq!(detect(&[0xd4, 0xc3, 0xb2, 0xa1, 2, 0, 4, 0]), Some(LogFormat::Vlp16), "a pcap");
    assert_eq!(detect(&[0xff, 0xee, 0x10, 0x27]), Some(LogFormat::Vlp16), "a raw VLP-16 payload");
    assert_eq!(detect(b"# CARMEN\nODOM 0 0 0 0 0 0 1 h 1\n"), Some(LogFormat::Carmen));
    assert_eq!(detect(&[0u8, 1, 2, 3]), None);
    assert_eq!(detect(&[0u8; 64]), None, "zeros");
    // Issue 29: one NUL (or a few) in the first 4 KiB no longer makes a log "not a CARMEN log".
    assert_eq!(detect(b"# CARMEN\nODOM 0 0\x00 0 0 0 0 1 h 1\n"), Some(LogFormat::Carmen));
    let mut damaged = b"ODOM 1.0 2.0 0.5 0 0 0 1 h 1\n".repeat(100);
    damaged[40..552].fill(0);
    assert_eq!(detect(&damaged), Some(LogFormat::Carmen), "a zeroed 512-byte block");
    // Binary: about one byte in eight is a control byte.
    let binary: Vec<u8> = (0..4096u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
    assert_eq!(detect(&binary), None);
    // A ROS 1 bag: its connection records are text enough to pass for a CARMEN log.
    let ros1 = [&b"#ROSBAG V2.0\n"[..], &b"op=\x07topic=/scan message_definition=float32 angle_min\n".repeat(60)].concat();
    assert_eq!(detect(&ros1), Some(LogFormat::Ros1Bag));
    assert_eq!(detect(b"#ROSBAG V1.2\n"), Some(LogFormat::Ros1Bag), "the reader names the version");
}

#[test]
fn a_ros1_bag_of_another_version_or_with_a_damaged_record_is_named() {
    let file = std::env::temp_dir().join(format!("lives-ros1-{}.bag", std::process::id()));
    let read = |bytes: &[u8]| {
        std::fs::write(&file, bytes).unwrap();
        let log = read_log(&file).expect("a ROS 1 bag");
        assert_eq!(log.format, LogFormat::Ros1Bag);
        assert!(log.scans.is_empty());
        log.error.expect("damage named").to_string()
    };
    let old = read(b"#ROSBAG V1.2\nrest");
    assert!(old.contains("byte 0: ROS bag format 1.2; replay reads format 2.0"), "{old}");
    let zeros = read(&[&b"#ROSBAG V2.0\n"[..], &[0u8; 4096][..]].concat());
    assert!(zeros.contains("byte 13: record header has no one-byte `op` field"), "{zeros}");
    let cut = read(&[&b"#ROSBAG V2.0\n"[..], &200u32.to_le_bytes()[..], b"\x04\0\0\0op=\x03"].concat());
    assert!(cut.contains("byte 13: record header of 200 bytes runs past the end of the file, 8 bytes left (truncated)"), "{cut}");
    let huge = read(&[&b"#ROSBAG V2.0\n"[..], &(64u32 << 20).to_le_bytes()[..], b"\x04\0\0\0op=\x03"].concat());
    assert!(huge.contains("byte 13: record header of 67108864 bytes is more than a record header holds"), "{huge}");
    let _ = std::fs::remove_file(&file);
}

#[test]
fn the_grid_is_centred_on_the_trajectory() {
    // The intel log's trajectory: centre (3.65, -9.1), the grid 25.6 m to either side of it.
    let o = grid_origin([[-9.2, -22.1], [16.5, 3.9]]);
    assert!((o[0] + grid_size_m() / 2.0 - 3.65).abs() <= 0.05 && (o[1] + grid_size_m() / 2.0 + 9.1).abs() <= 0.05, "{o:?}");
    for v in o {
        assert!(((v * 10.0).round() - v * 10.0).abs() < 1e-9, "on the 0.1 m lattice: {v}");
    }
    // Near the ends of the core's fixed-point range the grid stays inside it.
    assert_eq!(grid_origin([[-32_767.0, 32_767.0], [-32_760.0, 32_767.0]]), [-32_767.0, 32_715.8]);
}

fn scan_at(x: f64, y: f64, line: usize) -> ScanRecord {
    ScanRecord {
        t_s: line as f64,
        pose: [x, y, 0.0],
        angle_min: 0.0,
        angle_increment: 0.01,
        ranges_m: vec![1.0],
        range_limits_m: [0.0, 80.0],
        at: Location::Line(line),
    }
}

#[test]
fn stray_poses_do_not_place_the_grid() {
    // A 40 m walk along x, and y between −5 and 5.
    let mut scans: Vec<ScanRecord> = (0..100).map(|i| scan_at(i as f64 * 0.4, (i % 11) as f64 - 5.0, i)).collect();
    let clean = place_grid(&scans).unwrap();
    assert_eq!(clean.bounds, [[0.0, -5.0], [39.6, 5.0]]);
    assert!(clean.stray.iter().all(|s| !s));
    // A corrupt x of 1e9 (beyond the core's range), one of 5 000 m (in range, far from the
    // rest), one just within a grid side of the middle half, and non-finite ones (no pose,
    // not strays).
    scans[10].pose[0] = 1e9;
    scans[20].pose[1] = 5_000.0;
    scans[30].pose[0] = f64::NAN;
    scans[40].pose[1] = f64::INFINITY;
    scans.push(scan_at(29.7 + 51.2, 0.0, 100));
    let p = place_grid(&scans).unwrap();
    let strays: Vec<usize> = p.stray.iter().enumerate().filter(|(_, s)| **s).map(|(i, _)| i).collect();
    assert_eq!(strays, [10, 20]);
    assert_eq!(p.bounds, [[0.0, -5.0], [80.9, 5.0]]);
    // Nothing finite: nothing places the grid.
    assert_eq!(place_grid(&[scan_at(f64::NAN, 0.0, 1)]), None);
    // Only strays beyond the core's range: nothing either.
    assert_eq!(place_grid(&[scan_at(1e9, 0.0, 1), scan_at(-1e9, 0.0, 2)]), None);
}

#[test]
fn huge_numbers_print_compactly() {
    assert_eq!(compact(1e300), "1e300");
    assert_eq!(compact(-1e9), "-1e9");
    assert_eq!(compact(f64::INFINITY), "inf");
    assert_eq!(compact(65.5), "65.5");
    assert_eq!(compact(-16.7655), "-16.7655");
}

#[test]
fn a_line_longer_than_a_log_line_is_skipped_without_holding_it_and_the_rest_is_read() {
    use std::io::Write as _;
    let odom = "ODOM 1.0 2.0 0.5 0 0 0 1 h 1\n";
    let long = format!("FLASER 3 {} 1.0 2.0 0 1 2 0 2 h 2\n", "1.0 ".repeat(MAX_LINE_BYTES / 4 + 10));
    let text = [odom, &long, odom].concat();
    for gz in [false, true] {
        let bytes = if gz {
            let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
            e.write_all(text.as_bytes()).unwrap();
            e.finish().unwrap()
        } else {
            text.clone().into_bytes()
        };
        let format = if gz { LogFormat::CarmenGzip } else { LogFormat::Carmen };
        let log = read_carmen(std::path::Path::new("long.log"), format, bytes);
        assert_eq!(log.odometry, 2, "the lines around it are read");
        assert_eq!(log.bad_records.total, 1);
        let e = log.bad_records.first[0].to_string();
        assert!(e.starts_with(&format!("long.log:2: a line of {} bytes", long.len())), "{e}");
        assert_eq!(log.bad_records.first[0].reason(), "line_too_long");
        assert!(log.error.is_none());
    }
}

#[test]
fn a_gzip_log_that_decompresses_past_the_cap_stops_with_an_error_keeping_what_came_before() {
    use std::io::Write as _;
    // A bomb: a valid ODOM line, then zeros (one very long line) beyond the cap.
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    e.write_all(b"ODOM 1.0 2.0 0.5 0 0 0 1 h 1\n").unwrap();
    let zeros = vec![b'0'; 1 << 24];
    for _ in 0..(MAX_GZIP_TEXT_BYTES >> 24) + 1 {
        e.write_all(&zeros).unwrap();
    }
    let log = read_carmen(std::path::Path::new("bomb.log.gz"), LogFormat::CarmenGzip, e.finish().unwrap());
    assert_eq!(log.odometry, 1, "the line before it is kept");
    let err = log.error.expect("stopped").to_string();
    assert!(err.starts_with("bomb.log.gz: ") && err.contains("more than 1024 MiB of text"), "{err}");
}

#[test]
fn a_device_is_not_read_as_a_log() {
    let e = read_log(std::path::Path::new("/dev/zero")).unwrap_err().to_string();
    assert!(e.starts_with("/dev/zero") && e.contains("not a regular file"), "{e}");
}
