use super::*;
use crate::io::replay::TimedPose;
use firmware::Cell;

const N: i32 = 40;

/// A reference with a vertical wall at column `x` from row 10 to 29, seen from `(10.5, 20.5)`.
fn wall_reference(x: i32) -> Reference {
    let mut r = Reference::new(N, 3.0);
    for y in 10..30 {
        r.mark_cell(x, y);
    }
    r.viewpoints.push([10.5, 20.5]);
    r
}

fn grid_with_wall(x: i32) -> MapGrid {
    let mut g = MapGrid::new(N);
    for y in 10..30 {
        g.set(x, y, Cell::Occupied);
    }
    g
}

#[test]
fn near_offsets_are_the_13_cells_within_two_tenths() {
    let v = near_offsets();
    assert_eq!(v.len(), 13);
    assert!(v.contains(&(2, 0)) && v.contains(&(1, 1)) && v.contains(&(0, -2)));
    assert!(!v.contains(&(2, 1)), "√5 · 0.1 m = 0.224 m is beyond 0.2 m");
}

#[test]
fn a_wall_fully_recovered() {
    let s = score(&grid_with_wall(20), &wall_reference(20), 3.0, RAYS);
    assert_eq!((s.reference_wall_cells, s.recovered_cells, s.occupied_cells, s.phantom_cells), (20, 20, 20, 0));
    assert_eq!((s.walls_recovered, s.phantom_walls), (Some(1.0), Some(0.0)));
    // No free cells: no leak figure.
    assert_eq!((s.free_cells, s.free_space_leak), (0, None));
}

#[test]
fn a_wall_shifted_by_two_tenths_is_recovered_and_by_three_tenths_is_not() {
    // 0.2 m: every cell matches its neighbour two columns over.
    let s = score(&grid_with_wall(22), &wall_reference(20), 3.0, RAYS);
    assert_eq!((s.recovered_cells, s.phantom_cells), (20, 0));
    // 0.3 m: nothing matches; every reference cell lost, every grid cell a phantom.
    let s = score(&grid_with_wall(23), &wall_reference(20), 3.0, RAYS);
    assert_eq!((s.recovered_cells, s.phantom_cells), (0, 20));
    assert_eq!((s.walls_recovered, s.phantom_walls), (Some(0.0), Some(1.0)));
    // Half the grid's wall shifted: rows 10–19 at 0.3 m, rows 20–29 in place.
    let mut g = grid_with_wall(20);
    for y in 10..20 {
        g.set(20, y, Cell::Unknown);
        g.set(23, y, Cell::Occupied);
    }
    let s = score(&g, &wall_reference(20), 3.0, RAYS);
    // Reference cell (20, 19) has the grid's (20, 20) one cell above it, (20, 18) has it two
    // above: both recovered. Rows 10–17 have no occupied cell within 0.2 m (the nearest in
    // column 23 are 3 cells away): lost. 2 + 10 = 12 recovered.
    assert_eq!(s.recovered_cells, 12);
    // Grid cells (23, 10..20): nearest reference column is 3 cells away: all phantom.
    assert_eq!(s.phantom_cells, 10);
}

#[test]
fn free_space_behind_a_wall_leaks() {
    // The viewpoint at (10.5, 20.5) sees up to and including the wall at column 20, rows
    // 10–29; the wall is 20 cells long, so rays leaving above or below it go on.
    let reference = wall_reference(20);
    // Free cells in front of the wall: seen.
    let mut g = grid_with_wall(20);
    for x in 12..20 {
        g.set(x, 20, Cell::Free);
    }
    let s = score(&g, &reference, 3.0, RAYS);
    assert_eq!((s.free_cells, s.leak_cells), (8, 0));
    // Free cells straight behind the wall, at x = 21..=28, row 20: the nearest cell the
    // viewpoint sees is the wall cell (20, 20); x = 21 and 22 are within 0.2 m of it, the
    // six from 23 on are leaks.
    for x in 21..29 {
        g.set(x, 20, Cell::Free);
    }
    let s = score(&g, &reference, 3.0, RAYS);
    assert_eq!((s.free_cells, s.leak_cells), (16, 6));
    assert_eq!(s.free_space_leak, Some(6.0 / 16.0));
    // Without the wall in the reference the viewpoint sees them (all within 3 m = 30 cells):
    // no leak.
    let mut open = Reference::new(N, 3.0);
    open.viewpoints.push([10.5, 20.5]);
    assert_eq!(score(&g, &open, 3.0, RAYS).leak_cells, 0);
    // With a 1 m clearing range (10 cells) the rays see the cells within 10 cells of the
    // viewpoint: on row 20 up to column 20 (entered at t = 9.5; column 21's nearest point
    // is 10.5 cells away, as are those of its neighbours off the row). Free cells up to
    // column 22 lie within 0.2 m of (20, 20); columns 23..=28 leak.
    let s = score(&g, &open, 1.0, RAYS);
    assert_eq!(s.leak_cells, 6);
    // The same with the clearing range at 3 m and the viewpoint's scanner reaching 1 m (its
    // range_max): the nearer of the two.
    open.reach_m.push(1.0);
    assert_eq!(score(&g, &open, 3.0, RAYS).leak_cells, 6);
}

#[test]
fn a_floor_maps_wall_beyond_the_scanners_reach_is_not_counted_as_seen() {
    // A floor map's wall at column 20, 9.5 cells from the viewpoint: seen by a scanner that
    // reaches 3 m, not by one that reaches 0.5 m, whatever the clearing range.
    let mut r = wall_reference(20);
    r.seen_walls_only = true;
    let g = MapGrid::new(N);
    assert!(score(&g, &r, 3.0, RAYS).reference_wall_cells > 0);
    r.reach_m.push(0.5);
    assert_eq!(score(&g, &r, 3.0, RAYS).reference_wall_cells, 0);
}

#[test]
fn a_diagonal_wall_stops_rays() {
    // A 45° staircase wall of 8-connected cells; a viewpoint on one side, free cells on the
    // other, far from the wall: a ray cannot slip between two diagonal wall cells.
    let mut r = Reference::new(N, 3.0);
    for k in 0..N {
        r.mark_cell(k, k);
    }
    r.viewpoints.push([5.5, 30.5]);
    let mut g = MapGrid::new(N);
    g.set(30, 10, Cell::Free);
    g.set(31, 5, Cell::Free);
    let s = score(&g, &r, 5.0, RAYS);
    assert_eq!((s.free_cells, s.leak_cells), (2, 2));
}

#[test]
fn pose_algebra() {
    let a = [1.0, 2.0, 0.5];
    let b = [-0.3, 0.7, -1.2];
    let ab = compose(&a, &b);
    let back = compose(&inverse(&a), &ab);
    for k in 0..3 {
        assert!((back[k] - b[k]).abs() < 1e-12, "{back:?}");
    }
    assert_eq!(wrap(std::f64::consts::PI), std::f64::consts::PI);
    assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
}

fn timed(t: f64, pose: [f64; 3]) -> TimedPose {
    TimedPose { t_s: t, pose }
}

#[test]
fn relation_errors_on_a_hand_made_trajectory() {
    // The truth: 1 m forward, then a 90° left turn in place, then 1 m forward.
    // p0 = (0, 0, 0), p1 = (1, 0, 0), p2 = (1, 0, 90°), p3 = (1, 1, 90°).
    let q = std::f64::consts::FRAC_PI_2;
    let rels = [
        Relation { t1: 0.0, t2: 1.0, delta: [1.0, 0.0, 0.0] },
        Relation { t1: 1.0, t2: 2.0, delta: [0.0, 0.0, q] },
        Relation { t1: 2.0, t2: 3.0, delta: [1.0, 0.0, 0.0] },
        // A relation whose end has no pose: not used.
        Relation { t1: 3.0, t2: 4.0, delta: [1.0, 0.0, 0.0] },
    ];
    // A perfect estimate, in another frame (moved and turned): zero error.
    let moved = |p: [f64; 3]| compose(&[5.0, -3.0, 1.0], &p);
    let perfect: Vec<TimedPose> = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, q], [1.0, 1.0, q]]
        .iter()
        .enumerate()
        .map(|(i, p)| timed(i as f64, moved(*p)))
        .collect();
    let s = relation_errors(&PoseIndex::new(&perfect), &rels);
    assert_eq!(s.used, 3);
    assert!(s.trans_mean_m.unwrap() < 1e-12 && s.rot_mean_deg.unwrap() < 1e-9, "{s:?}");
    // An estimate that drives 1.2 m on the first leg and turns 100° instead of 90°:
    // relation 1: δ_est = (1.2, 0, 0): error 0.2 m, 0°;
    // relation 2: δ_est = (0, 0, 100°): error 0 m, 10°;
    // relation 3: from (1.2, 0, 100°) 1 m forward: δ_est = (1, 0, 0): no error.
    let ten = 10f64.to_radians();
    let p2 = [1.2, 0.0, q + ten];
    let est = [timed(0.0, [0.0, 0.0, 0.0]), timed(1.0, [1.2, 0.0, 0.0]), timed(2.0, p2), timed(3.0, compose(&p2, &[1.0, 0.0, 0.0]))];
    let s = relation_errors(&PoseIndex::new(&est), &rels);
    assert_eq!(s.used, 3);
    let close = |a: Option<f64>, b: f64| (a.unwrap() - b).abs() < 1e-9;
    // Translations 0.2, 0, 0: mean 0.2/3, population std √(Σ(x−m)²/3).
    let m: f64 = 0.2 / 3.0;
    let sd = (((0.2 - m) * (0.2 - m) + 2.0 * m * m) / 3.0).sqrt();
    assert!(close(s.trans_mean_m, m) && close(s.trans_std_m, sd), "{s:?}");
    // Rotations 0°, 10°, 0°.
    let m: f64 = 10.0 / 3.0;
    let sd = (((10.0 - m) * (10.0 - m) + 2.0 * m * m) / 3.0).sqrt();
    assert!(close(s.rot_mean_deg, m) && close(s.rot_std_deg, sd), "{s:?}");
    // Time stamps match within 1 ms, not beyond.
    let shifted: Vec<TimedPose> = est.iter().map(|p| timed(p.t_s + 0.0009, p.pose)).collect();
    assert_eq!(relation_errors(&PoseIndex::new(&shifted), &rels).used, 3);
    let shifted: Vec<TimedPose> = est.iter().map(|p| timed(p.t_s + 0.0011, p.pose)).collect();
    let s = relation_errors(&PoseIndex::new(&shifted), &rels);
    assert_eq!((s.used, s.trans_mean_m), (0, None));
}

#[test]
fn rigid_fit_recovers_a_known_transform() {
    let t = [3.0, -2.0, 0.7];
    let pts = [[0.0, 0.0, 0.1], [4.0, 1.0, 0.2], [-2.0, 5.0, 0.3], [1.0, -3.0, 0.0]];
    let pairs: Vec<([f64; 3], [f64; 3])> = pts.iter().map(|p| (*p, compose(&t, p))).collect();
    let (f, rms, max) = fit_rigid(&pairs).unwrap();
    for k in 0..3 {
        assert!((f[k] - t[k]).abs() < 1e-9, "{f:?}");
    }
    assert!(rms < 1e-9 && max < 1e-9);
    // One pair: the transform of its poses.
    let (f, _, _) = fit_rigid(&pairs[1..2]).unwrap();
    for k in 0..3 {
        assert!((f[k] - t[k]).abs() < 1e-9, "{f:?}");
    }
    // A point 1 m off among four: the residuals say so.
    let mut bad = pairs.clone();
    bad[0].1[0] += 1.0;
    let (_, rms, max) = fit_rigid(&bad).unwrap();
    assert!(rms > 0.3 && max > 0.5 && max < 1.0, "{rms} {max}");
    assert!(fit_rigid(&[]).is_none());
}

#[test]
fn bad_relation_and_pose_lines_name_the_file_and_line() {
    let dir = std::env::temp_dir().join(format!("lives-mapcheck-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rel = dir.join("bad.relations");
    std::fs::write(&rel, "# comment\n1 2 0.1 0 0 0 0 0.05\n\n1 2 0.1 0 0 0 0\n").unwrap();
    let e = read_relations(&rel).unwrap_err();
    assert_eq!(e, format!("{}:4: expected 8 numbers `t1 t2 x y z roll pitch yaw`, found 7 fields", rel.display()));
    std::fs::write(&rel, "1 2 0.1 0 0 0 0 nan\n").unwrap();
    assert_eq!(read_relations(&rel).unwrap_err(), format!("{}:1: yaw `nan` is not a finite number", rel.display()));
    std::fs::write(&rel, "# only a comment\n").unwrap();
    assert!(read_relations(&rel).unwrap_err().contains("no relations"));
    std::fs::write(&rel, "1 2 0.1 0 0 0 0 0.05\n").unwrap();
    assert_eq!(read_relations(&rel).unwrap(), [Relation { t1: 1.0, t2: 2.0, delta: [0.1, 0.0, 0.05] }]);
    let poses = dir.join("bad.txt");
    std::fs::write(&poses, "1.5 0 0 x0\n").unwrap();
    assert_eq!(read_poses(&poses).unwrap_err(), format!("{}:1: theta `x0` is not a finite number", poses.display()));
    let missing = dir.join("missing.txt");
    assert!(read_poses(&missing).unwrap_err().starts_with(&format!("{}: ", missing.display())));
    std::fs::remove_dir_all(&dir).unwrap();
}

fn scan_at(pose: [f64; 3], ranges: &[f32]) -> crate::io::replay::ScanRecord {
    crate::io::replay::ScanRecord {
        t_s: 0.0,
        pose,
        angle_min: 0.0,
        angle_increment: std::f64::consts::FRAC_PI_2,
        ranges_m: ranges.to_vec(),
        range_limits_m: [0.1, 2.5],
        at: crate::io::replay::Location::Line(1),
    }
}

#[test]
fn the_rays_own_map_follows_the_core_range_rule() {
    // At (1.05, 2.05) m: east a return at 1.0 m, north nothing within range_max (2.5 m), west
    // NaN, south below range_min. The grid's origin is (0, 0), cells of 0.1 m.
    let s = scan_at([1.05, 2.05, 0.0], &[1.0, f32::INFINITY, f32::NAN, 0.05]);
    let g = own_rays_map(N, &[&s], &[0.0, 0.0, 0.0], [0.0, 0.0], 0.1, 3.0).grid;
    // East: cells 10..=19 of row 20 free, the return's cell (20, 20) occupied.
    assert!((10..20).all(|x| g.get(x, 20) == Cell::Free));
    assert_eq!(g.get(20, 20), Cell::Occupied);
    assert_eq!(g.get(21, 20), Cell::Unknown);
    // North: free out to range_max, 2.5 m (row 45 is outside the 40-cell grid: up to 39).
    assert!((21..40).all(|y| g.get(10, y) == Cell::Free));
    // West and south: nothing.
    assert_eq!((g.get(9, 20), g.get(10, 19)), (Cell::Unknown, Cell::Unknown));
    assert_eq!(g.cells.iter().filter(|c| **c != Cell::Unknown).count(), 10 + 1 + 19);
    // A clearing range of 0.5 m: the return beyond it clears to it and marks nothing, and so
    // does nothing-within-range_max.
    let g = own_rays_map(N, &[&s], &[0.0, 0.0, 0.0], [0.0, 0.0], 0.1, 0.5).grid;
    assert_eq!(g.cells.iter().filter(|c| **c == Cell::Occupied).count(), 0);
    assert!((10..=15).all(|x| g.get(x, 20) == Cell::Free) && g.get(16, 20) == Cell::Unknown);
}

#[test]
fn a_beam_through_a_wall_another_scan_saw_is_the_datas_own_leak() {
    // A door 2 m wide at column 20: other scans saw it closed (returns on rows 10..=29), this
    // one sees it open (a return at 2.0 m east, the wall behind). From the viewpoint the closed
    // door hides the room behind it, so this beam's cells 21..=29 are free in the rays' own map
    // and, but for the two within 0.2 m of the door, leak: the floor the reference sets.
    let open = scan_at([1.05, 2.05, 0.0], &[2.0]);
    let mut reference = Reference::new(N, 3.0);
    project_scans(&mut reference, &[&open], &[0.0, 0.0, 0.0], [0.0, 0.0], 0.1, 3.0);
    for y in 10..30 {
        reference.mark_cell(20, y);
    }
    assert!(reference.is_wall(30, 20) && reference.viewpoints.len() == 1);
    let g = own_rays_map(N, &[&open], &[0.0, 0.0, 0.0], [0.0, 0.0], 0.1, 3.0).grid;
    assert_eq!((g.get(20, 20), g.get(29, 20), g.get(30, 20)), (Cell::Free, Cell::Free, Cell::Occupied));
    let s = score(&g, &reference, 3.0, RAYS);
    // Free: 10..=29 of row 20. Visible: up to the door (20), and within 0.2 m 21 and 22. Leaks:
    // 23..=29.
    assert_eq!((s.free_cells, s.leak_cells), (20, 7));
}

#[test]
fn the_rays_own_map_counts_the_scans_that_hit_and_that_crossed_a_cell() {
    // A door at (20, 20): closed in one scan (its return at 1.0 m), open in two (returns at
    // 2.0 m, the wall behind). One beam of each scan, one update per cell per scan.
    let closed = scan_at([1.05, 2.05, 0.0], &[1.0]);
    let open = scan_at([1.05, 2.05, 0.0], &[2.0]);
    let m = own_rays_map(N, &[&closed, &open, &open], &[0.0, 0.0, 0.0], [0.0, 0.0], 0.1, 3.0);
    let at = |x: usize, y: usize| (m.hit_scans[y * N as usize + x], m.crossed_scans[y * N as usize + x]);
    assert_eq!(at(20, 20), (1, 2), "the door: hit once, crossed twice (seen through)");
    assert_eq!(at(30, 20), (2, 0), "the wall behind it");
    assert_eq!(at(15, 20), (0, 3), "the floor before it");
    assert_eq!(at(25, 20), (0, 2));
    // Two beams of one scan (east and north, 1 m each) both leave the robot's cell (10, 20):
    // it counts once per scan; each beam's end is hit once per scan.
    let two = scan_at([1.05, 2.05, 0.0], &[1.0, 1.0]);
    let m = own_rays_map(N, &[&two, &two], &[0.0, 0.0, 0.0], [0.0, 0.0], 0.1, 3.0);
    let at = |x: usize, y: usize| (m.hit_scans[y * N as usize + x], m.crossed_scans[y * N as usize + x]);
    assert_eq!((at(10, 20), at(20, 20), at(10, 30)), ((0, 2), (2, 0), (2, 0)));
}
