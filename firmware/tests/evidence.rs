//! The LiDAR grid's occupancy evidence (issue 27): walls survive the rays that graze or miss them,
//! do not thicken where their face meets a cell boundary, a person who walks away leaves free cells
//! within a few scans, and "no return" clears only out to the scan's `range_max`, never through a
//! wall.

mod common;
use common::*;
use firmware::grid::{Cell, GridGeometry, LidarGrid, EVIDENCE_MAX, EVIDENCE_MIN_OCCUPIED, EVIDENCE_MISS};
use firmware::scan::{BeamScan, RANGE_INVALID, RANGE_NO_RETURN};
use firmware::{Config, ScanInput};

const BEAMS: usize = firmware::capacity::BEAMS;

fn geom() -> GridGeometry {
    GridGeometry { origin_x: Config::mm(0), origin_y: Config::mm(0) }
}

/// A full scan on the core's beam grid from `ranges(angle_rad)` (None: invalid beam), with the
/// given `range_max_mm`.
fn scan(range_max_mm: u16, ranges: impl Fn(f64) -> Option<u16>) -> BeamScan {
    let r: Vec<u16> = (0..BEAMS)
        .map(|b| {
            let a = -std::f64::consts::PI + b as f64 * std::f64::consts::TAU / BEAMS as f64;
            ranges(a).unwrap_or(RANGE_INVALID)
        })
        .collect();
    let mut s = BeamScan::new();
    s.resample(&ScanInput { range_max_mm, ..scan_input(&r, None) }).unwrap();
    s
}

/// Range to a wall whose face is the plane `x = face_x` seen from `x0`, for a beam at `a`.
fn to_plane(x0: f64, face_x: f64, a: f64) -> Option<f64> {
    (a.cos() > 0.2).then(|| (face_x - x0) / a.cos())
}

#[test]
fn a_wall_face_on_a_cell_boundary_stays_one_cell_thick() {
    // The face at x = 13.0 m, exactly between cells 129 and 130; ±10 mm of range noise, so about
    // half the returns measure a face in front of the boundary.
    let mut g = Box::new(LidarGrid::new(geom()));
    let p = pose(10.05, 10.05, 0.0);
    for k in 0..40u32 {
        let s = scan(30_000, |a| {
            let noise = ((k as i64 * 7 + (a * 1000.0) as i64 * 13).rem_euclid(21) - 10) as f64 / 1000.0;
            to_plane(10.05, 13.0, a).filter(|&r| r < 6.0).map(|r| ((r + noise) * 1000.0).round() as u16)
        });
        g.integrate(&p, &s, Config::DEFAULT.lidar_max_range_m);
    }
    for y in 95..=105 {
        assert_eq!(g.get(130, y), Cell::Occupied, "the wall's own cell (130, {y})");
        assert_eq!(g.get(129, y), Cell::Free, "the cell in front of the face (129, {y}) stays free");
    }
}

#[test]
fn a_person_who_walks_away_leaves_free_cells_within_a_few_scans_and_a_wall_survives_a_miss() {
    let mut g = Box::new(LidarGrid::new(geom()));
    let p = pose(10.05, 10.05, 0.0);
    // A person 2 m ahead (their near side at 12.0 m) stands for 20 scans, with a wall at 15 m
    // beside them; then they walk away and the beams reach the wall at 15 m behind them.
    let person = |a: f64| a.abs() < 0.05;
    let standing = |a: f64| {
        if person(a) { to_plane(10.05, 12.0, a) } else { to_plane(10.05, 15.0, a).filter(|&r| r < 8.0) }
            .map(|r| (r * 1000.0).round() as u16)
    };
    for _ in 0..20 {
        g.integrate(&p, &scan(30_000, standing), Config::DEFAULT.lidar_max_range_m);
    }
    assert_eq!(g.get(120, 100), Cell::Occupied);
    assert_eq!(g.evidence.get(120, 100), Some(EVIDENCE_MAX));
    let gone = |a: f64| to_plane(10.05, 15.0, a).filter(|&r| r < 8.0).map(|r| (r * 1000.0).round() as u16);
    let scans_to_free = (EVIDENCE_MAX - EVIDENCE_MIN_OCCUPIED) / -EVIDENCE_MISS + 1;
    for k in 1..=scans_to_free {
        g.integrate(&p, &scan(30_000, gone), Config::DEFAULT.lidar_max_range_m);
        let want = if k < scans_to_free { Cell::Occupied } else { Cell::Free };
        assert_eq!(g.get(120, 100), want, "after {k} scans without the person");
    }
    assert_eq!(scans_to_free, 6, "a few scans: 1.2 s at 5 Hz");
    assert_eq!(g.get(150, 100), Cell::Occupied, "the wall behind them");
}

#[test]
fn one_update_per_cell_per_scan() {
    let mut g = Box::new(LidarGrid::new(geom()));
    let p = pose(10.05, 10.05, 0.0);
    // Every beam returns at 3 m: the cells next to the robot lie on many rays of the scan, yet
    // take one miss, and each hit cell one hit.
    let st = g.integrate(&p, &scan(30_000, |_| Some(3000)), Config::DEFAULT.lidar_max_range_m);
    assert_eq!(g.evidence.get(101, 100), Some(EVIDENCE_MISS));
    assert_eq!(g.evidence.get(100, 101), Some(EVIDENCE_MISS));
    assert!(st.hits > 100 && st.hits as usize <= BEAMS, "{st:?}");
    assert_eq!(st.misses + st.hits, g.grid.count(Cell::Free) + g.grid.count(Cell::Occupied));
}

#[test]
fn no_return_clears_only_to_range_max_and_never_through_a_wall() {
    let mut g = Box::new(LidarGrid::new(geom()));
    let p = pose(25.05, 25.05, 0.0);
    // First a wall at 2 m east (face at 27.05 m: cell 270) is seen.
    let east = |a: f64| to_plane(25.05, 27.05, a).filter(|&r| r < 2.2).map(|r| (r * 1000.0).round() as u16);
    for _ in 0..3 {
        g.integrate(&p, &scan(12_000, east), Config::DEFAULT.lidar_max_range_m);
    }
    assert_eq!(g.get(270, 250), Cell::Occupied);
    // Then every beam says "nothing within 12 m" (+inf, or a reading at range_max).
    let s = scan(12_000, |a| Some(if a.sin() > 0.0 { RANGE_NO_RETURN } else { 12_000 }));
    g.integrate(&p, &s, Config::DEFAULT.lidar_max_range_m);
    assert_eq!(g.get(270, 250), Cell::Occupied, "the wall stands");
    assert_eq!(g.get(271, 250), Cell::Unknown, "nothing cleared behind it");
    // West: cleared to 12 m (cell 250 − 120 = 130), not to the clearing range of 30 m.
    assert_eq!(g.get(131, 250), Cell::Free);
    assert_eq!(g.get(129, 250), Cell::Unknown, "beyond range_max");
    // North: +inf clears to 12 m as well.
    assert_eq!(g.get(250, 369), Cell::Free);
    assert_eq!(g.get(250, 371), Cell::Unknown);
    // A clearing range below range_max bounds it instead (Nav2's raytrace range).
    let mut g2 = Box::new(LidarGrid::new(geom()));
    g2.integrate(&p, &s, Config::mm(5_000));
    assert_eq!(g2.get(250 - 49, 250), Cell::Free);
    assert_eq!(g2.get(250 - 51, 250), Cell::Unknown);
}
