//! Run recordings (issue 8 part 3): an MCAP written by `lives search --record` is read back by an
//! independent reader, the PyPI `mcap` package (`tests/python/check_mcap.py`), which checks
//! topics, schemas, encodings, frames, fields and exact message counts; recording does not change
//! the run; a recording cut short by a crash is read up to its last flushed chunk.
//!
//! Needs python3 with `mcap` (`./scripts/test.sh` installs it into `target/py-mcap`; or set
//! `LIVES_PYTHON` to an interpreter that has it).

use host::io::record::{RecordOptions, Recorder};
use host::search::record_search;
use host::search::{PlannerChoice, SearchSpec};
use host::sim::{Scenario, World};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;
use std::time::Duration;

mod common;
use common::{lives, root};

fn tmp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("lives-record-test-{}-{name}", std::process::id()))
}

/// A Python with the `mcap` package, or a failure that says how to get one.
fn python() -> &'static str {
    static PY: OnceLock<String> = OnceLock::new();
    PY.get_or_init(|| {
        let venv = root().join("target/py-mcap/bin/python");
        let candidates: Vec<String> =
            std::env::var("LIVES_PYTHON").ok().into_iter().chain([venv.to_string_lossy().into_owned(), "python3".to_string()]).collect();
        for py in &candidates {
            let ok = Command::new(py).args(["-c", "import mcap"]).stderr(Stdio::null()).status().is_ok_and(|s| s.success());
            if ok {
                return py.clone();
            }
        }
        panic!(
            "no Python with the `mcap` package (tried {candidates:?}). Run ./scripts/test.sh (it installs it into \
             target/py-mcap), or: python3 -m venv target/py-mcap && target/py-mcap/bin/pip install mcap"
        )
    })
}

/// Runs the checker; its JSON report on success, the failure text otherwise.
fn check(file: &Path, args: &[String]) -> Result<Value, String> {
    let out: Output =
        Command::new(python()).arg(root().join("tests/python/check_mcap.py")).arg(file).args(args).output().expect("python runs");
    if out.status.success() {
        Ok(serde_json::from_slice(&out.stdout).expect("the checker prints JSON"))
    } else {
        Err(format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr)))
    }
}

fn search_json(extra: &[&str]) -> (String, Output) {
    let out = Command::new(lives())
        // The 4 m robot: this run finds the suitcase after more than 100 ticks (office easy seed 1,
        // 70.0 s), which the counts below need.
        .args(["search", "--world", "office", "--scenario", "easy", "--planner", "lives-gt", "--seed", "1", "--json", "--robot", "short"])
        .args(extra)
        .output()
        .expect("lives runs");
    (String::from_utf8_lossy(&out.stdout).into_owned(), out)
}

#[test]
fn lives_search_record_is_read_back_by_the_python_mcap_reader_with_exact_counts() {
    let file = tmp("search.mcap");
    let (plain, _) = search_json(&[]);
    let (recorded, out) = search_json(&["--record", file.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0), "found: {}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(plain, recorded, "--json output with and without --record");
    let r: Value = serde_json::from_str(&recorded).unwrap();
    let ticks = r["ticks"].as_u64().unwrap();
    let goals = r["goals"].as_u64().unwrap();
    assert!(r["found"].as_bool().unwrap() && ticks > 100, "{r}");
    // Grids every 1 s of run time (every 5th tick from t = 0) and at the detection.
    let grids = (ticks - 1) / 5 + 1 + u64::from(!(ticks - 1).is_multiple_of(5));
    let mut expect: Vec<String> = ["/tf", "/lives/pose", "/lives/scan", "/lives/status"].iter().map(|t| format!("{t}={ticks}")).collect();
    expect.extend(["/lives/lidar_grid", "/lives/visual_grid", "/lives/nonmap_points"].iter().map(|t| format!("{t}={grids}")));
    expect.extend([format!("/lives/goal={goals}"), format!("/lives/path={goals}"), "/lives/detection=1".into(), "/lives/labels=0".into()]);
    let args: Vec<String> = expect.iter().flat_map(|e| ["--expect".to_string(), e.clone()]).collect();
    let report = check(&file, &args);
    let size = std::fs::metadata(&file).map(|m| m.len()).unwrap_or(0);
    std::fs::remove_file(&file).ok();
    let report = report.unwrap_or_else(|e| panic!("the recording does not check out:\n{e}"));
    let counts = &report["counts"];
    // The checker also tied frontier and candidate updates to the controller's planning steps,
    // and the log to its mode changes, goals and detection; here: they are there.
    let plans = report["last_status"]["plans"].as_u64().unwrap();
    assert!(plans >= goals && counts["/lives/candidates"].as_u64() == Some(plans), "{report}");
    assert_eq!(report["modes"], serde_json::json!(["Exploring", "TargetFound"]));
    assert_eq!(report["truncated"], false);
    // Every candidate a step rated is recorded, not only the chosen one (how many depends on the
    // map: at most 10 in one step of this search since the no-return bounds, more before).
    assert!(report["max_candidates"].as_u64().unwrap() > 1, "candidates recorded: {report}");
    // A grid cropped to the office (25 x 45 m at 0.1 m, at most 112 500 cells), not the whole
    // 512 x 512 map (262 144).
    let cells = report["max_grid_cells"].as_u64().unwrap();
    assert!((10_000..=120_000).contains(&cells), "{cells} cells");
    assert!(size < 10 << 20, "{size} bytes (3.0 MB measured)");
}

#[test]
fn the_checker_rejects_a_wrong_count() {
    // The checker can fail: a count off by one is caught.
    let file = tmp("wrong.mcap");
    let (out, _) = search_json(&["--record", file.to_str().unwrap()]);
    let ticks = serde_json::from_str::<Value>(&out).unwrap()["ticks"].as_u64().unwrap();
    let bad = check(&file, &["--expect".into(), format!("/lives/pose={}", ticks + 1)]);
    let good = check(&file, &["--expect".into(), format!("/lives/pose={ticks}")]);
    std::fs::remove_file(&file).ok();
    assert!(bad.unwrap_err().contains("/lives/pose"));
    assert!(good.is_ok());
}

#[test]
fn a_recording_cut_short_is_read_up_to_its_last_flushed_chunk() {
    // Deterministic: chunks every 97 messages, the file taken as it is on disk mid-way (what a
    // crash leaves), never finished. The run writes 1696 messages; a chunk size that divides the
    // count leaves nothing unflushed and the premise "more after them" fails (it did with 100).
    let file = tmp("cut.mcap");
    let w = World::builtin("office", Scenario::Easy).unwrap();
    let spec = SearchSpec::new("office", w, Scenario::Easy, PlannerChoice::LivesGt, 1);
    let opts = RecordOptions { flush_every: Duration::from_secs(3600), flush_every_messages: 97, ..RecordOptions::default() };
    let mut rec = Recorder::create(&file, opts).unwrap();
    let (_, ok) = record_search(&spec, Some(&mut rec), |_| {}).unwrap();
    ok.unwrap();
    let on_disk = rec.summary().total_messages() - rec.unflushed_messages();
    let cut = tmp("cut-copy.mcap");
    std::fs::copy(&file, &cut).unwrap();
    drop(rec); // finishes the original: now complete
    let full = check(&file, &[]).unwrap_or_else(|e| panic!("{e}"));
    let partial = check(&cut, &["--partial".into()]).unwrap_or_else(|e| panic!("{e}"));
    let not_partial = check(&cut, &[]);
    std::fs::remove_file(&file).ok();
    std::fs::remove_file(&cut).ok();
    assert_eq!(partial["messages"].as_u64(), Some(on_disk));
    assert_eq!(partial["truncated"], true, "no footer: the stream breaks off");
    assert!(
        on_disk >= 300 && full["messages"].as_u64().unwrap() > on_disk,
        "several chunks on disk, and more after them: {on_disk} of {}",
        full["messages"]
    );
    assert!(not_partial.unwrap_err().contains("summary"), "an unfinished file is not taken for a complete one");
}

#[test]
fn a_killed_lives_search_leaves_a_readable_recording() {
    // A real crash: SIGKILL a long search (office hard, 300 s simulated) mid-run.
    let file = tmp("killed.mcap");
    let mut child = Command::new(lives())
        .args(["search", "--world", "office", "--scenario", "hard", "--planner", "nearest", "--seed", "2", "--json"])
        .args(["--record", file.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("lives runs");
    // Wait until a few chunks are on disk (the file grows as it goes), then kill.
    let t0 = std::time::Instant::now();
    while std::fs::metadata(&file).map_or(0, |m| m.len()) < 1 << 20 && t0.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(5));
    }
    let finished_already = child.try_wait().unwrap().is_some();
    child.kill().ok();
    child.wait().unwrap();
    let partial = check(&file, &["--partial".into()]);
    std::fs::remove_file(&file).ok();
    assert!(!finished_already, "the search ended before it could be killed; pick a longer one");
    let partial = partial.unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(partial["truncated"], true, "no footer: the stream breaks off");
    let counts = &partial["counts"];
    let poses = counts["/lives/pose"].as_u64().unwrap();
    assert!(poses >= 20, "{partial}");
    // Messages of a tick are written together: what was read is whole ticks, give or take the
    // one tick a chunk boundary split.
    assert!(counts["/lives/scan"].as_u64().unwrap().abs_diff(poses) <= 1, "{partial}");
}

#[test]
fn a_bridge_recording_holds_the_protocol_messages_and_changes_nothing() {
    use firmware::node::TimeMode;
    use firmware::Config;
    use host::link::record::SharedRecording;
    use host::link::{mem_pair, run_bridge, BridgeOptions, NodeOptions, NodeProcess, Source};
    use std::sync::atomic::{AtomicBool, Ordering};

    // A short search: the built-in `apartment easy` of 2026-11-25, kept as an example.
    let w = World::load(&root().join("examples/worlds/apartment-easy-bedroom-start.toml")).unwrap();
    let spec = SearchSpec::new("apartment-easy-bedroom-start", w, Scenario::Easy, PlannerChoice::LivesGt, 1);
    let inproc = host::search::run(&spec, |_| {});
    let file = tmp("bridge.mcap");
    let recording = SharedRecording::create(&file).unwrap();
    let bopts = BridgeOptions {
        max_wall: Some(Duration::from_secs(240)),
        want_labels: true,
        observer: Some(recording.observer()),
        ..BridgeOptions::new(TimeMode::Lockstep)
    };
    let (mut node_link, mut bridge_link) = mem_pair();
    let (stop_node, stop_bridge) = (AtomicBool::new(false), AtomicBool::new(false));
    let r = std::thread::scope(|s| {
        let _stop = common::StopOnDrop(&[&stop_node, &stop_bridge]);
        let node = s.spawn(|| {
            let mut p = NodeProcess::new(Config::DEFAULT, NodeOptions::new(TimeMode::Lockstep)).expect("no model");
            p.run(&mut node_link, &stop_node);
        });
        let r = run_bridge(&mut bridge_link, Source::Sim(spec.clone()), &bopts, &stop_bridge).expect("a session");
        std::thread::sleep(Duration::from_millis(300));
        stop_node.store(true, Ordering::Relaxed);
        node.join().expect("node thread");
        r
    });
    drop(bopts);
    let summary = recording.finish().unwrap();
    assert_eq!(r.result, inproc.result, "recording the bridge changes nothing");
    assert_eq!(r.goals, inproc.goals);
    let ticks = r.result.ticks;
    let goals = r.result.goals;
    let expect = [
        format!("/tf={ticks}"),
        format!("/lives/pose={ticks}"),
        format!("/lives/scan={ticks}"),
        // The node answers every tick with its status and the labels of the scan it integrated.
        format!("/lives/status={ticks}"),
        format!("/lives/labels={ticks}"),
        format!("/lives/goal={goals}"),
        format!("/lives/path={goals}"),
        "/lives/detection=1".into(),
        // Only in in-process recordings.
        "/lives/lidar_grid=0".into(),
        "/lives/candidates=0".into(),
    ];
    let args: Vec<String> = expect.iter().flat_map(|e| ["--expect".to_string(), e.clone()]).collect();
    let report = check(&file, &args);
    std::fs::remove_file(&file).ok();
    let report = report.unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(report["messages"].as_u64(), Some(summary.total_messages()));
    assert_eq!(report["modes"], serde_json::json!(["Exploring", "TargetFound"]));
}
