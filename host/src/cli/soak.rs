//! `lives soak`: node and bridge for hours, resources and link recoveries recorded.

use std::path::PathBuf;
use std::process::ExitCode;

/// Soak: `lives node` as a process on a pseudo-terminal in real time, the bridge here running
/// searches back to back over a noisy line with the link pulled every few minutes, then node
/// and bridge in lockstep for hours of simulated time; memory, descriptors, overruns, link
/// losses and recoveries recorded; exit 1 on growth, a panic, or a pull not answered by a stop
/// within one watchdog period (docs/reliability.md).
#[derive(clap::Args)]
pub struct SoakArgs {
    /// Wall time of the real-time part, minutes.
    #[arg(long, default_value_t = 30.0)]
    minutes: f64,
    /// Simulated time of the lockstep part, hours.
    #[arg(long, default_value_t = 8.0)]
    sim_hours: f64,
    /// Seconds between link pulls.
    #[arg(long, default_value_t = 180.0)]
    pull_every: f64,
    /// Seconds each pull lasts.
    #[arg(long, default_value_t = 2.5)]
    pull_for: f64,
    /// Probability that a byte on the line is replaced by a random one, each direction.
    #[arg(long, default_value_t = 2e-5)]
    noise: f64,
    /// Seconds between memory samples.
    #[arg(long, default_value_t = 5.0)]
    sample_every: f64,
    /// Memory growth allowed, KiB.
    #[arg(long, default_value_t = 2048)]
    growth_kib: u64,
    /// Seed (noise, searches).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write the whole report (every sample, every pull) as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(args: SoakArgs) -> Result<ExitCode, String> {
    let SoakArgs { minutes, sim_hours, pull_every, pull_for, noise, sample_every, growth_kib, seed, json } = args;
    let positive = |name: &str, v: f64| match v.is_finite() && v > 0.0 {
        true => Ok(std::time::Duration::from_secs_f64(v)),
        false => Err(format!("--{name} {v}: expected a positive number")),
    };
    if !(0.0..=0.5).contains(&noise) {
        return Err(format!("--noise {noise}: expected a probability from 0 to 0.5"));
    }
    if !(sim_hours.is_finite() && sim_hours >= 0.0) {
        return Err(format!("--sim-hours {sim_hours}: expected hours, 0 or more"));
    }
    let opts = host::measure::soak::SoakOptions {
        wall: positive("minutes", minutes * 60.0)?,
        sim_hours,
        pull_every: positive("pull-every", pull_every)?,
        pull_for: positive("pull-for", pull_for)?,
        noise,
        sample_every: positive("sample-every", sample_every)?,
        lives: std::env::current_exe().map_err(|e| format!("cannot find this program: {e}"))?,
        seed,
        growth_kib,
    };
    let report = host::measure::soak::run(&opts, &mut |line| eprintln!("{line}")).map_err(|e| format!("soak: {e}"))?;
    if let Some(path) = &json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    println!("{}", host::measure::soak::summary(&report));
    if report.failures.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        for f in &report.failures {
            eprintln!("FAIL: {f}");
        }
        Ok(ExitCode::from(1))
    }
}
