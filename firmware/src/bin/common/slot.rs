//! A `static` handed out once as `&'static mut`.
//!
//! * [`Slot::new`] + [`Slot::init`]: zero bytes in `.bss`, initialised at run time through a
//!   `&mut MaybeUninit` (fine for small types: the value may pass through the stack).
//! * [`Slot::with`] + [`Slot::take`]: initialised at compile time (a `const fn` constructor), so
//!   the value is in `.data`: its image is in flash and the runtime copies it to RAM before
//!   `main`, and it never exists on the stack. The controller uses this: built at run time, LLVM
//!   assembles `Controller::new`'s 1 MiB on the stack first (1.35 MiB of stack measured), which
//!   a 2 MiB part could not afford; `.data` costs 1 MiB of flash instead.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, Ordering};

/// See the module documentation.
pub struct Slot<T> {
    taken: AtomicBool,
    cell: UnsafeCell<MaybeUninit<T>>,
}

// SAFETY: the storage is handed out once, by `init_with`, guarded by `taken`.
unsafe impl<T> Sync for Slot<T> {}

impl<T> Slot<T> {
    /// An empty slot.
    pub const fn new() -> Self {
        Slot { taken: AtomicBool::new(false), cell: UnsafeCell::new(MaybeUninit::uninit()) }
    }

    /// A slot holding `v` from the start (in `.data`); hand it out with [`Slot::take`].
    pub const fn with(v: T) -> Self {
        Slot { taken: AtomicBool::new(false), cell: UnsafeCell::new(MaybeUninit::new(v)) }
    }

    /// The value of a slot made with [`Slot::with`]. A second call is a fault.
    #[allow(clippy::mut_from_ref)] // handed out once: `taken` guards it
    pub fn take(&'static self) -> &'static mut T {
        if self.taken.swap(true, Ordering::AcqRel) {
            super::fault::stop(format_args!("a static slot was taken twice"));
        }
        // SAFETY: initialised by `with` (the only way to reach `take` soundly: callers use
        // `take` only on slots made with `with`), handed out once.
        unsafe { (*self.cell.get()).assume_init_mut() }
    }

    /// Initialises the slot with `init(slot)` (typically `|s| s.write(T::new(..))`) and returns
    /// it. A second call is a fault. For small types: the value may pass through the stack.
    #[allow(clippy::mut_from_ref)] // handed out once: `taken` guards it
    pub fn init(&'static self, init: impl FnOnce(&'static mut MaybeUninit<T>) -> &'static mut T) -> &'static mut T {
        if self.taken.swap(true, Ordering::AcqRel) {
            super::fault::stop(format_args!("a static slot was initialised twice"));
        }
        // SAFETY: `taken` guarantees this is the only reference ever made to the storage.
        init(unsafe { &mut *self.cell.get() })
    }
}

/// A cell for state shared by the main loop and the stage hook (both on the main thread; never
/// touched from an interrupt).
pub struct MainCell<T>(UnsafeCell<T>);

// SAFETY: single core, and only used from thread mode (see the type's documentation).
unsafe impl<T> Sync for MainCell<T> {}

impl<T> MainCell<T> {
    /// A cell holding `v`.
    pub const fn new(v: T) -> Self {
        MainCell(UnsafeCell::new(v))
    }

    /// Runs `f` on the value (never re-entered: `f` must not call back into `with`).
    pub fn with<R>(&self, f: impl FnOnce(&mut T) -> R) -> R {
        // SAFETY: thread mode only and not re-entrant (see above), so the borrow is unique.
        f(unsafe { &mut *self.0.get() })
    }
}
