//! Build facts the code needs but stable Rust does not give.
//!
//! * `lives_dsp`: the target has the Arm DSP extension (SMLAD, SXTB16): every `thumbv7em` target
//!   (Cortex-M4/M7). The classifier's int8 inner product then uses it (`classifier::dot`). Stable
//!   Rust reports no Arm `target_feature`s, hence the target name.
//! * For bare-metal targets, the workspace's `memory.x` (the board's memory map, included by
//!   `cortex-m-rt`'s `link.x`) is put on the linker's search path and relinks when it changes.

use std::path::PathBuf;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(lives_dsp)");
    println!("cargo::rerun-if-changed=build.rs");
    let target = std::env::var("TARGET").unwrap_or_default();
    if target.starts_with("thumbv7em") {
        println!("cargo::rustc-cfg=lives_dsp");
    }
    if target.starts_with("thumb") {
        let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
        let memory_x = manifest.join("../memory.x");
        let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
        match std::fs::copy(&memory_x, out.join("memory.x")) {
            Ok(_) => println!("cargo::rustc-link-search={}", out.display()),
            Err(e) => println!("cargo::warning=cannot copy {}: {e} (the MCU images will not link)", memory_x.display()),
        }
        println!("cargo::rerun-if-changed={}", memory_x.display());
    }
}
