use super::*;

fn scan(n: usize, inc: f32, intensities: usize) -> cdr::LaserScan {
    cdr::LaserScan {
        header: wire::header_at(1, "laser"),
        angle_min: -1.0,
        angle_max: -1.0 + inc * (n as f32 - 1.0),
        angle_increment: inc,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: 0.1,
        range_max: 10.0,
        ranges: vec![1.0; n],
        intensities: vec![1.0; intensities],
    }
}

#[test]
fn bad_scans_are_named() {
    assert_eq!(scan_problem(&scan(10, 0.01, 10)), None);
    assert_eq!(scan_problem(&scan(10, 0.01, 0)), None);
    assert_eq!(scan_problem(&scan(10, 0.0, 0)).unwrap().0, "scan-angle-increment");
    assert_eq!(scan_problem(&scan(10, f32::NAN, 0)).unwrap().0, "scan-angle-increment");
    assert_eq!(scan_problem(&scan(10, 0.01, 7)).unwrap().0, "scan-length-mismatch");
    assert_eq!(scan_problem(&scan(0, 0.01, 0)).unwrap().0, "scan-empty");
    let mut s = scan(10, 0.01, 0);
    s.angle_max = 2.0;
    assert_eq!(scan_problem(&s).unwrap().0, "scan-length-mismatch");
}

#[test]
fn remapping_and_the_environment() {
    let o = Ros2Options { remap: vec![("scan".into(), "/spot/lidar/scan".into())], ..Ros2Options::default() };
    assert_eq!(o.topic("scan"), "/spot/lidar/scan");
    assert_eq!(o.topic("odom"), "odom");
}
