//! The `lives` command line, as a user runs it.

use std::process::Command;

fn lives() -> Command {
    Command::new(env!("CARGO_BIN_EXE_lives"))
}

#[test]
fn search_json_is_identical_for_the_same_seed() {
    let run = || {
        let out = lives()
            .args(["search", "--world", "apartment", "--scenario", "easy", "--planner", "lives-gt", "--seed", "1", "--json"])
            .output()
            .unwrap();
        // Status 0 when found, 1 when not: either way one JSON object.
        assert!(matches!(out.status.code(), Some(0 | 1)), "{}", String::from_utf8_lossy(&out.stderr));
        (out.status.code(), String::from_utf8(out.stdout).unwrap())
    };
    let (code, a) = run();
    assert_eq!((code, a.clone()), run());
    let v: serde_json::Value = serde_json::from_str(a.trim()).expect("one JSON object");
    for key in ["world", "scenario", "planner", "seed", "found", "time_s", "path_m", "ticks"] {
        assert!(v.get(key).is_some(), "missing `{key}` in {a}");
    }
    assert_eq!(v["found"], code == Some(0), "the exit status says whether it found the target: {a}");
    assert_eq!(v["world"], "apartment");
    assert_eq!(v["planner"], "lives-gt");
}

#[test]
fn search_writes_a_png() {
    let dir = std::env::temp_dir().join(format!("lives-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("run.png");
    let out = lives().args(["search", "--planner", "lives-gt", "--seed", "1", "--png"]).arg(&png).output().unwrap();
    assert!(matches!(out.status.code(), Some(0 | 1)), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let expect = if out.status.success() { "FOUND apartment easy lives-gt seed 1" } else { "NOT FOUND apartment easy lives-gt seed 1" };
    assert!(stdout.starts_with(expect), "{stdout}");
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(bytes.len() > 10_000);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_malformed_world_file_gives_a_clear_error_not_a_panic() {
    let dir = std::env::temp_dir().join(format!("lives-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases = [
        ("syntax.toml", "name = \"x\"\ntime_limit_s = 60\n[start\nposition = [1, 1]\n", "syntax.toml:3"),
        (
            "negative.toml",
            "name = \"x\"\ntime_limit_s = 60\n\n[[obstacles]]\nkind = \"furniture\"\nrect = { center = [2.0, 2.0], size = [-1.0, 2.0] }\n",
            "negative.toml:",
        ),
    ];
    // A complete world whose time limit is NaN, and one whose first obstacle has a negative size:
    // the error names the exact line.
    let good = String::from_utf8(lives().args(["worlds", "--export", "apartment"]).output().unwrap().stdout).unwrap();
    let limit_line = good.lines().position(|l| l.starts_with("time_limit_s")).expect("time_limit_s line") + 1;
    let nan = good.replacen(good.lines().nth(limit_line - 1).unwrap(), "time_limit_s = nan", 1);
    let nan_want = format!("nan.toml:{limit_line}");
    let cases: Vec<(&str, String, &str)> =
        cases.iter().map(|(f, t, w)| (*f, t.to_string(), *w)).chain([("nan.toml", nan, nan_want.as_str())]).collect();
    for (file, text, want) in cases {
        let path = dir.join(file);
        std::fs::write(&path, text).unwrap();
        let out = lives().args(["search", "--world"]).arg(&path).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{file}: {stderr}");
        assert!(stderr.starts_with("error: "), "{file}: {stderr}");
        assert!(stderr.contains(want), "{file}: expected `{want}` in: {stderr}");
        assert!(!stderr.contains("panicked"), "{file}: {stderr}");
    }
    let out = lives().args(["search", "--world", "no-such-world"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown world `no-such-world`"));
    let out = lives().args(["search", "--set", "w_dist_per_m=banana"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn worlds_lists_every_built_in_world_and_exports_a_loadable_file() {
    let out = lives().arg("worlds").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for w in ["apartment", "office", "hallway"] {
        assert_eq!(text.lines().filter(|l| l.starts_with(w)).count(), 2, "{text}");
    }
    let out = lives().args(["worlds", "--export", "office", "--scenario", "hard"]).output().unwrap();
    assert!(out.status.success());
    let dir = std::env::temp_dir().join(format!("lives-cli-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("office-hard.toml");
    std::fs::write(&path, &out.stdout).unwrap();
    let out = lives().args(["search", "--planner", "nearest", "--json", "--world"]).arg(&path).output().unwrap();
    assert!(out.status.code() == Some(0) || out.status.code() == Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["world"], "office-hard");
    assert_eq!(v["scenario"], "file", "a world file holds its own scenario");
    // ... so `--scenario` with one is refused, not ignored.
    let out = lives().args(["search", "--scenario", "easy", "--world"]).arg(&path).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("holds its own scenario"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_corrupt_model_blob_is_refused_with_a_clear_error() {
    let dir = std::env::temp_dir().join(format!("lives-cli-model-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.bin");
    std::fs::write(&path, b"LIVM but not really a model").unwrap();
    let out = lives().args(["search", "--planner", "lives", "--model"]).arg(&path).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("the model does not validate"), "{stderr}");
    assert!(!stderr.contains("panicked"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn eval_writes_the_table_json_csv_and_plots() {
    let dir = std::env::temp_dir().join(format!("lives-eval-{}", std::process::id()));
    let out = lives()
        .args(["eval", "--trials", "2", "--worlds", "apartment", "--scenarios", "easy", "--planners", "nearest,lives-gt", "--threads", "2"])
        .args(["--heldout", "2"])
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(table.contains("| setting | limit | nearest | lives-gt |"), "{table}");
    assert!(table.contains("| apartment easy | 120 s |"), "{table}");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    // Two held-out worlds (one easy, one hard), one trial each, per planner: 4 more searches and
    // two more rows; every trial has an oracle.
    assert!(table.contains("| heldout easy | per world |") && table.contains("| heldout hard | per world |"), "{table}");
    assert!(table.contains("| setting | oracle, mean | nearest | lives-gt |"), "{table}");
    assert!(table.contains("Robot: `calibrated`"), "{table}");
    assert_eq!(json["trials"].as_array().unwrap().len(), 8);
    assert!(json["trials"].as_array().unwrap().iter().all(|t| t["oracle_s"].as_f64().is_some_and(|o| o >= 0.0)), "{json}");
    assert_eq!(json["summary"].as_array().unwrap().len(), 6);
    let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 7, "{csv}");
    for png in ["times.png", "trajectories/apartment-easy-nearest.png", "trajectories/apartment-easy-lives-gt.png"] {
        assert_eq!(&std::fs::read(dir.join(png)).unwrap()[..8], b"\x89PNG\r\n\x1a\n", "{png}");
    }
    // The same trials give the same numbers (the summary, not the wall time).
    let again = lives()
        .args([
            "eval",
            "--trials",
            "2",
            "--worlds",
            "apartment",
            "--scenarios",
            "easy",
            "--planners",
            "nearest,lives-gt",
            "--threads",
            "1",
            "--no-pictures",
            "--heldout",
            "2",
        ])
        .arg("--out")
        .arg(dir.join("again"))
        .output()
        .unwrap();
    assert!(again.status.success());
    assert_eq!(std::fs::read_to_string(dir.join("again/results.csv")).unwrap(), csv);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn tune_rejects_unknown_parameters_before_running_and_ranks_a_grid() {
    let out = lives().args(["tune", "--grid", "no_such_knob=1,2"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown parameter `no_such_knob`"));
    let path = std::env::temp_dir().join(format!("lives-tune-{}.json", std::process::id()));
    let out = lives()
        .args(["tune", "--worlds", "1", "--planners", "nearest", "--grid", "replan_interval_s=2,3", "--out"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let ranking: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    // The defaults and the two grid values; 3 s is the default replan interval, so it pairs
    // with the defaults at exactly 0.
    let ranking = ranking.as_array().unwrap();
    assert_eq!(ranking.len(), 3);
    let three = ranking.iter().find(|r| r["sets"] == serde_json::json!(["replan_interval_s=3"])).unwrap();
    assert_eq!((three["vs_defaults"].as_f64(), three["vs_defaults_ci95"].as_f64()), (Some(0.0), Some(0.0)));
    assert!(ranking.iter().any(|r| r["sets"] == serde_json::json!([])));
    assert!(String::from_utf8_lossy(&out.stdout).contains("best on random worlds 1..=1"));
    // A held-out range: other worlds, so other searches.
    let held_out = lives()
        .args(["tune", "--first-world", "7", "--worlds", "1", "--planners", "nearest", "--grid", "replan_interval_s=2", "--out"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(held_out.status.success(), "{}", String::from_utf8_lossy(&held_out.stderr));
    assert!(String::from_utf8_lossy(&held_out.stdout).contains("on random worlds 7..=7"));
    let other: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let defaults = |r: &[serde_json::Value]| r.iter().find(|r| r["sets"] == serde_json::json!([])).unwrap()["per_search"].clone();
    assert_ne!(defaults(ranking), defaults(other.as_array().unwrap()), "world 7 is not world 1");
    let out =
        lives().args(["tune", "--first-world", "18446744073709551615", "--worlds", "2", "--grid", "w_dist_per_m=1"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "a range past the last seed is refused");
    let _ = std::fs::remove_file(&path);
}

#[test]
fn sim_settings_change_the_simulated_robot_and_bad_ones_are_refused() {
    let search = |extra: &[&str]| {
        let out = lives()
            .args(["search", "--world", "apartment", "--scenario", "easy", "--planner", "nearest", "--seed", "1", "--json"])
            .args(extra)
            .output()
            .unwrap();
        assert_ne!(out.status.code(), Some(101), "panicked: {}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_str(String::from_utf8_lossy(&out.stdout).trim()).expect("one JSON object");
        v
    };
    let default = search(&[]);
    assert!(default.get("sim").is_none(), "the default robot is not echoed: {default}");
    // The short robot is not the default: its 4 m camera is echoed.
    let short = search(&["--robot", "short"]);
    assert_eq!(short["sim"]["camera_range_m"], 4.0, "{short}");
    // `nearest` seed 1 walks for the whole limit (52.7 m at the default 0.5 m/s); at 0.2 m/s the
    // base cannot cover more than 0.2 m/s × the time it ran.
    let slow = search(&["--sim", "speed_mps=0.2", "--sim", "camera_range_m=6"]);
    assert_eq!(slow["sim"]["speed_mps"], 0.2);
    assert_eq!(slow["sim"]["camera_range_m"], 6.0);
    assert_eq!(slow["sim"]["turn_rate_rps"], 1.0, "the rest stay at their defaults");
    let (path, time) = (slow["path_m"].as_f64().unwrap(), slow["time_s"].as_f64().unwrap());
    assert!(path > 1.0 && path <= 0.2 * time + 0.05, "path {path} m in {time} s at 0.2 m/s");
    assert!(default["path_m"].as_f64().unwrap() > 0.2 * default["time_s"].as_f64().unwrap() + 1.0, "{default}");
    for (bad, says) in [
        ("speed_mps=0", "speed_mps"),
        ("dropout_prob=1.5", "dropout_prob"),
        ("camera_fov_deg=NaN", "camera_fov_deg"),
        ("beams=16", "unknown simulator setting `beams`"),
        ("speed_mps", "expected name=value"),
    ] {
        let out = lives().args(["search", "--sim", bad]).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {err}");
        assert!(err.contains(says), "{bad}: {err}");
    }
}

#[test]
fn node_and_replay_refuse_a_bad_model_before_starting() {
    let readme = concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md");
    for args in [
        vec!["node", "--port", "/nonexistent/tty", "--model", readme],
        vec!["replay", "/nonexistent/log.gz", "--model", readme],
        vec!["search", "--model", readme],
    ] {
        let out = lives().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("the model does not validate: not a classifier blob"), "{args:?}: {err}");
    }
    // `/dev/zero` is refused before it is opened (not a regular file), a file larger than any
    // blob by its size without being read whole; a planner that runs no classifier refuses
    // `--model` rather than ignoring it.
    let out = lives().args(["search", "--model", "/dev/zero"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/dev/zero: not a regular file"));
    let big = std::env::temp_dir().join(format!("lives-big-blob-{}", std::process::id()));
    std::fs::File::create(&big).unwrap().set_len(64 << 20).unwrap();
    let out = lives().args(["search", "--model", big.to_str().unwrap()]).output().unwrap();
    let _ = std::fs::remove_file(&big);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("larger than any classifier blob"));
    let geo = concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware/model/lives-geo-int8.bin");
    let out = lives().args(["search", "--planner", "nearest", "--model", geo]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("`nearest` runs none"));
    let out = lives().args(["node", "--port", "/nonexistent/tty", "--model", readme, "--no-model"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "--model and --no-model conflict");
}

#[test]
fn a_cut_off_trace_replays_its_good_records_then_fails() {
    let golden = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/golden.trace");
    let bytes = std::fs::read(&golden).unwrap();
    let full = lives().args(["trace", "replay"]).arg(&golden).output().unwrap();
    assert!(full.status.success(), "{}", String::from_utf8_lossy(&full.stderr));
    let full = String::from_utf8(full.stdout).unwrap();
    let dir = std::env::temp_dir().join(format!("lives-cli-trace-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let half = dir.join("half.trace");
    std::fs::write(&half, &bytes[..bytes.len() / 2]).unwrap();
    let out = lives().args(["trace", "replay"]).arg(&half).output().unwrap();
    // Before: status 2 and nothing printed.
    assert_eq!(out.status.code(), Some(1));
    let printed = String::from_utf8(out.stdout).unwrap();
    let n = printed.lines().count();
    assert!(n > 10, "{printed}");
    assert_eq!(
        printed.lines().collect::<Vec<_>>(),
        full.lines().take(n).collect::<Vec<_>>(),
        "the good records replay as in the whole trace"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!("trace record {n} is cut off")) && err.contains(&format!("the {n} records before it were replayed")),
        "{err}"
    );
    // No good record (the header and part of the first): nothing to replay, status 2.
    std::fs::write(&half, &bytes[..30]).unwrap();
    let out = lives().args(["trace", "replay"]).arg(&half).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replay_refuses_an_absurd_max_range_in_few_digits() {
    let out = lives().args(["replay", "/nonexistent/log.gz", "--max-range", "1e300"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--max-range 1e300: expected metres"), "{err}");
    assert!(err.len() < 200, "{err}");
}

#[test]
fn lidar_decode_refuses_a_file_without_a_packet_and_names_the_damage_it_skips() {
    let dir = std::env::temp_dir().join(format!("lives-cli-lidar-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let decode = |path: &std::path::Path, json: bool| {
        let mut cmd = lives();
        cmd.args(["lidar", "decode"]).arg(path);
        if json {
            cmd.arg("--json");
        }
        let out = cmd.output().unwrap();
        (out.status.code(), String::from_utf8(out.stdout).unwrap(), String::from_utf8(out.stderr).unwrap())
    };
    // A text file and an empty file: one clear error each, status 2 (before: the README gave 28 lines
    // of "rejected at byte …" and status 1, the empty file status 0 and no word).
    let readme = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md");
    let empty = dir.join("empty.bin");
    std::fs::write(&empty, b"").unwrap();
    for (path, why) in [(&readme, "no packet found (neither pcap nor raw 1206-byte payloads)"), (&empty, "the file is empty")] {
        let (code, stdout, stderr) = decode(path, false);
        assert_eq!(code, Some(2), "{stderr}");
        assert_eq!(stdout, "");
        assert_eq!(stderr, format!("error: {} is not a VLP-16 capture: {why}\n", path.display()));
    }
    // Nothing decoded is status 2 too: a pcap holding only its file header, a file cut inside its
    // first packet.
    let clean = std::fs::read(host::io::sensors::vlp16::default_recording()).unwrap();
    let pcap = std::fs::read(host::io::sensors::vlp16::default_recording().with_file_name("velodyne_vlp16.pcap")).unwrap();
    let (hdr, cut) = (dir.join("hdr.pcap"), dir.join("cut.bin"));
    std::fs::write(&hdr, &pcap[..24]).unwrap();
    std::fs::write(&cut, &clean[..500]).unwrap();
    for (path, why) in [
        (&hdr, "no VLP-16 data packet among its 0 pcap records (0 other traffic, 0 rejected)".to_string()),
        (&cut, "byte 0: the file ends 500 bytes into a 1206-byte packet (no VLP-16 data packet before it)".to_string()),
    ] {
        let (code, stdout, stderr) = decode(path, true);
        assert_eq!((code, stdout.as_str()), (Some(2), ""));
        assert_eq!(stderr, format!("error: {}: {why}\n", path.display()));
    }
    // The real recording with one byte inserted into packet 500: resynchronised after it, status 1.
    let mut bytes = clean.clone();
    bytes.insert(500 * 1206 + 321, 0);
    let ins = dir.join("ins.bin");
    std::fs::write(&ins, &bytes).unwrap();
    let (code, stdout, stderr) = decode(&ins, false);
    assert_eq!(code, Some(1));
    assert!(
        stdout.ends_with(&format!(
            "{} (raw): 999 data packets, 0 rejected, 0 other, 1207 bytes skipped; scans: 13 + 1 partial; lasers [1, -1]°, 897 beams\n",
            ins.display()
        )),
        "{stdout}"
    );
    assert_eq!(
        stderr,
        format!(
            "warning: byte 603000: 1207 bytes skipped to the next packet (none starts in them)\n\
             error: {}: 1207 bytes skipped; the 999 packets around it were decoded\n",
            ins.display()
        )
    );
    let (code, stdout, _) = decode(&ins, true);
    assert_eq!(code, Some(1));
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["packets"]["data"], 999);
    assert_eq!(v["scans"].as_array().unwrap().len(), 13);
    assert_eq!(v["skipped_bytes"], 1207);
    assert_eq!(v["skips"], serde_json::json!([{"offset": 603000, "bytes": 1207}]));
    // Ten packets with a broken flag: the first five are named, the rest counted.
    let mut bytes = clean.clone();
    for k in 0..10 {
        bytes[k * 100 * 1206 + 500] = 0;
    }
    let flags = dir.join("flags.bin");
    std::fs::write(&flags, &bytes).unwrap();
    let (code, _, stderr) = decode(&flags, false);
    assert_eq!(code, Some(1));
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 7, "{stderr}");
    assert_eq!(lines[0], "warning: byte 0: block 5 starts with 00 EE, expected FF EE (packet rejected)");
    assert_eq!(lines[5], "warning: … and 5 more packets rejected");
    assert_eq!(lines[6], format!("error: {}: 10 packets rejected; the 990 packets around them were decoded", flags.display()));
    // The clean recording: status 0, nothing on stderr.
    let (code, _, stderr) = decode(&host::io::sensors::vlp16::default_recording(), false);
    assert_eq!((code, stderr.as_str()), (Some(0), ""));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn docs_params_md_is_what_lives_params_markdown_prints() {
    let out = lives().args(["params", "--markdown"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/params.md");
    let committed = std::fs::read_to_string(path).unwrap_or_default();
    assert!(
        committed == String::from_utf8(out.stdout).unwrap(),
        "docs/params.md is not what `lives params --markdown` prints: regenerate it with\n  \
         cargo run --release -p host --bin lives -- params --markdown > docs/params.md"
    );
    let text = lives().arg("params").output().unwrap();
    assert!(text.status.success() && String::from_utf8_lossy(&text.stdout).contains("replan_interval_s"));
}
