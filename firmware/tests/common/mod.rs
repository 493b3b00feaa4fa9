//! Test fixtures: a tiny box world with an exact ray caster, and helpers to build scans.
#![allow(dead_code)]

use firmware::scan::{BeamLabel, ScanInput, RANGE_NO_RETURN};
use firmware::{BinaryAngle, Config, Controller, Pose2};

/// An axis-aligned box `[x0, y0, x1, y1]` in metres and whether it is a wall (map) or not.
#[derive(Clone, Copy)]
pub struct Box2 {
    pub min: [f64; 2],
    pub max: [f64; 2],
    pub wall: bool,
}

pub fn wall(x0: f64, y0: f64, x1: f64, y1: f64) -> Box2 {
    Box2 { min: [x0.min(x1), y0.min(y1)], max: [x0.max(x1), y0.max(y1)], wall: true }
}
pub fn thing(x0: f64, y0: f64, x1: f64, y1: f64) -> Box2 {
    Box2 { wall: false, ..wall(x0, y0, x1, y1) }
}

/// Slab-method ray cast; returns (range, is_wall) of the nearest hit within `max`.
pub fn cast(boxes: &[Box2], o: [f64; 2], a: f64, max: f64) -> Option<(f64, bool)> {
    let d = [a.cos(), a.sin()];
    let mut best: Option<(f64, bool)> = None;
    for b in boxes {
        let (mut t0, mut t1) = (0.0f64, max);
        let mut hit = true;
        for k in 0..2 {
            if d[k].abs() < 1e-12 {
                if o[k] < b.min[k] || o[k] > b.max[k] {
                    hit = false;
                }
            } else {
                let (mut ta, mut tb) = ((b.min[k] - o[k]) / d[k], (b.max[k] - o[k]) / d[k]);
                if ta > tb {
                    std::mem::swap(&mut ta, &mut tb);
                }
                t0 = t0.max(ta);
                t1 = t1.min(tb);
            }
        }
        if hit && t0 <= t1 && t0 > 0.0 && best.is_none_or(|(r, _)| t0 < r) {
            best = Some((t0, b.wall));
        }
    }
    best
}

/// A 360-beam scan of `boxes` from `pose` (x, y, yaw), with ground-truth labels.
pub fn scan_of(boxes: &[Box2], pose: (f64, f64, f64), beams: usize) -> (Vec<u16>, Vec<BeamLabel>) {
    let mut ranges = Vec::with_capacity(beams);
    let mut labels = Vec::with_capacity(beams);
    for i in 0..beams {
        let a = -std::f64::consts::PI + i as f64 * std::f64::consts::TAU / beams as f64 + pose.2;
        match cast(boxes, [pose.0, pose.1], a, 30.0) {
            Some((r, w)) => {
                ranges.push((r * 1000.0).round() as u16);
                labels.push(if w { BeamLabel::Map } else { BeamLabel::NonMap });
            }
            None => {
                ranges.push(RANGE_NO_RETURN);
                labels.push(BeamLabel::Unlabelled);
            }
        }
    }
    (ranges, labels)
}

pub fn scan_input<'a>(ranges: &'a [u16], labels: Option<&'a [BeamLabel]>) -> ScanInput<'a> {
    ScanInput {
        angle_min: BinaryAngle::HALF,
        angle_increment: BinaryAngle::from_fraction(1, ranges.len() as i64),
        ranges_mm: ranges,
        labels,
        range_min_mm: 0,
        range_max_mm: firmware::scan::RANGE_LIMIT_MM,
    }
}

pub fn pose(x: f64, y: f64, yaw: f64) -> Pose2 {
    Pose2::from_f64(x, y, yaw).unwrap()
}

/// A controller on the heap (it is ~1.4 MiB).
pub fn controller(cfg: Config) -> Box<Controller> {
    Box::new(Controller::new(cfg))
}

/// A 10 m × 8 m room at (2, 2)–(12, 10) with a door in the east wall at y ∈ [5.5, 6.5] leading
/// to a corridor, plus furniture.
pub fn room_world() -> Vec<Box2> {
    vec![
        wall(2.0, 2.0, 12.0, 2.1),
        wall(2.0, 9.9, 12.0, 10.0),
        wall(2.0, 2.0, 2.1, 10.0),
        wall(11.9, 2.0, 12.0, 5.5),
        wall(11.9, 6.5, 12.0, 10.0),
        // corridor beyond the door
        wall(12.0, 3.0, 20.0, 3.1),
        wall(12.0, 8.9, 20.0, 9.0),
        wall(19.9, 3.0, 20.0, 9.0),
        thing(4.0, 8.0, 6.0, 9.0),
        thing(9.0, 3.0, 9.6, 3.5),
        thing(16.0, 7.0, 16.5, 7.35),
    ]
}
