//! `lives` — LiDAR Informed Visual Search: simulate, run and measure the controller.
//!
//! This file parses the command line and dispatches; each subcommand's flags and work are in
//! `cli/` (one module per subcommand or small family, `cli::common` for what they share).

mod cli;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use cli::common::{load_spec, RunArgs};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "lives", version, about = "LiDAR Informed Visual Search: find a target in an unseen building, fast")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

// The subcommands, in the order `lives --help` lists them; the help of those with a module of
// their own is on their argument types in `cli/`.
#[derive(Subcommand)]
enum Cmd {
    Search(cli::search::SearchArgs),
    Team(cli::team::TeamArgs),
    Dataset(cli::dataset::DatasetArgs),
    Soak(cli::soak::SoakArgs),
    Node(cli::node::NodeArgs),
    Bridge(cli::bridge::BridgeArgs),
    #[cfg(feature = "ros2")]
    Ros2(cli::ros2::Ros2Args),
    SimServe(cli::sim_serve::SimServeArgs),
    #[cfg(feature = "train")]
    Train(cli::train::TrainArgs),
    #[cfg(feature = "train")]
    TrainGeo(cli::train_geo::TrainGeoArgs),
    #[cfg(feature = "train")]
    ClassifierEval(cli::train_geo::ClassifierEvalArgs),
    #[cfg(feature = "train")]
    CalibrateBias(cli::train::CalibrateBiasArgs),
    #[cfg(feature = "train")]
    Quantise(cli::train::QuantiseArgs),
    #[command(subcommand)]
    Trace(cli::trace::TraceCmd),
    Eval(cli::eval::EvalArgs),
    Tune(cli::tune::TuneArgs),
    /// List the controller parameters `--set` accepts, with their defaults.
    Params(host::overrides::ParamsArgs),
    /// Replay a recorded log through the controller (no base to move): CARMEN logs (FLASER,
    /// ROBOTLASER1, ODOM; plain or gzip), ROS 2 bags (MCAP or sqlite3, or zstd-compressed files)
    /// and ROS 1 bags with LaserScan or a 3D LiDAR's PointCloud2 (cut to a plane), and VLP-16
    /// captures (docs/replay.md).
    Replay(host::io::replay::ReplayArgs),
    /// Score a LiDAR map against a reference: walls recovered, phantom walls, free-space leak
    /// (a replayed log against its own poses or another log; a simulated search against the true
    /// world), and pose errors on ground-truth relations (docs/mapcheck.md).
    Mapcheck(host::measure::mapcheck::MapcheckArgs),
    /// Write a ROS 2 MCAP bag from a CARMEN log as a robot records one: LaserScan with +inf
    /// readings, odometry starting a few scans late, a rotated laser mount (host::io::export_bag).
    ExportBag(host::io::export_bag::ExportBagArgs),
    Worlds(cli::worlds::WorldsArgs),
    #[command(subcommand)]
    Map(cli::map::MapCmd),
    Bench(cli::bench::BenchArgs),
    /// VLP-16 LiDAR: decode a capture (.pcap or raw payloads) or listen on UDP (docs/vlp16.md).
    #[command(subcommand)]
    Lidar(host::io::sensors::LidarCmd),
}

/// Every option or positional that takes a value accepts a negative number as its value
/// (`--max-range -1`, `--seed -3`), which the command then range-checks like any other; without
/// this clap took `-1` for an unknown flag (issue 29).
fn negatives_as_values(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| if a.get_action().takes_values() { a.allow_negative_numbers(true) } else { a }).mut_subcommands(negatives_as_values)
}

fn main() -> ExitCode {
    // A controller core is 1.4 MiB (docs/architecture.md, "Memory budget"), built by value
    // before it is boxed; the worker threads of `eval`, `tune`, `dataset` and the bridge need
    // more stack than Rust's 2 MiB default for that. Set before any thread is spawned (the
    // standard library reads it once); a value the user set is kept.
    if std::env::var_os("RUST_MIN_STACK").is_none() {
        std::env::set_var("RUST_MIN_STACK", (32usize << 20).to_string());
    }
    let matches = negatives_as_values(Cli::command()).get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run(cli: Cli) -> Result<ExitCode, String> {
    match cli.command {
        Cmd::Search(args) => cli::search::run(args),
        Cmd::Team(args) => cli::team::run(args),
        Cmd::Dataset(args) => cli::dataset::run(args),
        Cmd::Soak(args) => cli::soak::run(args),
        Cmd::Node(args) => cli::node::run(args),
        Cmd::Bridge(args) => cli::bridge::run(args),
        #[cfg(feature = "ros2")]
        Cmd::Ros2(args) => cli::ros2::run(args),
        Cmd::SimServe(args) => cli::sim_serve::run(args),
        #[cfg(feature = "train")]
        Cmd::Train(args) => cli::train::train(args),
        #[cfg(feature = "train")]
        Cmd::TrainGeo(args) => cli::train_geo::train_geo(args),
        #[cfg(feature = "train")]
        Cmd::ClassifierEval(args) => cli::train_geo::classifier_eval(args),
        #[cfg(feature = "train")]
        Cmd::CalibrateBias(args) => cli::train::calibrate_bias(args),
        #[cfg(feature = "train")]
        Cmd::Quantise(args) => cli::train::quantise(args),
        Cmd::Trace(cmd) => cli::trace::run(cmd),
        Cmd::Eval(args) => cli::eval::run(args),
        Cmd::Tune(args) => cli::tune::run(args),
        Cmd::Params(args) => host::overrides::run_params(&args),
        Cmd::Replay(args) => host::io::replay::run_command(&args),
        Cmd::Mapcheck(args) => host::measure::mapcheck::run_command(&args, |world, scenario, planner, seed| {
            load_spec(&RunArgs { world: world.to_string(), scenario, planner, seed, map: None })
        }),
        Cmd::ExportBag(args) => host::io::export_bag::run_command(&args),
        Cmd::Worlds(args) => cli::worlds::run(args),
        Cmd::Map(cmd) => cli::map::run(cmd),
        Cmd::Bench(args) => cli::bench::run(args),
        Cmd::Lidar(cmd) => host::io::sensors::run(cmd),
    }
}

#[cfg(test)]
mod tests {
    /// clap's own checks of the whole command line (flags, defaults, conflicts, the `mut_arg`s).
    #[test]
    fn the_command_line_is_consistent() {
        super::negatives_as_values(<super::Cli as clap::CommandFactory>::command()).debug_assert();
    }
}
