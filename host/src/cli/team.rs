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
    /// With --processes: no lockstep. The coordinator and every robot keep their own clock
    /// (docs/team.md, "In real time"): a round of the coordinator and a tick of a robot take
    /// 0.2 s of wall time divided by --speedup.
    #[arg(long)]
    real_time: bool,
    /// With --processes --real-time: freeze robot R's process at the team's time T seconds for
    /// D seconds of wall time (`R@T:D`), a link that drops and comes back: the robot is lost,
    /// its work shared out, and it is taken in again when it answers.
    #[arg(long, value_name = "R@T:D")]
    pause: Option<String>,
    /// With --real-time: simulated seconds per wall second (e.g. 4: a 0.2 s tick every 50 ms).
    #[arg(long, default_value_t = 1.0)]
    speedup: f64,
    /// Coordinate robots started elsewhere, in real time: real robots running `lives ros2
    /// --team-robot I --origin X,Y` (or simulated ones, `lives team --real-time --as-robot I`)
    /// on this DDS domain. --planner, --map and --origin say what the coordinator plans on.
    #[arg(long)]
    external: bool,
    /// With --external: the grid's lower-left corner `X,Y` every robot was given (`lives ros2
    /// --origin`), in the frame the robots share.
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    origin: Option<String>,
    /// With --external: end the search after this many seconds (default: the world's limit).
    #[arg(long, value_name = "S")]
    time_limit: Option<f64>,
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

fn parse_pause(s: &str) -> Result<(usize, f64, f64), String> {
    let bad = || format!("--pause {s}: expected ROBOT@SECONDS:WALL_SECONDS, e.g. 1@20:5");
    let (rt, d) = s.split_once(':').ok_or_else(bad)?;
    let (r, t) = parse_kill(rt).map_err(|_| bad())?;
    let d = d.trim().parse::<f64>().ok().filter(|d| d.is_finite() && *d > 0.0 && *d <= 3600.0).ok_or_else(bad)?;
    Ok((r, t, d))
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
    if !args.speedup.is_finite() || args.speedup <= 0.0 || args.speedup > 100.0 {
        return Err(format!("--speedup {}: a factor in (0, 100]", args.speedup));
    }
    if (args.speedup != 1.0 && !(args.real_time || args.external)) || (args.real_time && !(args.processes || args.as_robot.is_some())) {
        return Err(
            "--real-time (and --speedup) run a team of processes over DDS: add --processes (or --external, always in real time)".into()
        );
    }
    let pause = args.pause.as_deref().map(parse_pause).transpose()?;
    if let Some((r, _, _)) = pause {
        if !(args.real_time && args.processes) || r >= args.robots {
            return Err(format!("--pause: a robot 0..{} of a team run with --processes --real-time", args.robots.max(1) - 1));
        }
    }
    if args.external {
        return external(&args);
    }
    if args.origin.is_some() || args.time_limit.is_some() {
        return Err("--origin and --time-limit are for --external (robots started elsewhere)".into());
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

/// `--external`: the coordinator of robots started elsewhere.
fn external(args: &TeamArgs) -> Result<ExitCode, String> {
    if args.known_map || args.processes || args.kill.is_some() || args.as_robot.is_some() {
        return Err("--external coordinates robots started elsewhere: not with --known-map, --processes, --kill or --as-robot".into());
    }
    let origin = args.origin.as_deref().map(host::link::robot::parse_origin).transpose()?.ok_or(
        "--external: give the grid's origin with --origin X,Y, the one every robot was given (`lives ros2 --team-robot I --origin X,Y`)",
    )?;
    let map = args.run.map.as_deref().map(host::io::map_file::PriorMap::load).transpose().map_err(|e| e.to_string())?;
    // The planner and the controller's settings as for a search, without the map (it is the
    // robots' frame's, placed at --origin below).
    let mut spec = load_spec(&RunArgs { planner: host::search::PlannerChoice::Lives, map: None, ..args.run.clone() })?;
    spec.planner = args.run.planner;
    spec.controller = spec.controller.with_planner(spec.planner.kind());
    args.robot.configure(&mut spec)?;
    spec.world_name = "external".into();
    spec.scenario = None;
    if let Some(t) = args.time_limit {
        if !t.is_finite() || t <= 0.0 {
            return Err(format!("--time-limit {t}: a time > 0 s"));
        }
        spec.world.time_limit_s = t;
    }
    let sim_for = args.sim_for.iter().map(|s| parse_sim_for(s)).collect::<Result<Vec<_>, _>>()?;
    let tspec = TeamSpec { sim_for, ..TeamSpec::new(spec, args.robots) };
    let result = coordinate_external(args, &tspec, origin, map.as_ref())?;
    if args.json {
        say!("{}", serde_json::to_string_pretty(&result).map_err(|e| e.to_string())?);
    } else {
        say!("{}", result.summary());
    }
    Ok(if result.found { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

#[cfg(feature = "ros2")]
fn coordinate_external(
    args: &TeamArgs,
    spec: &TeamSpec,
    origin: [f64; 2],
    map: Option<&host::io::map_file::PriorMap>,
) -> Result<TeamResult, String> {
    let opts = host::link::ros2::Ros2Options::from_env()?;
    let dds = team::dds::DdsOptions {
        domain: args.domain.unwrap_or(opts.domain),
        localhost_only: opts.localhost_only,
        link_timeout: std::time::Duration::from_secs_f64(args.link_timeout),
    };
    team::realtime::coordinate_external(spec, origin, map, &team::realtime::RealtimeOptions { dds, speedup: args.speedup, pause: None })
}

#[cfg(not(feature = "ros2"))]
fn coordinate_external(
    _args: &TeamArgs,
    _spec: &TeamSpec,
    _origin: [f64; 2],
    _map: Option<&host::io::map_file::PriorMap>,
) -> Result<TeamResult, String> {
    Err("--external talks over DDS: build with `--features ros2`".into())
}

#[cfg(feature = "ros2")]
fn over_dds(args: &TeamArgs, spec: &TeamSpec) -> Result<Option<TeamResult>, String> {
    let domain = match args.domain {
        Some(d) => d,
        None => host::link::ros2::Ros2Options::from_env()?.domain,
    };
    let opts = team::dds::DdsOptions { domain, localhost_only: true, link_timeout: std::time::Duration::from_secs_f64(args.link_timeout) };
    let pause = args.pause.as_deref().map(parse_pause).transpose()?;
    let realtime = team::realtime::RealtimeOptions { dds: opts.clone(), speedup: args.speedup, pause };
    if let Some(i) = args.as_robot {
        if args.real_time {
            team::realtime::sim_robot(spec, i, &realtime)?;
        } else {
            team::dds::robot(spec, i, &opts)?;
        }
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
            "--kill" | "--domain" | "--pause" => {
                skip = true;
                continue;
            }
            _ if a.starts_with("--kill=") || a.starts_with("--domain=") || a.starts_with("--pause=") => continue,
            _ => base.push(a),
        }
    }
    let robot_args = |i: usize| {
        let mut v = base.clone();
        v.extend(["--domain".to_string(), domain.to_string(), "--as-robot".to_string(), i.to_string()]);
        v
    };
    if args.real_time {
        team::realtime::run(spec, &realtime, robot_args).map(Some)
    } else {
        team::dds::run(spec, &opts, robot_args).map(Some)
    }
}

#[cfg(not(feature = "ros2"))]
fn over_dds(_args: &TeamArgs, _spec: &TeamSpec) -> Result<Option<TeamResult>, String> {
    Err("--processes talks over DDS: build with `--features ros2`".into())
}
