//! `host`: the `lives` command-line program's library — the simulator, the in-process search loop,
//! pictures and benchmarks. The controller itself is the `firmware` crate.

pub mod bench;
pub mod dataset;
pub mod eval;
pub mod export_bag;
pub mod fuzz;
pub mod labeller;
pub mod link;
pub mod mapcheck;
pub mod model;
pub mod overrides;
pub mod picture;
pub mod range;
pub mod record;
pub mod render;
pub mod replay;
pub mod robot_model;
pub mod run;
pub mod search;
pub mod sensors;
pub mod soak;
pub use lives_sim as sim;
pub mod trace;
#[cfg(feature = "train")]
pub mod train;
#[cfg(feature = "train")]
pub mod train_geo;
