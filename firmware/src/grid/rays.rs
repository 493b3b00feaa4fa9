//! What a scan's beams say about each other: a return on a grazing surface ([`grazing`]), a mixed
//! pixel at a depth edge ([`veiling`]), and how far a beam with no return may clear
//! ([`no_return_bounds`]). [`super::LidarGrid::integrate`] applies them.

use super::{beam_angle, mm_to_meters};
use crate::capacity::{BEAMS, CELL_MM};
use crate::scan::{BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use fixed_point::{cos, sin, Meters};

/// Whether beam `b` meets its surface at a grazing angle: a neighbouring beam's range differs
/// from its own by more than [`GRAZING_STEP_PER_MILLE`] thousandths of it (a wall seen edge-on,
/// or a depth edge).
pub fn grazing(scan: &BeamScan, b: usize) -> bool {
    let r = scan.ranges_mm[b];
    let step = r as u64 * GRAZING_STEP_PER_MILLE / 1000;
    [(b + BEAMS - 1) % BEAMS, (b + 1) % BEAMS].iter().any(|&n| {
        let rn = scan.ranges_mm[n];
        rn != RANGE_INVALID && rn != RANGE_NO_RETURN && (rn as i64 - r as i64).unsigned_abs() > step
    })
}

/// Whether beam `b` is a mixed pixel (a "veiling" return): its footprint straddled a depth edge
/// and the sensor reported a range between the two surfaces, so one neighbour is nearer and the
/// other farther, each by more than [`VEIL_STEP_PER_MILLE`] of its range. Such a return lies on
/// no surface: it marks no cell (ROS `laser_filters`' shadow filter drops such points by their
/// angle to the neighbours), and like a grazing beam it frees no occupied cell. A thin object
/// one beam wide has both neighbours farther, and is kept; a wall met at more than about 4° (its
/// neighbours a few per cent nearer and farther) is kept too.
pub fn veiling(scan: &BeamScan, b: usize) -> bool {
    let r = scan.ranges_mm[b];
    if r == RANGE_INVALID || r == RANGE_NO_RETURN {
        return false;
    }
    let step = (r as u64 * VEIL_STEP_PER_MILLE / 1000) as i64;
    let side = |n: usize| {
        let rn = scan.ranges_mm[n];
        if rn == RANGE_INVALID {
            0
        } else if rn == RANGE_NO_RETURN || rn as i64 > r as i64 + step {
            1
        } else if (rn as i64) < r as i64 - step {
            -1
        } else {
            0
        }
    };
    side((b + BEAMS - 1) % BEAMS) * side((b + 1) % BEAMS) == -1
}

/// See [`veiling`]: a mixed pixel lies at least 10 % of its range from both its neighbours (the
/// surfaces either side of a depth edge are far apart); consecutive beams on a wall met at 4° or
/// more differ by less (the beams are 0.4° apart).
pub const VEIL_STEP_PER_MILLE: u64 = 100;

/// See [`grazing`]: 28 mm per metre of range is 4 beam spacings (2π/897 rad each) across the
/// beam, so a surface met at under about 14° counts as grazed.
pub const GRAZING_STEP_PER_MILLE: u64 = 28;

/// Whether range `r` is a return the grid marks: a valid reading within the clearing range (not
/// "no return", not at or beyond `clear_range`).
#[inline]
pub fn is_return(r: u16, clear_range: Meters) -> bool {
    r != RANGE_INVALID && r != RANGE_NO_RETURN && mm_to_meters(r) < clear_range
}

/// In [`no_return_bounds`]: the beam is not bounded by its neighbours.
pub const NO_BOUND: u16 = u16::MAX;

/// Two returns bound the beams between them only if they are less than a quarter turn apart
/// (beam spacings): across a wider gap a straight surface is a guess, and between two returns
/// nearly opposite each other it would pass through the sensor and let no beam clear anything.
pub const MAX_BOUND_SPAN: usize = BEAMS / 4;

/// For every beam that clears without a return of its own (no return within the scan's
/// `range_max`, or a return at or beyond `clear_range`), how far it may clear, millimetres:
/// up to one cell short of the surface its two nearest returning beams, one on each side
/// (any beams without a return, or invalid, between them), span — the straight segment between
/// their two return points — where the beam meets that segment in front of the sensor.
/// [`NO_BOUND`] where it does not (no return anywhere or only one, two returns a quarter turn or
/// more apart ([`MAX_BOUND_SPAN`]), a segment not in front of it), and for returning beams.
///
/// Why: "no return" is what a real scanner reports for glass, dark surfaces and walls met
/// edge-on, not only for open space (REP 117's `+inf`); a wall its neighbours see is the likely
/// reason. Open space, where no neighbour returns, is still cleared out to the range. Returns the
/// work (beams visited).
pub fn no_return_bounds(scan: &BeamScan, clear_range: Meters, out: &mut [u16; BEAMS]) -> u32 {
    let returns = |b: usize| is_return(scan.ranges_mm[b], clear_range);
    out.fill(NO_BOUND);
    let Some(first) = (0..BEAMS).find(|&b| returns(b)) else { return BEAMS as u32 };
    let mut work = BEAMS as u32;
    let mut l = first;
    for k in 1..=BEAMS {
        let b = (first + k) % BEAMS;
        if !returns(b) {
            continue;
        }
        // Beams l+1 … b−1 (round the circle) have no return of their own.
        let span = (b + BEAMS - l) % BEAMS;
        if span > 1 && span < MAX_BOUND_SPAN {
            let (pl, pr) = (point(scan, l), point(scan, b));
            let mut i = (l + 1) % BEAMS;
            while i != b {
                work += 1;
                if scan.ranges_mm[i] != RANGE_INVALID {
                    out[i] = bound(pl, pr, i);
                }
                i = (i + 1) % BEAMS;
            }
        }
        l = b;
    }
    work
}

/// Beam `b`'s return point in the sensor's frame: millimetres scaled by 2³⁰.
fn point(scan: &BeamScan, b: usize) -> (i64, i64) {
    let a = beam_angle(b);
    let r = scan.ranges_mm[b] as i64;
    (r * cos(a).to_bits() as i64, r * sin(a).to_bits() as i64)
}

/// Where beam `b`'s ray from the sensor meets the segment `pl`–`pr`, less a cell, millimetres;
/// [`NO_BOUND`] if it does not meet it in front.
fn bound(pl: (i64, i64), pr: (i64, i64), b: usize) -> u16 {
    let a = beam_angle(b);
    let d = (cos(a).to_bits() as i128, sin(a).to_bits() as i128);
    let (plx, ply) = (pl.0 as i128, pl.1 as i128);
    let e = (pr.0 as i128 - plx, pr.1 as i128 - ply);
    // t·d − s·e = pl: t = (pl × e) / (d × e), s = (pl × d) / (d × e).
    let mut den = d.0 * e.1 - d.1 * e.0;
    let mut num_t = plx * e.1 - ply * e.0;
    let mut num_s = plx * d.1 - ply * d.0;
    if den == 0 {
        return NO_BOUND;
    }
    if den < 0 {
        (den, num_t, num_s) = (-den, -num_t, -num_s);
    }
    if num_t <= 0 || num_s < 0 || num_s > den {
        return NO_BOUND;
    }
    // num_t / den is in millimetres (both scaled by 2⁶⁰).
    let t = num_t / den - CELL_MM as i128;
    t.clamp(0, NO_BOUND as i128 - 1) as u16
}
