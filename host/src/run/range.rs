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
}

impl EncodedScan {
    /// Encodes ranges in metres (ROS conventions) taken at `angle_min + i·angle_increment`
    /// (radians); `None` if an angle is not finite. An increment that cannot be represented
    /// (zero, with more than one beam) is left for the core to refuse.
    pub fn new(angle_min: f64, angle_increment: f64, ranges_m: impl IntoIterator<Item = f64>, limits: &RangeLimits) -> Option<Self> {
        let (range_min_mm, range_max_mm) = limits.mm();
        Some(EncodedScan {
            angle_min: BinaryAngle::from_radians(angle_min)?,
            angle_increment: BinaryAngle::from_radians(angle_increment)?,
            ranges_mm: ranges_m.into_iter().map(|r| encode_range(r, limits)).collect(),
            range_min_mm,
            range_max_mm,
            labels: Vec::new(),
        })
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
}
