//! Scan matching on the raw MIT CSAIL log (issue 27): the controller's poses with
//! `scan_matching` on, scored on the ground-truth relations of Kümmerle et al. 2009 against the
//! raw odometry's. Reads `../shared/data/carmen/raw/` like the other real-log tests.

use firmware::Config;
use host::replay::{self, ReplayOptions, TimedPose};

mod common;

/// Relation errors: translation (m) and absolute rotation (degrees), mean and standard
/// deviation, over the relations whose two stamps both have a pose; and how many those are.
#[derive(Debug)]
struct RelationErrors {
    trans: (f64, f64),
    rot_deg: (f64, f64),
    used: usize,
    total: usize,
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n).sqrt())
}

/// The Kümmerle metric: for each relation (t1, t2, δ*), δ = p(t1)⁻¹ ⊕ p(t2), the error
/// e = δ*⁻¹ ⊕ δ; translation |e.t|, rotation |e.θ|.
fn relation_errors(poses: &[TimedPose], relations: &str) -> RelationErrors {
    let find = |t: f64| {
        let k = poses.partition_point(|p| p.t_s < t - 1e-4);
        poses.get(k).filter(|p| (p.t_s - t).abs() < 1e-4).map(|p| p.pose)
    };
    let wrap = |a: f64| (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    let (mut te, mut re, mut total) = (Vec::new(), Vec::new(), 0);
    for line in relations.lines().filter(|l| !l.trim().is_empty()) {
        total += 1;
        let f: Vec<f64> = line.split_whitespace().map(|v| v.parse().unwrap()).collect();
        let (Some(a), Some(b)) = (find(f[0]), find(f[1])) else { continue };
        // δ = a⁻¹ ⊕ b.
        let (s, c) = a[2].sin_cos();
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let d = [c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2])];
        // e = δ*⁻¹ ⊕ δ.
        let (s, c) = f[7].sin_cos();
        let (ex, ey) = (d[0] - f[2], d[1] - f[3]);
        let e = [c * ex + s * ey, -s * ex + c * ey, wrap(d[2] - f[7])];
        te.push(e[0].hypot(e[1]));
        re.push(e[2].abs().to_degrees());
    }
    RelationErrors { trans: mean_std(&te), rot_deg: mean_std(&re), used: te.len(), total }
}

#[test]
fn scan_matching_beats_raw_odometry_on_the_csail_relations() {
    let dir = common::root().join("../shared/data/carmen/raw");
    let log = dir.join("mit-csail-raw.clf.gz");
    let relations = std::fs::read_to_string(dir.join("mit-csail.relations")).unwrap();
    let corrected: Vec<TimedPose> = std::fs::read_to_string(dir.join("mit-csail-corrected-poses.txt"))
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| {
            let f: Vec<f64> = l.split_whitespace().map(|v| v.parse().unwrap()).collect();
            TimedPose { t_s: f[0], pose: [f[1], f[2], f[3]] }
        })
        .collect();
    // The relations with both ends among the corrected poses.
    let has = |t: f64| corrected.iter().any(|p| (p.t_s - t).abs() < 1e-4);
    let shared: String = relations
        .lines()
        .filter(|l| {
            let f: Vec<f64> = l.split_whitespace().filter_map(|v| v.parse().ok()).collect();
            f.len() == 8 && has(f[0]) && has(f[1])
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let mut figures = Vec::new();
    for matching in [false, true] {
        let opts =
            ReplayOptions { model: None, config: Config { scan_matching: matching, ..Config::DEFAULT }, ..ReplayOptions::default() };
        let run = replay::replay(&log, &opts).unwrap();
        let e = relation_errors(&run.poses, &relations);
        let on_shared = relation_errors(&run.poses, &shared);
        eprintln!(
            "scan_matching={matching} on the {} relations the SLAM-corrected poses meet: translation {:.3} ± {:.3} m, rotation {:.3} ± {:.3}°",
            on_shared.used, on_shared.trans.0, on_shared.trans.1, on_shared.rot_deg.0, on_shared.rot_deg.1
        );
        let m = &run.controller.matcher.stats;
        eprintln!(
            "scan_matching={matching}: {} scans used ({:?}, exceeds_grid {}); relations {}/{}: translation {:.3} ± {:.3} m, \
             rotation {:.3} ± {:.3}°; matcher: {} matched, {} low score, {} too few points",
            run.report.scans_used,
            run.report.rejected,
            run.report.exceeds_grid,
            e.used,
            e.total,
            e.trans.0,
            e.trans.1,
            e.rot_deg.0,
            e.rot_deg.1,
            m.matched,
            m.low_score,
            m.too_few_points
        );
        figures.push(e);
    }
    // The SLAM-corrected poses (406 of them): only the relations with both ends among them.
    let c = relation_errors(&corrected, &relations);
    eprintln!(
        "SLAM-corrected poses: relations {}/{}: translation {:.3} ± {:.3} m, rotation {:.3} ± {:.3}°",
        c.used, c.total, c.trans.0, c.trans.1, c.rot_deg.0, c.rot_deg.1
    );
    let (raw, matched) = (&figures[0], &figures[1]);
    assert!(raw.used > 1000, "{raw:?}");
    assert_eq!(matched.used, raw.used);
    assert!(matched.trans.0 < raw.trans.0 && matched.rot_deg.0 < raw.rot_deg.0, "{raw:?} {matched:?}");
}
