//! The board's CMSDK APB UART0 (0x4000_4000; ARM DDI0479C): blocking transmit, interrupt-driven
//! receive into a ring buffer, so bytes that arrive while a tick runs are kept.
//!
//! Registers: DATA (0x00), STATE (0x04: bit 0 TX full, bit 1 RX full, bits 2/3 overruns),
//! CTRL (0x08: TX enable, RX enable, TX/RX interrupt enables), INTSTATUS (0x0C, write 1 to
//! clear), BAUDDIV (0x10). On `mps2-an386` UART0's receive interrupt is IRQ 0.

use core::cell::UnsafeCell;
use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;

/// UART0's base address.
pub const UART0: usize = 0x4000_4000;
/// UART0's receive interrupt.
pub const UART0_RX_IRQ: u16 = 0;
/// Line rate (meaningful on a real UART; QEMU ignores it).
pub const BAUD: u32 = 921_600;

const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTSTATUS: usize = 0x0C;
const BAUDDIV: usize = 0x10;
const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const STATE_RX_OVERRUN: u32 = 1 << 3;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_RX_INT_EN: u32 = 1 << 3;
const INT_RX: u32 = 1 << 1;

fn reg(offset: usize) -> *mut u32 {
    (UART0 + offset) as *mut u32
}

fn read_reg(offset: usize) -> u32 {
    // SAFETY: a device register of UART0 (always mapped on the board).
    unsafe { read_volatile(reg(offset)) }
}

fn write_reg(offset: usize, v: u32) {
    // SAFETY: as above.
    unsafe { write_volatile(reg(offset), v) }
}

#[derive(Clone, Copy)]
struct Irq(u16);

// SAFETY: a valid external interrupt number of the board.
unsafe impl InterruptNumber for Irq {
    fn number(self) -> u16 {
        self.0
    }
}

static READY: AtomicBool = AtomicBool::new(false);

/// Bytes the ring buffer had no room for, and hardware overruns.
pub static RX_LOST: AtomicU32 = AtomicU32::new(0);

const RING: usize = 16 * 1024;

/// Single-producer (the RX interrupt) single-consumer (the main loop) byte ring.
struct Ring {
    buf: UnsafeCell<[u8; RING]>,
    head: AtomicUsize,
    tail: AtomicUsize,
}

// SAFETY: the interrupt only writes `buf[head]` then publishes `head`; the main loop only reads
// `buf[tail]` below `head` then publishes `tail`.
unsafe impl Sync for Ring {}

static RX: Ring = Ring { buf: UnsafeCell::new([0; RING]), head: AtomicUsize::new(0), tail: AtomicUsize::new(0) };

/// Enables UART0 (8N1 at `baud`, receive interrupt on).
pub fn init(baud: u32) {
    write_reg(CTRL, 0);
    write_reg(BAUDDIV, (super::clock::CPU_HZ / baud).max(16));
    write_reg(INTSTATUS, 0xF);
    write_reg(CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INT_EN);
    READY.store(true, Ordering::Release);
    // SAFETY: the handler (`on_rx_interrupt`) only touches the ring.
    unsafe { NVIC::unmask(Irq(UART0_RX_IRQ)) };
}

/// True once [`init`] ran.
pub fn ready() -> bool {
    READY.load(Ordering::Acquire)
}

/// Sends `bytes`, waiting while the transmitter is full.
pub fn write_all(bytes: &[u8]) {
    for &b in bytes {
        while read_reg(STATE) & STATE_TX_FULL != 0 {}
        write_reg(DATA, u32::from(b));
    }
}

/// True if received bytes wait in the ring.
pub fn pending() -> bool {
    RX.head.load(Ordering::Acquire) != RX.tail.load(Ordering::Acquire)
}

/// Moves received bytes to `buf`; returns how many.
pub fn read(buf: &mut [u8]) -> usize {
    let head = RX.head.load(Ordering::Acquire);
    let mut tail = RX.tail.load(Ordering::Relaxed);
    let mut n = 0;
    while tail != head && n < buf.len() {
        // SAFETY: `tail` is below `head`: the interrupt wrote it and will not touch it until
        // `tail` is published past it.
        buf[n] = unsafe { (*RX.buf.get())[tail] };
        tail = (tail + 1) % RING;
        n += 1;
    }
    RX.tail.store(tail, Ordering::Release);
    n
}

/// The receive interrupt: drains the data register into the ring.
pub fn on_rx_interrupt() {
    write_reg(INTSTATUS, INT_RX);
    loop {
        let state = read_reg(STATE);
        if state & STATE_RX_OVERRUN != 0 {
            RX_LOST.fetch_add(1, Ordering::Relaxed);
            write_reg(STATE, STATE_RX_OVERRUN);
        }
        if state & STATE_RX_FULL == 0 {
            break;
        }
        let b = read_reg(DATA) as u8;
        let head = RX.head.load(Ordering::Relaxed);
        let next = (head + 1) % RING;
        if next == RX.tail.load(Ordering::Acquire) {
            RX_LOST.fetch_add(1, Ordering::Relaxed);
            continue;
        }
        // SAFETY: `head` is not readable by the consumer until published below.
        unsafe { (*RX.buf.get())[head] = b };
        RX.head.store(next, Ordering::Release);
    }
}
