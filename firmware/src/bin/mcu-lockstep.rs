//! The controller on a Cortex-M (QEMU `mps2-an386`), serial protocol on UART0, ticking in
//! lockstep with the host (`lives bridge --lockstep`): deterministic, for simulation and the
//! end-to-end test. See docs/mcu.md.
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[cfg(target_os = "none")]
mod common;

#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    common::run_node(firmware::node::TimeMode::Lockstep)
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("mcu-lockstep is a Cortex-M image: build it with --target thumbv7em-none-eabihf (docs/mcu.md)");
    std::process::exit(2);
}
