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
    let mut field_poses = Vec::new();
    // The relations the SLAM-corrected poses meet (both ends among its 406 poses): the three side
    // by side on the same relations.
    let corrected_index = PoseIndex::new(&corrected);
    let common: Vec<_> =
        relations.iter().filter(|r| corrected_index.at(r.t1).is_some() && corrected_index.at(r.t2).is_some()).copied().collect();
    let mut on_common = Vec::new();
    // Raw odometry, the hill-climbing matcher (the simulator's), the field matcher (real logs').
    for (matching, field) in [(false, true), (true, false), (true, true)] {
        let mut opts = ReplayOptions { model: None, scan_matching: Some(matching), ..ReplayOptions::default() };
        opts.config.scan_match_field = field;
        let run = replay::replay(&log, &opts).unwrap();
        let e = relation_errors(&PoseIndex::new(&run.poses), &relations);
        let m = &run.controller.matcher.stats;
        eprintln!(
            "{}; {} scans used ({:?}); matcher: {} matched, {} low score, {} too few points",
            show(&format!("scan_matching={matching} scan_match_field={field}"), &e),
            run.report.scans_used,
            run.report.rejected,
            m.matched,
            m.low_score,
            m.too_few_points
        );
        figures.push(e);
        on_common.push(relation_errors(&PoseIndex::new(&run.poses), &common));
        if matching && field {
            field_poses = run.poses;
        }
    }
    // The SLAM-corrected poses (406 of them) meet only the relations with both ends among them.
    eprintln!("{}", show("SLAM-corrected poses", &relation_errors(&PoseIndex::new(&corrected), &relations)));
    for (name, e) in ["raw odometry", "hill-climbing matcher", "field matcher"].iter().zip(&on_common) {
        eprintln!("{}", show(&format!("{name} on the corrected poses' relations"), e));
    }
    assert_eq!(common.len(), 16);
    let (raw, matched, field) = (&figures[0], &figures[1], &figures[2]);
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
    // The field matcher (`scan_match_field`, what replay uses on real logs): measured 0.17 ± 0.49 m,
    // 1.13 ± 2.51° on all 1172 (raw odometry 1.68 m, 5.07°); on the 1044 relations spanning
    // under 5 s 0.030 m, 0.63° (raw 0.033 m, 2.88°), on the 128 revisits 1.31 m, 5.20° (raw
    // 15.1 m, 22.9°). Small changes of its weights gave 0.10–0.36 m (docs/experiments/
    // real-lidar-maps.md): the bounds leave room for that, not for raw odometry's figures.
    assert_eq!(field.used, raw.used);
    let (ft, fr) = (field.trans_mean_m.unwrap(), field.rot_mean_deg.unwrap());
    assert!(ft < 0.5 && fr < 2.5, "the field matcher: {field:?}");
    let short: Vec<_> = relations.iter().filter(|r| r.t2 - r.t1 < 5.0).copied().collect();
    let long: Vec<_> = relations.iter().filter(|r| r.t2 - r.t1 >= 5.0).copied().collect();
    assert!(ReplayOptions::default().config.scan_match_field, "replay matches with the field matcher");
    let (s, l) = (relation_errors(&PoseIndex::new(&field_poses), &short), relation_errors(&PoseIndex::new(&field_poses), &long));
    eprintln!("{}\n{}", show("field matcher, spans < 5 s", &s), show("field matcher, spans >= 5 s", &l));
    assert_eq!((s.used, l.used), (1044, 128));
    // Short spans: the heading a quarter of raw odometry's, the translation no worse than its 0.033 m.
    assert!(s.rot_mean_deg.unwrap() < 1.0 && s.trans_mean_m.unwrap() < 0.035, "{s:?}");
    assert!(l.trans_mean_m.unwrap() < 3.0 && l.rot_mean_deg.unwrap() < 10.0, "{l:?}");
}
