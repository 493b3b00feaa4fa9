//! Pose accuracy: rigid transforms, the least-squares alignment and the relations metric
//! (Kümmerle et al. 2009).

use super::*;
use crate::io::replay::TimedPose;
use serde::Serialize;
use std::path::Path;

/// A rigid transform of the plane: `p ↦ R(θ) p + (x, y)`, as `[x, y, θ]`.
pub type Rigid = [f64; 3];

/// `t` applied to the point `p`.
pub fn apply(t: &Rigid, p: [f64; 2]) -> [f64; 2] {
    let (s, c) = t[2].sin_cos();
    [t[0] + c * p[0] - s * p[1], t[1] + s * p[0] + c * p[1]]
}

/// `a ⊕ b`: pose `b` expressed in `a`'s frame, composed onto `a`.
pub fn compose(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    let p = apply(a, [b[0], b[1]]);
    [p[0], p[1], wrap(a[2] + b[2])]
}

/// `a⁻¹`.
pub fn inverse(a: &[f64; 3]) -> [f64; 3] {
    let (s, c) = a[2].sin_cos();
    [-c * a[0] - s * a[1], s * a[0] - c * a[1], wrap(-a[2])]
}

/// An angle in (−π, π].
pub fn wrap(a: f64) -> f64 {
    let w = a.sin().atan2(a.cos());
    if w <= -std::f64::consts::PI {
        w + std::f64::consts::TAU
    } else {
        w
    }
}

/// The rigid transform `T` minimising `Σ |T(from_i) − to_i|²` over matched positions (the 2D
/// Kabsch/Umeyama solution without scale), with the RMS and largest residual, metres. One pair
/// gives the transform of its poses (`to ⊕ from⁻¹`, headings included); none gives `None`.
pub fn fit_rigid(pairs: &[([f64; 3], [f64; 3])]) -> Option<(Rigid, f64, f64)> {
    let t = match pairs.len() {
        0 => return None,
        1 => compose(&pairs[0].1, &inverse(&pairs[0].0)),
        n => {
            let k = n as f64;
            let ca = pairs.iter().fold([0.0, 0.0], |s, (a, _)| [s[0] + a[0] / k, s[1] + a[1] / k]);
            let cb = pairs.iter().fold([0.0, 0.0], |s, (_, b)| [s[0] + b[0] / k, s[1] + b[1] / k]);
            let (mut cross, mut dot) = (0.0, 0.0);
            for (a, b) in pairs {
                let (ax, ay, bx, by) = (a[0] - ca[0], a[1] - ca[1], b[0] - cb[0], b[1] - cb[1]);
                cross += ax * by - ay * bx;
                dot += ax * bx + ay * by;
            }
            let th = cross.atan2(dot);
            let r = apply(&[0.0, 0.0, th], ca);
            [cb[0] - r[0], cb[1] - r[1], th]
        }
    };
    let res: Vec<f64> = pairs
        .iter()
        .map(|(a, b)| {
            let p = apply(&t, [a[0], a[1]]);
            (p[0] - b[0]).hypot(p[1] - b[1])
        })
        .collect();
    let rms = (res.iter().map(|r| r * r).sum::<f64>() / res.len() as f64).sqrt();
    Some((t, rms, res.iter().cloned().fold(0.0, f64::max)))
}

/// One ground-truth relation: the true pose of the robot at `t2` in its frame at `t1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relation {
    /// First time stamp, seconds.
    pub t1: f64,
    /// Second time stamp, seconds.
    pub t2: f64,
    /// `δ* = [x, y, yaw]`, metres and radians.
    pub delta: [f64; 3],
}

pub(super) fn read_text(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The numbers of line `line_no` of `path`: exactly `names.len()` of them, finite. Blank lines
/// and `#` comments give `None`.
pub(super) fn numbers(path: &Path, line_no: usize, text: &str, names: &[&str]) -> Result<Option<Vec<f64>>, String> {
    let text = text.trim();
    if text.is_empty() || text.starts_with('#') {
        return Ok(None);
    }
    let toks: Vec<&str> = text.split_ascii_whitespace().collect();
    let at = || format!("{}:{line_no}", path.display());
    if toks.len() != names.len() {
        return Err(format!("{}: expected {} numbers `{}`, found {} fields", at(), names.len(), names.join(" "), toks.len()));
    }
    toks.iter()
        .zip(names)
        .map(|(t, name)| match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("{}: {name} `{t}` is not a finite number", at())),
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Reads a relations file: lines `t1 t2 x y z roll pitch yaw` (z, roll and pitch are read and
/// must be numbers, but a planar pose has no use for them).
pub fn read_relations(path: &Path) -> Result<Vec<Relation>, String> {
    let mut out = Vec::new();
    for (i, line) in read_text(path)?.lines().enumerate() {
        if let Some(v) = numbers(path, i + 1, line, &["t1", "t2", "x", "y", "z", "roll", "pitch", "yaw"])? {
            out.push(Relation { t1: v[0], t2: v[1], delta: [v[2], v[3], v[7]] });
        }
    }
    if out.is_empty() {
        return Err(format!("{}: no relations in the file (expected lines `t1 t2 x y z roll pitch yaw`)", path.display()));
    }
    Ok(out)
}

/// Reads a poses file: lines `timestamp x y theta`.
pub fn read_poses(path: &Path) -> Result<Vec<TimedPose>, String> {
    let mut out = Vec::new();
    for (i, line) in read_text(path)?.lines().enumerate() {
        if let Some(v) = numbers(path, i + 1, line, &["timestamp", "x", "y", "theta"])? {
            out.push(TimedPose { t_s: v[0], pose: [v[1], v[2], v[3]] });
        }
    }
    if out.is_empty() {
        return Err(format!("{}: no poses in the file (expected lines `timestamp x y theta`)", path.display()));
    }
    Ok(out)
}

/// Poses looked up by time stamp (the nearest within [`MATCH_S`]).
pub struct PoseIndex(Vec<TimedPose>);

impl PoseIndex {
    /// Indexes `poses` (any order; of equal time stamps the first is kept).
    pub fn new(poses: &[TimedPose]) -> Self {
        let mut v: Vec<TimedPose> = poses.iter().filter(|p| p.t_s.is_finite() && p.pose.iter().all(|c| c.is_finite())).copied().collect();
        v.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        v.dedup_by(|b, a| a.t_s == b.t_s);
        PoseIndex(v)
    }

    /// The pose at `t`, if one lies within [`MATCH_S`].
    pub fn at(&self, t: f64) -> Option<[f64; 3]> {
        let i = self.0.partition_point(|p| p.t_s < t);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|j| self.0.get(j))
            .filter(|p| (p.t_s - t).abs() <= MATCH_S)
            .min_by(|a, b| (a.t_s - t).abs().total_cmp(&(b.t_s - t).abs()))
            .map(|p| p.pose)
    }
}

/// The relation errors of one pose estimate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelationStats {
    /// Relations whose two time stamps both have a pose.
    pub used: usize,
    /// Mean translational error, metres (`None` when none was used).
    pub trans_mean_m: Option<f64>,
    /// Its standard deviation (population, over the relations used).
    pub trans_std_m: Option<f64>,
    /// Mean absolute rotational error, degrees.
    pub rot_mean_deg: Option<f64>,
    /// Its standard deviation.
    pub rot_std_deg: Option<f64>,
    /// Mean squared translational error, m² (the paper's squared form).
    pub trans_sq_mean_m2: Option<f64>,
    /// Mean squared rotational error, deg².
    pub rot_sq_mean_deg2: Option<f64>,
}

/// Relations spanning less than this (seconds) are "short" in `lives mapcheck`'s split: in the
/// CSAIL relations, 1044 of 1172 span under 5 s (consecutive stretches) and the other 128
/// minutes (a place revisited).
pub const SHORT_SPAN_S: f64 = 5.0;

/// The relations metric of Kümmerle et al. 2009: for every relation whose two time stamps both
/// have a pose in `poses`, `δ_est = p(t1)⁻¹ ⊕ p(t2)` and the error `e = δ*⁻¹ ⊕ δ_est`
/// (`δ_est ⊖ δ*`); its translational error is `|(e_x, e_y)|`, its rotational error `|e_θ|`.
pub fn relation_errors(poses: &PoseIndex, relations: &[Relation]) -> RelationStats {
    let mut te = Vec::new();
    let mut re = Vec::new();
    for r in relations {
        let (Some(a), Some(b)) = (poses.at(r.t1), poses.at(r.t2)) else { continue };
        let est = compose(&inverse(&a), &b);
        let e = compose(&inverse(&r.delta), &est);
        te.push(e[0].hypot(e[1]));
        re.push(wrap(e[2]).abs().to_degrees());
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let std = |v: &[f64]| mean(v).map(|m| (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64).sqrt());
    let sq = |v: &[f64]| mean(&v.iter().map(|x| x * x).collect::<Vec<_>>());
    RelationStats {
        used: te.len(),
        trans_mean_m: mean(&te),
        trans_std_m: std(&te),
        rot_mean_deg: mean(&re),
        rot_std_deg: std(&re),
        trans_sq_mean_m2: sq(&te),
        rot_sq_mean_deg2: sq(&re),
    }
}
