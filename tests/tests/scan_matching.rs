//! Scan matching on the raw MIT CSAIL log (issue 27): the controller's poses with
//! `scan_matching` on, scored on the ground-truth relations of Kümmerle et al. 2009 against the
//! raw odometry's, with `lives mapcheck`'s metric (`host::measure::mapcheck::relation_errors`). Reads
//! `tests/data/carmen/raw/`.

use host::io::replay::{self, ReplayOptions};
use host::measure::mapcheck::{read_poses, read_relations, relation_errors, PoseIndex, RelationStats};

mod common;

fn show(what: &str, s: &RelationStats) -> String {
    format!(
        "{what}: {} relations, translation {:.3} ± {:.3} m, rotation {:.3} ± {:.3}°",
        s.used,
        s.trans_mean_m.unwrap_or(f64::NAN),
        s.trans_std_m.unwrap_or(f64::NAN),
        s.rot_mean_deg.unwrap_or(f64::NAN),
        s.rot_std_deg.unwrap_or(f64::NAN)
    )
}

#[test]
fn scan_matching_beats_raw_odometry_on_the_csail_relations() {
    let dir = common::root().join("tests/data/carmen/raw");
    let log = dir.join("mit-csail-raw.clf.gz");
    let relations = read_relations(&dir.join("mit-csail.relations")).unwrap();
    let corrected = read_poses(&dir.join("mit-csail-corrected-poses.txt")).unwrap();
    let mut figures = Vec::new();
    for matching in [false, true] {
        let opts = ReplayOptions { model: None, scan_matching: Some(matching), ..ReplayOptions::default() };
        let run = replay::replay(&log, &opts).unwrap();
        let e = relation_errors(&PoseIndex::new(&run.poses), &relations);
        let m = &run.controller.matcher.stats;
        eprintln!(
            "{}; {} scans used ({:?}); matcher: {} matched, {} low score, {} too few points",
            show(&format!("scan_matching={matching}"), &e),
            run.report.scans_used,
            run.report.rejected,
            m.matched,
            m.low_score,
            m.too_few_points
        );
        figures.push(e);
    }
    // The SLAM-corrected poses (406 of them) meet only the relations with both ends among them.
    eprintln!("{}", show("SLAM-corrected poses", &relation_errors(&PoseIndex::new(&corrected), &relations)));
    let (raw, matched) = (&figures[0], &figures[1]);
    assert!(raw.used > 1000, "{raw:?}");
    assert_eq!(matched.used, raw.used);
    let (rt, mt) = (raw.trans_mean_m.unwrap(), matched.trans_mean_m.unwrap());
    let (rr, mr) = (raw.rot_mean_deg.unwrap(), matched.rot_mean_deg.unwrap());
    // Measured: 1.68 -> 1.63 m, 5.07 -> 4.78 degrees, rotation spread 8.24 -> 7.69 degrees
    // (docs/experiments/real-lidar-maps.md): a little better than raw odometry on every figure,
    // far from the SLAM poses (no loop closure). Versions of the matcher measured 1.16-1.76 m
    // here: on this log it is sensitive to small changes of the map.
    let (rrs, mrs) = (raw.rot_std_deg.unwrap(), matched.rot_std_deg.unwrap());
    assert!(mt < rt && mr < rr && mrs < rrs, "matching must beat raw odometry on the relations: {raw:?} {matched:?}");
}
