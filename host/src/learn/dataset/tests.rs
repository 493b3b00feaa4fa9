use super::*;
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use crate::learn::labeller::Agreement;
use crate::sim::World;

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lives-dataset-test-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    d
}

/// Two worlds (seeds 10 → val, 11 → train), two short episodes each.
fn small_spec(dir: &Path) -> DatasetSpec {
    let mut s = DatasetSpec::new(dir, 10, 2, 2);
    s.plan.episode_min_s = 3.0;
    s.plan.episode_max_s = 5.0;
    s
}

#[test]
fn record_layout() {
    assert_eq!(record_bytes(BEAMS), 5412);
    let r = Record {
        world_seed: u64::MAX - 3,
        episode: 7,
        tick: 9,
        pose: [1.5, -2.25, 3.0],
        ranges: (0..BEAMS)
            .map(|i| {
                if i % 3 == 0 {
                    f32::INFINITY
                } else if i % 5 == 0 {
                    f32::NAN
                } else {
                    i as f32 * 0.01
                }
            })
            .collect(),
        labels: (0..BEAMS).map(|i| (i % 4) as u8).collect(),
        truth: (0..BEAMS).map(|i| (i % 6) as u8).collect(),
    };
    let mut b = Vec::new();
    r.encode(&mut b);
    assert_eq!(b.len(), record_bytes(BEAMS));
    let back = Record::decode(&b, BEAMS).unwrap();
    let bits = |r: &Record| r.ranges.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&back), bits(&r));
    assert_eq!((back.world_seed, back.episode, back.tick, back.pose), (r.world_seed, r.episode, r.tick, r.pose));
    assert_eq!(back.labels, r.labels);
    assert_eq!(back.truth, r.truth);
}

#[test]
fn round_trip_split_by_world_no_builtins() {
    let dir = tmp_dir("roundtrip");
    let spec = small_spec(&dir);
    let sum = generate(&spec).unwrap();
    assert_eq!(sum.val_worlds, vec![10]);
    assert_eq!(sum.train_worlds, vec![11]);
    assert_eq!(sum.episodes, 4);
    assert!(sum.train_records >= 2 * 15 && sum.train_records <= 2 * 25, "{}", sum.train_records);
    let meta = read_meta(&dir).unwrap();
    assert_eq!(meta.version, VERSION);
    assert_eq!(meta.excluded_worlds, EXCLUDED_WORLDS.map(String::from).to_vec());
    for e in &meta.episodes {
        assert!(e.world_name.starts_with("random-"), "{}", e.world_name);
        assert!(!EXCLUDED_WORLDS.contains(&e.world_name.as_str()));
    }
    let builtins = builtin_walls();
    for split in Split::ALL {
        let mut r = DatasetReader::open(&dir, split).unwrap();
        assert!(r.truncation().is_none());
        let n = r.len();
        assert_eq!(n, if split == Split::Train { sum.train_records } else { sum.val_records });
        let mut count = 0;
        let mut last: Option<(u32, u32)> = None;
        for rec in r.by_ref() {
            let rec = rec.unwrap();
            assert_eq!(Split::of_world(rec.world_seed, 5), split);
            assert_eq!(rec.ranges.len(), BEAMS);
            // Ticks count up within an episode.
            if let Some((e, t)) = last {
                if e == rec.episode {
                    assert_eq!(rec.tick, t + 1);
                } else {
                    assert_eq!(rec.tick, 0);
                }
            }
            last = Some((rec.episode, rec.tick));
            // Labels and truth agree on "no return" and match the ranges.
            for i in 0..BEAMS {
                assert_eq!(rec.labels[i] == 0, rec.truth[i] == 0);
                assert_eq!(rec.truth[i] == 0, !rec.ranges[i].is_finite());
            }
            let w = World::random(rec.world_seed);
            assert!(builtins.iter().all(|(_, walls)| *walls != w.walls));
            count += 1;
        }
        assert_eq!(count, n);
        // Random access agrees with the iteration.
        let a = r.get(n - 1).unwrap();
        let b = r.get(0).unwrap();
        assert_eq!(b.tick, 0);
        assert_eq!(a.world_seed, b.world_seed);
        assert!(matches!(r.get(n), Err(DatasetError::OutOfRange { .. })));
    }
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn deterministic_and_thread_independent() {
    let (a, b) = (tmp_dir("det-a"), tmp_dir("det-b"));
    let sa = small_spec(&a);
    let mut sb = small_spec(&b);
    sb.threads = 2;
    generate(&sa).unwrap();
    generate(&sb).unwrap();
    for f in ["meta.json", "train.bin", "val.bin"] {
        let (x, y) = (fs::read(a.join(f)).unwrap(), fs::read(b.join(f)).unwrap());
        assert!(x == y, "{f} differs");
    }
    let _ = fs::remove_dir_all(&a);
    let _ = fs::remove_dir_all(&b);
}

#[test]
fn truncated_and_corrupt_files_give_clear_errors() {
    let dir = tmp_dir("trunc");
    let mut spec = small_spec(&dir);
    spec.plan.worlds = 1;
    spec.plan.first_world_seed = 11; // train only
    spec.plan.episodes_per_world = 1;
    let sum = generate(&spec).unwrap();
    let n = sum.train_records;
    assert!(n >= 3);
    let path = dir.join("train.bin");
    let full = fs::read(&path).unwrap();
    // Cut the last record in half.
    let cut = full.len() - record_bytes(BEAMS) / 2;
    fs::write(&path, &full[..cut]).unwrap();
    let mut r = DatasetReader::open(&dir, Split::Train).unwrap();
    assert_eq!(r.len(), n - 1);
    assert!(matches!(r.truncation(), Some(DatasetError::Truncated { complete_records, trailing_bytes, expected_records, .. })
        if *complete_records == n - 1 && *trailing_bytes == (record_bytes(BEAMS) - record_bytes(BEAMS) / 2) as u64 && *expected_records == n));
    let items: Vec<_> = r.by_ref().collect();
    assert_eq!(items.len() as u64, n);
    assert!(items[..(n - 1) as usize].iter().all(|r| r.is_ok()));
    let last = items.last().unwrap().as_ref().unwrap_err();
    assert!(last.to_string().contains("truncated"), "{last}");
    // A whole record missing is also reported (meta.json lists more).
    fs::write(&path, &full[..full.len() - record_bytes(BEAMS)]).unwrap();
    let r = DatasetReader::open(&dir, Split::Train).unwrap();
    assert!(matches!(r.truncation(), Some(DatasetError::Truncated { trailing_bytes: 0, .. })));
    // Bad magic.
    let mut bad = full.clone();
    bad[0] = b'X';
    fs::write(&path, &bad).unwrap();
    assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::BadMagic { .. })));
    // Shorter than a header.
    fs::write(&path, &full[..12]).unwrap();
    assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::BadHeader { .. })));
    fs::write(&path, &full[..3]).unwrap();
    assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::BadMagic { .. })));
    // Another version in the file header.
    let mut v2 = full.clone();
    v2[8..12].copy_from_slice(&2u32.to_le_bytes());
    fs::write(&path, &v2).unwrap();
    assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::UnsupportedVersion { found: 2, .. })));
    fs::write(&path, &full).unwrap();
    assert_eq!(DatasetReader::open(&dir, Split::Train).unwrap().len(), n);
    // Another version, or garbage, in meta.json.
    let meta_path = dir.join("meta.json");
    let text = fs::read_to_string(&meta_path).unwrap();
    fs::write(&meta_path, text.replacen("\"version\": 1", "\"version\": 9", 1)).unwrap();
    assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::UnsupportedVersion { found: 9, .. })));
    fs::write(&meta_path, "{ not json").unwrap();
    assert!(matches!(DatasetReader::open(&dir, Split::Train), Err(DatasetError::Meta { .. })));
    fs::remove_file(&meta_path).unwrap();
    let e = DatasetReader::open(&dir, Split::Train).err().unwrap();
    assert!(matches!(e, DatasetError::Meta { .. }), "{e}");
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn bad_specs_are_refused() {
    let dir = tmp_dir("bad");
    // `small_spec` changed by `edit` is refused as invalid.
    let refused = |edit: &dyn Fn(&mut DatasetSpec)| {
        let mut s = small_spec(&dir);
        edit(&mut s);
        matches!(generate(&s), Err(DatasetError::InvalidSpec(_)))
    };
    assert!(refused(&|s| s.plan.worlds = 0));
    assert!(refused(&|s| {
        s.plan.episode_min_s = 10.0;
        s.plan.episode_max_s = 5.0;
    }));
    assert!(refused(&|s| s.plan.first_world_seed = u64::MAX));
    for bad in [[0.5, 0.2], [-0.1, 1.0], [0.0, 1.5]] {
        assert!(refused(&|s| s.density = bad), "{bad:?}");
    }
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn furniture_density_default_is_world_random_and_range_is_respected() {
    for seed in [1, 5, 12] {
        assert_eq!(dataset_world(seed, [1.0, 1.0]), World::random(seed));
        let d = world_density(seed, [0.2, 0.6]);
        assert!((0.2..=0.6).contains(&d), "{d}");
        assert_eq!(d, world_density(seed, [0.2, 0.6]));
        assert_eq!(world_density(seed, [0.3, 0.3]), 0.3);
        assert!(dataset_world(seed, [0.0, 0.0]).obstacles.is_empty());
    }
    // The default range is not written to meta.json, so default datasets stay byte-identical.
    let dir = tmp_dir("density-meta");
    let meta = build_meta(&small_spec(&dir), &sim_config(), BTreeMap::new(), &Agreement::default(), Vec::new());
    assert!(!serde_json::to_string(&meta).unwrap().contains("furniture_density"));
}

#[test]
fn trajectories_rotate_and_seeds_differ() {
    let kinds: Vec<_> = (0..4u64).map(|w| Trajectory::for_episode(w, 0, 1)).collect();
    assert_eq!(kinds, Trajectory::ROTATION.to_vec());
    assert_ne!(episode_seed(1, 0), episode_seed(1, 1));
    assert_ne!(episode_seed(1, 0), episode_seed(2, 0));
}
