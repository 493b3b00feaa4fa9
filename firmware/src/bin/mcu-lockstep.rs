//! The controller on a Cortex-M (QEMU `mps2-an386`), serial protocol on UART0, ticking in
//! lockstep with the host (`lives bridge --lockstep`): deterministic, for simulation and the
//! end-to-end test. See docs/mcu.md.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod common;

firmware::mcu_main! {
    common::run_node(firmware::node::TimeMode::Lockstep)
}
