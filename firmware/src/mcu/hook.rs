//! A run-time hook for stage boundaries: [`install`] a function, and every tick observed through
//! [`Hooked`] (`Controller::tick_observed`, `Node::receive_observed`, `Trace::replay_observed`:
//! the MCU's trace image) calls it at the start and end of each [`Stage`]. The hook sees no data
//! and cannot change the tick; `Controller::tick` itself observes nothing.
#![allow(unsafe_code)]

use crate::controller::{Stage, StageObserver};
use core::sync::atomic::{AtomicPtr, Ordering};

/// What the hook is told: the stage, and `true` at its start, `false` at its end.
pub type HookFn = fn(Stage, bool);

/// The installed hook as a raw pointer (null: none). Only ever holds a `HookFn`.
static HOOK: AtomicPtr<()> = AtomicPtr::new(core::ptr::null_mut());

/// Installs `f` (replacing any previous hook).
pub fn install(f: HookFn) {
    HOOK.store(f as *mut (), Ordering::Release);
}

/// Removes the hook.
pub fn uninstall() {
    HOOK.store(core::ptr::null_mut(), Ordering::Release);
}

fn call(stage: Stage, begin: bool) {
    let p = HOOK.load(Ordering::Acquire);
    if !p.is_null() {
        // SAFETY: `HOOK` is only written by `install` (a `HookFn` cast to a pointer) and
        // `uninstall` (null, excluded above); fn pointers and data pointers have the same size
        // on every target this crate builds for.
        let f = unsafe { core::mem::transmute::<*mut (), HookFn>(p) };
        f(stage, begin);
    }
}

/// The observer that forwards to the hook (the trace image passes it to `Trace::replay_observed`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Hooked;

impl StageObserver for Hooked {
    #[inline]
    fn begin(&mut self, stage: Stage) {
        call(stage, true);
    }
    #[inline]
    fn end(&mut self, stage: Stage) {
        call(stage, false);
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use core::cell::Cell;

    std::thread_local! {
        // Per thread: controllers ticking in other test threads may call the hook too.
        static SEEN: Cell<u32> = const { Cell::new(0) };
    }

    fn count(stage: Stage, begin: bool) {
        let add = if begin { 1 } else { 1 << 16 } * (stage as u32 + 1);
        SEEN.with(|s| s.set(s.get() + add));
    }

    #[test]
    fn the_hook_sees_begin_and_end_and_can_be_removed() {
        install(count);
        Hooked.begin(Stage::Plan);
        Hooked.end(Stage::Plan);
        uninstall();
        Hooked.begin(Stage::Lidar);
        assert_eq!(SEEN.with(|s| s.get()), 5 + (5 << 16));
    }
}
