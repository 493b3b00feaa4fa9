//! The golden trace on the MCU (QEMU `mps2-an386`, run with `-icount shift=0`): replays
//! `tests/fixtures/golden.trace`, embedded in flash (with the `LabelPoseNet` model it asks for),
//! through the node and the controller exactly as the host does (`firmware::mcu::trace`), and
//! prints per record (lines `R`) the digest of the node's answer and the SysTick counts of each
//! stage; then the stack high-water mark. The known-map trace has its own image
//! (`mcu-trace-live`): the two traces, the model and the controller's `.data` image do not fit one
//! image's 4 MiB of flash. Output format in docs/mcu.md.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod common;

#[cfg(target_os = "none")]
static TRACE: &[u8] = include_bytes!("../../../tests/fixtures/golden.trace");

firmware::mcu_main! {
    common::trace_app::run(TRACE, "R")
}
