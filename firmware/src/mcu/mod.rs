//! # Support for the Cortex-M images (`src/bin/mcu-*.rs`, docs/mcu.md)
//!
//! Portable parts only, so the host runs the very same code as the MCU:
//!
//! * [`trace`]: the golden-trace format (a recorded host → core byte stream with timestamps) and
//!   its replay through a [`crate::node::Node`] and a [`crate::Controller`], one CRC-32 digest of
//!   the node's output per record. The host and the MCU under QEMU replay the same fixture and
//!   must print the same digests, tick by tick.
//! * [`hook`]: an observer that reports each stage's start and end to a function installed at
//!   run time; the trace image passes it through `Trace::replay_observed` and times the stages
//!   with SysTick.
//!
//! * [`mcu_main!`](crate::mcu_main): each image's `main`.
//!
//! The register drivers (UART, SysTick) and the fault handlers are in the binaries
//! (`src/bin/common/`), which alone depend on `cortex-m`.

pub mod hook;
pub mod trace;

/// The `main` of a Cortex-M image (`src/bin/mcu-*.rs`): on the target, `cortex-m-rt`'s entry
/// point, running the body (which never returns); on any other target (a host build with
/// `--features mcu`), a `main` that says the image is for Cortex-M and exits with status 2.
/// Expanded in the image's crate, which depends on `cortex-m-rt` and has `std` off the target.
#[macro_export]
macro_rules! mcu_main {
    ($($body:tt)*) => {
        #[cfg(target_os = "none")]
        #[cortex_m_rt::entry]
        fn main() -> ! {
            $($body)*
        }

        #[cfg(not(target_os = "none"))]
        fn main() {
            eprintln!("{} is a Cortex-M image: build it with --target thumbv7em-none-eabihf (docs/mcu.md)", env!("CARGO_BIN_NAME"));
            std::process::exit(2);
        }
    };
}
