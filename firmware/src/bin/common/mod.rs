//! What every Cortex-M image shares (included by each `src/bin/mcu-*.rs` as `mod common`): the
//! board's registers (SysTick clock, CMSDK UART0), statics initialised in place, the fault path
//! (panic, HardFault, unexpected interrupts), semihosting helpers, and the node loop.
//!
//! Target: QEMU `mps2-an386` (Cortex-M4F, 25 MHz; memory map in `memory.x`). See docs/mcu.md.
#![allow(dead_code)]

pub mod clock;
pub mod fault;
pub mod slot;
pub mod trace_app;
pub mod uart;

use cortex_m_semihosting::hprintln;
use firmware::classifier::EMBEDDED_GEO_MODEL;
use firmware::node::{Node, NodeConfig, TimeMode};
use firmware::{Config, Controller};
use slot::Slot;

/// The controller (~1 MiB), built at compile time with the default configuration (`.data`, see
/// [`slot`]); the node sends it the host's configuration.
pub static CONTROLLER: Slot<Controller> = Slot::with(Controller::new(Config::DEFAULT));
/// The node (~8 KiB), in `.bss`, built at run time.
pub static NODE: Slot<Node> = Slot::new();

/// Builds the controller (default configuration, the embedded geometric classifier installed, the default of `lives search --planner lives`) and a node in
/// `mode`, in their statics. Call once.
pub fn init_core(mode: TimeMode) -> (&'static mut Controller, &'static mut Node) {
    let ctl = CONTROLLER.take();
    let node = NODE.init(|s| s.write(Node::new(NodeConfig::new(mode))));
    if let Err(e) = ctl.set_model(EMBEDDED_GEO_MODEL) {
        // Without a model the core still runs on labelled scans; say so rather than stop.
        hprintln!("warning: the embedded classifier model does not validate: {:?}", e);
    }
    (ctl, node)
}

/// The controller as a node on UART0, for ever: bytes from the line go to the node (which ticks
/// on lockstep batches), its frames go back. In real time the node also ticks on every SysTick
/// period (200 ms); a period missed while a tick ran is counted, not caught up.
pub fn run_node(mode: TimeMode) -> ! {
    let mut cp = cortex_m::Peripherals::take().unwrap_or_else(|| fault::stop(format_args!("peripherals taken twice")));
    let (ctl, node) = init_core(mode);
    clock::start(&mut cp.SYST);
    uart::init(uart::BAUD);
    hprintln!("LIVES node on UART0 ({:?})", mode);
    let mut buf = [0u8; 256];
    let mut ticked = clock::periods();
    let mut missed = 0u32;
    loop {
        let n = uart::read(&mut buf);
        if n > 0 {
            node.receive(&buf[..n], ctl, uart::write_all);
        }
        if mode == TimeMode::RealTime {
            let now = clock::periods();
            if now != ticked {
                missed = missed.wrapping_add(now.wrapping_sub(ticked).wrapping_sub(1));
                ticked = now;
                node.tick(u64::from(now) * clock::PERIOD_US, ctl, uart::write_all);
            }
        }
        if n == 0 {
            // Sleep until the next interrupt (a byte from the line or the SysTick period). With
            // interrupts masked, a byte that arrives after the check still wakes the WFI.
            cortex_m::interrupt::disable();
            if !uart::pending() && (mode == TimeMode::Lockstep || clock::periods() == ticked) {
                cortex_m::asm::wfi();
            }
            // SAFETY: re-enables what was disabled just above (no critical section is open).
            unsafe { cortex_m::interrupt::enable() };
        }
    }
}

/// The semihosting command line (`-semihosting-config enable=on,arg=...`) into `buf`; "" if none.
pub fn cmdline(buf: &mut [u8]) -> &str {
    let mut args = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: SYS_GET_CMDLINE writes at most `args[1]` bytes to `args[0]` and the length back.
    let r = unsafe { cortex_m_semihosting::syscall1(cortex_m_semihosting::nr::GET_CMDLINE, args.as_mut_ptr() as usize) };
    // SAFETY: the host wrote `args` through the pointer; read it back without assuming it did not.
    let n = unsafe { core::ptr::read_volatile(&args[1]) };
    if r != 0 || n > buf.len() {
        return "";
    }
    core::str::from_utf8(&buf[..n]).unwrap_or("")
}

/// Ends the QEMU run with success.
pub fn exit_ok() -> ! {
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_SUCCESS);
    fault::halt()
}
