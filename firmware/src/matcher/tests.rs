//! The scan matcher's tests: offsets recovered, no structure no correction, bounded work.

use super::*;
use crate::capacity::GRID_CELLS;
use crate::grid::Line;

extern crate std;
use std::vec::Vec;

/// A grid of occupied cells set by hand.
struct Room {
    occ: Vec<bool>,
}

impl Occupancy for Room {
    fn occupied(&self, x: i32, y: i32) -> bool {
        let n = GRID_CELLS as i32;
        (0..n).contains(&x) && (0..n).contains(&y) && self.occ[(y * n + x) as usize]
    }
}

impl Room {
    fn set(&mut self, x: i32, y: i32) {
        self.occ[(y * GRID_CELLS as i32 + x) as usize] = true;
    }
}

fn geom() -> GridGeometry {
    GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO }
}

/// Millimetres as metres.
fn mm(v: i64) -> Meters {
    Meters::from_bits(((v << 16) / 1000) as i32)
}

/// A pose from millimetres and tenths of a degree.
fn pose(x_mm: i64, y_mm: i64, deci_deg: i64) -> Pose2 {
    Pose2::new(mm(x_mm), mm(y_mm), BinaryAngle::from_fraction(deci_deg, 3600))
}

/// `got` is within `tol` of `want` in x and y, and `deg_tenths` tenths of a degree in θ.
fn near(got: &Pose2, want: &Pose2, tol: Meters, deg_tenths: i64) -> bool {
    (got.x - want.x).abs() <= tol
        && (got.y - want.y).abs() <= tol
        && (got.theta - want.theta).unsigned_abs() <= BinaryAngle::from_fraction(deg_tenths, 3600).0 as u32
}

/// An empty grid.
fn empty() -> Room {
    Room { occ: std::vec![false; GRID_CELLS * GRID_CELLS] }
}

/// An 8 m × 6 m room with its corner at (10, 10), a 1 m × 0.5 m pillar inside and a 1.5 m
/// wall stub: enough structure to fix x, y and θ.
fn room() -> Room {
    let mut r = empty();
    let mut wall = |x0: i32, y0: i32, x1: i32, y1: i32| {
        for (x, y) in Line::new(x0, y0, x1, y1) {
            r.set(x, y);
        }
    };
    wall(100, 100, 180, 100);
    wall(180, 100, 180, 160);
    wall(180, 160, 100, 160);
    wall(100, 160, 100, 100);
    for y in 130..135 {
        wall(150, y, 160, y);
    }
    wall(120, 100, 120, 115);
    r
}

/// A 2 m-wide corridor along x, 40 m long: nothing fixes x.
fn corridor() -> Room {
    let mut r = empty();
    for x in 50..450 {
        r.set(x, 100);
        r.set(x, 120);
    }
    r
}

/// The scan a sensor at `pose` sees in `room`: each beam of the core's grid marched in
/// 1 cm steps until it enters an occupied cell (at most 10 m), as millimetres.
fn cast(room: &Room, pose: &Pose2) -> BeamScan {
    let g = geom();
    let mut s = BeamScan::new();
    for b in 0..BEAMS {
        let a = pose.theta + beam_angle(b);
        let mut hit = None;
        for step in 1..1000i64 {
            let (cx, cy) = g.cell_of(pose.x + mul_unit(mm(10 * step), cos(a)), pose.y + mul_unit(mm(10 * step), sin(a)));
            if room.occupied(cx, cy) {
                hit = Some(10 * step);
                break;
            }
        }
        s.ranges_mm[b] = hit.map_or(RANGE_NO_RETURN, |d| d as u16);
    }
    s
}

#[test]
fn recovers_a_pose_offset_by_20_cm_and_3_degrees() {
    let r = room();
    let truth = pose(13_000, 12_500, 200);
    let scan = cast(&r, &truth);
    let range = mm(10_000);
    let mut mm_ = ScanMatcher::new();
    for (ox, oy, odeg) in [(200, 0, 30), (0, -200, -30), (140, 140, 30), (-200, 100, -20)] {
        let predicted = pose(13_000 + ox, 12_500 + oy, 200 + odeg);
        let got = mm_.match_scan(&r, &geom(), &predicted, &scan, range, Motion::UNKNOWN).unwrap();
        // Within a cell (0.1 m) and 1°.
        assert!(near(&got.pose, &truth, mm(100), 10), "offset ({ox} mm, {oy} mm, {odeg}/10°): {got:?}");
        assert!(got.score_per_mille >= 800, "{got:?}");
        assert!(mm_.stats.last_work <= MATCH_WORST_CASE_WORK && mm_.stats.last_work > 0);
    }
    // At the true pose it stays within half a cell and an eighth of a degree.
    let got = mm_.match_scan(&r, &geom(), &truth, &scan, range, Motion::UNKNOWN).unwrap();
    assert!(near(&got.pose, &truth, mm(50), 2), "{got:?}");
    assert_eq!(mm_.stats.matched, 5);
    // The same inputs give the same bits.
    let again = ScanMatcher::new().match_scan(&r, &geom(), &pose(13_200, 12_500, 230), &scan, range, Motion::UNKNOWN).unwrap();
    let first = ScanMatcher::new().match_scan(&r, &geom(), &pose(13_200, 12_500, 230), &scan, range, Motion::UNKNOWN).unwrap();
    assert_eq!(again, first);
}

#[test]
fn the_field_refinement_recovers_offsets_below_a_cell() {
    let r = room();
    let truth = pose(13_030, 12_470, 200);
    let scan = cast(&r, &truth);
    let range = mm(10_000);
    let mut m = ScanMatcher::new();
    m.field = true;
    let motion = Motion { dist_mm: 300, turn_mdeg: 5_000 };
    for (ox, oy, odeg) in [(0, 0, 0), (60, 0, 20), (0, -60, -20), (40, 40, 30), (-70, 30, -15)] {
        let predicted = pose(13_030 + ox, 12_470 + oy, 200 + odeg);
        let got = m.match_scan(&r, &geom(), &predicted, &scan, range, motion).unwrap();
        // Within 25 mm and 0.2°, from up to 76 mm and 3° off.
        assert!(near(&got.pose, &truth, mm(25), 2), "offset ({ox} mm, {oy} mm, {odeg}/10°): {got:?}");
        assert!(m.stats.last_work > 0 && m.stats.last_work <= MATCH_WORST_CASE_WORK);
    }
    let again = m.clone().match_scan(&r, &geom(), &pose(13_100, 12_470, 230), &scan, range, motion).unwrap();
    assert_eq!(again, m.match_scan(&r, &geom(), &pose(13_100, 12_470, 230), &scan, range, motion).unwrap());
}

#[test]
fn no_structure_no_correction() {
    let range = mm(10_000);
    // An empty map: the scan (cast in a room) scores nothing anywhere; refused.
    let r = room();
    let at = pose(13_000, 12_500, 0);
    let scan = cast(&r, &at);
    let mut m = ScanMatcher::new();
    assert_eq!(m.match_scan(&empty(), &geom(), &at, &scan, range, Motion::UNKNOWN), Err(MatchRefusal::LowScore(0)));
    assert_eq!(m.stats.low_score, 1);
    // Too few returns: refused before any work.
    let mut sparse = BeamScan::new();
    for b in (0..BEAMS).step_by(40) {
        sparse.ranges_mm[b] = 2000;
    }
    assert_eq!(m.match_scan(&r, &geom(), &at, &sparse, range, Motion::UNKNOWN), Err(MatchRefusal::TooFewPoints(23)));
    assert_eq!((m.stats.last_work, m.stats.too_few_points), (0, 1));
    // A corridor along x: the walls fix y and θ; x is free, so the prediction's x stands.
    let c = corridor();
    let truth = pose(25_000, 11_000, 0);
    let scan = cast(&c, &truth);
    for ox in [-200, 0, 200] {
        let predicted = pose(25_000 + ox, 11_150, 20);
        let got = m.match_scan(&c, &geom(), &predicted, &scan, range, Motion::UNKNOWN).unwrap();
        assert_eq!(got.pose.x, predicted.x, "x moved along the corridor: {got:?}");
        assert!(near(&got.pose, &pose(25_000 + ox, 11_000, 0), mm(100), 10), "{got:?}");
    }
}

#[test]
fn worst_case_work_is_bounded() {
    assert_eq!(MATCH_WORST_CASE_WORK, MATCH_MAX_POINTS as u32 * (25 * 49 + 26 + 1 + 26 * 4));
    // A full scan of close returns: the points are capped.
    let r = room();
    let mut full = BeamScan::new();
    full.ranges_mm = [1500; BEAMS];
    let mut m = ScanMatcher::new();
    let _ = m.match_scan(&r, &geom(), &pose(13_000, 12_500, 0), &full, mm(10_000), Motion::UNKNOWN);
    assert_eq!(m.n, MATCH_MAX_POINTS);
    assert_eq!(m.stats.last_work, MATCH_WORST_CASE_WORK);
    // The field matcher: at most the coarse search and FIELD_MAX_EVALS evaluations.
    m.field = true;
    let _ = m.match_scan(&r, &geom(), &pose(13_000, 12_500, 0), &full, mm(10_000), Motion::UNKNOWN);
    assert!(m.stats.last_work <= FIELD_WORST_CASE_WORK && m.stats.last_work > MATCH_MAX_POINTS as u32 * 25 * 49, "{:?}", m.stats);
}

/// A deterministic xorshift for the property tests below.
fn xorshift(s: &mut u64) -> u64 {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    *s
}

#[test]
fn the_window_scores_are_the_sums_of_each_translation_scored_on_its_own() {
    // A random map with a third of the cells occupied near the grid's edges and corners too,
    // both through the default row read (`Room`) and the packed grid's (`LidarGrid`).
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut r = empty();
    let mut lidar = LidarGrid::new(geom());
    let n = GRID_CELLS as i32;
    for y in (0..12).chain(n / 2 - 6..n / 2 + 6).chain(n - 12..n) {
        for x in (0..12).chain(n / 2 - 6..n / 2 + 6).chain(n - 12..n) {
            if xorshift(&mut s).is_multiple_of(3) {
                r.set(x, y);
                lidar.grid.set(x, y, Cell::Occupied);
            } else if xorshift(&mut s).is_multiple_of(2) {
                lidar.grid.set(x, y, Cell::Free);
            }
        }
    }
    let mut cells = Vec::new();
    for _ in 0..MATCH_MAX_POINTS {
        let pick = |v: u64| -> i32 {
            match v % 4 {
                0 => (v / 4 % 16) as i32 - 4,
                1 => n / 2 - 8 + (v / 4 % 16) as i32,
                2 => n - 12 + (v / 4 % 16) as i32,
                _ => [i32::MIN, i32::MAX, -100_000, 100_000][(v / 4 % 4) as usize],
            }
        };
        cells.push((pick(xorshift(&mut s)), pick(xorshift(&mut s))));
    }
    let naive = |map: &dyn Fn(i32, i32) -> bool, dx: i32, dy: i32| -> u32 {
        cells
            .iter()
            .map(|&(cx, cy)| {
                let (x, y) = (cx.saturating_add(dx), cy.saturating_add(dy));
                let occ = |x: i64, y: i64| i32::try_from(x).ok().zip(i32::try_from(y).ok()).is_some_and(|(x, y)| map(x, y));
                let (x, y) = (x as i64, y as i64);
                if occ(x, y) {
                    HIT_SCORE
                } else if occ(x + 1, y) || occ(x - 1, y) || occ(x, y + 1) || occ(x, y - 1) {
                    NEAR_SCORE
                } else {
                    0
                }
            })
            .sum()
    };
    let from_room = window_scores(&r, &cells);
    let from_grid = window_scores(&lidar, &cells);
    let w = MATCH_WINDOW_CELLS;
    let mut total = 0;
    for dy in -w..=w {
        for dx in -w..=w {
            let want = naive(&|x, y| r.occupied(x, y), dx, dy);
            assert_eq!(from_room[(dy + w) as usize][(dx + w) as usize], want, "shift ({dx}, {dy})");
            assert_eq!(from_grid[(dy + w) as usize][(dx + w) as usize], want, "shift ({dx}, {dy}), packed grid");
            total += want;
        }
    }
    assert!(total > 1000, "the map and the cells overlap: {total}");
}

#[test]
fn a_packed_row_read_agrees_with_reading_each_cell() {
    let mut s = 7u64;
    let mut lidar = LidarGrid::new(geom());
    let n = GRID_CELLS as i32;
    for y in [0, 1, n / 2, n - 2, n - 1] {
        for x in 0..n {
            let c = [Cell::Unknown, Cell::Free, Cell::Occupied][(xorshift(&mut s) % 3) as usize];
            lidar.grid.set(x, y, c);
        }
    }
    for y in [-1, 0, 1, n / 2, n - 2, n - 1, n] {
        for x in (-12..20).chain(n / 2 - 10..n / 2 + 10).chain(n - 14..n + 2) {
            let want = (0..SPAN as i32).filter(|&k| lidar.occupied(x + k, y)).fold(0u32, |m, k| m | 1 << (2 * k));
            assert_eq!(lidar.occupied_span(x, y), want, "row at ({x}, {y})");
        }
    }
}
