//! `lives search`: one simulated search, its result, and optionally a picture and a recording.

use super::common::{load_spec, progress_bar, result_line, say, RobotArgs, RunArgs};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Run one simulated search and report the result.
#[derive(clap::Args)]
pub struct SearchArgs {
    #[command(flatten)]
    run: RunArgs,
    /// Write a picture of the run here.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Print one JSON object instead of the human-readable line.
    #[arg(long)]
    json: bool,
    /// Print every goal the controller chooses, with its utility terms, to stderr.
    #[arg(long)]
    trace: bool,
    /// With each goal `--trace` prints, also print the N best candidate viewpoints of that
    /// planning step (the chosen one marked `*`); implies `--trace`.
    #[arg(long, value_name = "N")]
    trace_candidates: Option<usize>,
    /// The int8 classifier blob for `lives` (docs/model-format.md: a `LabelPoseNet` blob such
    /// as `firmware/model/lives-int8.bin`, or a geometric one); without it `lives` runs the
    /// committed geometric classifier (`firmware/model/lives-geo-int8.bin`).
    #[arg(long)]
    model: Option<PathBuf>,
    #[command(flatten)]
    robot: RobotArgs,
    /// Record the run (scans, pose, both grids, frontiers, candidates, goals, detection) to an
    /// MCAP file that Foxglove opens (docs/recording.md).
    #[arg(long, value_name = "FILE.mcap")]
    record: Option<PathBuf>,
    /// Search with a team of N robots sharing the search (`lives team --robots N`, docs/team.md;
    /// in this process, no picture or recording).
    #[arg(long, default_value_t = 1)]
    robots: usize,
}

pub fn run(args: SearchArgs) -> Result<ExitCode, String> {
    let SearchArgs { run, png, json, trace, trace_candidates, model, robot, record, robots } = args;
    let mut spec = load_spec(&run)?;
    if robots != 1 {
        if png.is_some() || record.is_some() || trace || trace_candidates.is_some() || model.is_some() {
            return Err(format!("--robots {robots}: a team search takes no --png, --record, --trace or --model (lives team)"));
        }
        robot.configure(&mut spec)?;
        if spec.planner.uses_classifier() {
            spec.model = host::io::model_file::model_option(None, false)?;
        }
        let r = host::team::local::run(&host::team::TeamSpec::new(spec, robots))?;
        say!("{}", if json { serde_json::to_string(&r).map_err(|e| e.to_string())? } else { r.summary() });
        return Ok(if r.found { ExitCode::SUCCESS } else { ExitCode::from(1) });
    }
    spec.trace = trace || trace_candidates.is_some();
    spec.trace_candidates = trace_candidates.unwrap_or(0);
    robot.configure(&mut spec)?;
    let pb = progress_bar(spec.world.time_limit_s as u64);
    let t0 = Instant::now();
    // The committed geometric classifier (docs/model-card-geo.md) unless `--model`; only
    // `lives` runs it.
    if model.is_some() && !spec.planner.uses_classifier() {
        return Err(format!("--model is the classifier `lives` runs; `{}` runs none", spec.planner));
    }
    spec.model = host::io::model_file::model_option(model.as_deref(), false)?;
    let mut recorder =
        record.as_ref().map(|p| host::io::record::Recorder::create(p, Default::default())).transpose().map_err(|e| e.to_string())?;
    let (run, recorded) = host::search::record_search(&spec, recorder.as_mut(), |t| pb.set_position(t as u64)).map_err(|e| {
        format!("{}: the model does not validate: {e}", model.as_ref().map(|p| p.display().to_string()).unwrap_or_default())
    })?;
    let wall = t0.elapsed().as_secs_f64();
    pb.finish_and_clear();
    let mut recording = None;
    if let (Some(rec), Some(path)) = (recorder, &record) {
        recording = Some(recorded.and_then(|()| rec.finish()).map_err(|e| format!("{}: {e}", path.display()))?);
    }
    let r = &run.result;
    if let Some(path) = &png {
        let title = format!(
            "{} {} · {} · seed {} · {} · path {:.1} m",
            r.world,
            r.scenario,
            r.planner,
            r.seed,
            if r.found {
                format!("FOUND in {:.1} s", r.time_s)
            } else {
                format!("NOT FOUND ({}, limit {:.0} s)", r.outcome, r.time_limit_s)
            },
            r.path_m
        );
        host::search::picture::write_png(&run, path, &title).map_err(|e| format!("writing {}: {e}", path.display()))?;
    }
    if json {
        say!("{}", serde_json::to_string(r).map_err(|e| e.to_string())?);
    } else {
        let sim_s = r.ticks as f64 * host::run::TICK_US as f64 / 1e6;
        say!("{}; {:.1} s simulated in {:.2} s ({:.0}x real time)", result_line(r), sim_s, wall, sim_s / wall.max(1e-9));
        if let Some(m) = r.motion {
            let lidar = r.lidar_saw_target_s.map_or("never saw the target".to_string(), |t| format!("first saw the target at {t:.1} s"));
            let reach = match (r.found, r.target_in_camera_reach_s) {
                (false, Some(t)) => format!(
                    "; it was within the camera's reach at {t:.1} s, but the camera did not look that way (or saw too little of it)"
                ),
                _ => String::new(),
            };
            say!("time: {:.1} s moving, {:.1} s turning, {:.1} s still; the LiDAR {lidar}{reach}", m.moving_s, m.turning_s, m.still_s);
        }
        if let Some(x) = &r.sim {
            say!(
                "robot (--robot {}{}): {} m/s, {} rad/s; LiDAR {} m, noise {} m, dropouts {}; camera {} m, {}°, detects at {} of the outline; body {} m",
                robot.robot,
                if robot.set_sim.sim.is_empty() { "" } else { " --sim" },
                x.speed_mps,
                x.turn_rate_rps,
                x.lidar_max_range_m,
                x.range_noise_std_m,
                x.dropout_prob,
                x.camera_range_m,
                x.camera_fov_deg,
                x.detect_min_visible_fraction,
                x.robot_radius_m
            );
        }
        if let Some(c) = r.classifier {
            say!(
                "labels: the classifier agreed with the simulator's truth on {:.1} % of {} beams (non-map: {:.1} % found, {:.1} % of its non-map labels right)",
                100.0 * c.accuracy,
                c.beams,
                100.0 * c.nonmap_recall,
                100.0 * c.nonmap_precision
            );
        }
        if let Some(p) = &png {
            say!("picture: {}", p.display());
        }
        if let (Some(p), Some(s)) = (&record, &recording) {
            say!("recording: {} ({} messages on {} topics)", p.display(), s.total_messages(), s.messages.len());
        }
    }
    Ok(if r.found { ExitCode::SUCCESS } else { ExitCode::from(1) })
}
