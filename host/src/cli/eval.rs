//! `lives eval`: the paper's Table I, every planner over the built-in worlds and scenarios.

use super::common::{cores, count_bar, say, write_file, RobotArgs};
use host::measure::eval;
use host::search::{self, PlannerChoice, SearchSpec};
use host::sim::Scenario;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Reproduce the paper's Table I: every planner over the built-in worlds and scenarios,
/// N trials each, in parallel; writes the table (Markdown, JSON, CSV) and plots.
#[derive(clap::Args)]
#[command(mut_arg("set", |a| a.help("Override a controller parameter for every planner (repeatable)")))]
pub struct EvalArgs {
    /// Trials per planner and setting (seeds 1..=N: start pose, target placement, people, noise);
    /// 0 runs no built-in setting (the held-out worlds only).
    #[arg(long, default_value_t = 10)]
    trials: u64,
    /// Built-in worlds, comma-separated; a world file (.toml, e.g. from `lives worlds --from-map`)
    /// is one setting of its own (it holds its own scenario and time limit).
    #[arg(long, value_delimiter = ',', default_value = "apartment,office,hallway")]
    worlds: Vec<String>,
    /// Scenarios, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "easy,hard")]
    scenarios: Vec<Scenario>,
    /// Planners, comma-separated (`lives` runs the embedded int8 classifier). Default: every
    /// planner `--planner` knows, the last first (today rrt, explore-lite, nearest,
    /// multisensor, lives-gt, lives).
    #[arg(long, value_delimiter = ',')]
    planners: Vec<PlannerChoice>,
    /// Worker threads (default: the machine's cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Output directory: table.md, results.json, results.csv, times.png, trajectories/.
    #[arg(long, default_value = "out/eval")]
    out: PathBuf,
    /// Skip the trajectory pictures.
    #[arg(long)]
    no_pictures: bool,
    #[command(flatten)]
    robot: RobotArgs,
    /// Also run N held-out procedural worlds (seeds 1000001.., which `lives tune` and
    /// `lives dataset` refuse), one trial each, alternately easy and hard: the rows
    /// `heldout easy` and `heldout hard`. 0 runs none.
    #[arg(long, default_value_t = 100)]
    heldout: u64,
    /// Start the held-out worlds this many in (seeds 1000001 + K ..): a second held-out set that
    /// the default run never looks at, e.g. `--heldout-from 100 --heldout 100` to confirm a
    /// result on worlds it was not chosen on.
    #[arg(long, default_value_t = 0)]
    heldout_from: u64,
    /// LIVE's setting: every search is given its world's true map (walls and furniture; not the
    /// targets, clutter or people), and the planners default to `live`, `visual-cpp` and
    /// `lidar-cpp` (docs/live.md). The held-out worlds get theirs too.
    #[arg(long)]
    known_map: bool,
    /// Teams: run a team of each size given (e.g. `1,2,3`) on every setting and seed instead of
    /// single robots (`lives team`, docs/team.md), and write the team table (team.md,
    /// team.json). Held-out worlds are not run.
    #[arg(long, value_delimiter = ',')]
    robots: Vec<usize>,
}

pub fn run(args: EvalArgs) -> Result<ExitCode, String> {
    let EvalArgs {
        trials,
        worlds,
        scenarios,
        planners,
        threads,
        out,
        no_pictures,
        robot: robot_args,
        heldout,
        heldout_from,
        known_map,
        robots,
    } = args;
    let planners = match (planners.is_empty(), known_map) {
        (false, _) => planners,
        (true, false) => PlannerChoice::ALL.into_iter().rev().collect(),
        (true, true) => PlannerChoice::KNOWN_MAP.into_iter().collect(),
    };
    if let Some(p) = planners.iter().find(|p| PlannerChoice::KNOWN_MAP.contains(p) && !known_map) {
        return Err(format!("`{p}` searches a known building: add --known-map"));
    }
    let robot = robot_args.robot;
    if trials == 0 && (heldout == 0 || !robots.is_empty()) {
        return Err("--trials 0 runs no built-in setting: give held-out worlds (--heldout N, no --robots) or at least 1 trial".into());
    }
    let configure = |spec: &mut SearchSpec| robot_args.configure(spec);
    let mut specs = eval::eval_specs(&worlds, &scenarios, &planners, trials, firmware::classifier::EMBEDDED_GEO_MODEL, configure)?;
    if !robots.is_empty() {
        return teams(specs, &robots, known_map, threads.unwrap_or_else(cores), &out);
    }
    specs.extend(eval::heldout_specs(heldout_from, heldout, &planners, firmware::classifier::EMBEDDED_GEO_MODEL, configure)?);
    if known_map {
        host::measure::eval::give_true_maps(&mut specs)?;
    }
    let pb = count_bar();
    pb.set_length(specs.len() as u64);
    let t0 = Instant::now();
    let threads_n = threads.unwrap_or_else(cores);
    let mut results = eval::run_batch(&specs, threads_n, |n| pb.set_position(n as u64))?;
    pb.finish_and_clear();
    let searches_s = t0.elapsed().as_secs_f64();
    eval::attach_oracles(&specs, &mut results, threads_n);
    let wall = t0.elapsed().as_secs_f64();
    let oracles_s = wall - searches_s;
    let cells = eval::summarise(&results);
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    let command = std::env::args().map(|a| if a.contains(' ') { format!("'{a}'") } else { a }).collect::<Vec<_>>().join(" ");
    let table = eval::markdown_table(&cells);
    let claims = eval::claims(&results).unwrap_or_default();
    let heldout_note = if heldout > 0 {
        format!(
            "The held-out rows: {heldout} procedural worlds (`World::random_scenario`, seeds {}–{}, alternately easy and hard; \
             seeds `lives tune` and `lives dataset` refuse), one trial each; their limits are each world's own.\n\n",
            eval::HELDOUT_FIRST_SEED + heldout_from,
            eval::HELDOUT_FIRST_SEED + heldout_from + heldout - 1
        )
    } else {
        String::new()
    };
    let md = format!(
        "Robot: `{robot}` (camera {} m).\n\n{table}\n{heldout_note}{claims}\nCommand: `{command}` · commit {commit} · {} searches in {searches_s:.0} s and their oracles in {oracles_s:.0} s on {threads_n} threads ({wall:.0} s).\n",
        robot.camera_range_m(),
        results.len(),
    );
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    write_file(&out.join("table.md"), &md)?;
    write_file(&out.join("results.csv"), eval::csv(&cells))?;
    let json =
        serde_json::json!({ "command": command, "commit": commit, "robot": robot, "wall_s": wall, "summary": cells, "trials": results });
    write_file(&out.join("results.json"), &serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?)?;
    // Time-to-find distributions: one panel per setting, one column per planner.
    let mut panels = Vec::new();
    let mut seen: Vec<(String, String)> = Vec::new();
    for c in &cells {
        let key = (c.world.clone(), c.scenario.clone());
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        let columns = cells
            .iter()
            .filter(|d| d.world == c.world && d.scenario == c.scenario)
            .map(|d| (d.planner.as_str(), d.times_s.clone()))
            .collect();
        panels.push(host::render::StripPanel {
            title: format!("{} {} (limit {:.0} s)", c.world, c.scenario, c.time_limit_s),
            y_max: c.time_limit_s,
            columns,
        });
    }
    let times_png = out.join("times.png");
    host::render::write_strip_plot(&times_png, &format!("time to find, {trials} trials (failure = limit)"), "s", &panels)
        .map_err(|e| format!("{}: {e}", times_png.display()))?;
    if !no_pictures {
        // One trajectory picture per planner and setting, all for seed 1.
        let dir = out.join("trajectories");
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for spec in specs.iter().filter(|s| s.seed == 1) {
            let run = search::try_run(spec, |_| {}).map_err(|e| format!("{e}"))?;
            let r = &run.result;
            let title = format!(
                "{} {} · {} · seed 1 · {}",
                r.world,
                r.scenario,
                r.planner,
                if r.found { format!("FOUND in {:.1} s", r.time_s) } else { "NOT FOUND".into() }
            );
            let path = dir.join(format!("{}-{}-{}.png", r.world, r.scenario, r.planner));
            host::search::picture::write_png(&run, &path, &title).map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    say!("{md}");
    say!(
        "written: {0}/table.md, {0}/results.json, {0}/results.csv, {0}/times.png{1}",
        out.display(),
        if no_pictures { "" } else { ", trajectories/" }
    );
    Ok(ExitCode::SUCCESS)
}

/// `--robots`: a team of each size on every spec.
fn teams(mut specs: Vec<SearchSpec>, robots: &[usize], known_map: bool, threads: usize, out: &std::path::Path) -> Result<ExitCode, String> {
    if let Some(n) = robots.iter().find(|&&n| n == 0 || n > host::team::MAX_ROBOTS) {
        return Err(format!("--robots {n}: a team has 1 to {} robots", host::team::MAX_ROBOTS));
    }
    if known_map {
        host::measure::eval::give_true_maps(&mut specs)?;
    }
    let pb = count_bar();
    pb.set_length((specs.len() * robots.len()) as u64);
    let t0 = Instant::now();
    let results = host::team::eval::run_batch(&specs, robots, threads, |n| pb.set_position(n as u64))?;
    pb.finish_and_clear();
    let cells = host::team::eval::summarise(&results);
    let command = std::env::args().map(|a| if a.contains(' ') { format!("'{a}'") } else { a }).collect::<Vec<_>>().join(" ");
    let md = format!(
        "{}\nCommand: `{command}` · {} team searches in {:.0} s on {threads} threads.\n",
        host::team::eval::markdown_table(&cells),
        results.len(),
        t0.elapsed().as_secs_f64()
    );
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    write_file(&out.join("team.md"), &md)?;
    let json = serde_json::json!({ "command": command, "summary": cells, "trials": results });
    write_file(&out.join("team.json"), &serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?)?;
    say!("{md}");
    say!("written: {0}/team.md, {0}/team.json", out.display());
    Ok(ExitCode::SUCCESS)
}
