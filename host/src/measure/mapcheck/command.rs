//! `lives mapcheck`: a log or a simulated search scored, and the report as a table.

use super::*;
use crate::io::replay::{self, TimedPose};
use crate::search::{PlannerChoice, SearchSpec};
use crate::sim::Scenario;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// `lives mapcheck` arguments.
#[derive(clap::Args, Debug)]
pub struct MapcheckArgs {
    /// The log to replay and score (as `lives replay` reads it); omit it with `--world`.
    #[arg(required_unless_present = "world", conflicts_with = "world")]
    pub file: Option<PathBuf>,
    /// Score against the map drawn from another log of the same building (e.g. the SLAM-corrected
    /// CSAIL log) instead of this log's own poses; needs `--align`.
    #[arg(long, value_name = "OTHER.log", requires = "align")]
    pub reference: Option<PathBuf>,
    /// Poses `timestamp x y theta` in the `--reference` log's frame, keyed by this log's time
    /// stamps: they place the reference in this run's frame (least squares over every match).
    #[arg(long, value_name = "POSES.txt", requires = "reference")]
    pub align: Option<PathBuf>,
    /// Score against the building's floor map (a ROS map_server `.yaml`, e.g. the map a robot
    /// localised in with AMCL): its occupied cells are the walls, and walls recovered counts those
    /// the log's viewpoints could see (docs/mapcheck.md). The map is placed in the log's frame by
    /// `--floor-map-pose` (default: the same frame, as a bag whose frame tree has `map` at its root).
    #[arg(long, value_name = "MAP.yaml", conflicts_with_all = ["world", "reference"])]
    pub floor_map: Option<PathBuf>,
    /// The floor map's frame in the log's frame, `X,Y,YAW` (metres, metres, degrees).
    #[arg(long, value_name = "X,Y,YAW", requires = "floor_map", allow_hyphen_values = true)]
    pub floor_map_pose: Option<String>,
    /// Ground-truth relations `t1 t2 x y z roll pitch yaw` (Kümmerle et al. 2009): report the
    /// relation errors of the log's poses and of the controller's.
    #[arg(long, value_name = "FILE", conflicts_with = "world")]
    pub relations: Option<PathBuf>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Write a picture of the scored grid here (two pixels per cell): free white, free-space leak
    /// orange, matched wall black, phantom wall magenta, lost reference wall red, unknown grey.
    #[arg(long, value_name = "FILE.png")]
    pub png: Option<PathBuf>,
    /// Do not run a classifier.
    #[arg(long, conflicts_with = "model")]
    pub no_classifier: bool,
    /// The int8 classifier blob to run (as `lives replay` and `lives search`).
    #[arg(long, value_name = "BLOB")]
    pub model: Option<PathBuf>,
    /// The controller's LiDAR range for a log, metres (as `lives replay --max-range`).
    #[arg(long, value_name = "METRES", conflicts_with = "world")]
    pub max_range: Option<f64>,
    /// Override a controller parameter (repeatable; `lives params` lists them).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Simulate a search in this world instead (as `lives search --world`) and score its map
    /// against the true world.
    #[arg(long)]
    pub world: Option<String>,
    /// easy or hard (with `--world`; default easy).
    #[arg(long, requires = "world")]
    pub scenario: Option<Scenario>,
    /// The planner (with `--world`; default lives).
    #[arg(long, requires = "world")]
    pub planner: Option<PlannerChoice>,
    /// The seed (with `--world`; default 1).
    #[arg(long, requires = "world")]
    pub seed: Option<u64>,
    /// The simulated robot (with `--world`; as `lives search --robot`): `calibrated` (the
    /// default) or `short`. `--sim` then changes it further.
    #[arg(long, requires = "world")]
    pub robot: Option<crate::search::Robot>,
    /// Change the simulated robot (with `--world`; as `lives search --sim`).
    #[arg(long = "sim", value_name = "NAME=VALUE", requires = "world")]
    pub sim: Vec<String>,
}

/// Runs `lives mapcheck`. `load_spec(world, scenario, planner, seed)` builds a search as `lives
/// search` does. Exit status 0, 1 when the log was not clean (as `lives replay`), `Err` (status 2)
/// on bad input.
pub fn run_command(
    args: &MapcheckArgs,
    load_spec: impl FnOnce(&str, Option<Scenario>, PlannerChoice, u64) -> Result<SearchSpec, String>,
) -> Result<std::process::ExitCode, String> {
    let (report, clean) = match (&args.world, &args.file) {
        (Some(world), _) => {
            let planner = args.planner.unwrap_or(PlannerChoice::Lives);
            let mut spec = load_spec(world, args.scenario, planner, args.seed.unwrap_or(1))?;
            // The robot `lives search` simulates unless told otherwise.
            args.robot.unwrap_or(crate::search::Robot::Calibrated).apply(&mut spec)?;
            for a in &args.sim {
                crate::overrides::apply_sim(&mut spec.sim, &mut spec.controller, a)?;
            }
            for a in &args.set {
                crate::overrides::apply(&mut spec.controller, a)?;
            }
            if args.model.is_some() && !planner.uses_classifier() {
                return Err(format!("--model is the classifier `lives` runs; `{planner}` runs none"));
            }
            spec.model = crate::io::model_file::model_option(args.model.as_deref(), args.no_classifier)?;
            (check_search(&spec, args.png.as_deref())?, true)
        }
        (None, Some(file)) => check_log(file, args)?,
        (None, None) => return Err("give a log to replay, or --world".into()),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?);
    } else {
        print!("{}", table(&report));
    }
    Ok(if clean { std::process::ExitCode::SUCCESS } else { std::process::ExitCode::from(1) })
}

/// Replays `file` and scores it (the bool: the log, and the `--reference` log if any, were clean).
pub fn check_log(file: &Path, args: &MapcheckArgs) -> Result<(MapcheckReport, bool), String> {
    // The options exactly as `lives replay` takes them.
    let opts = replay::options(args.model.as_deref(), args.no_classifier, &args.set, args.max_range)?;
    // Read every input file before the replay, so a bad one fails fast.
    let relations = args.relations.as_deref().map(|p| read_relations(p).map(|r| (p, r))).transpose()?;
    let align = args.align.as_deref().map(|p| read_poses(p).map(|r| (p, r))).transpose()?;
    let other = args.reference.as_deref().map(|p| replay::read_log(p).map_err(|e| e.to_string())).transpose()?;
    let floor = args.floor_map.as_deref().map(|p| crate::io::map_file::PriorMap::load(p).map_err(|e| e.to_string())).transpose()?;
    let floor_pose = args.floor_map_pose.as_deref().map(parse_pose).transpose()?.unwrap_or([0.0; 3]);
    let t0 = Instant::now();
    let log = replay::read_log(file).map_err(|e| e.to_string())?;
    let read_s = t0.elapsed().as_secs_f64();
    let log_poses: Vec<TimedPose> = log.scans.iter().map(|s| TimedPose { t_s: s.t_s, pose: s.pose }).collect();
    let own_scans = if other.is_none() { log.scans.clone() } else { Vec::new() };
    let viewpoints: Vec<([f64; 2], f64)> = drawable(&log.scans).iter().map(|s| ([s.pose[0], s.pose[1]], reach(s))).collect();
    let run = replay::replay_log(log, &opts, t0, read_s).map_err(|e| e.to_string())?;
    // The reference log's own damage makes the figures less than they seem: said, and not clean.
    let other_clean = other.as_ref().is_none_or(|o| {
        for e in o.bad_records.first.iter() {
            eprintln!("warning: the reference: {e} (skipped)");
        }
        if let Some(e) = &o.error {
            eprintln!("warning: the reference: {e} (reading stopped there; the scans before it are the reference)");
        }
        o.bad_records.total == 0 && o.error.is_none()
    });
    let clean = run.bad_records.total == 0 && run.error.is_none() && other_clean;
    let cfg = run.controller.config();
    let range = cfg.lidar_max_range_m.to_num::<f64>();
    let min_range = cfg.lidar_min_range_m.to_num::<f64>();
    let geom = run.controller.lidar.geom;
    let origin = [geom.origin_x.to_num::<f64>(), geom.origin_y.to_num::<f64>()];
    let grid = MapGrid::of(&run.controller.lidar);
    let mut reference = Reference::new(grid.n, range);
    let (kind, ref_file, alignment) = match (&other, &align) {
        _ if floor.is_some() => {
            let map = floor.as_ref().expect("a floor map");
            draw_floor_map(&mut reference, map, &floor_pose, origin);
            let c = cell_m();
            reference.viewpoints = viewpoints.iter().map(|(p, _)| [(p[0] - origin[0]) / c, (p[1] - origin[1]) / c]).collect();
            reference.reach_m = viewpoints.iter().map(|(_, r)| *r).collect();
            reference.seen_walls_only = true;
            ("floor-map", Some(map.file.clone()), None)
        }
        (Some(other), Some((apath, aposes))) => {
            let index = PoseIndex::new(&run.poses);
            let pairs: Vec<([f64; 3], [f64; 3])> = aposes.iter().filter_map(|p| index.at(p.t_s).map(|q| (q, p.pose))).collect();
            let Some((t, rms, max)) = fit_rigid(&pairs) else {
                return Err(format!(
                    "{}: none of its {} time stamps matches a scan the replay of {} used (within {} ms)",
                    apath.display(),
                    aposes.len(),
                    file.display(),
                    MATCH_S * 1e3
                ));
            };
            let to_grid = inverse(&t);
            project_scans(&mut reference, &drawable(&other.scans), &to_grid, origin, min_range, range);
            let a = Alignment {
                file: apath.display().to_string(),
                poses: aposes.len(),
                matched: pairs.len(),
                transform: t,
                rms_m: rms,
                max_m: max,
            };
            ("other-log", Some(other.file.display().to_string()), Some(a))
        }
        (None, _) => {
            project_scans(&mut reference, &drawable(&own_scans), &[0.0, 0.0, 0.0], origin, min_range, range);
            ("log-poses", Some(file.display().to_string()), None)
        }
        (Some(_), None) => return Err("--reference needs --align POSES.txt (its poses keyed by this log's time stamps)".into()),
    };
    let (map, classes) = score_cells(&grid, &reference, range, RAYS);
    let own_rays = (kind != "other-log").then(|| {
        let rays = own_rays_map(grid.n, &drawable(&own_scans), &[0.0, 0.0, 0.0], origin, min_range, range);
        let (m, own_classes) = score_cells(&rays.grid, &reference, range, RAYS);
        let shared = classes.iter().zip(&own_classes).filter(|(a, b)| **a == CellClass::Leak && **b == CellClass::Leak).count();
        let lost: Vec<usize> = (0..classes.len()).filter(|&i| classes[i] == CellClass::Lost).collect();
        let through = |i: usize| rays.crossed_scans[i] > rays.hit_scans[i];
        let seen_through = lost.iter().filter(|&&i| through(i)).count();
        let n = grid.n as usize;
        let walls_seen_through = (0..n * n).filter(|&i| reference.is_wall((i % n) as i32, (i / n) as i32) && through(i)).count();
        OwnRays {
            free_cells: m.free_cells,
            leak_cells: m.leak_cells,
            free_space_leak: m.free_space_leak,
            grid_leaks_shared: shared as u64,
            lost_walls: lost.len() as u64,
            lost_walls_seen_through: seen_through as u64,
            walls_seen_through: walls_seen_through as u64,
        }
    });
    if let Some(p) = &args.png {
        write_png(p, grid.n, &classes)?;
    }
    let relations = relations.map(|(p, rels)| {
        let (log_idx, run_idx) = (PoseIndex::new(&log_poses), PoseIndex::new(&run.poses));
        let align_idx = align.as_ref().map(|(_, a)| PoseIndex::new(a));
        let subset = |short: bool| {
            let sub: Vec<Relation> = rels.iter().filter(|r| ((r.t2 - r.t1).abs() < SHORT_SPAN_S) == short).copied().collect();
            RelationSubset {
                relations: sub.len(),
                log_poses: relation_errors(&log_idx, &sub),
                controller: relation_errors(&run_idx, &sub),
                align_poses: align_idx.as_ref().map(|a| relation_errors(a, &sub)),
            }
        };
        RelationsReport {
            file: p.display().to_string(),
            relations: rels.len(),
            log_poses: relation_errors(&log_idx, &rels),
            controller: relation_errors(&run_idx, &rels),
            align_poses: align_idx.as_ref().map(|a| relation_errors(a, &rels)),
            short: subset(true),
            long: subset(false),
        }
    });
    let report = MapcheckReport {
        subject: file.display().to_string(),
        reference: ReferenceInfo {
            kind: kind.into(),
            file: ref_file,
            viewpoints: reference.viewpoints.len(),
            rays_per_viewpoint: RAYS,
            alignment,
        },
        grid_origin: origin,
        cell_m: cell_m(),
        grid_size_m: grid.n as f64 * cell_m(),
        clearing_range_m: range,
        map,
        own_rays,
        relations,
        replay: Some(run.report),
        search: None,
    };
    Ok((report, clean))
}

/// `X,Y,YAW` (metres, metres, degrees) as `[x, y, yaw in radians]`.
fn parse_pose(text: &str) -> Result<[f64; 3], String> {
    let [x, y, yaw] = crate::overrides::finite_numbers(text)
        .ok_or_else(|| format!("--floor-map-pose `{text}`: three finite numbers X,Y,YAW (metres, metres, degrees)"))?;
    Ok([x, y, yaw.to_radians()])
}

/// Draws the occupied cells of a floor map, placed at `pose` (the map frame in the log's frame),
/// into `reference` (grid lower-left corner `origin`): each map cell is sampled at points at
/// most half a grid cell apart, so a map coarser than the grid marks every grid cell it covers
/// and a finer one marks the grid cell of each of its cells.
pub fn draw_floor_map(reference: &mut Reference, map: &crate::io::map_file::PriorMap, pose: &[f64; 3], origin: [f64; 2]) {
    let c = cell_m();
    let res = map.resolution_m;
    let k = (res / (c / 2.0)).ceil().max(1.0) as usize;
    let (sin, cos) = pose[2].sin_cos();
    for y in 0..map.height {
        for x in 0..map.width {
            if map.get(x, y) != Some(crate::io::map_file::Cell3::Occupied) {
                continue;
            }
            for j in 0..k {
                for i in 0..k {
                    let [u, v] =
                        map.world([(x as f64 + (i as f64 + 0.5) / k as f64) * res, (y as f64 + (j as f64 + 0.5) / k as f64) * res]);
                    let p = [pose[0] + cos * u - sin * v, pose[1] + sin * u + cos * v];
                    reference.mark((p[0] - origin[0]) / c, (p[1] - origin[1]) / c);
                }
            }
        }
    }
}

/// Runs the search `spec` and scores its final LiDAR grid against the true world.
pub fn check_search(spec: &SearchSpec, png: Option<&Path>) -> Result<MapcheckReport, String> {
    use crate::sim::geometry::NO_OWNER;
    let run = crate::search::try_run(spec, |_| {}).map_err(|e| format!("the classifier model does not validate: {e}"))?;
    let cfg = run.controller.config();
    let range = cfg.lidar_max_range_m.to_num::<f64>();
    let geom = run.controller.lidar.geom;
    let origin = [geom.origin_x.to_num::<f64>(), geom.origin_y.to_num::<f64>()];
    let grid = MapGrid::of(&run.controller.lidar);
    // The static true world: walls, furniture, clutter and the placed targets (people move).
    let scene = run.sim.world().static_scene(run.sim.target_shapes());
    // One scan per tick, taken at trajectory[k] (the last entry is where the base stopped after
    // the last tick, not scanned).
    let scanned = &run.trajectory[..run.trajectory.len().min(run.result.ticks as usize)];
    let beams = spec.sim.beams.max(1);
    let sim_range = spec.sim.lidar_max_range_m.min(range);
    let mut reference = Reference::new(grid.n, range);
    let c = cell_m();
    for p in scanned {
        reference.viewpoints.push([(p[0] - origin[0]) / c, (p[1] - origin[1]) / c]);
        for k in 0..beams {
            let a = 2.0 * std::f64::consts::PI * k as f64 / beams as f64;
            let d = [a.cos(), a.sin()];
            if let Some(h) = scene.raycast(*p, d, sim_range, NO_OWNER) {
                if h.t < spec.sim.lidar_min_range_m {
                    continue;
                }
                // Just behind the surface, so a wall on a cell boundary goes to the far cell.
                let t = h.t + 1e-6;
                reference.mark((p[0] + t * d[0] - origin[0]) / c, (p[1] + t * d[1] - origin[1]) / c);
            }
        }
    }
    let (map, classes) = score_cells(&grid, &reference, range, RAYS);
    if let Some(p) = png {
        write_png(p, grid.n, &classes)?;
    }
    let r = &run.result;
    Ok(MapcheckReport {
        subject: format!("world {} {} {} seed {}", r.world, r.scenario, r.planner, r.seed),
        reference: ReferenceInfo {
            kind: "true-world".into(),
            file: None,
            viewpoints: reference.viewpoints.len(),
            rays_per_viewpoint: RAYS,
            alignment: None,
        },
        grid_origin: origin,
        cell_m: c,
        grid_size_m: grid.n as f64 * c,
        clearing_range_m: range,
        map,
        own_rays: None,
        relations: None,
        replay: None,
        search: Some(run.result),
    })
}

pub(super) fn pct(v: Option<f64>) -> String {
    v.map_or("n/a".into(), |v| format!("{:.1} %", 100.0 * v))
}

pub(super) fn pm(mean: Option<f64>, std: Option<f64>, digits: usize) -> String {
    match (mean, std) {
        (Some(m), Some(s)) => format!("{m:.digits$} ± {s:.digits$}"),
        _ => "n/a".into(),
    }
}

/// The human-readable table.
pub fn table(r: &MapcheckReport) -> String {
    let mut s = String::new();
    let m = &r.map;
    let _ = writeln!(s, "mapcheck {}", r.subject);
    if let Some(p) = &r.replay {
        let _ = writeln!(
            s,
            "  replay: {} scans read, {} used, {} rejected ({} outside the grid); grid {:.1} m at ({:.1}, {:.1}), clearing range {:.1} m",
            p.scans_read,
            p.scans_used,
            p.scans_rejected,
            p.rejected.outside_grid,
            r.grid_size_m,
            r.grid_origin[0],
            r.grid_origin[1],
            r.clearing_range_m
        );
    }
    if let Some(q) = &r.search {
        let _ = writeln!(
            s,
            "  search: {} after {:.1} s, {} ticks; grid {:.1} m at ({:.1}, {:.1}), LiDAR range {:.1} m",
            q.outcome, q.time_s, q.ticks, r.grid_size_m, r.grid_origin[0], r.grid_origin[1], r.clearing_range_m
        );
    }
    let what = match r.reference.kind.as_str() {
        "log-poses" => "the log's own scans at its own poses".to_string(),
        "other-log" => format!("the scans of {} at its poses", r.reference.file.as_deref().unwrap_or("?")),
        "floor-map" => format!(
            "the floor map {}: its walls the viewpoints see (within the clearing range and the scanner's range_max) score walls recovered",
            r.reference.file.as_deref().unwrap_or("?")
        ),
        _ => "the true world's walls and obstacles the run's noise-free rays hit".to_string(),
    };
    let _ =
        writeln!(s, "  reference: {what}; {} viewpoints × {} rays for the leak", r.reference.viewpoints, r.reference.rays_per_viewpoint);
    if let Some(a) = &r.reference.alignment {
        let _ = writeln!(
            s,
            "  aligned by {}: {} of {} poses matched, transform ({:.3} m, {:.3} m, {:.2}°), residual RMS {:.2} m, max {:.2} m",
            a.file,
            a.matched,
            a.poses,
            a.transform[0],
            a.transform[1],
            a.transform[2].to_degrees(),
            a.rms_m,
            a.max_m
        );
    }
    let _ = writeln!(s, "  {:<18} {:>8}   cells (within {TOLERANCE_M} m, at {} m cells)", "figure", "value", r.cell_m);
    let _ = writeln!(
        s,
        "  {:<18} {:>8}   {} of {} reference wall cells in the grid ({} more in the margin outside it)",
        "walls recovered",
        pct(m.walls_recovered),
        m.recovered_cells,
        m.reference_wall_cells,
        m.reference_walls_outside_grid
    );
    let _ =
        writeln!(s, "  {:<18} {:>8}   {} of {} occupied cells", "phantom walls", pct(m.phantom_walls), m.phantom_cells, m.occupied_cells);
    let _ = writeln!(s, "  {:<18} {:>8}   {} of {} free cells", "free-space leak", pct(m.free_space_leak), m.leak_cells, m.free_cells);
    if let Some(o) = &r.own_rays {
        let _ = writeln!(
            s,
            "  {:<18} {:>8}   {} of the {} cells the log's own beams crossed leak against this reference ({} of the grid's leak cells among them)",
            "the rays' own leak",
            pct(o.free_space_leak),
            o.leak_cells,
            o.free_cells,
            o.grid_leaks_shared
        );
        let _ = writeln!(
            s,
            "  {:<18} {:>8}   of the {} reference wall cells lost, {} are cells the log's own beams crossed in more scans than they ended in ({} of all {})",
            "walls seen through",
            pct(share(o.lost_walls_seen_through, o.lost_walls)),
            o.lost_walls,
            o.lost_walls_seen_through,
            o.walls_seen_through,
            m.reference_wall_cells
        );
    }
    if let Some(rel) = &r.relations {
        let _ = writeln!(s, "  relations {} ({} relations): translation (m) and rotation (°), mean ± std", rel.file, rel.relations);
        relation_rows(&mut s, "  ", 18, 2, [Some(&rel.log_poses), Some(&rel.controller), rel.align_poses.as_ref()]);
        for (what, sub) in [("shorter", &rel.short), ("longer", &rel.long)] {
            let _ = writeln!(s, "  {} relations spanning {what} than {SHORT_SPAN_S} s:", sub.relations);
            relation_rows(&mut s, "    ", 16, 3, [Some(&sub.log_poses), Some(&sub.controller), sub.align_poses.as_ref()]);
        }
    }
    s
}

/// The relation errors of the log's poses, the controller's and the `--align` poses, one row
/// each (`indent`, the name in `width` columns, translations to `decimals` places).
fn relation_rows(s: &mut String, indent: &str, width: usize, decimals: usize, stats: [Option<&RelationStats>; 3]) {
    for (name, st) in ["log poses", "controller", "--align poses"].into_iter().zip(stats) {
        let Some(st) = st else { continue };
        let _ = writeln!(
            s,
            "{indent}{name:<width$} {:>5} used   {:>15} m   {:>15}°",
            st.used,
            pm(st.trans_mean_m, st.trans_std_m, decimals),
            pm(st.rot_mean_deg, st.rot_std_deg, 2)
        );
    }
}
