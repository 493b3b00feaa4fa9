//! What several subcommands share: the flags that describe a simulated search (`RunArgs`,
//! `RobotArgs`, `SetSimArgs`), loading worlds and searches, the result line, progress bars, files
//! and the serial link.

use host::link::SerialLink;
use host::search::{self, PlannerChoice, Robot, SearchSpec};
use host::sim::{Scenario, World};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::Path;

/// `println!` that does not panic when stdout is closed early (`lives search | head -1`).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}
pub(crate) use say;

/// What to simulate: the world, scenario, planner and seed (shared by `search`, `bridge` and
/// `trace record`).
#[derive(clap::Args, Clone)]
pub struct RunArgs {
    /// A built-in world (apartment, office, hallway), `random` (with --seed), or a world file (.toml).
    #[arg(long, default_value = "apartment")]
    pub world: String,
    /// easy or hard (built-in and random worlds; default easy). A world file holds its own
    /// scenario, so it takes none.
    #[arg(long)]
    pub scenario: Option<Scenario>,
    /// lives, lives-gt, lives-no-nonmap, lives-greedy, multisensor, nearest, explore-lite, rrt;
    /// with --map also live, visual-cpp, lidar-cpp.
    #[arg(long, default_value = "lives")]
    pub planner: PlannerChoice,
    /// Seed: start jitter, target placement, people, sensor noise (and the random world).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// LIVE's known-map mode: the building's map (ROS map_server `.yaml`, docs/map-files.md; e.g.
    /// from `lives map export`) labels the scans in the core (LTF map, STF non-map) instead of
    /// the classifier, seeds the LiDAR grid, and gives `live`, `visual-cpp` and `lidar-cpp` their
    /// coverage route (docs/live.md).
    #[arg(long, value_name = "FILE.yaml")]
    pub map: Option<std::path::PathBuf>,
}

/// `--set` and `--sim`: changes to the controller and to the simulated robot (`search`, `eval`,
/// `bridge`; a subcommand whose words differ replaces the help with `mut_arg`).
#[derive(clap::Args)]
pub struct SetSimArgs {
    /// Override a controller parameter, e.g. `--set w_dist_per_m=2` (repeatable; `lives params` lists them).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Change the simulated robot, e.g. `--sim speed_mps=0.3` or `--sim camera_range_m=8`
    /// (repeatable; `lives params` lists them). The camera, the LiDAR's range and the body's
    /// size also set the controller's model of them; a `--set` then changes the model alone.
    #[arg(long = "sim", value_name = "NAME=VALUE")]
    pub sim: Vec<String>,
}

impl SetSimArgs {
    /// Applies `--sim` (changes to the simulated robot, and to the controller's model of its
    /// sensors), then `--set` (the controller alone, so it may still change that model).
    pub fn configure(&self, spec: &mut SearchSpec) -> Result<(), String> {
        for a in &self.sim {
            host::overrides::apply_sim(&mut spec.sim, &mut spec.controller, a)?;
        }
        for a in &self.set {
            host::overrides::apply(&mut spec.controller, a)?;
        }
        Ok(())
    }
}

/// `--set`, `--sim` and `--robot`: the simulated robot and changes to it (`search`, `eval`).
#[derive(clap::Args)]
pub struct RobotArgs {
    #[command(flatten)]
    pub set_sim: SetSimArgs,
    /// The simulated robot: `calibrated` (the camera's reach calibrated on the paper's
    /// multisensor baseline, docs/experiments/camera-calibration.md) or `short` (a 4 m
    /// camera). `--sim` then changes it further.
    #[arg(long, default_value = "calibrated")]
    pub robot: Robot,
}

impl RobotArgs {
    /// Applies `--robot` (a named simulated robot), then `--sim` and `--set`.
    pub fn configure(&self, spec: &mut SearchSpec) -> Result<(), String> {
        self.robot.apply(spec)?;
        self.set_sim.configure(spec)
    }
}

/// The world `name` names, its report name, and the scenario it was loaded in: `None` for a
/// world file, which holds one scenario of its own.
pub fn load_world(name: &str, scenario: Scenario, seed: u64) -> Result<(String, World, Option<Scenario>), String> {
    if name == "random" {
        return Ok((format!("random-{seed}"), World::random_scenario(seed, scenario), Some(scenario)));
    }
    if let Some(w) = World::builtin(name, scenario) {
        return Ok((name.to_string(), w, Some(scenario)));
    }
    let path = Path::new(name);
    if path.extension().is_some_and(|e| e == "toml") || path.exists() {
        // Reports name the world as the file does (`name = ...`, else the file's name).
        let w = World::load(path).map_err(|e| e.to_string())?;
        return Ok((w.name.clone(), w, None));
    }
    Err(format!("unknown world `{name}`: expected one of {}, `random`, or a .toml world file", World::builtin_names().join(", ")))
}

/// The search `--world`, `--scenario`, `--planner` and `--seed` describe. A world file holds one
/// scenario of its own: `--scenario` with one is refused rather than ignored, and reports say
/// `file` where a built-in world says `easy` or `hard`.
pub fn load_spec(run: &RunArgs) -> Result<SearchSpec, String> {
    let scenario = run.scenario.unwrap_or(Scenario::Easy);
    let (name, w, loaded_in) = load_world(&run.world, scenario, run.seed)?;
    if loaded_in.is_none() && run.scenario.is_some() {
        return Err(format!("--scenario applies to the built-in and random worlds; the world file {} holds its own scenario", run.world));
    }
    let mut spec = SearchSpec::new(&name, w, scenario, run.planner, run.seed);
    spec.scenario = loaded_in;
    if spec.planner.kind().is_coverage() && run.map.is_none() {
        return Err(format!("`{}` searches a known building: give its map with --map FILE.yaml (`lives map export WORLD FILE.yaml` writes a built-in world's)", spec.planner));
    }
    if let Some(path) = &run.map {
        let prior = host::io::map_file::PriorMap::load(path).map_err(|e| e.to_string())?;
        let cfg = host::run::controller_config(&spec.controller, &spec.world, spec.planner.kind());
        let origin = [cfg.origin_x_m.to_num::<f64>(), cfg.origin_y_m.to_num::<f64>()];
        let cells = prior.to_controller_grid(origin).map_err(|e| e.to_string())?;
        spec.prior_map = Some(std::sync::Arc::new(cells));
    }
    Ok(spec)
}

/// The human-readable summary of a search: `FOUND apartment easy lives seed 1: found in …`.
pub fn result_line(r: &search::SearchResult) -> String {
    // A search that runs out of places to look ends early; like the paper, it counts as the
    // limit (`time_s`), but the line says when it stopped.
    let when = if r.outcome == "exhausted" {
        let stopped = r.ticks as f64 * host::run::TICK_US as f64 / 1e6;
        format!("exhausted (nothing left to explore) at {stopped:.1} s, counted as the limit ({:.0} s)", r.time_limit_s)
    } else {
        format!("{} in {:.1} s (limit {:.0} s)", r.outcome, r.time_s, r.time_limit_s)
    };
    format!(
        "{} {} {} {} seed {}: {when}, path {:.1} m, {} ticks, {} goals",
        if r.found { "FOUND" } else { "NOT FOUND" },
        r.world,
        r.scenario,
        r.planner,
        r.seed,
        r.path_m,
        r.ticks,
        r.goals
    )
}

/// A progress bar on stderr drawn with `template` (hidden when stderr is not a terminal).
fn bar(len: u64, template: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len);
    pb.set_style(ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()));
    pb
}

/// A progress bar counting simulated seconds up to `len`.
pub fn progress_bar(len: u64) -> ProgressBar {
    bar(len, "{spinner} simulated {pos}/{len} s [{bar:40}] {elapsed}")
}

/// A progress bar counting searches.
pub fn count_bar() -> ProgressBar {
    bar(0, "{spinner} searches {pos}/{len} [{bar:40}] {elapsed} (eta {eta})")
}

pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Writes `contents` to `path`, creating its directory first.
pub fn write_file(path: &Path, contents: impl AsRef<[u8]>) -> Result<(), String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(path, contents).map_err(|e| format!("{}: {e}", path.display()))
}

/// Refuses the random worlds `first..=last` (`what` in the message) where they overlap the
/// held-out worlds that `lives eval --heldout` reports; `advice` ends the message.
pub fn refuse_heldout(first: u64, last: u64, what: &str, advice: &str) -> Result<(), String> {
    use host::measure::eval::{overlaps_heldout, HELDOUT_FIRST_SEED, HELDOUT_MAX_WORLDS};
    if overlaps_heldout(first, last) {
        return Err(format!(
            "{what} overlap the held-out worlds {HELDOUT_FIRST_SEED}..{} that `lives eval --heldout` reports; {advice}",
            HELDOUT_FIRST_SEED + HELDOUT_MAX_WORLDS
        ));
    }
    Ok(())
}

/// Opens the serial device, or waits for it when it is absent.
pub fn open_serial(port: &Path, baud: u32) -> SerialLink {
    SerialLink::open(port, baud).unwrap_or_else(|e| {
        eprintln!("waiting for {} ({e})", port.display());
        SerialLink::by_path(port, baud)
    })
}
