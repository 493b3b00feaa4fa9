//! Scans in and out of the core's beam grid.
//!
//! A scan arrives as the sensor produced it ([`ScanInput`]: any beam count up to
//! [`MAX_INPUT_BEAMS`], its own start angle and increment, ranges as integer millimetres, optional
//! per-beam labels) and is resampled onto the classifier's fixed grid of [`BEAMS`] beams over 360°
//! ([`BeamScan`]), keeping the nearest valid return per beam. Range encoding on the way in:
//!
//! | value | meaning |
//! |---|---|
//! | `0` ([`RANGE_INVALID`]) | no usable reading (NaN, below the minimum range, a dropout) |
//! | `1 ..= 65 534` | a return at that many millimetres |
//! | `65 535` ([`RANGE_NO_RETURN`]) | nothing within the sensor's range (ROS: `+inf`) |
//!
//! Every scan carries its sensor's limits, `range_min_mm` and `range_max_mm` (ROS
//! `sensor_msgs/LaserScan`'s `range_min`/`range_max`, capped at [`RANGE_LIMIT_MM`]). The range
//! rule is REP 117's, applied once, here, by [`BeamScan::resample`]: a reading below `range_min`
//! is invalid (skipped), a reading at or beyond `range_max` is "no return" — nothing within
//! `range_max` — and so is [`RANGE_NO_RETURN`]. The LiDAR grid clears a no-return beam out to
//! `range_max` only, and no farther than the configured clearing range
//! ([`crate::Config::lidar_max_range_m`]), never through a cell with wall evidence
//! ([`crate::grid::LidarGrid`]). A scan whose `range_max` is 0 or not above its `range_min` is
//! refused ([`ScanError::BadRangeLimits`]).

use crate::capacity::{BEAMS, MAX_INPUT_BEAMS};
use fixed_point::BinaryAngle;

/// Range value meaning "no usable reading".
pub const RANGE_INVALID: u16 = 0;
/// Range value meaning "no return within the sensor's range".
pub const RANGE_NO_RETURN: u16 = u16::MAX;
/// The longest return the encoding holds, millimetres: a sensor's `range_max` beyond it (a
/// VLP-16's 100 m) is capped here, and readings past it are "no return".
pub const RANGE_LIMIT_MM: u16 = u16::MAX - 1;

/// What a LiDAR point is, for the planner.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum BeamLabel {
    /// Not labelled (no classifier output, or no return).
    #[default]
    Unlabelled = 0,
    /// Permanent structure: walls (the paper's LTF).
    Map = 1,
    /// Furniture, objects, people (the paper's STF ∪ DF): where a target may be.
    NonMap = 2,
}

/// Why a scan was refused. The controller counts refusals and keeps its maps unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanError {
    /// No beams.
    Empty,
    /// More than [`MAX_INPUT_BEAMS`] beams.
    TooManyBeams(usize),
    /// A zero increment with more than one beam.
    ZeroIncrement,
    /// The label slice's length differs from the range slice's.
    LabelCountMismatch {
        /// Ranges given.
        ranges: usize,
        /// Labels given.
        labels: usize,
    },
    /// The scan's `range_max` is 0 or not above its `range_min` (REP 117 needs
    /// `0 <= range_min < range_max`).
    BadRangeLimits {
        /// The scan's `range_min`, millimetres.
        min_mm: u16,
        /// The scan's `range_max`, millimetres.
        max_mm: u16,
    },
}

/// A scan as the sensor produced it, borrowed from the caller.
#[derive(Clone, Copy, Debug)]
pub struct ScanInput<'a> {
    /// Angle of the first beam in the robot frame (counter-clockwise from forward).
    pub angle_min: BinaryAngle,
    /// Angle between consecutive beams (negative for clockwise sensors).
    pub angle_increment: BinaryAngle,
    /// One range per beam, see the module docs for the encoding.
    pub ranges_mm: &'a [u16],
    /// Optional labels, one per beam (ground truth from a simulator, or a classifier upstream).
    pub labels: Option<&'a [BeamLabel]>,
    /// The sensor's minimum range, millimetres: readings below it are invalid.
    pub range_min_mm: u16,
    /// The sensor's maximum range, millimetres (at most [`RANGE_LIMIT_MM`]): readings at or beyond
    /// it mean "nothing within it" and clear no farther than it.
    pub range_max_mm: u16,
}

/// A scan on the core's beam grid: beam `b` at −π + b·2π/[`BEAMS`] in the robot frame.
#[derive(Clone)]
pub struct BeamScan {
    /// Ranges in millimetres, encoded as in the module docs.
    pub ranges_mm: [u16; BEAMS],
    /// Labels per beam.
    pub labels: [BeamLabel; BEAMS],
    /// The scan's maximum range, millimetres: how far a "no return" beam says space is empty.
    pub range_max_mm: u16,
}

impl BeamScan {
    /// A scan with no readings.
    pub const fn new() -> Self {
        Self { ranges_mm: [RANGE_INVALID; BEAMS], labels: [BeamLabel::Unlabelled; BEAMS], range_max_mm: RANGE_LIMIT_MM }
    }

    /// The core beam nearest to angle `a` (robot frame).
    #[inline]
    pub fn beam_of(a: BinaryAngle) -> usize {
        // Shift so −π maps to 0, then scale a full turn onto BEAMS bins, rounding to nearest.
        let u = (a.0 as u32 ^ 0x8000_0000) as u64;
        (((u * BEAMS as u64) + (1 << 31)) >> 32) as usize % BEAMS
    }

    /// Fills `self` from `input`, keeping per beam the nearest valid return (then "no return",
    /// then invalid), after the range rule of the module docs (below `range_min` invalid, at or
    /// beyond `range_max` no return). Returns the number of input readings that were valid
    /// returns. A refused scan leaves `self` unchanged.
    pub fn resample(&mut self, input: &ScanInput<'_>) -> Result<usize, ScanError> {
        let n = input.ranges_mm.len();
        if n == 0 {
            return Err(ScanError::Empty);
        }
        if n > MAX_INPUT_BEAMS {
            return Err(ScanError::TooManyBeams(n));
        }
        if n > 1 && input.angle_increment.0 == 0 {
            return Err(ScanError::ZeroIncrement);
        }
        if let Some(l) = input.labels {
            if l.len() != n {
                return Err(ScanError::LabelCountMismatch { ranges: n, labels: l.len() });
            }
        }
        let (min, max) = (input.range_min_mm, input.range_max_mm.min(RANGE_LIMIT_MM));
        if max == 0 || max <= min {
            return Err(ScanError::BadRangeLimits { min_mm: input.range_min_mm, max_mm: input.range_max_mm });
        }
        self.range_max_mm = max;
        self.ranges_mm = [RANGE_INVALID; BEAMS];
        self.labels = [BeamLabel::Unlabelled; BEAMS];
        let rank = |r: u16| -> u32 {
            match r {
                RANGE_INVALID => u32::MAX,
                RANGE_NO_RETURN => u32::MAX - 1,
                r => r as u32,
            }
        };
        let mut valid = 0;
        for (i, &r) in input.ranges_mm.iter().enumerate() {
            let r = match r {
                RANGE_INVALID => RANGE_INVALID,
                r if r < min => RANGE_INVALID,
                r if r >= max => RANGE_NO_RETURN,
                r => r,
            };
            let a = input.angle_min + BinaryAngle((input.angle_increment.0 as i64 * i as i64) as i32);
            let b = Self::beam_of(a);
            if r != RANGE_INVALID && r != RANGE_NO_RETURN {
                valid += 1;
            }
            if rank(r) < rank(self.ranges_mm[b]) {
                self.ranges_mm[b] = r;
                self.labels[b] = input.labels.map_or(BeamLabel::Unlabelled, |l| l[i]);
            }
        }
        Ok(valid)
    }
}

impl Default for BeamScan {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn native_grid_maps_one_to_one() {
        let ranges: [u16; BEAMS] = core::array::from_fn(|i| 1000 + i as u16);
        let input = ScanInput {
            angle_min: BinaryAngle::HALF,
            angle_increment: BinaryAngle::from_fraction(1, BEAMS as i64),
            ranges_mm: &ranges,
            labels: None,
            range_min_mm: 0,
            range_max_mm: RANGE_LIMIT_MM,
        };
        let mut s = BeamScan::new();
        assert_eq!(s.resample(&input), Ok(BEAMS));
        assert_eq!(s.ranges_mm, ranges);
    }

    #[test]
    fn keeps_nearest_and_rejects_bad_shapes() {
        let ranges = [5000u16, 3000, RANGE_NO_RETURN, RANGE_INVALID];
        let labels = [BeamLabel::Map, BeamLabel::NonMap, BeamLabel::Map, BeamLabel::Map];
        // Four readings all within one core beam (tiny increment): the nearest wins with its label.
        let input = ScanInput {
            angle_min: BinaryAngle::ZERO,
            angle_increment: BinaryAngle(10),
            ranges_mm: &ranges,
            labels: Some(&labels),
            range_min_mm: 100,
            range_max_mm: 30_000,
        };
        let mut s = BeamScan::new();
        s.resample(&input).unwrap();
        let b = BeamScan::beam_of(BinaryAngle::ZERO);
        assert_eq!(s.ranges_mm[b], 3000);
        assert_eq!(s.labels[b], BeamLabel::NonMap);
        assert_eq!(s.resample(&ScanInput { ranges_mm: &[], ..input }), Err(ScanError::Empty));
        assert_eq!(
            s.resample(&ScanInput { labels: Some(&labels[..2]), ..input }),
            Err(ScanError::LabelCountMismatch { ranges: 4, labels: 2 })
        );
        assert_eq!(s.resample(&ScanInput { angle_increment: BinaryAngle::ZERO, ..input }), Err(ScanError::ZeroIncrement));
        for (min_mm, max_mm) in [(0, 0), (100, 100), (500, 100)] {
            assert_eq!(
                s.resample(&ScanInput { range_min_mm: min_mm, range_max_mm: max_mm, ..input }),
                Err(ScanError::BadRangeLimits { min_mm, max_mm })
            );
        }
        let big = [1u16; MAX_INPUT_BEAMS + 1];
        assert_eq!(s.resample(&ScanInput { ranges_mm: &big, labels: None, ..input }), Err(ScanError::TooManyBeams(MAX_INPUT_BEAMS + 1)));
    }

    /// REP 117 on the way in: below `range_min` invalid, at or beyond `range_max` no return, a
    /// `range_max` past the encoding capped at [`RANGE_LIMIT_MM`].
    #[test]
    fn the_range_rule_is_applied_once_on_the_way_in() {
        let step = BinaryAngle::from_fraction(1, BEAMS as i64);
        let ranges = [50u16, 100, 11_999, 12_000, 40_000, RANGE_NO_RETURN, RANGE_INVALID];
        let input = ScanInput {
            angle_min: BinaryAngle::HALF,
            angle_increment: step,
            ranges_mm: &ranges,
            labels: None,
            range_min_mm: 100,
            range_max_mm: 12_000,
        };
        let mut s = BeamScan::new();
        assert_eq!(s.resample(&input), Ok(2), "100 and 11 999 mm are returns");
        assert_eq!(&s.ranges_mm[..7], &[RANGE_INVALID, 100, 11_999, RANGE_NO_RETURN, RANGE_NO_RETURN, RANGE_NO_RETURN, RANGE_INVALID]);
        assert_eq!(s.range_max_mm, 12_000);
        s.resample(&ScanInput { range_max_mm: u16::MAX, ..input }).unwrap();
        assert_eq!(s.range_max_mm, RANGE_LIMIT_MM);
        assert_eq!(s.ranges_mm[4], 40_000);
    }
}
