//! The fault path: a panic, a HardFault or an unexpected interrupt reports what happened (on the
//! semihosting console) and stops the robot: a `Stop` frame on UART0 at once and then every
//! ~100 ms for ever, and the QEMU run ends with a failure status. Nothing hangs silently.

use core::fmt;
use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};
use cortex_m_rt::{exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hprintln};
use firmware::protocol::{encode, CoreToHost, StopMsg, WireMode};

static FAULTED: AtomicBool = AtomicBool::new(false);

/// Sends one `Stop` frame on UART0 (if it was set up).
fn send_stop() {
    if super::uart::ready() {
        let mut buf = [0u8; 32];
        if let Ok(frame) = encode(&CoreToHost::Stop(StopMsg { mode: WireMode::Stopped }), &mut buf) {
            super::uart::write_all(frame);
        }
    }
}

/// Never returns: keeps telling the base to stop.
pub fn halt() -> ! {
    cortex_m::interrupt::disable();
    loop {
        send_stop();
        // ~100 ms at 25 MHz (a few instructions per iteration).
        for _ in 0..800_000 {
            cortex_m::asm::nop();
        }
    }
}

/// Reports `what`, stops the robot, ends the run with a failure.
pub fn stop(what: fmt::Arguments<'_>) -> ! {
    cortex_m::interrupt::disable();
    if FAULTED.swap(true, Ordering::AcqRel) {
        // A fault while reporting a fault: just stop.
        halt();
    }
    send_stop();
    hprintln!("LIVES FAULT: {}", what);
    hprintln!("LIVES FAULT: the robot was told to stop");
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

#[panic_handler]
fn panic(info: &PanicInfo<'_>) -> ! {
    stop(format_args!("panic: {}", info))
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    // SAFETY: the System Control Block's fault status and address registers (always mapped).
    let (cfsr, hfsr, mmfar, bfar) = unsafe {
        (
            core::ptr::read_volatile(0xE000_ED28 as *const u32),
            core::ptr::read_volatile(0xE000_ED2C as *const u32),
            core::ptr::read_volatile(0xE000_ED34 as *const u32),
            core::ptr::read_volatile(0xE000_ED38 as *const u32),
        )
    };
    stop(format_args!(
        "HardFault at pc={:#010x} lr={:#010x} xpsr={:#010x} CFSR={:#010x} HFSR={:#010x} MMFAR={:#010x} BFAR={:#010x}",
        ef.pc(),
        ef.lr(),
        ef.xpsr(),
        cfsr,
        hfsr,
        mmfar,
        bfar
    ))
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) {
    if irqn == super::uart::UART0_RX_IRQ as i16 {
        super::uart::on_rx_interrupt();
    } else {
        stop(format_args!("unexpected exception or interrupt {}", irqn))
    }
}
