//! `lives team`: a team of robots sharing one search (host::team, docs/team.md).

use super::common::{load_spec, say, RobotArgs, RunArgs};
use host::team::{self, TeamResult, TeamSpec};
use std::process::ExitCode;

/// Search with a team of N simulated robots: each keeps its own controller core; a coordinator
/// shares out the known map's coverage route by path cost (planners live, visual-cpp,
/// lidar-cpp with --map or --known-map), merges what the cameras (and, without a map, the
/// LiDARs) saw, keeps each robot off a goal a nearer teammate pursues, re-assigns a lost
/// robot's waypoints, and stops everyone when one finds the target. `--processes` runs every robot as
/// a process of its own, talking to the coordinator over DDS (ROS 2's middleware).
#[derive(clap::Args)]
pub struct TeamArgs {
    #[command(flatten)]
    run: RunArgs,
    #[command(flatten)]
    robot: RobotArgs,
    /// Robots in the team (1 to 8).
    #[arg(long, default_value_t = 2)]
    robots: usize,
    /// Give the search the world's true map (walls and furniture), as `lives eval --known-map`.
    #[arg(long)]
    known_map: bool,
    /// Cut robot R's link at simulated time T seconds (`R@T`): its process is killed and its
    /// waypoints are re-assigned.
    #[arg(long, value_name = "R@T")]
    kill: Option<String>,
    /// Change robot I's simulated robot, e.g. `--sim-for 1:speed_mps=1.0` (a faster base) or
    /// `--sim-for 2:camera_range_m=4` (repeatable; names as `--sim`, applied after it): a team
    /// of different robots. The coordinator shares the route out by each robot's time.
    #[arg(long = "sim-for", value_name = "I:NAME=VALUE")]
    sim_for: Vec<String>,
    /// Every robot a separate process, over DDS on this machine (feature `ros2`).
    #[arg(long)]
    processes: bool,
    /// The DDS domain for --processes (default `ROS_DOMAIN_ID`, else 0).
    #[arg(long)]
    domain: Option<u16>,
    /// A robot that has not answered a tick within this many seconds of wall time is lost
    /// (--processes).
    #[arg(long, default_value_t = 10.0)]
    link_timeout: f64,
    /// Run as robot I of a team over DDS (what --processes starts; not for direct use).
    #[arg(long, hide = true)]
    as_robot: Option<usize>,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

fn parse_sim_for(s: &str) -> Result<(usize, String), String> {
    let (r, a) = s.split_once(':').ok_or_else(|| format!("--sim-for {s}: expected ROBOT:NAME=VALUE, e.g. 1:speed_mps=1.0"))?;
    let r = r.trim().parse::<usize>().map_err(|_| format!("--sim-for {s}: `{r}` is not a robot index"))?;
    Ok((r, a.trim().to_string()))
}

fn parse_kill(s: &str) -> Result<(usize, f64), String> {
    let (r, t) = s.split_once('@').ok_or_else(|| format!("--kill {s}: expected ROBOT@SECONDS, e.g. 1@60"))?;
    let r = r.trim().parse::<usize>().map_err(|_| format!("--kill {s}: `{r}` is not a robot index"))?;
    let t = t
        .trim()
        .parse::<f64>()
        .ok()
        .filter(|t| t.is_finite() && *t >= 0.0)
        .ok_or_else(|| format!("--kill {s}: `{t}` is not a time ≥ 0 s"))?;
    Ok((r, t))
}

pub fn run(args: TeamArgs) -> Result<ExitCode, String> {
    // Checked whether or not the run goes over DDS: a bad value is never silently ignored.
    if !args.link_timeout.is_finite() || args.link_timeout <= 0.0 {
        return Err(format!("--link-timeout {}: a time > 0 s", args.link_timeout));
    }
    // `--known-map` stands for `--map`: load as a search without one, then give the true map.
    let mut spec = if args.known_map && args.run.map.is_none() {
        let mut s = load_spec(&RunArgs { planner: host::search::PlannerChoice::Lives, map: None, ..args.run.clone() })?;
        s.planner = args.run.planner;
        s.controller = s.controller.with_planner(s.planner.kind());
        s
    } else {
        load_spec(&args.run)?
    };
    args.robot.configure(&mut spec)?;
    if spec.planner.uses_classifier() {
        spec.model = host::io::model_file::model_option(None, false)?;
    }
    if args.known_map {
        if args.run.map.is_some() {
            return Err("--known-map gives the world's own map; --map gives a file: not both".into());
        }
        host::measure::eval::give_true_maps(std::slice::from_mut(&mut spec))?;
    }
    if spec.planner.kind().is_coverage() && spec.prior_map.is_none() {
        return Err(format!("`{}` searches a known building: add --known-map or --map FILE.yaml", spec.planner));
    }
    let kill = args.kill.as_deref().map(parse_kill).transpose()?;
    let sim_for = args.sim_for.iter().map(|s| parse_sim_for(s)).collect::<Result<Vec<_>, _>>()?;
    let tspec = TeamSpec { kill, sim_for, ..TeamSpec::new(spec, args.robots) };
    let result = if args.processes || args.as_robot.is_some() { over_dds(&args, &tspec)? } else { Some(team::local::run(&tspec)?) };
    let Some(result) = result else { return Ok(ExitCode::SUCCESS) };
    if args.json {
        say!("{}", serde_json::to_string_pretty(&result).map_err(|e| e.to_string())?);
    } else {
        say!("{}", result.summary());
    }
    Ok(if result.found { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

#[cfg(feature = "ros2")]
fn over_dds(args: &TeamArgs, spec: &TeamSpec) -> Result<Option<TeamResult>, String> {
    let domain = match args.domain {
        Some(d) => d,
        None => host::link::ros2::Ros2Options::from_env()?.domain,
    };
    let opts = team::dds::DdsOptions { domain, localhost_only: true, link_timeout: std::time::Duration::from_secs_f64(args.link_timeout) };
    if let Some(i) = args.as_robot {
        team::dds::robot(spec, i, &opts)?;
        return Ok(None);
    }
    // Each robot runs this command again as robot I, minus what only the coordinator does.
    let mut base: Vec<String> = Vec::new();
    let mut skip = false;
    for a in std::env::args().skip(1) {
        if skip {
            skip = false;
            continue;
        }
        match a.as_str() {
            "--processes" | "--json" => continue,
            "--kill" | "--domain" => {
                skip = true;
                continue;
            }
            _ if a.starts_with("--kill=") || a.starts_with("--domain=") => continue,
            _ => base.push(a),
        }
    }
    let robot_args = |i: usize| {
        let mut v = base.clone();
        v.extend(["--domain".to_string(), domain.to_string(), "--as-robot".to_string(), i.to_string()]);
        v
    };
    team::dds::run(spec, &opts, robot_args).map(Some)
}

#[cfg(not(feature = "ros2"))]
fn over_dds(_args: &TeamArgs, _spec: &TeamSpec) -> Result<Option<TeamResult>, String> {
    Err("--processes talks over DDS: build with `--features ros2`".into())
}
