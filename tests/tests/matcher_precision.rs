//! The scan matcher's own precision on a synthetic building (issue 27): a scanner that walks
//! through rooms with walls at arbitrary angles and positions (not on cell boundaries), ranges
//! with 1 cm noise; the map is drawn by the core's LiDAR grid at the TRUE poses, and each scan
//! is matched from the true pose (and from a pose off by 15 cm and 2°) before it is drawn. The
//! error of each match is the matcher's own: with perfect odometry, whatever it moves is noise,
//! and the moves compound on a real robot.

use firmware::capacity::BEAMS;
use firmware::grid::{beam_angle, GridGeometry};
use firmware::matcher::{Motion, ScanMatcher};
use firmware::{BeamScan, BinaryAngle, LidarGrid, Meters, Pose2};

type Seg = ([f64; 2], [f64; 2]);

/// A building: an outer wall turned 17°, inner walls and boxes at odd angles and positions.
fn building() -> Vec<Seg> {
    let (c, s) = (17f64.to_radians().cos(), 17f64.to_radians().sin());
    let rot = |p: [f64; 2]| [20.0 + c * p[0] - s * p[1], 20.0 + s * p[0] + c * p[1]];
    let mut polys: Vec<Vec<[f64; 2]>> = vec![
        vec![[-9.03, -5.47], [9.11, -5.47], [9.11, 5.52], [-9.03, 5.52]],
        vec![[-3.37, -1.21], [-2.16, -1.21], [-2.16, 0.43], [-3.37, 0.43]],
        vec![[3.02, 1.77], [4.55, 2.31], [4.13, 3.49], [2.60, 2.95]],
        vec![[0.13, -5.47], [0.13, -2.4]],
        vec![[-9.03, 2.04], [-5.9, 2.04]],
        vec![[5.5, -3.3], [7.2, -4.1], [7.9, -2.6]],
    ];
    let mut segs = Vec::new();
    for (i, p) in polys.iter_mut().enumerate() {
        let closed = i < 3;
        let m = if closed { p.len() } else { p.len() - 1 };
        for k in 0..m {
            segs.push((rot(p[k]), rot(p[(k + 1) % p.len()])));
        }
    }
    segs
}

/// Range along `(dx, dy)` from `o` to the nearest segment, if within `max`.
fn cast(segs: &[Seg], o: [f64; 2], d: [f64; 2], max: f64) -> Option<f64> {
    let mut best: Option<f64> = None;
    for (a, b) in segs {
        let e = [b[0] - a[0], b[1] - a[1]];
        let den = d[0] * e[1] - d[1] * e[0];
        if den.abs() < 1e-12 {
            continue;
        }
        let w = [a[0] - o[0], a[1] - o[1]];
        let t = (w[0] * e[1] - w[1] * e[0]) / den;
        let u = (w[0] * d[1] - w[1] * d[0]) / den;
        if t > 0.05 && (0.0..=1.0).contains(&u) && t < max && best.is_none_or(|b| t < b) {
            best = Some(t);
        }
    }
    best
}

/// A deterministic uniform number in [-1, 1).
fn noise(k: &mut u64) -> f64 {
    *k = k.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((*k >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn pose(x: f64, y: f64, th: f64) -> Pose2 {
    Pose2::new(Meters::from_num(x), Meters::from_num(y), BinaryAngle::from_radians(th).unwrap())
}

fn scan_at(segs: &[Seg], p: [f64; 3], k: &mut u64) -> BeamScan {
    let mut s = BeamScan::new();
    for b in 0..BEAMS {
        let a = p[2] + beam_angle(b).0 as f64 / 4294967296.0 * std::f64::consts::TAU;
        // 1 cm noise (uniform over ±1.7 cm).
        s.ranges_mm[b] = match cast(segs, [p[0], p[1]], [a.cos(), a.sin()], 12.0) {
            Some(r) => ((r + 0.017 * noise(k)) * 1000.0).round() as u16,
            None => firmware::scan::RANGE_NO_RETURN,
        };
    }
    s
}

/// Errors (mm, degrees) of every match along the walk, for the field matcher or the hill-climbing one, from the truth offset by
/// `off` (m, m, rad).
fn walk(field: bool, off: [f64; 3]) -> (Vec<f64>, Vec<f64>) {
    let segs = building();
    let geom = GridGeometry { origin_x: Meters::ZERO, origin_y: Meters::ZERO };
    let mut grid = Box::new(LidarGrid::new(geom));
    let mut m = ScanMatcher::new();
    m.field = field;
    let mut k = 7u64;
    let (mut et, mut er) = (Vec::new(), Vec::new());
    let range = Meters::from_num(12);
    // A loop around the middle of the building, a scan every ~0.3 m.
    let (c, s) = (17f64.to_radians().cos(), 17f64.to_radians().sin());
    for i in 0..120 {
        let t = i as f64 / 120.0 * std::f64::consts::TAU;
        let (lx, ly) = (6.0 * t.cos(), 3.6 * t.sin());
        let (x, y) = (20.0 + c * lx - s * ly, 20.0 + s * lx + c * ly);
        let th = t + std::f64::consts::FRAC_PI_2 + 17f64.to_radians() + 0.1 * (3.0 * t).sin();
        let truth = [x, y, th];
        let scan = scan_at(&segs, truth, &mut k);
        if i >= 3 {
            let pred = pose(x + off[0], y + off[1], th + off[2]);
            let motion = Motion { dist_mm: 300, turn_mdeg: 5_000 };
            if let Ok(got) = m.match_scan(&*grid, &geom, &pred, &scan, range, motion) {
                let gx = got.pose.x.to_num::<f64>() - x;
                let gy = got.pose.y.to_num::<f64>() - y;
                let gr = (got.pose.theta - BinaryAngle::from_radians(th).unwrap()).0 as f64 / 4294967296.0 * 360.0;
                et.push(gx.hypot(gy) * 1000.0);
                er.push(gr.abs());
            }
        }
        grid.integrate(&pose(x, y, th), &scan, range);
    }
    (et, er)
}

fn stats(v: &[f64]) -> (f64, f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let mean = s.iter().sum::<f64>() / s.len() as f64;
    (mean, s[s.len() / 2], s[s.len() * 95 / 100])
}

#[test]
fn the_field_matcher_recovers_a_heading_error_the_hill_climbing_one_keeps() {
    let mut figures = Vec::new();
    for (name, field) in [("hill-climbing", false), ("field", true)] {
        for off in [[0.0, 0.0, 0.0], [0.05, -0.03, 2f64.to_radians()]] {
            let (et, er) = walk(field, off);
            let (t, r) = (stats(&et), stats(&er));
            eprintln!(
                "{name:>14} from {off:?}: {} matches; error mean {:.1} mm (median {:.1}, p95 {:.1}), {:.3}° (median {:.3}, p95 {:.3})",
                et.len(),
                t.0,
                t.1,
                t.2,
                r.0,
                r.1,
                r.2
            );
            assert_eq!(et.len(), 117, "every scan after the first 3 is matched");
            figures.push((t, r));
        }
    }
    let [(_, _), (_, hill_off_r), (field_t, field_r), (field_off_t, field_off_r)] = figures[..] else { unreachable!() };
    // Measured: from the true pose the field matcher errs by 4.3 mm and 0.050° (median; 7.0 mm,
    // 0.073° mean), the hill-climbing one by 6.2 mm and 0.031°.
    assert!(field_t.1 < 6.0 && field_t.0 < 10.0 && field_r.1 < 0.08, "{field_t:?} {field_r:?}");
    // From a prediction 2° and 58 mm off (a real odometry's heading error over a step, as on raw
    // CSAIL): the field matcher recovers the heading to 0.085° (mean; 14 mm, its translation
    // prior keeps a quarter of the offset); the hill-climbing matcher's motion prior keeps
    // 1.2° of the 2°.
    assert!(field_off_r.0 < 0.15 && field_off_t.1 < 20.0, "{field_off_t:?} {field_off_r:?}");
    assert!(hill_off_r.0 > 1.0, "{hill_off_r:?}");
}
