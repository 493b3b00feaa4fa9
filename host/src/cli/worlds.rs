//! `lives worlds`: the built-in worlds, or one of them as a world file.

use super::common::{load_world, say};
use host::sim::{Scenario, World};
use std::process::ExitCode;

/// List the built-in worlds, or print one as a world file.
#[derive(clap::Args)]
pub struct WorldsArgs {
    /// Print this built-in world (or `random`) as TOML.
    #[arg(long)]
    export: Option<String>,
    /// The scenario of the world `--export` prints: easy or hard.
    #[arg(long, default_value = "easy")]
    scenario: Scenario,
    /// The seed of `--export random` (which building it generates).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

pub fn run(args: WorldsArgs) -> Result<ExitCode, String> {
    let WorldsArgs { export, scenario, seed } = args;
    match export {
        Some(name) => {
            let (_, w, _) = load_world(&name, scenario, seed)?;
            say!("{}", w.to_toml_string().trim_end());
        }
        None => {
            for n in World::builtin_names() {
                for s in [Scenario::Easy, Scenario::Hard] {
                    if let Some(w) = World::builtin(n, s) {
                        let [lo, hi] = w.bounds;
                        say!(
                            "{n:10} {s:5} {:5.1} x {:5.1} m, time limit {:4.0} s, {} obstacles, {} people",
                            hi[0] - lo[0],
                            hi[1] - lo[1],
                            w.time_limit_s,
                            w.obstacles.len(),
                            w.people.len()
                        );
                    }
                }
            }
            say!("random     (any seed: --world random --seed N)");
        }
    }
    Ok(ExitCode::SUCCESS)
}
