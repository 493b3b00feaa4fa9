//! `lives worlds`: the built-in worlds, one of them as a world file, or a world traced from a
//! floor map.

use super::common::{load_world, say};
use host::io::map_file::{world as from_map, PriorMap};
use host::overrides::finite_numbers;
use host::sim::{Scenario, World};
use std::path::PathBuf;
use std::process::ExitCode;

/// List the built-in worlds, print one as a world file, or trace a world from a floor map.
#[derive(clap::Args)]
pub struct WorldsArgs {
    /// Print this built-in world (or `random`) as TOML.
    #[arg(long, conflicts_with = "from_map")]
    export: Option<String>,
    /// The scenario of the world `--export` prints: easy or hard.
    #[arg(long, default_value = "easy")]
    scenario: Scenario,
    /// The seed of `--export random` (which building it generates), or of `--random-targets`.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print a world traced from this floor map (ROS map_server `.yaml`: a `map_saver` map, a
    /// floor plan, `lives replay --map-out`): its free cells are the floor, every side they share
    /// with an occupied or unknown cell a wall (docs/world-format.md, "Worlds from floor maps").
    /// Needs --start and a target.
    #[arg(long, value_name = "MAP.yaml", requires = "start")]
    from_map: Option<PathBuf>,
    /// The start in the map's frame: X,Y in metres and optionally the yaw in degrees.
    #[arg(long, value_name = "X,Y[,YAW_DEG]", allow_hyphen_values = true)]
    start: Option<String>,
    /// A target position in the map's frame, X,Y in metres (repeatable: the simulation's seed
    /// picks one per search).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    target: Vec<String>,
    /// Also draw N target positions from --seed among the floor a robot reaches from the start.
    #[arg(long, value_name = "N", default_value_t = 0)]
    random_targets: usize,
    /// Random target positions lie at least this much path from the start, metres.
    #[arg(long, value_name = "M", default_value_t = 5.0)]
    min_target_path: f64,
    /// The world's time limit, seconds (default `60 + 3 (w + h)` rounded to 10 s).
    #[arg(long, value_name = "S")]
    time_limit: Option<f64>,
    /// Keep only the floor within a square of this side (metres) around the start: a building
    /// larger than a world may be (50 m) is searched in part.
    #[arg(long, value_name = "M")]
    window: Option<f64>,
    /// The world's name (default: the map file's name).
    #[arg(long)]
    name: Option<String>,
}

pub fn run(args: WorldsArgs) -> Result<ExitCode, String> {
    if let Some(map_file) = &args.from_map {
        return trace(&args, map_file);
    }
    let WorldsArgs { export, scenario, seed, .. } = args;
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

/// `lives worlds --from-map`: the traced world as TOML on stdout, what was done on stderr.
fn trace(args: &WorldsArgs, map_file: &std::path::Path) -> Result<ExitCode, String> {
    let map = PriorMap::load(map_file).map_err(|e| e.to_string())?;
    let start = args.start.as_deref().unwrap_or_default();
    let [x, y, yaw_deg] = finite_numbers::<3>(start)
        .or_else(|| finite_numbers::<2>(start).map(|[x, y]| [x, y, 0.0]))
        .ok_or_else(|| format!("--start {start}: expected 2 or 3 finite numbers separated by commas"))?;
    let targets = args
        .target
        .iter()
        .map(|t| finite_numbers::<2>(t).ok_or_else(|| format!("--target {t}: expected 2 finite numbers separated by commas")))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(t) = args.time_limit.filter(|t| !(t.is_finite() && *t > 0.0)) {
        return Err(format!("--time-limit {t}: expected a positive number of seconds"));
    }
    if !(args.min_target_path.is_finite() && args.min_target_path >= 0.0) {
        return Err(format!("--min-target-path {}: expected a distance ≥ 0 in metres", args.min_target_path));
    }
    let name =
        args.name.clone().unwrap_or_else(|| map_file.file_stem().map_or_else(|| "floor-map".into(), |n| n.to_string_lossy().into_owned()));
    let opts = from_map::FromMap {
        name,
        start: [x, y, yaw_deg.to_radians()],
        targets,
        random_targets: args.random_targets,
        seed: args.seed,
        min_target_path_m: args.min_target_path,
        time_limit_s: args.time_limit,
        window_m: args.window,
    };
    let t = from_map::world_from_map(&map, &opts)?;
    let [lo, hi] = t.world.bounds;
    say!(
        "# Traced by `lives worlds --from-map` from {} ({} x {} cells at {} m): {} wall segments.\n# World = map frame + ({:.3}, {:.3}) m. {:.1} x {:.1} m, {} target position(s), time limit {:.0} s.\n{}",
        map.file,
        map.width,
        map.height,
        map.resolution_m,
        t.segments,
        t.shift[0],
        t.shift[1],
        hi[0] - lo[0],
        hi[1] - lo[1],
        t.world.targets.iter().map(|x| x.positions().len()).sum::<usize>(),
        t.world.time_limit_s,
        t.world.to_toml_string().trim_end()
    );
    Ok(ExitCode::SUCCESS)
}
