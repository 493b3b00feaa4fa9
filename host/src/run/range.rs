//! The one place where a range in metres becomes the core's integer millimetres.
//!
//! Every scan source — the simulator, the serial bridge, the robot adapter, ROS 2 bags, CARMEN
//! logs, the VLP-16 — hands its ranges over with the ROS `sensor_msgs/LaserScan` conventions
//! (REP 117: NaN an invalid reading, `−inf` too close, `+inf` nothing within range) together with
//! its sensor's [`RangeLimits`], and [`encode_range`] turns them into the core's encoding
//! ([`firmware::scan`]):
//!
//! | reading | becomes |
//! |---|---|
//! | NaN, `−inf`, below `range_min`, or negative | invalid (`0`) |
//! | `+inf`, or at or beyond `range_max` | no return (`65 535`): nothing within `range_max` |
//! | anything else | millimetres, rounded (at least 1) |
//!
//! The limits travel with the scan to the core ([`ScanInput::range_min_mm`],
//! [`ScanInput::range_max_mm`], protocol v6), which applies the same rule again and clears a
//! no-return beam out to `range_max` only. A sensor whose `range_max` is beyond what the
//! millimetre encoding holds (65.534 m, e.g. a VLP-16's 100 m or a SICK LMS's 80 m) is capped
//! there; readings between are "no return", which clears no farther than the core's clearing range
//! (30 m by default) anyway.
//!
//! A scan of more than [`MAX_WIRE_BEAMS`] beams (a SICK microScan3 at 0.1°, an RPLidar S2, a
//! 3D LiDAR flattened at 0.1°) is combined `k` beams to one on its way to the core
//! ([`EncodedScan::new`]): each group of `k` neighbours becomes one beam at the group's middle
//! angle holding the group's nearest return (else "no return" if one beam of it had none, else
//! invalid): the rule by which the core resamples every scan onto its 897 beams, so a thin post
//! one beam wide is kept, and a log replays in process as the robot's core gets it over the wire.

use firmware::protocol::MAX_WIRE_BEAMS;
use firmware::scan::{ScanInput, RANGE_INVALID, RANGE_LIMIT_MM, RANGE_NO_RETURN};
use firmware::{BeamLabel, BinaryAngle};

/// A sensor's valid range, metres (ROS `range_min`, `range_max`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangeLimits {
    /// Readings below this are invalid.
    pub min_m: f64,
    /// Readings at or beyond this mean "nothing within it".
    pub max_m: f64,
}

impl RangeLimits {
    /// `min_m`..`max_m`.
    pub const fn new(min_m: f64, max_m: f64) -> Self {
        RangeLimits { min_m, max_m }
    }

    /// The limits in the core's millimetres: NaN or negative → 0, capped at [`RANGE_LIMIT_MM`].
    /// Limits the core cannot use (a `range_max` of 0 or not above `range_min`) are passed on as
    /// they are, and the core refuses the scan with a named, counted error
    /// ([`firmware::ScanError::BadRangeLimits`]).
    pub fn mm(&self) -> (u16, u16) {
        let mm = |m: f64| if m.is_nan() || m <= 0.0 { 0 } else { (m * 1000.0).round().min(RANGE_LIMIT_MM as f64) as u16 };
        (mm(self.min_m), mm(self.max_m))
    }
}

/// One range in metres to the core's millimetre encoding (see the module docs).
pub fn encode_range(r: f64, limits: &RangeLimits) -> u16 {
    let (min_mm, max_mm) = limits.mm();
    if r.is_nan() || r == f64::NEG_INFINITY || r < 0.0 {
        return RANGE_INVALID;
    }
    if r.is_infinite() {
        return RANGE_NO_RETURN;
    }
    let mm = (r * 1000.0).round();
    if mm >= max_mm as f64 || mm >= RANGE_LIMIT_MM as f64 {
        RANGE_NO_RETURN
    } else if mm < min_mm as f64 {
        RANGE_INVALID
    } else {
        (mm as u16).max(1)
    }
}

/// A scan in the core's encoding, owned: what the host sends over the wire or hands the
/// in-process core.
#[derive(Clone, Debug, PartialEq)]
pub struct EncodedScan {
    /// First beam's angle in the sensor (laser) frame.
    pub angle_min: BinaryAngle,
    /// Angle between beams.
    pub angle_increment: BinaryAngle,
    /// Ranges, see [`encode_range`].
    pub ranges_mm: Vec<u16>,
    /// The sensor's minimum range, millimetres.
    pub range_min_mm: u16,
    /// The sensor's maximum range, millimetres.
    pub range_max_mm: u16,
    /// Labels per beam (ground truth from the simulator), if any.
    pub labels: Vec<BeamLabel>,
    /// The sensor's beams combined into each beam here: 1, or `k` for a scan of more than
    /// [`MAX_WIRE_BEAMS`] beams (see the module docs).
    pub combined: u16,
}

/// The core's order of preference among readings: the nearest return, then "no return", then
/// invalid (`firmware::scan::BeamScan::resample`).
fn preference(r: u16) -> u32 {
    match r {
        RANGE_INVALID => u32::MAX,
        RANGE_NO_RETURN => u32::MAX - 1,
        r => r as u32,
    }
}

impl EncodedScan {
    /// Encodes ranges in metres (ROS conventions) taken at `angle_min + i·angle_increment`
    /// (radians); `None` if an angle is not finite. An increment that cannot be represented
    /// (zero, with more than one beam) is left for the core to refuse. More than
    /// [`MAX_WIRE_BEAMS`] ranges are combined `k` to one, `k` the fewest that fit (module docs).
    pub fn new(angle_min: f64, angle_increment: f64, ranges_m: impl IntoIterator<Item = f64>, limits: &RangeLimits) -> Option<Self> {
        let (range_min_mm, range_max_mm) = limits.mm();
        let scan = EncodedScan {
            angle_min: BinaryAngle::from_radians(angle_min)?,
            angle_increment: BinaryAngle::from_radians(angle_increment)?,
            ranges_mm: ranges_m.into_iter().map(|r| encode_range(r, limits)).collect(),
            range_min_mm,
            range_max_mm,
            labels: Vec::new(),
            combined: 1,
        };
        Some(scan.fitted())
    }

    /// The scan with at most [`MAX_WIRE_BEAMS`] beams: as it is if it has no more, else its
    /// beams combined `k` to one, `k` the fewest that fit (module docs); a labelled scan keeps
    /// the label of the beam whose reading it keeps.
    pub fn fitted(self) -> Self {
        let k = self.ranges_mm.len().div_ceil(MAX_WIRE_BEAMS).max(1);
        if k == 1 {
            return self;
        }
        let labelled = self.labels.len() == self.ranges_mm.len();
        let (mut ranges_mm, mut labels) = (Vec::new(), Vec::new());
        for (g, group) in self.ranges_mm.chunks(k).enumerate() {
            let (i, r) = group.iter().copied().enumerate().min_by_key(|&(_, r)| preference(r)).unwrap_or((0, RANGE_INVALID));
            ranges_mm.push(r);
            if labelled {
                labels.push(self.labels[g * k + i]);
            }
        }
        // The middle of the first group, in the binary angle's wrapping arithmetic.
        let half = (self.angle_increment.0 as i64 * (k as i64 - 1) / 2) as i32;
        EncodedScan {
            angle_min: self.angle_min + BinaryAngle(half),
            angle_increment: BinaryAngle((self.angle_increment.0 as i64 * k as i64) as i32),
            ranges_mm,
            labels,
            combined: u16::try_from(k).unwrap_or(u16::MAX),
            ..self
        }
    }

    /// The core's view of it, with the labels if `with_labels` and there are some.
    pub fn input(&self, with_labels: bool) -> ScanInput<'_> {
        ScanInput {
            angle_min: self.angle_min,
            angle_increment: self.angle_increment,
            ranges_mm: &self.ranges_mm,
            labels: (with_labels && !self.labels.is_empty()).then_some(&self.labels[..]),
            range_min_mm: self.range_min_mm,
            range_max_mm: self.range_max_mm,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rep_117_in_one_place() {
        let lim = RangeLimits::new(0.1, 12.0);
        assert_eq!(encode_range(f64::NAN, &lim), RANGE_INVALID);
        assert_eq!(encode_range(f64::NEG_INFINITY, &lim), RANGE_INVALID);
        assert_eq!(encode_range(-1.0, &lim), RANGE_INVALID);
        assert_eq!(encode_range(0.05, &lim), RANGE_INVALID, "below range_min");
        assert_eq!(encode_range(0.1, &lim), 100, "range_min itself is valid");
        assert_eq!(encode_range(f64::INFINITY, &lim), RANGE_NO_RETURN);
        assert_eq!(encode_range(12.0, &lim), RANGE_NO_RETURN, "at range_max: nothing within it");
        assert_eq!(encode_range(30.0, &lim), RANGE_NO_RETURN, "beyond range_max");
        assert_eq!(encode_range(11.9994, &lim), 11_999);
        assert_eq!(encode_range(1.2344, &lim), 1234);
        let wide = RangeLimits::new(0.0, 100.0);
        assert_eq!(wide.mm(), (0, RANGE_LIMIT_MM), "a 100 m sensor is capped at what millimetres hold");
        assert_eq!(encode_range(65.533, &wide), 65_533);
        assert_eq!(encode_range(70.0, &wide), RANGE_NO_RETURN);
        assert_eq!(encode_range(0.0004, &wide), 1, "a return is never 0 (invalid)");
        assert_eq!(RangeLimits::new(f64::NAN, -3.0).mm(), (0, 0), "limits the core will refuse");
    }

    #[test]
    fn a_scan_carries_its_limits_to_the_core() {
        let s = EncodedScan::new(-1.0, 0.5, [1.0, f64::INFINITY, 20.0], &RangeLimits::new(0.2, 12.0)).unwrap();
        assert_eq!(s.ranges_mm, vec![1000, RANGE_NO_RETURN, RANGE_NO_RETURN]);
        let i = s.input(true);
        assert_eq!((i.range_min_mm, i.range_max_mm, i.labels), (200, 12_000, None));
        assert!(EncodedScan::new(f64::NAN, 0.5, [1.0], &RangeLimits::new(0.2, 12.0)).is_none());
    }

    #[test]
    fn a_scan_beyond_the_wire_is_combined_keeping_the_nearest_return_at_the_groups_middle() {
        let lim = RangeLimits::new(0.1, 20.0);
        // 3 · MAX_WIRE_BEAMS + 1 beams: 4 to one. A post one beam wide at beam 4·10 + 3 reads
        // 1.5 m among 5 m; a group of no returns and one invalid reading stays "no return".
        let n = 3 * MAX_WIRE_BEAMS + 1;
        let mut ranges = vec![5.0; n];
        ranges[43] = 1.5;
        ranges[80..84].copy_from_slice(&[f64::INFINITY, f64::NAN, f64::INFINITY, f64::INFINITY]);
        ranges[120..124].fill(f64::NAN);
        let s = EncodedScan::new(-1.0, 0.001, ranges, &lim).unwrap();
        assert_eq!(s.combined, 4);
        assert_eq!(s.ranges_mm.len(), n.div_ceil(4));
        assert_eq!((s.ranges_mm[9], s.ranges_mm[10], s.ranges_mm[11]), (5000, 1500, 5000), "the post is kept");
        assert_eq!(s.ranges_mm[20], RANGE_NO_RETURN);
        assert_eq!(s.ranges_mm[30], RANGE_INVALID);
        let first =
            BinaryAngle::from_radians(-1.0).unwrap() + BinaryAngle((BinaryAngle::from_radians(0.001).unwrap().0 as i64 * 3 / 2) as i32);
        assert_eq!(s.angle_min, first, "the first group's middle");
        assert_eq!(s.angle_increment.0, BinaryAngle::from_radians(0.001).unwrap().0 * 4);
        // At the wire's capacity nothing changes.
        let s = EncodedScan::new(-1.0, 0.001, vec![5.0; MAX_WIRE_BEAMS], &lim).unwrap();
        assert_eq!((s.combined, s.ranges_mm.len(), s.angle_min), (1, MAX_WIRE_BEAMS, BinaryAngle::from_radians(-1.0).unwrap()));
    }

    #[test]
    fn a_labelled_scan_keeps_the_label_of_the_reading_it_keeps() {
        let n = MAX_WIRE_BEAMS + 1;
        let mut scan = EncodedScan::new(0.0, 0.002, vec![4.0; n], &RangeLimits::new(0.1, 20.0)).unwrap();
        assert_eq!(scan.combined, 2);
        let mut full = EncodedScan { ranges_mm: vec![4000; n], labels: vec![BeamLabel::Map; n], combined: 1, ..scan.clone() };
        full.ranges_mm[7] = 900;
        full.labels[7] = BeamLabel::NonMap;
        scan = full.fitted();
        assert_eq!((scan.ranges_mm[3], scan.labels[3]), (900, BeamLabel::NonMap));
        assert_eq!((scan.ranges_mm[2], scan.labels[2]), (4000, BeamLabel::Map));
        assert_eq!(scan.labels.len(), scan.ranges_mm.len());
    }
}
