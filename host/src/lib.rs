//! `host`: the `lives` program's library, one folder per concern: `run` (the run loop: sources,
//! brains, observers) with `search` and `robot_model` (the simulated search and robot),
//! `overrides` (`--set`/`--sim`), `link` (serial node, bridge, robot adapter), `io` (logs, bags,
//! sensors, recordings), `learn` (labels, dataset, training), `measure` (eval, bench, mapcheck,
//! soak, fuzz, trace) and `render` (pictures). The controller itself is the `firmware` crate; the
//! simulator is `lives-sim`, re-exported as [`sim`].

pub mod io;
pub mod learn;
pub mod link;
pub mod live;
pub mod measure;
pub mod overrides;
pub mod render;
pub mod robot_model;
pub mod run;
pub mod search;
pub mod team;
pub use lives_sim as sim;
