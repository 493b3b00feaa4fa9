//! # `firmware` — the LIVES controller core
//!
//! `#![no_std]`, no allocator: every buffer is an array or a `heapless` container whose capacity is
//! a constant in [`capacity`]. The same code runs inside the host simulator, as a Linux process on
//! a serial port, and on a Cortex-M; it never reads a clock or a random source (time is the
//! `now_us` argument of [`Controller::tick`]), and it decides every output with integer or
//! fixed-point arithmetic, so the same inputs give bit-identical outputs everywhere.
//!
//! One planning step (the paper's Algorithm 1), module by module:
//!
//! | step | module | what it owns |
//! |---|---|---|
//! | scan in, resampled to the 897-beam grid | [`scan`] | [`BeamScan`], input validation |
//! | label each point map / non-map (int8 network) | [`classifier`] | [`classifier::Classifier`], the model blob view |
//! | LiDAR and visual search maps | [`grid`] | [`LidarGrid`], [`VisualGrid`], ray traversal |
//! | non-map points, pooled and filtered | [`nonmap`] | [`NonMapStore`] |
//! | frontiers of both maps | [`frontier`] | [`FrontierSet`] |
//! | viewpoints, path distance, utility, argmax | [`planner`] | [`Planner`] |
//! | rooms, corridors and doorways of the LiDAR map | [`rooms`] | [`rooms::Rooms`] |
//! | the fixed-rate state machine | [`controller`] | [`Controller`] |
//!
//! [`tour`] orders a set of tasks (an open asymmetric TSP path with precedence classes) under a
//! work budget per call, for a planner that keeps a global tour over its frontiers.
//!
//! Parameters a user may tune are in [`Config`] (units in the names); capacities that size memory
//! are compile-time constants in [`capacity`].
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod capacity;
pub mod classifier;
pub mod config;
pub mod controller;
pub mod frontier;
pub mod grid;
pub mod knownmap;
pub mod matcher;
pub mod mcu;
pub mod node;
pub mod nonmap;
pub mod planner;
pub mod protocol;
pub mod rolling;
pub mod rooms;
pub mod rrt;
pub mod scan;
pub mod searchmap;
pub mod tour;

pub use config::{Config, PlannerKind};
pub use controller::{Command, Controller, Detection, Inputs, Mode, Outputs, Status};
pub use fixed_point::{BinaryAngle, Meters, Pose2};
pub use frontier::{Frontier, FrontierSet};
pub use grid::{Cell, GridGeometry, LidarGrid, VisualGrid};
pub use nonmap::NonMapStore;
pub use planner::{Goal, Planner, Viewpoint};
pub use scan::{BeamLabel, BeamScan, ScanError, ScanInput};
