//! Helpers shared by the end-to-end tests that run the `lives` program itself.

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
                "ros-bags",
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
