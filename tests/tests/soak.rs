//! The short soak in CI (issue 29; `docs/reliability.md` has the long one): `lives soak` for
//! about 25 s of real time on a pseudo-terminal (node process, noisy line, a silent and an
//! unplugged pull) and 0.1 h simulated. It must pass (exit 0) and its report must show what it
//! measured: the node's memory sampled, every pull answered by a stop within one watchdog period
//! and a resume.

use std::process::Command;

mod common;

#[test]
fn a_short_soak_stays_up_stops_on_every_pull_and_resumes() {
    let json = std::env::temp_dir().join(format!("lives-soak-{}.json", std::process::id()));
    let out = Command::new(common::lives())
        .args(["soak", "--minutes", "0.42", "--sim-hours", "0.1", "--pull-every", "7", "--pull-for", "1.5", "--sample-every", "1"])
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stdout}");
    assert_eq!(out.status.code(), Some(0), "{stdout}\n{stderr}");
    assert!(stdout.trim_end().ends_with("PASS"), "{stdout}");
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let rt = &r["real_time"];
    assert!(rt["node"].as_array().unwrap().len() >= 15, "node samples: {}", rt["node"]);
    let pulls = rt["pulls"].as_array().unwrap();
    assert!(pulls.len() >= 2, "{pulls:?}");
    let kinds: Vec<&str> = pulls.iter().map(|p| p["kind"].as_str().unwrap()).collect();
    assert_eq!(&kinds[..2], ["silent", "unplugged"]);
    for p in pulls.iter().filter(|p| p["search_ended_during"] == false) {
        let stop = p["stopped_after_ms"].as_f64().unwrap_or(f64::INFINITY);
        assert!(stop <= 1500.0, "{p}");
        assert!(p["resumed_after_ms"].as_f64().is_some(), "{p}");
    }
    assert!(rt["node_report"]["ticks"].as_u64().unwrap() >= 100, "{}", rt["node_report"]);
    assert!(r["simulated"]["sim_s"].as_f64().unwrap() >= 360.0);
    assert_eq!(r["failures"].as_array().unwrap().len(), 0);
    let _ = std::fs::remove_file(&json);
}
