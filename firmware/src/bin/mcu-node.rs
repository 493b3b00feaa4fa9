//! The controller on a Cortex-M (QEMU `mps2-an386`): the serial protocol on UART0, a control
//! tick every 200 ms driven by SysTick (real time: the deployment). See docs/mcu.md.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod common;

firmware::mcu_main! {
    common::run_node(firmware::node::TimeMode::RealTime)
}
