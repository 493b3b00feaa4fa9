//! Where a bridge's data comes from, and the one entry point that runs either: the simulator
//! ([`super::bridge`]) or a real robot behind the base adapter ([`super::robot`]).

use super::bridge::{BridgeError, BridgeOptions, BridgeResult};
use super::robot::{run_robot, RobotSpec};
use super::sim_bridge::run_sim;
use super::Link;
use crate::search::SearchSpec;
use std::sync::atomic::AtomicBool;

/// Where the data comes from.
// One per run, moved once: the size difference between the variants costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Source {
    /// The simulator, with this search's world, scenario, planner and seed.
    Sim(SearchSpec),
    /// A real robot behind the base adapter (`docs/base-adapter.md`): real time only.
    Robot(RobotSpec),
}

/// Runs the search of `source` through the node at the other end of `link` until the target is
/// found, the search is exhausted, the time limit passes, or `stop` is set.
pub fn run_bridge(link: &mut dyn Link, source: Source, opts: &BridgeOptions, stop: &AtomicBool) -> Result<BridgeResult, BridgeError> {
    match source {
        Source::Sim(spec) => run_sim(link, spec, opts, stop),
        Source::Robot(robot) => run_robot(link, robot, opts, stop).map(|r| r.bridge),
    }
}
