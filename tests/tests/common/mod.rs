//! Helpers shared by the end-to-end tests: the `lives` program, and guards that keep a failing
//! real-time test from hanging the suite. (Each test binary uses some of them.)
#![allow(dead_code)]

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

/// The `lives` binary, built now (this package cannot name another package's binary).
pub fn lives() -> &'static Path {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        let out = Command::new(env!("CARGO"))
            .current_dir(root())
            .args([
                "build",
                "--release",
                "-p",
                "host",
                "--features",
                "ros-bags,ros2",
                "--bin",
                "lives",
                "--message-format=json-render-diagnostics",
            ])
            .stderr(Stdio::inherit())
            .output()
            .expect("cargo runs");
        assert!(out.status.success(), "building `lives` failed");
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| serde_json::from_str::<Value>(l).ok())
            .filter(|v| v["target"]["name"] == "lives")
            .find_map(|v| v["executable"].as_str().map(PathBuf::from))
            .expect("cargo names the lives executable")
    })
}

/// Sets every flag when dropped: a test that runs a node or a bridge on a scoped thread holds
/// one inside the scope, so that a failed assertion stops those threads and the test fails
/// instead of waiting for them for ever.
pub struct StopOnDrop<'a>(pub &'a [&'a std::sync::atomic::AtomicBool]);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        for f in self.0 {
            f.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    }
}

/// Ends the whole test process with a message if the holder is still alive after `limit`: a
/// test that talks to threads, sockets or child processes in real time can hang in ways an
/// assertion cannot catch, and a hung suite tells nobody which test it was.
pub struct HangGuard(Option<std::sync::mpsc::Sender<()>>);

pub fn hang_guard(what: &'static str, limit: std::time::Duration) -> HangGuard {
    let (tx, rx) = std::sync::mpsc::channel::<()>();
    std::thread::spawn(move || {
        if let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = rx.recv_timeout(limit) {
            eprintln!("HUNG: `{what}` still running after {limit:?}; ending the test process");
            std::process::exit(3);
        }
    });
    HangGuard(Some(tx))
}

impl Drop for HangGuard {
    fn drop(&mut self) {
        if let Some(tx) = self.0.take() {
            let _ = tx.send(());
        }
    }
}
