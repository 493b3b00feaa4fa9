use super::*;
use crate::io::replay::cdr::{self, Transform};
use crate::io::replay::{Location, ReplayError};
use std::path::Path;

fn iso(x: f64, y: f64, yaw: f64) -> Iso {
    Iso::from(&Transform::planar(x, y, yaw)).unwrap()
}

#[test]
fn composing_planar_transforms_matches_se2() {
    // base at (1, 2) facing +y; laser 0.5 m ahead of the base, turned −90°: the laser sits at
    // (1, 2.5) facing +x.
    let p = iso(1.0, 2.0, std::f64::consts::FRAC_PI_2).compose(&iso(0.5, 0.0, -std::f64::consts::FRAC_PI_2));
    assert!((p.t[0] - 1.0).abs() < 1e-12 && (p.t[1] - 2.5).abs() < 1e-12, "{p:?}");
    let x = p.rotate([1.0, 0.0, 0.0]);
    assert!((x[0] - 1.0).abs() < 1e-12 && x[1].abs() < 1e-12);
}

#[test]
fn upside_down_laser_negates_angles_and_ros_ranges_apply() {
    // Rolled by π about x: z points down.
    let flipped = Iso { t: [0.0; 3], q: [1.0, 0.0, 0.0, 0.0] };
    let s = cdr::LaserScan {
        angle_min: -0.5,
        angle_increment: 0.25,
        range_min: 0.2,
        range_max: 10.0,
        ranges: vec![f32::NAN, f32::NEG_INFINITY, f32::INFINITY, 0.1, 10.5, 5.0, 10.0],
        ..Default::default()
    };
    let r = scan_record(&s, &flipped, 2_000_000_000, Location::Row(1));
    assert_eq!((r.angle_min, r.angle_increment), (0.5, -0.25));
    assert_eq!(r.t_s, 2.0);
    // Kept as recorded, with the scan's limits: the range rule is applied when encoding.
    for (a, b) in r.ranges_m.iter().zip(&s.ranges) {
        assert!(a == b || (a.is_nan() && b.is_nan()), "{:?}", r.ranges_m);
    }
    assert_eq!(r.range_limits_m, [0.2f32 as f64, 10.0]);
    let lim = crate::run::range::RangeLimits::new(r.range_limits_m[0], r.range_limits_m[1]);
    let enc: Vec<u16> = r.ranges_m.iter().map(|&v| crate::run::range::encode_range(v as f64, &lim)).collect();
    use firmware::scan::{RANGE_INVALID as I, RANGE_NO_RETURN as N};
    assert_eq!(enc, [I, I, N, I, N, 5000, N], "NaN, -inf, +inf, below min, beyond max, a return, at max");
}

#[test]
fn frame_tree_resolves_chains_and_refuses_cycles() {
    let mut t = FrameTree::default();
    assert_eq!(t.push("odom", "/base_link", 1_000, &Transform::planar(2.0, 0.0, 0.0), EdgeSource::Tf), Ok(()));
    assert_eq!(t.set_static("base_link", "laser", &Transform::planar(0.0, 1.0, 0.0)), Ok(()));
    let (p, root, depth) = t.resolve_at("laser", 1_000).unwrap();
    assert_eq!((root.as_str(), depth), ("odom", 2));
    assert!((p.t[0] - 2.0).abs() < 1e-12 && (p.t[1] - 1.0).abs() < 1e-12);
    assert_eq!(t.push("a", "a", 1_000, &Transform::IDENTITY, EdgeSource::Tf), Err(EdgeReject::Invalid), "a frame cannot be its own parent");
    assert_eq!(t.push("laser", "odom", 1_000, &Transform::IDENTITY, EdgeSource::Tf), Err(EdgeReject::Loop));
    assert_eq!(t.set_static("laser", "odom", &Transform::IDENTITY), Err(EdgeReject::Loop));
    // The tree is as it was: the loop was refused, not half-applied.
    assert_eq!(t.resolve_at("laser", 1_000).unwrap().1, "odom");
}

#[test]
fn moving_edges_interpolate_to_the_stamp_and_refuse_jumps_and_backward_stamps() {
    let mut t = FrameTree::default();
    let s = 1_000_000_000u64;
    // 170° to −170°: the short way round is through 180°, not through 0°.
    t.push("odom", "base", s, &Transform::planar(0.0, 0.0, 170f64.to_radians()), EdgeSource::Tf).unwrap();
    t.push("odom", "base", s + 100_000_000, &Transform::planar(0.5, 1.0, (-170f64).to_radians()), EdgeSource::Tf).unwrap();
    let (p, _, _) = t.resolve_at("base", s + 25_000_000).unwrap();
    assert!((p.t[0] - 0.125).abs() < 1e-12 && (p.t[1] - 0.25).abs() < 1e-12, "{p:?}");
    let x = p.rotate([1.0, 0.0, 0.0]);
    assert!((x[1].atan2(x[0]).to_degrees() - 175.0).abs() < 1e-9, "{}", x[1].atan2(x[0]).to_degrees());
    // Before the first sample: no odometry yet. After the last: held up to the age bound.
    assert_eq!(t.resolve_at("base", s - 1), Err(PoseError::NoOdometryYet));
    assert!(t.resolve_at("base", s + 100_000_000 + MAX_POSE_AGE_NS).is_ok());
    assert_eq!(t.resolve_at("base", s + 100_000_001 + MAX_POSE_AGE_NS), Err(PoseError::Stale));
    // A 100 m jump, and a stamp going backwards, are refused; the samples around them stay.
    assert_eq!(t.push("odom", "base", s + 120_000_000, &Transform::planar(100.5, 1.0, 0.0), EdgeSource::Tf), Err(EdgeReject::Jump));
    assert_eq!(t.push("odom", "base", s + 50_000_000, &Transform::planar(0.5, 1.0, 0.0), EdgeSource::Tf), Err(EdgeReject::Backwards));
    t.push("odom", "base", s + 140_000_000, &Transform::planar(0.6, 1.0, 0.0), EdgeSource::Tf).unwrap();
    assert_eq!(t.edges["base"].samples.len(), 3);
    // A gap longer than the bound in the middle: a stamp in it is stale.
    t.push("odom", "base", s + 2_000_000_000, &Transform::planar(2.0, 1.0, 0.0), EdgeSource::Tf).unwrap();
    assert_eq!(t.resolve_at("base", s + 1_000_000_000), Err(PoseError::Stale));
    assert!(t.resolve_at("base", s + 1_600_000_000).is_ok());
}

#[test]
fn an_edge_takes_its_samples_from_one_source_tf_before_odometry_else_the_first_topic() {
    let s = 1_000_000_000u64;
    let x = |t: &FrameTree, at: u64| t.resolve_at("base", at).unwrap().0.t[0];
    // Two odometry topics with the same frames (raw and filtered): the first keeps the edge.
    let mut t = FrameTree::default();
    t.push("odom", "base", s, &Transform::planar(1.0, 0.0, 0.0), EdgeSource::Odometry("/wheel/odom")).unwrap();
    let r = t.push("odom", "base", s + 10, &Transform::planar(1.4, 0.0, 0.0), EdgeSource::Odometry("/odometry/filtered"));
    assert_eq!(r, Err(EdgeReject::Superseded));
    t.push("odom", "base", s + 20, &Transform::planar(1.0, 0.0, 0.0), EdgeSource::Odometry("/wheel/odom")).unwrap();
    assert_eq!((x(&t, s + 10), t.source_of("base").as_deref()), (1.0, Some("/wheel/odom")));
    // `tf` takes the edge over (a new history), and the topic is not used after it.
    t.push("odom", "base", s + 30, &Transform::planar(2.0, 0.0, 0.0), EdgeSource::Tf).unwrap();
    assert_eq!(t.edges["base"].samples.len(), 1, "tf starts its own history");
    assert_eq!(
        t.push("odom", "base", s + 40, &Transform::planar(1.0, 0.0, 0.0), EdgeSource::Odometry("/wheel/odom")),
        Err(EdgeReject::Superseded)
    );
    t.push("odom", "base", s + 50, &Transform::planar(2.0, 0.0, 0.0), EdgeSource::Tf).unwrap();
    assert_eq!((x(&t, s + 40), t.source_of("base").as_deref()), (2.0, Some("tf")));
    // A fixed edge has no source to speak of.
    t.set_static("base", "laser", &Transform::IDENTITY).unwrap();
    assert_eq!(t.source_of("laser"), None);
}

#[test]
fn mcap_without_magic_is_an_error_at_byte_zero() {
    let c = read_mcap(Path::new("x.mcap"), b"not an mcap file");
    assert!(matches!(c.error, Some(ReplayError::Bag { offset: 0, .. })), "{:?}", c.error);
}

/// A build without a codec (the default features) names the feature a compressed chunk
/// needs; a build with it reports the junk payload as damage instead. `scripts/test.sh` runs
/// this test both ways.
#[test]
fn a_compressed_chunk_names_the_feature_it_needs() {
    for codec in ["zstd", "lz4"] {
        let mut body = Vec::new();
        body.extend_from_slice(&0u64.to_le_bytes()); // message start time
        body.extend_from_slice(&0u64.to_le_bytes()); // message end time
        body.extend_from_slice(&16u64.to_le_bytes()); // uncompressed size
        body.extend_from_slice(&0u32.to_le_bytes()); // uncompressed CRC (0: unchecked)
        body.extend_from_slice(&(codec.len() as u32).to_le_bytes());
        body.extend_from_slice(codec.as_bytes());
        body.extend_from_slice(&4u64.to_le_bytes());
        body.extend_from_slice(b"junk");
        let mut file = MCAP_MAGIC.to_vec();
        file.push(0x06); // Chunk
        file.extend_from_slice(&(body.len() as u64).to_le_bytes());
        file.extend_from_slice(&body);
        let c = read_mcap(Path::new("c.mcap"), &file);
        // The chunk is skipped (its length is intact); the file then ends without a footer.
        let [ReplayError::BagChunk { offset: 8, reason, .. }] = &c.bad.first[..] else { panic!("{codec}: {:?}", c.bad) };
        assert!(matches!(&c.error, Some(ReplayError::Bag { reason, .. }) if reason.contains("truncated")), "{:?}", c.error);
        // Constant in any one build (both `true` with the default features), not in general.
        #[allow(clippy::needless_bool)]
        let built_with = if codec == "zstd" { cfg!(feature = "zstd") } else { cfg!(feature = "lz4") };
        assert_eq!(reason.contains(&format!("rebuild with `--features {codec}`")), !built_with, "{codec}: {reason}");
        assert!(c.messages.is_empty());
    }
}

#[cfg(not(feature = "db3"))]
#[test]
fn without_db3_a_sqlite_bag_names_the_feature() {
    let c = read_db3(Path::new("x.db3"));
    let Some(ReplayError::Sqlite { reason, .. }) = &c.error else { panic!("{:?}", c.error) };
    assert!(reason.contains("`--features db3`"), "{reason}");
}

#[test]
fn odometry_with_empty_frames_moves_the_body_the_scans_are_mounted_on() {
    let mut t = FrameTree::default();
    t.set_static("base_link", "laser", &Transform::planar(0.2, 0.0, 0.0)).unwrap();
    t.set_static("base_link", "rear_laser", &Transform::planar(-0.2, 0.0, 3.0)).unwrap();
    t.set_static("chassis", "base_link", &Transform::IDENTITY).unwrap();
    let scans = ["laser", "/rear_laser"];
    // Named frames stand, even with scans elsewhere.
    assert_eq!(t.odometry_edge("odom", "base_footprint", scans.into_iter()), ("odom".into(), "base_footprint".into(), false));
    // Empty: `odom` and the one frame both scanners' fixed transforms end in.
    assert_eq!(t.odometry_edge("", "", scans.into_iter()), ("odom".into(), "chassis".into(), true));
    assert_eq!(t.odometry_edge("/world", "", ["laser"].into_iter()), ("world".into(), "chassis".into(), true));
    // A laser with no fixed transform is its own body; two trees, or no scan yet: no body.
    assert_eq!(t.odometry_edge("odom", "", ["hokuyo"].into_iter()), ("odom".into(), "hokuyo".into(), true));
    assert_eq!(t.odometry_edge("odom", "", ["laser", "hokuyo"].into_iter()), ("odom".into(), String::new(), true));
    assert_eq!(t.odometry_edge("odom", "", std::iter::empty()), ("odom".into(), String::new(), true));
}
