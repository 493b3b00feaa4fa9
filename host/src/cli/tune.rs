//! `lives tune`: planner parameters scored on procedurally generated worlds.

use super::common::{cores, count_bar, refuse_heldout, say, write_file};
use host::search::PlannerChoice;
use host::sim::Scenario;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Tune planner parameters on procedurally generated worlds only (never the built-in ones):
/// scores every combination of the `--grid` values by mean time to find / time limit.
#[derive(clap::Args)]
pub struct TuneArgs {
    /// How many random worlds: `--world random --seed F..F+N-1`, F = `--first-world`.
    #[arg(long, default_value_t = 48)]
    worlds: u64,
    /// The first random world's seed. Choose values on one range, then confirm them on
    /// another that played no part in the choice, e.g. `--first-world 193 --worlds 192`.
    #[arg(long, default_value_t = 1)]
    first_world: u64,
    /// Planners the score averages over, comma-separated (`lives` runs the committed geometric
    /// classifier, as in `lives eval`).
    #[arg(long, value_delimiter = ',', default_value = "lives-gt,multisensor")]
    planners: Vec<PlannerChoice>,
    /// Settings of each random world, comma-separated: `easy` (the suitcase 2.5–8 m from the
    /// start, a shorter limit) and `hard` (in another room); see `--world random --scenario`.
    #[arg(long, value_delimiter = ',', default_value = "easy,hard")]
    scenarios: Vec<Scenario>,
    /// A parameter and its candidate values, e.g. `--grid w_dist_per_m=0.5,1,2` (repeatable).
    #[arg(long, value_name = "NAME=V1,V2,...", required = true)]
    grid: Vec<String>,
    /// Worker threads (default: the machine's cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Write the ranking as JSON here.
    #[arg(long, default_value = "out/tune.json")]
    out: PathBuf,
}

pub fn run(args: TuneArgs) -> Result<ExitCode, String> {
    let TuneArgs { worlds, first_world, planners, scenarios, grid, threads, out } = args;
    let grid: Vec<(String, Vec<String>)> = grid.iter().map(|g| host::measure::eval::parse_grid_axis(g)).collect::<Result<_, _>>()?;
    // Reject unknown names and bad values before spending minutes.
    for a in host::measure::eval::grid_assignments(&grid) {
        let mut c = firmware::Config::DEFAULT;
        for x in &a {
            host::overrides::apply(&mut c, x)?;
        }
    }
    if worlds == 0 {
        return Err("--worlds must be at least 1".into());
    }
    let last_world = first_world.checked_add(worlds - 1).ok_or("--first-world + --worlds is past the last seed")?;
    refuse_heldout(first_world, last_world, &format!("worlds {first_world}..={last_world}"), "tune on others")?;
    if scenarios.is_empty() || planners.is_empty() {
        return Err("--scenarios and --planners need at least one value each".into());
    }
    let pb = count_bar();
    let t0 = Instant::now();
    let scores = host::measure::eval::tune(
        &grid,
        &planners,
        &scenarios,
        first_world..=last_world,
        threads.unwrap_or_else(cores),
        firmware::classifier::EMBEDDED_GEO_MODEL,
        |n, total| {
            pb.set_length(total as u64);
            pb.set_position(n as u64);
        },
    )?;
    pb.finish_and_clear();
    say!("| rank | assignment | mean time / limit | 95 % CI | found | paired Δ vs defaults |\n|---|---|---|---|---|---|");
    let label = |sets: &[String]| if sets.is_empty() { "(defaults)".to_string() } else { sets.join(" ") };
    for (i, sc) in scores.iter().enumerate() {
        say!(
            "| {} | {} | {:.3} | ± {:.3} | {:.0} % | {:+.3} ± {:.3} |",
            i + 1,
            label(&sc.sets),
            sc.mean_normalised_time,
            sc.ci95,
            100.0 * sc.success_rate,
            sc.vs_defaults,
            sc.vs_defaults_ci95
        );
    }
    if let Some(best) = scores.first().filter(|b| !b.sets.is_empty()) {
        say!(
            "best on random worlds {first_world}..={last_world}, {} ({} searches each, {:.0} s): --set {}",
            scenarios.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(" and "),
            best.searches,
            t0.elapsed().as_secs_f64(),
            best.sets.join(" --set ")
        );
    } else {
        say!("best on random worlds {first_world}..={last_world}: the defaults ({:.0} s)", t0.elapsed().as_secs_f64());
    }
    write_file(&out, &serde_json::to_string_pretty(&scores).map_err(|e| e.to_string())?)?;
    say!("ranking: {}", out.display());
    Ok(ExitCode::SUCCESS)
}
