//! The known-map trace on the MCU (QEMU `mps2-an386`, run with `-icount shift=0`): replays
//! `tests/fixtures/golden-live.trace`, a LIVE search of a known building, embedded in flash,
//! through the node and the controller exactly as the host does (`firmware::mcu::trace`), and
//! prints per record (lines `L`) the digest of the node's answer and the SysTick counts of each
//! stage; then the stack high-water mark. Output format in docs/mcu.md.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod common;

#[cfg(target_os = "none")]
static TRACE_LIVE: &[u8] = include_bytes!("../../../tests/fixtures/golden-live.trace");

firmware::mcu_main! {
    common::trace_app::run(TRACE_LIVE, "L")
}
