//! `sensor_msgs/msg/PointCloud2` from a 3D LiDAR (a VLP-16's `velodyne_points`, an Ouster's
//! `points`) cut to the plane the controller maps, as it is read: each cloud becomes a 360°
//! planar scan ([`cut`]) in the cloud's own frame, so a bag of clouds is held in memory as scans
//! (a few kB a cloud, not the cloud's megabyte).
//!
//! The cut is the one `lives lidar` makes of a VLP-16's packets (`crate::io::sensors::vlp16`):
//! the points within [`CLOUD_BAND_DEG`] of the sensor's horizontal plane (a VLP-16's ±1° lasers,
//! a 64-beam sensor's few middle rings), horizontal range and azimuth, binned onto the core's
//! [`CLOUD_BEAMS`] beams keeping the nearest point of each bin; points nearer than
//! [`CLOUD_RANGE_MIN_M`] (the robot's own body) are dropped. A bin no point fell in is NaN
//! (unknown, clears nothing): a cloud lists its returns, not the directions that had none.
//!
//! The cut is made in the cloud's frame, so it is the horizontal plane only for a sensor mounted
//! level (or upside down): replay refuses the scans of a cloud whose frame is tilted
//! ([`MAX_CLOUD_TILT_DEG`]; a depth camera's optical frame, z forward, is the common case) by
//! name rather than map a slanted cut.

use crate::io::replay::cdr::{header, CdrError, CdrReader, Header, LaserScan, Wire};

/// Bins of the planar scan: the core's beam grid.
pub const CLOUD_BEAMS: usize = firmware::capacity::BEAMS;
/// Points within this elevation of the sensor's horizontal plane make the cut, degrees.
pub const CLOUD_BAND_DEG: f64 = 2.0;
/// Nearer points are the robot's own body (as for the VLP-16's packets), metres.
pub const CLOUD_RANGE_MIN_M: f32 = 0.3;
/// The planar scan's `range_max`, metres (a cloud has no "no return" reading to compare).
pub const CLOUD_RANGE_MAX_M: f32 = 100.0;
/// A cloud frame whose z axis is farther than this from the vertical (up or down) is tilted.
pub const MAX_CLOUD_TILT_DEG: f64 = 10.0;

/// `sensor_msgs/msg/PointField` datatypes this reads for `x`, `y`, `z`.
const FLOAT32: u8 = 7;
const FLOAT64: u8 = 8;

/// Where a coordinate sits in a point.
#[derive(Clone, Copy)]
struct Field {
    offset: usize,
    wide: bool,
}

/// Decodes a serialised `sensor_msgs/msg/PointCloud2` and cuts it to a planar scan (module docs),
/// stamped and framed as the cloud. An error names the field: a cloud whose points lie beyond its
/// data, without float `x`/`y`/`z` fields, or whose fields lie beyond its `point_step`.
pub fn cut(buf: &[u8], wire: Wire) -> Result<LaserScan, CdrError> {
    let mut r = CdrReader::of(buf, wire)?;
    let head: Header = header(&mut r)?;
    let height = r.u32("height")? as u64;
    let width = r.u32("width")? as u64;
    // Each PointField is at least 13 bytes: a string length, offset, datatype and count.
    let nfields = r.count("fields", 13)?;
    let (mut x, mut y, mut z) = (None, None, None);
    for _ in 0..nfields {
        let name = r.string("fields.name")?;
        let offset = r.u32("fields.offset")? as usize;
        let datatype = r.u8("fields.datatype")?;
        let _count = r.u32("fields.count")?;
        let slot = match name.as_str() {
            "x" => &mut x,
            "y" => &mut y,
            "z" => &mut z,
            _ => continue,
        };
        *slot = match datatype {
            FLOAT32 => Some(Field { offset, wide: false }),
            FLOAT64 => Some(Field { offset, wide: true }),
            other => return Err(r.unusable("fields", format!("`{name}` has datatype {other}, not float32 (7) or float64 (8)"))),
        };
    }
    let big_endian = r.u8("is_bigendian")? != 0;
    let point_step = r.u32("point_step")? as u64;
    let row_step = r.u32("row_step")? as u64;
    let at = r.offset();
    let data = r.bytes("data")?;
    let _is_dense = r.u8("is_dense")?;
    let (Some(x), Some(y), Some(z)) = (x, y, z) else {
        return Err(r.unusable("fields", "a cloud without float `x`, `y` and `z` fields".into()));
    };
    for f in [x, y, z] {
        let end = f.offset as u64 + if f.wide { 8 } else { 4 };
        if end > point_step {
            return Err(
                r.unusable("point_step", format!("a field at byte {} of a point lies beyond its point_step {point_step}", f.offset))
            );
        }
    }
    if height > 0 && width > 0 {
        let need = (height - 1).saturating_mul(row_step).saturating_add(width.saturating_mul(point_step));
        if row_step < width.saturating_mul(point_step) || need > data.len() as u64 {
            return Err(CdrError {
                offset: at,
                kind: crate::io::replay::cdr::CdrErrorKind::Unusable {
                    what: "data",
                    why: format!(
                        "{height} rows of {width} points ({point_step} bytes each, {row_step} a row) need {need} bytes; the cloud holds {}",
                        data.len()
                    ),
                },
            });
        }
    }
    let read = |p: &[u8], f: Field| -> f64 {
        let b = &p[f.offset..];
        if f.wide {
            let a: [u8; 8] = b[..8].try_into().unwrap_or([0; 8]);
            if big_endian {
                f64::from_be_bytes(a)
            } else {
                f64::from_le_bytes(a)
            }
        } else {
            let a: [u8; 4] = b[..4].try_into().unwrap_or([0; 4]);
            (if big_endian { f32::from_be_bytes(a) } else { f32::from_le_bytes(a) }) as f64
        }
    };
    let band = CLOUD_BAND_DEG.to_radians().tan();
    let step = std::f64::consts::TAU / CLOUD_BEAMS as f64;
    let mut ranges = vec![f32::NAN; CLOUD_BEAMS];
    // A cloud with no columns has no points, however many rows it declares (4·10⁹ empty rows
    // took seconds to walk).
    let rows = if width == 0 { 0 } else { height as usize };
    for row in 0..rows {
        let start = row * row_step as usize;
        for col in 0..width as usize {
            let p = &data[start + col * point_step as usize..][..point_step as usize];
            let (px, py, pz) = (read(p, x), read(p, y), read(p, z));
            let d = px.hypot(py);
            if !(d.is_finite() && pz.is_finite()) || d < CLOUD_RANGE_MIN_M as f64 || pz.abs() > band * d {
                continue;
            }
            let a = py.atan2(px) + std::f64::consts::PI;
            let b = ((a / step).round() as usize) % CLOUD_BEAMS;
            let d = d as f32;
            if ranges[b].is_nan() || d < ranges[b] {
                ranges[b] = d;
            }
        }
    }
    Ok(LaserScan {
        header: head,
        angle_min: -std::f32::consts::PI,
        angle_max: (std::f64::consts::PI - step) as f32,
        angle_increment: step as f32,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: CLOUD_RANGE_MIN_M,
        range_max: CLOUD_RANGE_MAX_M,
        ranges,
        intensities: Vec::new(),
    })
}

/// Serialises a `sensor_msgs/msg/PointCloud2` of float32 `x`, `y`, `z` points, one row
/// (unorganised), CDR little-endian: for tests and for anyone making a bag.
pub fn encode_xyz_cloud(h: &Header, points: &[[f32; 3]]) -> Vec<u8> {
    encode_cloud(h, ["x", "y", "z"], points.len() as u32, points)
}

fn encode_cloud(h: &Header, names: [&str; 3], width: u32, points: &[[f32; 3]]) -> Vec<u8> {
    let mut w = crate::io::replay::cdr::CdrWriter::new();
    w.header(h);
    w.put(1u32.to_le_bytes());
    w.put(width.to_le_bytes());
    w.put(3u32.to_le_bytes());
    for (i, name) in names.iter().enumerate() {
        w.string(name);
        w.put((4 * i as u32).to_le_bytes());
        w.put([FLOAT32]);
        w.put(1u32.to_le_bytes());
    }
    w.put([0u8]);
    w.put(12u32.to_le_bytes());
    w.put((12 * width).to_le_bytes());
    w.put((12 * points.len() as u32).to_le_bytes());
    for v in points.iter().flatten() {
        w.put(v.to_le_bytes());
    }
    w.put([1u8]);
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::replay::cdr::Time;

    fn head() -> Header {
        Header { stamp: Time { sec: 5, nanosec: 0 }, frame_id: "velodyne".into() }
    }

    #[test]
    fn a_cloud_is_cut_to_its_horizontal_band_keeping_the_nearest_point_per_beam() {
        let pts = [
            [3.0, 0.0, 0.05],  // straight ahead, in the band
            [2.0, 0.0, -0.01], // nearer, same beam
            [0.0, 4.0, 1.0],   // to the left, 14° up: out of the band
            [0.0, 5.0, 0.1],   // to the left, in it
            [0.1, 0.1, 0.0],   // the body
            [f32::NAN, 1.0, 0.0],
        ];
        let s = cut(&encode_xyz_cloud(&head(), &pts), Wire::Cdr).unwrap();
        assert_eq!((s.header.frame_id.as_str(), s.ranges.len()), ("velodyne", CLOUD_BEAMS));
        let beam = |a: f64| (((a + std::f64::consts::PI) / (std::f64::consts::TAU / CLOUD_BEAMS as f64)).round() as usize) % CLOUD_BEAMS;
        assert_eq!(s.ranges[beam(0.0)], 2.0);
        assert_eq!(s.ranges[beam(std::f64::consts::FRAC_PI_2)], 5.0);
        assert_eq!(s.ranges.iter().filter(|r| r.is_finite()).count(), 2, "every other bin unknown");
        assert_eq!((s.range_min, s.range_max), (CLOUD_RANGE_MIN_M, CLOUD_RANGE_MAX_M));
    }

    #[test]
    fn a_cloud_that_lies_about_its_size_or_fields_is_an_error_every_truncation_too() {
        let pts = [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0]];
        let good = encode_xyz_cloud(&head(), &pts);
        assert!(cut(&good, Wire::Cdr).is_ok());
        for n in 0..good.len() {
            assert!(cut(&good[..n], Wire::Cdr).is_err(), "cut at {n}");
        }
        let e = cut(&encode_cloud(&head(), ["x", "y", "z"], 3, &pts), Wire::Cdr).unwrap_err().to_string();
        assert!(e.contains("1 rows of 3 points") && e.contains("need 36 bytes; the cloud holds 24"), "{e}");
        let e = cut(&encode_cloud(&head(), ["x", "y", "w"], 2, &pts), Wire::Cdr).unwrap_err().to_string();
        assert!(e.contains("without float `x`, `y` and `z`"), "{e}");
    }

    #[test]
    fn a_cloud_of_no_columns_has_no_points_whatever_its_rows() {
        // The fuzzer's hang, minimal: width 0 and height u32::MAX (the size check needs both).
        let mut b = encode_xyz_cloud(&head(), &[]);
        let height_at = b.windows(8).position(|w| w == [1, 0, 0, 0, 0, 0, 0, 0]).expect("height 1, width 0");
        b[height_at..height_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let s = cut(&b, Wire::Cdr).unwrap();
        assert!(s.ranges.iter().all(|r| r.is_nan()), "no point, no range");
        // The fuzzer's input itself (a libFuzzer timeout before the fix) cuts or is refused.
        let hang = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/corpus/cdr/cloud-zero-width-4e9-rows.bin")).unwrap();
        let _ = cut(&hang, Wire::Cdr);
    }

    #[test]
    fn the_fuzz_seed_is_a_cloud_that_cuts() {
        let seed = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/corpus/cdr/pointcloud2.cdr")).unwrap();
        let s = cut(&seed, Wire::Cdr).unwrap();
        // 120 directions of the ring at 4 m, the post at 1.5 m among them (straight ahead).
        assert_eq!(s.ranges.iter().filter(|r| r.is_finite()).count(), 120);
        assert!(s.ranges.iter().all(|&r| r.is_nan() || (r - 4.0).abs() < 1e-4 || r == 1.5));
    }

    #[test]
    fn a_ros1_cloud_cuts_as_its_cdr_twin_does() {
        // ROS 1's serialisation (a ROS 1 bag's `velodyne_points`): no encapsulation, no
        // alignment, a `seq` in the header, strings without NUL.
        let pts = [[3.0f32, 0.0, 0.05], [0.0, 5.0, 0.1], [0.0, 4.0, 1.0]];
        let mut b = Vec::new();
        let u32s = |b: &mut Vec<u8>, v: u32| b.extend(v.to_le_bytes());
        let text = |b: &mut Vec<u8>, t: &str| {
            b.extend((t.len() as u32).to_le_bytes());
            b.extend(t.as_bytes());
        };
        for v in [7, 5, 0] {
            u32s(&mut b, v); // seq, stamp
        }
        text(&mut b, "velodyne");
        for v in [1, pts.len() as u32, 3] {
            u32s(&mut b, v); // height, width, fields
        }
        for (k, name) in ["x", "y", "z"].iter().enumerate() {
            text(&mut b, name);
            u32s(&mut b, 4 * k as u32);
            b.push(FLOAT32);
            u32s(&mut b, 1);
        }
        b.push(0);
        for v in [12, 12 * pts.len() as u32, 12 * pts.len() as u32] {
            u32s(&mut b, v); // point_step, row_step, data's length
        }
        b.extend(pts.iter().flatten().flat_map(|v| v.to_le_bytes()));
        b.push(1);
        let ros1 = cut(&b, Wire::Ros1).unwrap();
        let cdr = cut(&encode_xyz_cloud(&head(), &pts), Wire::Cdr).unwrap();
        assert_eq!(ros1.header, cdr.header);
        assert_eq!(ros1.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>(), cdr.ranges.iter().map(|r| r.to_bits()).collect::<Vec<_>>());
        assert_eq!(ros1.ranges.iter().filter(|r| r.is_finite()).count(), 2, "the point 14° up is not in the cut");
        assert!(cut(&b[..b.len() - 1], Wire::Ros1).is_err());
    }
}
