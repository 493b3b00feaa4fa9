//! Scoring a run: where its time went and when the LiDAR first saw a target ([`RunTally`], fed
//! by the simulator source), and how a classifier's labels compared with the truth
//! ([`LabelScore`]).

use super::cycle::TICK_US;
use crate::sim::{HitKind, Scan};
use firmware::scan::{BeamLabel, BeamScan};
use serde::Serialize;

/// The classifier's labels against the simulator's truth, every beam of every scan of a run
/// that both labelled (map or non-map).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LabelScore {
    /// Beams compared.
    pub beams: u64,
    /// Fraction labelled as the truth labels them.
    pub accuracy: f64,
    /// Fraction of the true non-map beams labelled non-map.
    pub nonmap_recall: f64,
    /// Fraction of the beams labelled non-map that are non-map.
    pub nonmap_precision: f64,
    /// The counts: `confusion[truth][label]`, index 0 map, 1 non-map.
    pub confusion: [[u64; 2]; 2],
}

impl LabelScore {
    /// The score of a confusion matrix (`[truth][label]`, 0 map, 1 non-map); ratios of nothing
    /// are 0.
    pub fn from_confusion(c: [[u64; 2]; 2]) -> Self {
        let ratio = |a: u64, b: u64| if b == 0 { 0.0 } else { (a as f64 / b as f64 * 1e4).round() / 1e4 };
        let beams = c[0][0] + c[0][1] + c[1][0] + c[1][1];
        LabelScore {
            beams,
            accuracy: ratio(c[0][0] + c[1][1], beams),
            nonmap_recall: ratio(c[1][1], c[1][0] + c[1][1]),
            nonmap_precision: ratio(c[1][1], c[0][1] + c[1][1]),
            confusion: c,
        }
    }

    /// The score of several runs together (their beams pooled).
    pub fn pooled<'a>(scores: impl IntoIterator<Item = &'a LabelScore>) -> Self {
        let mut c = [[0u64; 2]; 2];
        for s in scores {
            for (row, srow) in c.iter_mut().zip(s.confusion.iter()) {
                for (v, sv) in row.iter_mut().zip(srow.iter()) {
                    *v += sv;
                }
            }
        }
        Self::from_confusion(c)
    }
}

/// Adds one scan's beams to `confusion` (`[truth][label]`, 0 map, 1 non-map): every beam both
/// labelled.
pub fn count_labels(confusion: &mut [[u64; 2]; 2], truth: &BeamScan, used: &BeamScan) {
    let class = |l: BeamLabel| match l {
        BeamLabel::Map => Some(0),
        BeamLabel::NonMap => Some(1),
        BeamLabel::Unlabelled => None,
    };
    for (&t, &u) in truth.labels.iter().zip(used.labels.iter()) {
        if let (Some(t), Some(u)) = (class(t), class(u)) {
            confusion[t][u] += 1;
        }
    }
}

/// Where a run's time went, tick by tick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Motion {
    /// The base translated ([`MOVING_M_PER_TICK`] or more in the tick).
    pub moving_s: f64,
    /// It turned in place ([`TURNING_RAD_PER_TICK`] or more, without moving).
    pub turning_s: f64,
    /// It stood still (waiting out a block, arrived, stopped, or waiting for a goal).
    pub still_s: f64,
}

/// Tallies a simulated run for [`SearchResult::motion`], [`SearchResult::lidar_saw_target_s`]
/// and [`SearchResult::target_in_camera_reach_s`]; the in-process loop and the serial bridge both
/// feed one.
#[derive(Clone, Debug)]
pub struct RunTally {
    /// Seconds moving, turning, still.
    split: [f64; 3],
    camera_range_m: f64,
    lidar_saw_target_s: Option<f64>,
    in_camera_reach_s: Option<f64>,
}

impl RunTally {
    /// A tally for a camera of this range.
    pub fn new(camera_range_m: f64) -> Self {
        Self { split: [0.0; 3], camera_range_m, lidar_saw_target_s: None, in_camera_reach_s: None }
    }

    /// A scan taken at `now_us`.
    pub fn scan(&mut self, now_us: u64, scan: &Scan) {
        let t = round3(now_us as f64 / 1e6);
        let on_target = || scan.hits.iter().zip(&scan.ranges_m).filter(|&(&h, _)| h == HitKind::Target);
        if self.lidar_saw_target_s.is_none() && on_target().count() >= LIDAR_SIGHTING_BEAMS {
            self.lidar_saw_target_s = Some(t);
        }
        if self.in_camera_reach_s.is_none() {
            let near = on_target().filter(|&(_, &r)| (r as f64) <= self.camera_range_m).count();
            if near >= LIDAR_SIGHTING_BEAMS {
                self.in_camera_reach_s = Some(t);
            }
        }
    }

    /// One base step of `dt_s` seconds (a tick), from pose `before` to pose `after`.
    pub fn step(&mut self, before: [f64; 3], after: [f64; 3], dt_s: f64) {
        let scale = dt_s / (TICK_US as f64 / 1e6);
        let kind = if (after[0] - before[0]).hypot(after[1] - before[1]) >= MOVING_M_PER_TICK * scale {
            0
        } else if crate::sim::geometry::wrap_angle(after[2] - before[2]).abs() >= TURNING_RAD_PER_TICK * scale {
            1
        } else {
            2
        };
        self.split[kind] += dt_s;
    }

    /// The motion split.
    pub fn motion(&self) -> Motion {
        let [moving_s, turning_s, still_s] = self.split.map(round3);
        Motion { moving_s, turning_s, still_s }
    }

    /// When the LiDAR first saw a target.
    pub fn lidar_saw_target_s(&self) -> Option<f64> {
        self.lidar_saw_target_s
    }

    /// When a target was first within the camera's reach.
    pub fn target_in_camera_reach_s(&self) -> Option<f64> {
        self.in_camera_reach_s
    }
}

/// A tick (of the nominal 0.2 s; scaled for other periods) in which the base moves at least this
/// far counts as moving (2.5 cm/s).
pub const MOVING_M_PER_TICK: f64 = 0.005;
/// A tick in which the base turns at least this much (and does not move) counts as turning.
pub const TURNING_RAD_PER_TICK: f64 = 0.01;
/// Beams that must hit a target in one scan for [`SearchResult::lidar_saw_target_s`].
pub const LIDAR_SIGHTING_BEAMS: usize = 3;

/// `v` rounded to thousandths, as the reports write seconds and metres (to the ms and the mm).
pub fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// Summary of a set of samples (microseconds, millimetres, degrees: whatever they measure).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Summary {
    /// Samples.
    pub n: usize,
    /// Smallest.
    pub min: f64,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl Summary {
    /// Of `samples` (any order).
    pub fn of(samples: &[f64]) -> Summary {
        if samples.is_empty() {
            return Summary::default();
        }
        let mut v = samples.to_vec();
        v.sort_by(|a, b| a.total_cmp(b));
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        Summary { n: v.len(), min: v[0], p50: at(0.5), p95: at(0.95), max: v[v.len() - 1], mean: v.iter().sum::<f64>() / v.len() as f64 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_label_score_counts_every_beam_both_labelled() {
        use BeamLabel::{Map, NonMap, Unlabelled};
        let mut truth = BeamScan::new();
        let mut used = BeamScan::new();
        let pairs = [(Map, Map), (Map, NonMap), (NonMap, Map), (NonMap, NonMap), (NonMap, NonMap), (Unlabelled, NonMap), (Map, Unlabelled)];
        for (b, &(t, u)) in pairs.iter().enumerate() {
            truth.labels[b] = t;
            used.labels[b] = u;
        }
        let mut confusion = [[0u64; 2]; 2];
        count_labels(&mut confusion, &truth, &used);
        let s = LabelScore::from_confusion(confusion);
        assert_eq!(s.beams, 5, "beams either side left unlabelled are not scored");
        assert_eq!(s.accuracy, 0.6);
        assert_eq!(s.nonmap_recall, 0.6667);
        assert_eq!(s.nonmap_precision, 0.6667);
        assert_eq!(s.confusion, [[1, 1], [1, 2]]);
        assert_eq!(LabelScore::from_confusion([[0; 2]; 2]), LabelScore::default(), "nothing to score is zeros, not NaN");
        // Pooled runs add their counts: not the mean of their ratios.
        let other = LabelScore::from_confusion([[0, 0], [3, 0]]);
        let both = LabelScore::pooled([&s, &other]);
        assert_eq!(both.beams, 8);
        assert_eq!(both.nonmap_recall, 0.3333);
        assert_eq!(both.nonmap_precision, s.nonmap_precision);
    }

    #[test]
    fn the_tally_times_the_first_lidar_sighting_and_the_first_within_camera_reach() {
        let scan = |target_ranges: &[f32]| {
            let mut ranges_m = vec![6.0f32; 20];
            let mut hits = vec![HitKind::Wall; 20];
            for (i, &r) in target_ranges.iter().enumerate() {
                ranges_m[i] = r;
                hits[i] = HitKind::Target;
            }
            Scan {
                angle_min: -std::f64::consts::PI,
                angle_increment: std::f64::consts::TAU / 20.0,
                range_min_m: 0.1,
                range_max_m: 30.0,
                ranges_m,
                hits,
            }
        };
        let mut t = RunTally::new(4.0);
        t.scan(0, &scan(&[5.0, 5.0]));
        assert_eq!((t.lidar_saw_target_s(), t.target_in_camera_reach_s()), (None, None), "two beams are not a sighting");
        t.scan(200_000, &scan(&[5.0, 4.5, 4.2]));
        assert_eq!((t.lidar_saw_target_s(), t.target_in_camera_reach_s()), (Some(0.2), None), "seen, but beyond 4 m");
        t.scan(400_000, &scan(&[4.5, 3.9, 3.8, 4.0]));
        assert_eq!(t.target_in_camera_reach_s(), Some(0.4), "three beams within 4 m");
        t.scan(600_000, &scan(&[1.0, 1.0, 1.0]));
        assert_eq!((t.lidar_saw_target_s(), t.target_in_camera_reach_s()), (Some(0.2), Some(0.4)), "the first times stay");
    }
}
