//! `lives bench`: the core's stages timed on the host.

use std::process::ExitCode;

/// Time the core's stages on a realistic, partly explored 512 × 512 map (host wall clock).
#[derive(clap::Args)]
pub struct BenchArgs {
    /// Repetitions per stage (the median is reported).
    #[arg(long, default_value_t = 30)]
    reps: usize,
    /// Virtual seconds of search before measuring (how explored the map is).
    #[arg(long, default_value_t = 120.0)]
    explore_s: f64,
    /// Also time whole simulated searches (apartment hard, seeds 1–5, `lives-gt` and `lives`) against real time.
    #[arg(long)]
    searches: bool,
}

pub fn run(args: BenchArgs) -> Result<ExitCode, String> {
    host::measure::bench::run(args.reps, args.explore_s, args.searches);
    Ok(ExitCode::SUCCESS)
}
