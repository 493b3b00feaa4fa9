//! Tests of the parent module (`geometry.rs`).

use super::*;

#[test]
fn raycast_finds_nearest_wall_and_ignores_owner() {
    let mut b = SceneBuilder::new();
    b.wall([2.0, -1.0], [2.0, 1.0]);
    b.wall([5.0, -1.0], [5.0, 1.0]);
    b.shape(&Shape::Circle { center: [1.0, 0.0], radius: 0.2 }, HitKind::Clutter, 0);
    let s = b.build(0.5);
    let h = s.raycast([0.0, 0.0], [1.0, 0.0], 30.0, NO_OWNER).unwrap();
    assert!((h.t - 0.8).abs() < 1e-12);
    assert_eq!(h.kind, HitKind::Clutter);
    let h = s.raycast([0.0, 0.0], [1.0, 0.0], 30.0, 0).unwrap();
    assert!((h.t - 2.0).abs() < 1e-12);
    assert_eq!(h.kind, HitKind::Wall);
    assert!(s.raycast([0.0, 0.0], [-1.0, 0.0], 30.0, NO_OWNER).is_none());
    assert!(s.raycast([0.0, 0.0], [1.0, 0.0], 0.5, NO_OWNER).is_none());
}

#[test]
fn raycast_matches_brute_force() {
    let mut b = SceneBuilder::new();
    let mut segs = Vec::new();
    for i in 0..40 {
        let a = [(i * 7 % 13) as f64 * 0.77, (i * 5 % 11) as f64 * 0.91];
        let c = [a[0] + ((i % 5) as f64 - 2.0) * 0.6, a[1] + ((i % 3) as f64 - 1.0) * 0.8];
        b.wall(a, c);
        segs.push((a, c));
    }
    let s = b.build(0.5);
    for k in 0..360 {
        let ang = k as f64 * 0.01745 + 0.003;
        let d = [ang.cos(), ang.sin()];
        let o = [4.1, 4.3];
        let brute = segs.iter().filter_map(|&(a, c)| ray_segment(o, d, a, c)).fold(f64::INFINITY, f64::min);
        let got = s.raycast(o, d, 100.0, NO_OWNER).map(|h| h.t).unwrap_or(f64::INFINITY);
        assert_eq!(got, brute, "angle {ang}");
    }
}

#[test]
fn disc_collision_with_solids() {
    let mut b = SceneBuilder::new();
    let rect = Shape::Rect { center: [0.0, 0.0], size: [2.0, 1.0], yaw: 0.0 };
    b.shape(&rect, HitKind::Furniture, 0);
    let s = b.build(0.5);
    assert!(s.disc_collides([0.0, 0.0], 0.1)); // inside
    assert!(s.disc_collides([1.25, 0.0], 0.3)); // touching the edge
    assert!(!s.disc_collides([1.35, 0.0], 0.3));
}

#[test]
fn outline_samples_lie_on_outline() {
    let r = Shape::Rect { center: [1.0, 2.0], size: [0.5, 0.35], yaw: 0.7 };
    let pts = r.outline_samples(24);
    assert_eq!(pts.len(), 24);
    for p in pts {
        let v = r.vertices().unwrap();
        let d = (0..4).map(|i| point_segment_distance(p, v[i], v[(i + 1) % 4])).fold(f64::INFINITY, f64::min);
        assert!(d < 1e-9);
    }
}

#[test]
fn shape_distance_sees_containment() {
    let big = Shape::Rect { center: [0.0, 0.0], size: [2.0, 2.0], yaw: 0.3 };
    let small = Shape::Rect { center: [0.1, 0.0], size: [0.5, 0.35], yaw: 0.0 };
    assert_eq!(small.shape_distance(&big), 0.0);
    assert_eq!(big.shape_distance(&small), 0.0);
    let far = Shape::Polygon { points: vec![[3.0, 0.0], [4.0, 0.0], [3.5, 1.0]] };
    assert!((far.shape_distance(&small) - 2.65).abs() < 1e-9);
    let c = Shape::Circle { center: [0.0, 0.0], radius: 0.1 };
    assert_eq!(c.shape_distance(&big), 0.0);
    assert_eq!(big.shape_distance(&c), 0.0);
}

#[test]
fn huge_or_broken_geometry_does_not_explode() {
    let mut b = SceneBuilder::new();
    b.wall([0.0, 0.0], [1e9, 0.0]);
    b.wall([f64::NAN, 0.0], [1.0, f64::INFINITY]);
    b.shape(&Shape::Circle { center: [5.0, 5.0], radius: 1.0 }, HitKind::Clutter, 0);
    let s = b.build(0.5);
    assert!(s.nx <= MAX_GRID_CELLS + 2 && s.ny <= MAX_GRID_CELLS + 2);
    let h = s.raycast([5.0, 2.0], [0.0, 1.0], 100.0, NO_OWNER).unwrap();
    assert!((h.t - 2.0).abs() < 1e-9);
    assert!(s.disc_collides([5.0, 0.1], 0.3));
}

#[test]
fn wrap_angle_range() {
    use std::f64::consts::PI;
    for k in -20..20 {
        let a = wrap_angle(k as f64 * 0.9);
        assert!(a > -PI && a <= PI);
    }
    assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
}
