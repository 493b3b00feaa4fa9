//! The subcommands of `lives`: one module per subcommand (or small family), each with its clap
//! arguments and its `run`; `common` holds what several share. The modules use `common` and
//! never each other.

pub mod bench;
pub mod bridge;
pub mod common;
pub mod dataset;
pub mod eval;
pub mod map;
pub mod node;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod search;
pub mod sim_serve;
pub mod soak;
pub mod team;
pub mod trace;
#[cfg(feature = "train")]
pub mod train;
#[cfg(feature = "train")]
pub mod train_geo;
pub mod tune;
pub mod worlds;
