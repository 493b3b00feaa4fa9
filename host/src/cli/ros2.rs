//! `lives ros2`: the controller on a robot's ROS 2 graph (host::link::ros2, docs/ros2.md).

use super::common::say;
use host::link::ros2::{self, Ros2Options};
use host::search::PlannerChoice;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// Joins a ROS 2 graph over DDS (no ROS installation) and searches with the robot on it:
/// subscribes to `scan` (or a 3D LiDAR's `points`), `odom`, `tf`, `tf_static`, `target`, `detections` and `base_blocked`;
/// publishes `goal_pose`, `plan`, `lives/status`, `lives/lidar_map`, `lives/camera_map` and
/// `lives/markers` (docs/ros2.md). The domain is `ROS_DOMAIN_ID`; `ROS_LOCALHOST_ONLY=1` or
/// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` keep it on this machine.
#[derive(clap::Args)]
pub struct Ros2Args {
    /// lives, multisensor, nearest, explore-lite or rrt (`lives-gt` needs the simulator's labels).
    #[arg(long, default_value = "lives")]
    planner: PlannerChoice,
    /// Override a controller parameter, e.g. `--set w_dist_per_m=2` (repeatable; `lives params`).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// The int8 classifier blob `lives` runs (default: the committed geometric one).
    #[arg(long)]
    model: Option<PathBuf>,
    /// The grid's lower-left corner `X,Y` in the odometry frame, metres (default: a 51.2 m grid
    /// centred on the first placed scan).
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    origin: Option<String>,
    /// Remap a topic, `FROM:=TO` (repeatable), e.g. `--remap scan:=/spot/lidar/scan`.
    #[arg(long, value_name = "FROM:=TO")]
    remap: Vec<String>,
    /// Answer every scan, in stamp order (a simulator that waits for each answer); default: the
    /// newest scan every 200 ms.
    #[arg(long)]
    lockstep: bool,
    /// Never end the run: search again when exhausted, as `lives replay` does (a robot driven by
    /// someone else, a log played back); stop it with --max-wall or a signal.
    #[arg(long)]
    continuous: bool,
    /// Stop after this many seconds of wall time.
    #[arg(long, value_name = "S")]
    max_wall: Option<f64>,
    /// Stop when no scan has arrived for this many seconds (or none since the start).
    #[arg(long, value_name = "S")]
    max_idle: Option<f64>,
    /// LIVE's known-map mode: the building's map (ROS map_server `.yaml`, in the frame the scans
    /// are placed in: `map` when the robot localises in it). It seeds the grid and labels the
    /// scans; `live`, `visual-cpp` and `lidar-cpp` follow a coverage route planned from where
    /// the first scan was placed (in a team, the one the coordinator assigns).
    #[arg(long, value_name = "FILE.yaml")]
    map: Option<PathBuf>,
    /// Join a team in real time as robot I (0 to N-1): its coordinator (`lives team --external
    /// --robots N`) runs elsewhere on this DDS domain, shares out the route, merges what the
    /// robots saw and stops everyone on a find (docs/team.md). Needs --origin, the same on every
    /// robot and the coordinator, in the frame the robots share.
    #[arg(long, value_name = "I")]
    team_robot: Option<usize>,
    /// In a team: the coordinator counts this robot lost after this many seconds of silence.
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    link_timeout: f64,
    /// Keep DDS on the loopback interface (as `ROS_LOCALHOST_ONLY=1`).
    #[arg(long)]
    localhost: bool,
    /// Print one JSON object at the end.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Ros2Args) -> Result<ExitCode, String> {
    let Ros2Args {
        planner,
        set,
        model,
        origin,
        remap,
        lockstep,
        continuous,
        max_wall,
        max_idle,
        map,
        team_robot,
        link_timeout,
        localhost,
        json,
    } = args;
    if planner == PlannerChoice::LivesGt {
        return Err("`lives-gt` runs on the simulator's ground-truth labels, which do not travel over ROS; use `lives`".into());
    }
    let mut opts = Ros2Options::from_env()?;
    opts.lockstep = lockstep;
    opts.continuous = continuous;
    opts.localhost_only |= localhost;
    for r in &remap {
        let (from, to) =
            r.split_once(":=").filter(|(f, t)| !f.is_empty() && !t.is_empty()).ok_or_else(|| format!("--remap {r}: expected FROM:=TO"))?;
        opts.remap.push((from.to_string(), to.to_string()));
    }
    opts.max_wall = max_wall.map(|s| positive_secs("--max-wall", s)).transpose()?;
    opts.max_idle = max_idle.map(|s| positive_secs("--max-idle", s)).transpose()?;
    let origin = origin.as_deref().map(host::link::robot::parse_origin).transpose()?;
    // The planner's own defaults first, so that `--set` overrides them.
    let mut cfg = host::link::robot::REAL_ROBOT_CONFIG.with_planner(planner.kind());
    for a in &set {
        host::overrides::apply(&mut cfg, a)?;
    }
    let blob = if planner.uses_classifier() { host::io::model_file::model_option(model.as_deref(), false)? } else { None };
    if model.is_some() && blob.is_none() {
        return Err(format!("--model is the classifier `lives` runs; `{planner}` runs none"));
    }
    // SIGINT or SIGTERM: stop the base (an empty plan and a goal where it stands), then exit.
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone()).map_err(|e| format!("cannot handle signal {sig}: {e}"))?;
    }
    if planner.kind().is_coverage() && map.is_none() {
        return Err(format!("`{planner}` searches a known building: give its map with --map FILE.yaml"));
    }
    if team_robot.is_some() && continuous {
        return Err("--continuous and --team-robot: a team robot searches until its coordinator says stop".into());
    }
    if team_robot.is_some_and(|i| i >= host::team::MAX_ROBOTS) {
        return Err(format!("--team-robot {}: a team has robots 0 to {}", team_robot.unwrap_or(0), host::team::MAX_ROBOTS - 1));
    }
    let link_timeout = positive_secs("--link-timeout", link_timeout)?;
    let map = map.as_deref().map(host::io::map_file::PriorMap::load).transpose().map_err(|e| e.to_string())?;
    let brain = ros2::Ros2Brain { origin, model: blob, map };
    let run = match team_robot {
        Some(id) => team_member(opts, cfg, brain, id, link_timeout, stop)?,
        None => ros2::run(opts, cfg, brain, stop).map_err(|e| e.to_string())?,
    };
    let lat = host::link::Summary::of(&run.answer_us);
    if json {
        say!(
            "{}",
            serde_json::json!({
                "end": format!("{:?}", run.end).to_lowercase(),
                "ticks": run.ticks,
                "wall_s": run.wall_s,
                "goals": run.goals,
                "answer_us": lat,
                "received": run.received,
                "rejected": run.rejected,
            })
        );
    } else {
        say!("{:?} after {} ticks, {} goals, {:.1} s wall", run.end, run.ticks, run.goals.len(), run.wall_s);
        say!("scan to answer: p50 {:.0} us, p95 {:.0} us; received {:?}; rejected {:?}", lat.p50, lat.p95, run.received, run.rejected);
    }
    Ok(if run.end == host::run::End::Found { ExitCode::SUCCESS } else { ExitCode::from(1) })
}

/// `--team-robot I`: robot I of a team in real time (host::team::realtime, docs/team.md).
fn team_member(
    opts: Ros2Options,
    cfg: firmware::Config,
    brain: ros2::Ros2Brain,
    id: usize,
    link_timeout: Duration,
    stop: Arc<AtomicBool>,
) -> Result<ros2::Ros2Run, String> {
    host::team::realtime::ros2_member(opts, cfg, brain, host::team::realtime::TeamSeat { id, link_timeout }, stop)
}

fn positive_secs(flag: &str, s: f64) -> Result<Duration, String> {
    (s.is_finite() && s > 0.0)
        .then(|| Duration::from_secs_f64(s))
        .ok_or_else(|| format!("{flag} {s}: expected a positive number of seconds"))
}
