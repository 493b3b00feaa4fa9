//! The controller on a Cortex-M (QEMU `mps2-an386`): the serial protocol on UART0, a control
//! tick every 200 ms driven by SysTick (real time: the deployment). See docs/mcu.md.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod common;

#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    common::run_node(firmware::node::TimeMode::RealTime)
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("mcu-node is a Cortex-M image: build it with --target thumbv7em-none-eabihf (docs/mcu.md)");
    std::process::exit(2);
}
