//! `lives dataset`: the scan-classification dataset from procedural worlds.

use super::common::{progress_bar, refuse_heldout, say};
use host::learn::dataset::{generate_with, DatasetSpec};
use host::learn::labeller::LabellerConfig;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Generate the scan-classification dataset (docs/dataset.md) from procedural worlds only.
#[derive(clap::Args)]
pub struct DatasetArgs {
    /// Output directory (created; meta.json, train.bin, val.bin in it are replaced).
    #[arg(long)]
    out: PathBuf,
    /// Number of procedural worlds (seeds S, S+1, …).
    #[arg(long, default_value_t = 20)]
    worlds: u32,
    /// Episodes per world.
    #[arg(long, default_value_t = 2)]
    episodes_per_world: u32,
    /// First world seed S; worlds with seed % 5 == 0 go to the validation split.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Shortest episode, seconds.
    #[arg(long, default_value_t = 60.0)]
    min_episode_s: f64,
    /// Longest episode, seconds.
    #[arg(long, default_value_t = 120.0)]
    max_episode_s: f64,
    /// Labeller parameters: `sim` (LTF gate 0.1 m, the default) or `spot` (the paper's 0.7 m).
    #[arg(long, default_value = "sim")]
    labeller: String,
    /// Worlds generated at once (the output does not depend on it).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Furniture and clutter density range LO,HI in 0..=1: each world keeps each piece with
    /// probability d, d uniform in the range by a hash of the world seed (default 1,1 = `World::random`).
    #[arg(long, value_delimiter = ',', num_args = 1..=2, default_values_t = [1.0, 1.0])]
    furniture_density: Vec<f64>,
}

pub fn run(args: DatasetArgs) -> Result<ExitCode, String> {
    let DatasetArgs { out, worlds, episodes_per_world, seed, min_episode_s, max_episode_s, labeller, threads, furniture_density } = args;
    let last = seed.saturating_add(u64::from(worlds.max(1)) - 1);
    refuse_heldout(seed, last, &format!("worlds from seed {seed}"), "pick other seeds")?;
    let mut spec = DatasetSpec::new(&out, seed, worlds, episodes_per_world);
    spec.plan.episode_min_s = min_episode_s;
    spec.plan.episode_max_s = max_episode_s;
    spec.threads = threads;
    spec.density = match furniture_density[..] {
        [d] => [d, d],
        [lo, hi] => [lo, hi],
        _ => return Err(format!("--furniture-density takes LO,HI or one value, not {} values", furniture_density.len())),
    };
    spec.labeller = match labeller.as_str() {
        "sim" => LabellerConfig::default(),
        "spot" => LabellerConfig::spot(),
        other => return Err(format!("unknown labeller `{other}` (expected sim or spot)")),
    };
    spec.command = std::env::args().collect::<Vec<_>>().join(" ");
    let pb = progress_bar(worlds as u64);
    let t0 = Instant::now();
    let sum = generate_with(&spec, |p| {
        pb.set_position(p.worlds_done as u64);
    })
    .map_err(|e| e.to_string())?;
    pb.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();
    let a = &sum.agreement;
    say!(
        "dataset {}: {} worlds x {} episodes, {:.0} s simulated in {:.1} s",
        sum.out_dir.display(),
        worlds,
        episodes_per_world,
        sum.simulated_s,
        wall
    );
    say!(
        "  train: {} records from {} worlds, {:.1} MB; val: {} records from {} worlds {:?}, {:.1} MB",
        sum.train_records,
        sum.train_worlds.len(),
        sum.train_bytes as f64 / 1e6,
        sum.val_records,
        sum.val_worlds.len(),
        sum.val_worlds,
        sum.val_bytes as f64 / 1e6
    );
    say!(
        "  labeller vs simulator truth: map/non-map {:.2} % (wall->LTF {:.2} %, non-map->STF/DF {:.2} %)",
        a.map_accuracy() * 100.0,
        a.map_recall() * 100.0,
        a.non_map_recall() * 100.0
    );
    Ok(ExitCode::SUCCESS)
}
