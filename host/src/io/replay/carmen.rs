//! CARMEN text logs: `FLASER`, `ROBOTLASER1` and `ODOM` lines, plain or gzip-compressed.
//!
//! A CARMEN log is one message per line, tokens separated by white space, the last three tokens of
//! every message being `ipc_timestamp hostname logger_timestamp`. Replay reads:
//!
//! - `FLASER n r1..rn x y θ odom_x odom_y odom_θ ts host ts`: a front laser scan. The line carries
//!   no angles: the scan covers 180° starting at −π/2 (to the robot's right), in steps of π/n for
//!   an even n (180, 360 beams) and π/(n−1) for an odd n (181, 361: both ends included). `x y θ`
//!   is the laser's pose in the world.
//! - `ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn
//!   n_rem rem1..rem_n_rem laser_x laser_y laser_θ robot_x robot_y robot_θ tv rv fwd_safety
//!   side_safety turn_axis ts host ts`: a scan with its own angles and the laser's pose.
//! - `RAWLASER1 type start_angle fov resolution max_range accuracy [remission_mode] n r1..rn
//!   n_rem rem1..rem_n_rem ts host ts`: the front laser's scan without a pose (what CARMEN's
//!   logger writes beside `ROBOTLASER1`, and all some logs have); older loggers leave out
//!   `remission_mode`, and the counts tell which. `RAWLASER2`–`RAWLASER4` (the rear and other
//!   lasers) are read too, and replay counts them.
//! - `ODOM x y θ tv rv accel ts host ts`: the robot's odometry (replay places `RAWLASER1` scans
//!   with it, interpolated to their stamps; the other scans carry their own laser pose).
//! - `PARAM robot_frontlaser_offset|robot_frontlaser_side_offset|robot_frontlaser_angular_offset
//!   value ts host ts`: where the front laser sits on the robot (metres forward, metres left,
//!   radians), for `RAWLASER1` scans.
//!
//! `#` lines, other `PARAM` lines and other message types (`NEFF`, `RLASER`, `TRUEPOS`, …) are
//! skipped.
//! Ranges at or beyond the laser's maximum (80 m for `FLASER`, whose line has no maximum, the SICK
//! LMS's "no return" value being ≈ 81.9 m; the line's own `max_range` for `ROBOTLASER1`) become
//! `+inf` (no return), zero or negative ranges NaN (invalid): the ROS conventions the rest of
//! replay uses.
//!
//! A line that does not read (cut short, a bad number, a beam count that does not match the
//! line's fields, a `ROBOTLASER1` `max_range` that is not positive, a time stamp beyond
//! ±[`MAX_TIMESTAMP_S`]) is a [`LineError`]; replay skips that line and counts it by
//! [`LineError::reason`].
//!
//! What this module must not do: know about the controller or pictures.

use std::fmt;

/// `FLASER` scans: readings at or beyond this are "no return".
pub const FLASER_MAX_RANGE_M: f64 = 80.0;

/// The largest time stamp a line may carry, either side of 0, seconds: 2200-01-01 00:00 UTC.
/// CARMEN stamps are seconds since 1970 or since the start of the log; a larger one (`1e300`) is
/// a corrupt field, and would make the log's duration absurd.
pub const MAX_TIMESTAMP_S: f64 = 7_258_118_400.0;

/// The kinds of line replay reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    /// `FLASER`.
    Flaser,
    /// `ROBOTLASER1`.
    RobotLaser1,
    /// `ODOM`.
    Odom,
    /// `RAWLASER1` … `RAWLASER4`.
    RawLaser(u8),
    /// `PARAM` (the front laser's mount).
    Param,
}

impl fmt::Display for LineKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LineKind::Flaser => "FLASER",
            LineKind::RobotLaser1 => "ROBOTLASER1",
            LineKind::Odom => "ODOM",
            LineKind::RawLaser(1) => "RAWLASER1",
            LineKind::RawLaser(2) => "RAWLASER2",
            LineKind::RawLaser(3) => "RAWLASER3",
            LineKind::RawLaser(_) => "RAWLASER4",
            LineKind::Param => "PARAM",
        })
    }
}

/// One laser scan from a CARMEN line.
#[derive(Clone, Debug, PartialEq)]
pub struct CarmenScan {
    /// `FLASER` or `ROBOTLASER1`.
    pub kind: LineKind,
    /// `ipc_timestamp`, seconds.
    pub t_s: f64,
    /// The laser's pose in the world: x, y (metres), θ (radians).
    pub laser_pose: [f64; 3],
    /// The robot's pose (`odom_*` of `FLASER`, `robot_*` of `ROBOTLASER1`).
    pub robot_pose: [f64; 3],
    /// First beam's angle in the laser frame, radians.
    pub angle_min: f64,
    /// Angle between beams, radians.
    pub angle_increment: f64,
    /// Ranges, metres: `+inf` no return, NaN invalid.
    pub ranges_m: Vec<f32>,
    /// The scanner's maximum range, metres: [`FLASER_MAX_RANGE_M`] for `FLASER` (its line has
    /// none), the line's own `max_range` for `ROBOTLASER1`.
    pub range_max_m: f64,
}

/// A `RAWLASERn` scan: no pose in the line.
#[derive(Clone, Debug, PartialEq)]
pub struct RawScan {
    /// Which laser, 1 (front) to 4.
    pub laser: u8,
    /// `ipc_timestamp`, seconds.
    pub t_s: f64,
    /// First beam's angle in the laser frame, radians.
    pub angle_min: f64,
    /// Angle between beams, radians.
    pub angle_increment: f64,
    /// Ranges, metres: `+inf` no return, NaN invalid.
    pub ranges_m: Vec<f32>,
    /// The line's `max_range`, metres.
    pub range_max_m: f64,
}

/// Where the front laser sits on the robot, from a `PARAM` line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MountField {
    /// `robot_frontlaser_offset`: metres forward.
    Forward,
    /// `robot_frontlaser_side_offset`: metres to the left.
    Side,
    /// `robot_frontlaser_angular_offset`: radians, counter-clockwise.
    Angle,
}

/// One message replay uses.
#[derive(Clone, Debug, PartialEq)]
pub enum CarmenRecord {
    /// A scan with its laser's pose.
    Scan(CarmenScan),
    /// A scan without a pose (`RAWLASERn`).
    Raw(RawScan),
    /// A `PARAM` line giving the front laser's mount.
    Mount {
        /// Which part of the mount.
        field: MountField,
        /// Its value (metres or radians).
        value: f64,
    },
    /// `ODOM`: time and robot pose.
    Odom {
        /// `ipc_timestamp`, seconds.
        t_s: f64,
        /// x, y, θ.
        pose: [f64; 3],
    },
}

impl CarmenRecord {
    /// The record's time stamp, `None` for a `PARAM` line (whose stamp is the logger's start,
    /// often 0, not a time the robot was anywhere).
    pub fn stamp(&self) -> Option<f64> {
        match self {
            CarmenRecord::Scan(s) => Some(s.t_s),
            CarmenRecord::Raw(s) => Some(s.t_s),
            CarmenRecord::Odom { t_s, .. } => Some(*t_s),
            CarmenRecord::Mount { .. } => None,
        }
    }
}

/// Why a line could not be read.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum LineError {
    /// The line ended before `field` (a truncated line).
    MissingField {
        /// Line type.
        kind: LineKind,
        /// The first missing field.
        field: &'static str,
    },
    /// `field` is not a number (or not a finite one where that is required).
    BadNumber {
        /// Line type.
        kind: LineKind,
        /// The field.
        field: &'static str,
        /// What was there.
        token: String,
    },
    /// A beam count of zero or more than the core takes ([`firmware::capacity::MAX_INPUT_BEAMS`]).
    BadBeamCount {
        /// Line type.
        kind: LineKind,
        /// The count.
        count: String,
    },
    /// The line is complete (it ends in `ipc_timestamp hostname logger_timestamp`) but its beam
    /// count (with a `ROBOTLASER1`'s remission count) says it has a different number of fields.
    CountMismatch {
        /// Line type.
        kind: LineKind,
        /// The beam count.
        beams: usize,
        /// Fields (after the line type) the counts need; `None` for a `ROBOTLASER1` line with no
        /// remission count where its beam count puts one.
        expected: Option<usize>,
        /// Fields the line has.
        found: usize,
    },
    /// A number outside what the field can hold.
    OutOfRange {
        /// Line type.
        kind: LineKind,
        /// The field.
        field: &'static str,
        /// What was there.
        token: String,
        /// What it must be.
        expected: &'static str,
    },
    /// More tokens than the line type has (two lines run together, or a corrupt count).
    ExtraFields {
        /// Line type.
        kind: LineKind,
        /// Tokens expected.
        expected: usize,
        /// Tokens found.
        found: usize,
    },
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LineError::MissingField { kind, field } => write!(f, "{kind} line ends before its {field} (truncated line)"),
            LineError::BadNumber { kind, field, token } => write!(f, "{kind} {field} `{token}` is not a valid number"),
            LineError::BadBeamCount { kind, count } => {
                write!(f, "{kind} beam count `{count}` is not between 1 and {}", firmware::capacity::MAX_INPUT_BEAMS)
            }
            LineError::CountMismatch { kind, beams, expected: Some(expected), found } => {
                write!(f, "{kind} beam count {beams} does not match the number of fields: the line has {found}, its counts need {expected}")
            }
            LineError::CountMismatch { kind, beams, expected: None, found } => write!(
                f,
                "{kind} beam count {beams} does not match the number of fields: the line has {found}, with no remission count \
                 after that many readings"
            ),
            LineError::OutOfRange { kind, field, token, expected } => write!(f, "{kind} {field} `{token}` is out of range ({expected})"),
            LineError::ExtraFields { kind, expected, found } => {
                write!(f, "{kind} line has {found} fields where its counts say {expected}")
            }
        }
    }
}

impl LineError {
    /// The reason replay counts a skipped line under (`--json`'s `skipped_records.by_reason`).
    pub fn reason(&self) -> &'static str {
        match self {
            LineError::MissingField { .. } => "truncated_line",
            LineError::BadNumber { .. } => "bad_number",
            LineError::BadBeamCount { .. } => "bad_beam_count",
            LineError::CountMismatch { .. } => "count_mismatch",
            LineError::OutOfRange { .. } => "out_of_range",
            LineError::ExtraFields { .. } => "extra_fields",
        }
    }
}

/// A cursor over a line's tokens.
struct Tokens<'a> {
    kind: LineKind,
    toks: Vec<&'a str>,
    i: usize,
}

impl<'a> Tokens<'a> {
    fn next(&mut self, field: &'static str) -> Result<&'a str, LineError> {
        let t = self.toks.get(self.i).copied().ok_or(LineError::MissingField { kind: self.kind, field })?;
        self.i += 1;
        Ok(t)
    }

    /// A finite number.
    fn num(&mut self, field: &'static str) -> Result<f64, LineError> {
        let t = self.next(field)?;
        match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(LineError::BadNumber { kind: self.kind, field, token: t.to_string() }),
        }
    }

    /// A range reading (any number; non-finite ones become invalid later).
    fn range(&mut self, field: &'static str) -> Result<f64, LineError> {
        let t = self.next(field)?;
        t.parse::<f64>().map_err(|_| LineError::BadNumber { kind: self.kind, field, token: t.to_string() })
    }

    fn count(&mut self, field: &'static str, max: usize) -> Result<usize, LineError> {
        let t = self.next(field)?;
        match t.parse::<usize>() {
            Ok(n) if n <= max => Ok(n),
            _ => Err(LineError::BadNumber { kind: self.kind, field, token: t.to_string() }),
        }
    }

    fn beams(&mut self) -> Result<usize, LineError> {
        let t = self.next("beam count")?;
        match t.parse::<usize>() {
            Ok(n) if (1..=firmware::capacity::MAX_INPUT_BEAMS).contains(&n) => Ok(n),
            _ => Err(LineError::BadBeamCount { kind: self.kind, count: t.to_string() }),
        }
    }

    fn pose(&mut self, names: [&'static str; 3]) -> Result<[f64; 3], LineError> {
        Ok([self.num(names[0])?, self.num(names[1])?, self.num(names[2])?])
    }

    /// A time stamp: a number within ±[`MAX_TIMESTAMP_S`] (the Freiburg 079 log starts at
    /// −0.96 s).
    fn time(&mut self, field: &'static str) -> Result<f64, LineError> {
        let t = self.num(field)?;
        if t.abs() > MAX_TIMESTAMP_S {
            let token = self.toks[self.i - 1].to_string();
            return Err(LineError::OutOfRange {
                kind: self.kind,
                field,
                token,
                expected: "at most 7258118400 s either side of 0, the year 2200",
            });
        }
        Ok(t)
    }

    /// The line ends like a complete one: `number hostname number`, the hostname not a number.
    fn ends_with_stamp(&self) -> bool {
        let n = self.toks.len();
        let is_num = |t: &str| t.parse::<f64>().is_ok();
        n >= 3 && is_num(self.toks[n - 3]) && !is_num(self.toks[n - 2]) && is_num(self.toks[n - 1])
    }

    /// A complete line must have `expected` tokens after its type (a truncated one is left to the
    /// field-by-field reading, which names the first missing field).
    fn check_counts(&self, beams: usize, expected: Option<usize>) -> Result<(), LineError> {
        if expected != Some(self.toks.len()) && self.ends_with_stamp() {
            return Err(LineError::CountMismatch { kind: self.kind, beams, expected, found: self.toks.len() });
        }
        Ok(())
    }

    /// `ipc_timestamp hostname logger_timestamp`, and nothing after.
    fn stamp(&mut self) -> Result<f64, LineError> {
        let t = self.time("ipc_timestamp")?;
        self.next("hostname")?;
        self.time("logger_timestamp")?;
        if self.i != self.toks.len() {
            return Err(LineError::ExtraFields { kind: self.kind, expected: self.i, found: self.toks.len() });
        }
        Ok(t)
    }
}

/// A range in the log's convention to the ROS one: `≥ max` → `+inf`, `≤ 0` or not finite → NaN.
fn ros_range(r: f64, max_range_m: f64) -> f32 {
    if !r.is_finite() || r <= 0.0 {
        f32::NAN
    } else if r >= max_range_m {
        f32::INFINITY
    } else {
        r as f32
    }
}

/// A laser's configuration fields, from `start_angle` to `max_range` (after `laser_type`):
/// `(angle_min, angle_increment, max_range)`, the maximum checked to be above 0.
fn laser_config(t: &mut Tokens<'_>) -> Result<(f64, f64, f64), LineError> {
    let angle_min = t.num("start_angle")?;
    t.num("fov")?;
    let angle_increment = t.num("angular_resolution")?;
    let max_range = t.num("max_range")?;
    if max_range <= 0.0 {
        let token = t.toks[t.i - 1].to_string();
        return Err(LineError::OutOfRange { kind: t.kind, field: "max_range", token, expected: "metres above 0" });
    }
    Ok((angle_min, angle_increment, max_range))
}

/// `n` range readings by the ROS conventions ([`ros_range`] with `max_range`), then the
/// remission count and the remissions (read and dropped).
fn readings(t: &mut Tokens<'_>, n: usize, max_range: f64) -> Result<Vec<f32>, LineError> {
    let ranges_m = (0..n).map(|_| t.range("range").map(|r| ros_range(r, max_range))).collect::<Result<_, _>>()?;
    let n_rem = t.count("remission count", t.toks.len())?;
    for _ in 0..n_rem {
        t.range("remission")?;
    }
    Ok(ranges_m)
}

/// Does a `RAWLASERn` line have `header` fields before its beam count (7 with `remission_mode`,
/// 6 without), judged by its counts: the beam count, the remission count after that many
/// readings, and the stamp's three fields make up the whole line.
fn raw_header_fits(toks: &[&str], header: usize) -> bool {
    let count = |i: usize| toks.get(i).and_then(|c| c.parse::<usize>().ok());
    let Some(n) = count(header) else { return false };
    let Some(rem) = count(header + 1 + n) else { return false };
    header.saturating_add(n).saturating_add(rem).saturating_add(5) == toks.len()
}

/// Parses one line. `Ok(None)`: a line replay does not use (comment, other `PARAM`s, other
/// types, blank).
pub fn parse_line(line: &str) -> Result<Option<CarmenRecord>, LineError> {
    let mut it = line.split_ascii_whitespace();
    let kind = match it.next() {
        Some("FLASER") => LineKind::Flaser,
        Some("ROBOTLASER1") => LineKind::RobotLaser1,
        Some("ODOM") => LineKind::Odom,
        Some("RAWLASER1") => LineKind::RawLaser(1),
        Some("RAWLASER2") => LineKind::RawLaser(2),
        Some("RAWLASER3") => LineKind::RawLaser(3),
        Some("RAWLASER4") => LineKind::RawLaser(4),
        Some("PARAM") => LineKind::Param,
        _ => return Ok(None),
    };
    let mut t = Tokens { kind, toks: it.collect(), i: 0 };
    let rec = match kind {
        LineKind::Param => {
            let field = match t.next("name")? {
                "robot_frontlaser_offset" => MountField::Forward,
                "robot_frontlaser_side_offset" => MountField::Side,
                "robot_frontlaser_angular_offset" => MountField::Angle,
                _ => return Ok(None),
            };
            // What follows the value varies between loggers (`ts host ts`, or `host ts` in the
            // Radish logs): it is not read.
            let value = t.num("value")?;
            CarmenRecord::Mount { field, value }
        }
        LineKind::RawLaser(laser) => {
            // 6 or 7 header fields (`remission_mode` came later); with neither fitting, the
            // current logger's 7 name the error.
            let header = if !raw_header_fits(&t.toks, 7) && raw_header_fits(&t.toks, 6) { 6 } else { 7 };
            t.next("laser_type")?;
            let (angle_min, angle_increment, max_range) = laser_config(&mut t)?;
            t.num("accuracy")?;
            if header == 7 {
                t.next("remission_mode")?;
            }
            let n = t.beams()?;
            // The header, count, n ranges, remission count, the remissions, 3 stamp fields.
            let remissions = t.toks.get(header + 1 + n).and_then(|c| c.parse::<usize>().ok());
            t.check_counts(n, remissions.map(|r| n.saturating_add(r).saturating_add(header + 5)))?;
            let ranges_m = readings(&mut t, n, max_range)?;
            let t_s = t.stamp()?;
            CarmenRecord::Raw(RawScan { laser, t_s, angle_min, angle_increment, ranges_m, range_max_m: max_range })
        }
        LineKind::Odom => {
            let pose = t.pose(["x", "y", "theta"])?;
            for f in ["tv", "rv", "accel"] {
                t.num(f)?;
            }
            CarmenRecord::Odom { t_s: t.stamp()?, pose }
        }
        LineKind::Flaser => {
            let n = t.beams()?;
            // count, n ranges, 6 pose values, 3 stamp fields.
            t.check_counts(n, Some(n + 10))?;
            let ranges_m = (0..n).map(|_| t.range("range").map(|r| ros_range(r, FLASER_MAX_RANGE_M))).collect::<Result<_, _>>()?;
            let laser_pose = t.pose(["x", "y", "theta"])?;
            let robot_pose = t.pose(["odom_x", "odom_y", "odom_theta"])?;
            let t_s = t.stamp()?;
            let steps = if n % 2 == 0 { n } else { n - 1 }.max(1);
            CarmenRecord::Scan(CarmenScan {
                kind,
                t_s,
                laser_pose,
                robot_pose,
                angle_min: -std::f64::consts::FRAC_PI_2,
                angle_increment: std::f64::consts::PI / steps as f64,
                ranges_m,
                range_max_m: FLASER_MAX_RANGE_M,
            })
        }
        LineKind::RobotLaser1 => {
            t.next("laser_type")?;
            let (angle_min, angle_increment, max_range) = laser_config(&mut t)?;
            t.num("accuracy")?;
            t.next("remission_mode")?;
            let n = t.beams()?;
            // 7 header fields, count, n ranges, remission count, the remissions, 6 pose values, 5
            // motion fields, 3 stamp fields.
            let remissions = t.toks.get(8 + n).and_then(|c| c.parse::<usize>().ok());
            t.check_counts(n, remissions.map(|r| n.saturating_add(r).saturating_add(23)))?;
            let ranges_m = readings(&mut t, n, max_range)?;
            let laser_pose = t.pose(["laser_x", "laser_y", "laser_theta"])?;
            let robot_pose = t.pose(["robot_x", "robot_y", "robot_theta"])?;
            for f in ["tv", "rv", "forward_safety_dist", "side_safety_dist", "turn_axis"] {
                t.num(f)?;
            }
            let t_s = t.stamp()?;
            CarmenRecord::Scan(CarmenScan {
                kind,
                t_s,
                laser_pose,
                robot_pose,
                angle_min,
                angle_increment,
                ranges_m,
                range_max_m: max_range,
            })
        }
    };
    Ok(Some(rec))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first `ODOM` line of `intel-corrected.log.gz` whose pose is not zero.
    const INTEL_ODOM: &str = "ODOM -0.322783 -0.0967671 0.00578343 0 0 0 2690.89 pippo 2690.89";

    #[test]
    fn odom_line_values() {
        assert_eq!(parse_line(INTEL_ODOM).unwrap(), Some(CarmenRecord::Odom { t_s: 2690.89, pose: [-0.322783, -0.0967671, 0.00578343] }));
    }

    #[test]
    fn flaser_line_values_and_angles() {
        // 4 beams (even: step π/4 from −π/2), one "no return" (81.91 ≥ 80) and one zero (invalid).
        let line = "FLASER 4 1.09 81.91 0 2.5 0.600266 -0.0320327 -0.354665 0.61 -0.03 -0.35 32.9068 pippo 32.9068";
        let Some(CarmenRecord::Scan(s)) = parse_line(line).unwrap() else { panic!("not a scan") };
        assert_eq!(s.kind, LineKind::Flaser);
        assert_eq!(s.t_s, 32.9068);
        assert_eq!(s.laser_pose, [0.600266, -0.0320327, -0.354665]);
        assert_eq!(s.robot_pose, [0.61, -0.03, -0.35]);
        assert_eq!(s.angle_min, -std::f64::consts::FRAC_PI_2);
        assert_eq!(s.angle_increment, std::f64::consts::PI / 4.0);
        assert_eq!(s.ranges_m[0], 1.09);
        assert_eq!(s.ranges_m[1], f32::INFINITY);
        assert!(s.ranges_m[2].is_nan());
        assert_eq!(s.ranges_m[3], 2.5);
        // Odd beam counts include both ends: 181 beams → 1°.
        let line181 = format!("FLASER 181 {} 0 0 0 0 0 0 1.0 h 1.0", vec!["1"; 181].join(" "));
        let Some(CarmenRecord::Scan(s)) = parse_line(&line181).unwrap() else { panic!("not a scan") };
        assert!((s.angle_increment - 1f64.to_radians()).abs() < 1e-15);
    }

    #[test]
    fn robotlaser1_line_values() {
        // type 0, start −90°, fov 180°, 1° resolution (values as CARMEN writes them), max 50 m,
        // 3 beams (the last beyond max → no return), 2 remissions.
        let line = "ROBOTLASER1 0 -1.5708 3.14159 0.0174533 50.0 0.01 0 3 1.5 2.25 50.0 2 0.1 0.2 \
                    1.0 2.0 0.5 0.9 2.1 0.45 0.3 0.01 1.2 0.4 0.0 105.25 host 105.26";
        let Some(CarmenRecord::Scan(s)) = parse_line(line).unwrap() else { panic!("not a scan") };
        assert_eq!(s.kind, LineKind::RobotLaser1);
        // The line's own digits, not π/2 and one degree.
        #[allow(clippy::approx_constant)]
        let written = (-1.5708, 0.0174533);
        assert_eq!((s.angle_min, s.angle_increment), written);
        assert_eq!(s.ranges_m, vec![1.5, 2.25, f32::INFINITY]);
        assert_eq!(s.laser_pose, [1.0, 2.0, 0.5]);
        assert_eq!(s.robot_pose, [0.9, 2.1, 0.45]);
        assert_eq!(s.t_s, 105.25);
    }

    #[test]
    fn rawlaser_lines_with_and_without_remission_mode_and_the_front_laser_mount() {
        // CARMEN's logger: 7 header fields (with `remission_mode`), 3 beams, 1 remission.
        let line = "RAWLASER1 0 -1.5708 3.14159 0.0174533 81.9 0.01 0 3 1.5 81.9 0 1 0.5 1.25 host 1.26";
        let Some(CarmenRecord::Raw(s)) = parse_line(line).unwrap() else { panic!("not a raw scan") };
        assert_eq!((s.laser, s.t_s, s.range_max_m), (1, 1.25, 81.9));
        #[allow(clippy::approx_constant)]
        let written = (-1.5708, 0.0174533);
        assert_eq!((s.angle_min, s.angle_increment), written);
        assert_eq!(s.ranges_m[..2], [1.5, f32::INFINITY]);
        assert!(s.ranges_m[2].is_nan());
        // An older logger: no `remission_mode`, no remissions; the rear laser.
        let old = "RAWLASER2 0 -1.5708 3.14159 0.0174533 81.9 0.01 2 1.5 2.5 0 7.5 host 7.5";
        let Some(CarmenRecord::Raw(s)) = parse_line(old).unwrap() else { panic!("not a raw scan") };
        assert_eq!((s.laser, s.ranges_m.clone(), s.t_s), (2, vec![1.5, 2.5], 7.5));
        // A beam count that fits neither layout: named against the current one.
        let bad = "RAWLASER1 0 -1.5708 3.14159 0.0174533 81.9 0.01 0 4 1.5 2.5 0 7.5 host 7.5";
        assert!(
            matches!(parse_line(bad), Err(LineError::CountMismatch { kind: LineKind::RawLaser(1), beams: 4, .. })),
            "{:?}",
            parse_line(bad)
        );
        let cut = "RAWLASER1 0 -1.5708 3.14159 0.0174533 81.9 0.01 0 3 1.5";
        assert_eq!(parse_line(cut).unwrap_err(), LineError::MissingField { kind: LineKind::RawLaser(1), field: "range" });
        let e = parse_line("RAWLASER3 0 -1.5708 3.14159 0.0174533 0 0.01 0 1 1.5 0 7.5 host 7.5").unwrap_err();
        assert_eq!(e.to_string(), "RAWLASER3 max_range `0` is out of range (metres above 0)");
        // The front laser's mount; other parameters are skipped.
        assert_eq!(
            parse_line("PARAM robot_frontlaser_offset 0.12 nohost 0").unwrap(),
            Some(CarmenRecord::Mount { field: MountField::Forward, value: 0.12 })
        );
        assert_eq!(
            parse_line("PARAM robot_frontlaser_offset 0.12 1.5 host 1.5").unwrap(),
            Some(CarmenRecord::Mount { field: MountField::Forward, value: 0.12 })
        );
        assert_eq!(
            parse_line("PARAM robot_frontlaser_angular_offset -0.05 nohost 0").unwrap(),
            Some(CarmenRecord::Mount { field: MountField::Angle, value: -0.05 })
        );
        assert_eq!(
            parse_line("PARAM robot_frontlaser_side_offset x nohost 0").unwrap_err(),
            LineError::BadNumber { kind: LineKind::Param, field: "value", token: "x".into() }
        );
        assert_eq!(parse_line("PARAM robot_rearlaser_offset 0.0 nohost 0").unwrap(), None);
    }

    #[test]
    fn skipped_and_broken_lines() {
        for l in ["", "# comment", "PARAM robot_length 0.47 nohost 0", "NEFF 8.39921", "RLASER 1 2 3", "RAWLASER5 1 2"] {
            assert_eq!(parse_line(l).unwrap(), None, "{l}");
        }
        // Cut in the middle of the pose.
        assert_eq!(
            parse_line("FLASER 2 1.0 2.0 0.5 0.25").unwrap_err(),
            LineError::MissingField { kind: LineKind::Flaser, field: "theta" }
        );
        assert_eq!(
            parse_line("ODOM 1 2 x 0 0 0 1 h 1").unwrap_err(),
            LineError::BadNumber { kind: LineKind::Odom, field: "theta", token: "x".into() }
        );
        assert_eq!(
            parse_line("FLASER 0 0 0 0 0 0 0 1 h 1").unwrap_err(),
            LineError::BadBeamCount { kind: LineKind::Flaser, count: "0".into() }
        );
        assert_eq!(
            parse_line("ODOM 1 2 3 0 0 0 1 h 1 ODOM").unwrap_err(),
            LineError::ExtraFields { kind: LineKind::Odom, expected: 9, found: 10 }
        );
        assert!(matches!(parse_line("FLASER 99999 1"), Err(LineError::BadBeamCount { .. })));
    }

    #[test]
    fn a_beam_count_that_does_not_match_a_complete_line_is_named() {
        // Three readings under a count of 2: without the check the stamp would be read one field
        // late (`logger_timestamp `pippo` is not a valid number`).
        let e = parse_line("FLASER 2 1 2 3 0 0 0 0 0 0 5.0 pippo 5.0").unwrap_err();
        assert_eq!(e, LineError::CountMismatch { kind: LineKind::Flaser, beams: 2, expected: Some(12), found: 13 });
        assert_eq!(e.to_string(), "FLASER beam count 2 does not match the number of fields: the line has 13, its counts need 12");
        assert_eq!(e.reason(), "count_mismatch");
        // One reading short.
        assert!(matches!(parse_line("FLASER 3 1 2 0 0 0 0 0 0 5.0 pippo 5.0"), Err(LineError::CountMismatch { found: 12, .. })));
        // A line cut short is still a truncated line, named by its first missing field.
        assert_eq!(parse_line("FLASER 3 1 2 0 0").unwrap_err(), LineError::MissingField { kind: LineKind::Flaser, field: "y" });
        // ROBOTLASER1: 2 readings and 1 remission written, a beam count of 3 (which makes the
        // remission `0.1` its remission count), then of 1 (the remission count `2.25`, no count).
        let rl = |n: usize| {
            format!(
                "ROBOTLASER1 0 -1.5708 3.14159 0.0174533 50.0 0.01 0 {n} 1.5 2.25 1 0.1 1.0 2.0 0.5 0.9 2.1 0.45 0.3 0.01 1.2 0.4 \
                 0.0 105.25 host 105.26"
            )
        };
        assert!(parse_line(&rl(2)).is_ok());
        let e = parse_line(&rl(3)).unwrap_err();
        assert_eq!(e, LineError::CountMismatch { kind: LineKind::RobotLaser1, beams: 3, expected: None, found: 26 });
        assert!(e.to_string().contains("with no remission count after that many readings"), "{e}");
        // A beam count of 1 puts the remission count at `2.25`: not a count either.
        assert!(matches!(parse_line(&rl(1)), Err(LineError::CountMismatch { beams: 1, expected: None, .. })));
        // Counts 2 and 1 but a remission missing: the counts need 26 fields.
        let short = rl(2).replace(" 1 0.1 ", " 1 ");
        assert_eq!(
            parse_line(&short).unwrap_err(),
            LineError::CountMismatch { kind: LineKind::RobotLaser1, beams: 2, expected: Some(26), found: 25 }
        );
    }

    #[test]
    fn a_max_range_that_is_not_positive_and_absurd_time_stamps_are_refused() {
        let rl = |max: &str, ts: &str| {
            format!("ROBOTLASER1 0 -1.5708 3.14159 0.0174533 {max} 0.01 0 2 1.5 2.25 0 1.0 2.0 0.5 0.9 2.1 0.45 0.3 0.01 1.2 0.4 0.0 {ts} host {ts}")
        };
        assert!(parse_line(&rl("50.0", "105.25")).is_ok());
        for max in ["-1", "0", "-0"] {
            let e = parse_line(&rl(max, "105.25")).unwrap_err();
            assert_eq!(
                e,
                LineError::OutOfRange { kind: LineKind::RobotLaser1, field: "max_range", token: max.into(), expected: "metres above 0" }
            );
            assert_eq!(e.reason(), "out_of_range");
        }
        for max in ["nan", "inf"] {
            assert!(matches!(parse_line(&rl(max, "105.25")), Err(LineError::BadNumber { field: "max_range", .. })), "{max}");
        }
        // Stamps up to the year 2200, either side of 0 (the Freiburg 079 log starts at −0.96 s).
        assert!(parse_line(&rl("50.0", "7258118400")).is_ok());
        assert!(parse_line("ODOM 0 0 0 0 0 0 -0.958593 pippo -0.958593").is_ok());
        for ts in ["1e300", "7258118401", "-1e10"] {
            let e = parse_line(&format!("ODOM 0 0 0 0 0 0 {ts} pippo 1")).unwrap_err();
            assert!(matches!(&e, LineError::OutOfRange { field: "ipc_timestamp", token, .. } if token == ts), "{e:?}");
            assert!(e.to_string().contains("the year 2200"), "{e}");
        }
        let e = parse_line("ODOM 0 0 0 0 0 0 1 pippo 1e300").unwrap_err();
        assert!(matches!(e, LineError::OutOfRange { field: "logger_timestamp", .. }), "{e:?}");
    }
}
