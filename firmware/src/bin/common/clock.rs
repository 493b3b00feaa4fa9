//! SysTick as the controller's clock: the processor clock (25 MHz on `mps2-an386`), reloading
//! every 200 ms (the control period), an interrupt per period. [`now_counts`] combines the
//! period count with the down-counter into a 64-bit count of 40 ns steps. Under QEMU with
//! `-icount shift=0` every guest instruction advances time 1 ns, so one count is 40 guest
//! instructions, the same from run to run.

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::exception;

/// Processor clock of the board (Hz).
pub const CPU_HZ: u32 = 25_000_000;
/// Control period: 200 ms (the LiDAR's 5 Hz), µs.
pub const PERIOD_US: u64 = 200_000;
/// SysTick counts per period.
pub const PERIOD_COUNTS: u32 = (CPU_HZ as u64 * PERIOD_US / 1_000_000) as u32;
/// Guest instructions per SysTick count under `-icount shift=0` (1 ns each, 25 MHz).
pub const INSTRUCTIONS_PER_COUNT: u64 = 1_000_000_000 / CPU_HZ as u64;

static PERIODS: AtomicU32 = AtomicU32::new(0);

/// Starts the clock (from 0).
pub fn start(syst: &mut SYST) {
    syst.disable_interrupt();
    syst.disable_counter();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(PERIOD_COUNTS - 1);
    syst.clear_current();
    syst.enable_counter();
    // The counter reads 0 until its first reload (which may also pend a wrap): start from there.
    while SYST::get_current() == 0 {}
    // SAFETY: a write of a System Control Block register (PENDSTCLR: forget a pending SysTick).
    unsafe { core::ptr::write_volatile(ICSR as *mut u32, PENDSTCLR) };
    PERIODS.store(0, Ordering::Release);
    syst.enable_interrupt();
}

/// Whole periods since [`start`].
pub fn periods() -> u32 {
    PERIODS.load(Ordering::Acquire)
}

/// Interrupt Control and State Register; bit 26: the SysTick exception is pending.
const ICSR: *const u32 = 0xE000_ED04 as *const u32;
const PENDSTSET: u32 = 1 << 26;
/// ICSR bit 25: clear a pending SysTick.
const PENDSTCLR: u32 = 1 << 25;

/// SysTick counts since [`start`].
///
/// The counter may have wrapped before its interrupt ran (QEMU takes interrupts between
/// translation blocks, a real core a few cycles late): a pending SysTick means one more period,
/// and the counter is read again after seeing it, so the value is surely past the wrap.
pub fn now_counts() -> u64 {
    loop {
        let p = PERIODS.load(Ordering::Acquire);
        let mut v = SYST::get_current();
        // SAFETY: a read of a System Control Block register (always mapped).
        let pending = unsafe { core::ptr::read_volatile(ICSR) } & PENDSTSET != 0;
        if pending {
            v = SYST::get_current();
        }
        // The interrupt ran meanwhile: read again.
        if PERIODS.load(Ordering::Acquire) == p {
            let periods = u64::from(p) + u64::from(pending);
            return periods * u64::from(PERIOD_COUNTS) + u64::from(PERIOD_COUNTS - 1 - v);
        }
    }
}

#[exception]
fn SysTick() {
    PERIODS.fetch_add(1, Ordering::AcqRel);
}
