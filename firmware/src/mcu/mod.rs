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
//! The register drivers (UART, SysTick) and the fault handlers are in the binaries
//! (`src/bin/common/`), which alone depend on `cortex-m`.

pub mod hook;
pub mod trace;
